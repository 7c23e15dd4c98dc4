"""The console's entity paths and timelines (the ``rr.*`` paths every part of the console logs to and the blueprint
arranges: :mod:`layouts.blueprint`), with the few display constants that go with them. Rerun is not imported here:
a run's process hands its frames to the console's (:mod:`app.console.process`) without loading it."""
from __future__ import annotations

import re

__all__ = ["TIMELINE_FRAME", "TIMELINE_CAPTURE", "SCENE", "ROBOT", "MICS_3D", "CAMERA_LEFT", "CAMERA_RIGHT", "IMAGE", "DEPTH", "DEPTH_EVERY", "FACES", "HEADS_SPEAKING", "HEADS_SILENT", "HM3D_POINTS", "BIRDSEYE", "BIRDSEYE_HEADS", "BIRDSEYE_VOICES", "SCENE_VOICES", "VOICE_RAY_M", "VOICE_RGB", "ITD", "ITD_GAUSSIANS", "ITD_TOP", "ITD_CLIP", "ITD_BARS", "ITD_PAIRS_HIST", "ITD_PAIRS_PEOPLE", "ITD_PAIRS_LABELS", "PAIR_ROW", "PEOPLE", "LIPS", "LEGEND", "COUNTS", "COUNT_SERIES", "DIAGNOSTICS", "EVENTS", "ENTITY_KEY"]

TIMELINE_FRAME = "frame"
TIMELINE_CAPTURE = "capture_time"

SCENE = "scene"
ROBOT = "scene/robot"
MICS_3D = "scene/robot/mics"
CAMERA_LEFT = "scene/cameras/left"
CAMERA_RIGHT = "scene/cameras/right"
IMAGE = f"{CAMERA_LEFT}/image"
DEPTH = f"{CAMERA_LEFT}/depth"  # an RGB-D camera's depth: the 3D view shows it as the scene's point cloud
DEPTH_EVERY = 10  # frames per depth image logged (a raw 640x480 depth image is 600 kB: 1.8 MB/s at 30 FPS)
FACES = f"{CAMERA_LEFT}/faces"
HEADS_SPEAKING = "scene/heads/speaking"
HEADS_SILENT = "scene/heads/silent"
HM3D_POINTS = "scene/hm3d_points"
BIRDSEYE = "birdseye"
BIRDSEYE_HEADS = "birdseye/heads/circles"
BIRDSEYE_VOICES = "birdseye/voices"  # a voice out of view: a ray from the robot along its direction
SCENE_VOICES = "scene/voices"
VOICE_RAY_M = 4.0  # how far a voice's ray is drawn (its distance is unknown)
VOICE_RGB = (148, 103, 189)
ITD = "itd"
ITD_GAUSSIANS = "itd/faces/gaussians"
ITD_TOP = 0.2  # the ITD pane's vertical scale: fraction of the interval's ITDs per bin at its top
ITD_CLIP = 1.25 * ITD_TOP  # what rises higher is drawn to here, so that one full bin cannot squash the pane
ITD_BARS = "itd/bars"
ITD_PAIRS_HIST = "itd_pairs/histograms"
ITD_PAIRS_PEOPLE = "itd_pairs/people"
ITD_PAIRS_LABELS = "itd_pairs/labels"
PAIR_ROW = 200.0  # display units (us) between two pairs' rows; a bin of ITD_TOP of a pair's ITDs rises 0.8 of it
PEOPLE = "people"
LIPS = "lips"  # each person's lip activity (the lips' cue), one series a person
LEGEND = "legend"  # one line a person (id, state, distance, mean ITD) in each person's colour, shared by every pane
COUNTS = "counts"
COUNT_SERIES = ("people", "speakers", "ITDs in the interval")  # the three series of ``counts``, in this order
DIAGNOSTICS = "diagnostics"
EVENTS = "events"

ENTITY_KEY = re.compile(r"^[A-Za-z0-9_.-]+(/[A-Za-z0-9_.-]+)*$")
