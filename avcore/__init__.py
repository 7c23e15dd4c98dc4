"""avcore: the method of "Vision-Guided Robot Hearing" (Alameda-Pineda and Horaud) as pure functions and classes.

No threads, no devices, no Rerun, no YAML: everything here is usable from a notebook. The application around it
lives in :mod:`app`.
"""
from __future__ import annotations

__all__ = ["__version__"]
__version__ = "0.1.0"
