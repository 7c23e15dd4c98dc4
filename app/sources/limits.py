"""The sources' bounds and defaults the command line states, known without opening a source (the simulator and the
devices' modules import what they need; these values live here so that `avhear --help` imports neither)."""
from __future__ import annotations

__all__ = ["CAMERAS", "DEFAULT_FOV_DEG", "MAX_SIMULATED_S", "MIN_SIMULATED_S"]

MAX_SIMULATED_S = 1800.0  # the simulator renders a scenario's audio in memory: half an hour at most
MIN_SIMULATED_S = 1.0  # and one second at least (sim.scenario's bound)
CAMERAS = ("stereo", "rgbd", "mono")  # the rig's stereo pair; an RGB-D camera, or its left camera alone, in its place
DEFAULT_FOV_DEG = 70.0  # a laptop webcam's horizontal field of view: typically 65-80 degrees
