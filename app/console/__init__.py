"""The Rerun operator console: the paper's visualisation tool (section 6, figure vtool) and more, as Rerun data.

:class:`Console` (console.py) is the sink that makes every ``rr.*`` call of a run; :class:`ConsoleFrame` (frame.py)
is what it draws of one result; the entity paths (entities.py), the pure geometry of what is drawn (geometry.py),
where the data goes (viewer.py) and the calibration session's view (calibration.py) each have a module.
In full: docs/architecture.md ("The console").
"""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from app.console.console import Console
    from app.console.frame import ConsoleFrame

__all__ = ["Console", "ConsoleFrame"]


def __getattr__(name: str) -> Any:
    """``Console`` and ``ConsoleFrame`` load Rerun when first asked for (PEP 562), not when a headless run imports
    where the console's data would go (``app.console.viewer``)."""
    if name == "Console":
        from app.console.console import Console
        return Console
    if name == "ConsoleFrame":
        from app.console.frame import ConsoleFrame
        return ConsoleFrame
    raise AttributeError(f"module 'app.console' has no attribute {name!r}")
