"""The simulated room's scenarios by name, and how long each runs by default: what the command line offers, known
without building a room (:mod:`sim.scenario` builds them)."""
from __future__ import annotations

__all__ = ["DEFAULT_DURATION_S", "INTERVAL_S", "PRESETS", "SCENARIOS", "SCENARIO_CHOICES", "SEQUENCES"]

PRESETS: tuple[str, ...] = ("S1", "S2", "S3", "S4", "S5", "S6", "calibration")
DEFAULT_DURATION_S: dict[str, float] = {"S1": 20.0, "S2": 20.0, "S3": 20.0, "S4": 20.0, "S5": 25.0, "S6": 25.0,
                                        "calibration": 40.0}
SCENARIOS: tuple[str, ...] = ("S1", "S2", "S3", "S4", "S5")
"""The paper's scenarios: what ``avhear eval scenarios`` runs by default."""
SCENARIO_CHOICES: tuple[str, ...] = (*SCENARIOS, "S6")
"""Every scenario that can be scored: the paper's and S6 (two people in one direction), which the paper has not."""
INTERVAL_S = 0.4
"""The paper's Delta t (section 7): one count of the per-interval scoring, a person during 0.4 s."""
SEQUENCES: tuple[str, ...] = ("StaCon", "DynCon", "StaVar", "DynVar")
"""The four sequence types of section 7.1: Sta(tic)/Dyn(amic) people, Con(stant)/Var(ying) number in view."""
