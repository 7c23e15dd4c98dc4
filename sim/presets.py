"""The simulated room's scenarios by name, and how long each runs by default: what the command line offers, known
without building a room (:mod:`sim.scenario` builds them)."""
from __future__ import annotations

__all__ = ["DEFAULT_DURATION_S", "PRESETS"]

PRESETS: tuple[str, ...] = ("S1", "S2", "S3", "S4", "S5", "S6", "calibration")
DEFAULT_DURATION_S: dict[str, float] = {"S1": 20.0, "S2": 20.0, "S3": 20.0, "S4": 20.0, "S5": 25.0, "S6": 25.0,
                                        "calibration": 40.0}
