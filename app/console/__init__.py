"""The Rerun operator console: the paper's visualisation tool (section 6, figure vtool) and more, as Rerun data.

Every ``rr.*`` call of the application lives here (docs/architecture.md); what is drawn is computed by the pure helpers
of :mod:`app.console.geometry`. The default layout of these entities is :func:`layouts.blueprint.default_blueprint`.

Entity paths (static entities are logged once, when the console is created). The people of a frame are the
instances of a few batched entities, one instance each, told apart by colour (:func:`~app.console.geometry.
person_colors`, stable per person id) and label (the id; the ``legend`` pane says the rest); such an entity is
cleared when its last person goes. ``<id>`` is a person id.

In full (every part, and why): docs/architecture.md ("The console").
"""
from __future__ import annotations

import logging
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np
import pyarrow as pa
import rerun as rr

from app.console import geometry as geo
from avcore.depth import depth_millimetres
from avcore.geometry import MicArray, MicPair
from avcore.mixture import Mixture1D
from avcore.stereo import StereoRig
from layouts.blueprint import APPLICATION_ID

__all__ = ["APPLICATION_ID", "TIMELINE_CAPTURE", "TIMELINE_FRAME", "Console", "ConsoleFrame"]

log = logging.getLogger(__name__)

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
_PAIR_ROW = 200.0  # display units (us) between two pairs' rows; a bin of ITD_TOP of a pair's ITDs rises 0.8 of it
PEOPLE = "people"
LIPS = "lips"  # each person's lip activity (the lips' cue), one series a person
LEGEND = "legend"  # one line a person (id, state, distance, mean ITD) in each person's colour, shared by every pane
COUNTS = "counts"
COUNT_SERIES = ("people", "speakers", "ITDs in the interval")  # the three series of ``counts``, in this order
DIAGNOSTICS = "diagnostics"
EVENTS = "events"

_SOLID = rr.components.FillMode.Solid
_WIREFRAME = rr.components.FillMode.MajorWireframe
_KEY = re.compile(r"^[A-Za-z0-9_.-]+(/[A-Za-z0-9_.-]+)*$")


# The two biggest per-frame arrays, the ITD pane's curves and the bar chart's counts, are handed to Rerun as Arrow
# arrays of its own component types (which it takes as they are): its generic converters build them one strip, or
# one tensor, at a time in Python, at ten times the cost.
_STRIPS_2D = rr.components.LineStrip2DBatch._ARROW_DATATYPE


def _strips_2d(strips: list[np.ndarray]) -> pa.Array:
    """Polylines (P_i, 2) as one Arrow LineStrip2D batch (list of fixed-size [x, y] float32 lists)."""
    offsets = np.zeros(len(strips) + 1, np.int32)
    np.cumsum([len(s) for s in strips], out=offsets[1:])
    flat = np.concatenate(strips).astype(np.float32).reshape(-1) if strips else np.zeros(0, np.float32)
    points = pa.FixedSizeListArray.from_arrays(pa.array(flat), type=_STRIPS_2D.value_type)
    return pa.ListArray.from_arrays(pa.array(offsets), points, type=_STRIPS_2D)


class _CountsTensor:
    """Histogram counts (B,) int64 as Rerun's TensorData Arrow array, reusing every part of a first conversion by
    Rerun (shape, names, the tensor buffer's union layout) but the values."""

    def __init__(self, first: np.ndarray) -> None:
        self.first = rr.components.TensorDataBatch(np.asarray(first, np.int64)).as_arrow_array()
        self._size = len(first)
        union = self.first.field("buffer")
        self._union_type = union.type
        self._children = [union.field(i) for i in range(union.type.num_fields)]
        self._slot = [union.type.field(i).name for i in range(union.type.num_fields)].index("I64")
        self._union_buffers = union.buffers()[:3]  # no validity; type ids; value offsets

    def __call__(self, counts: np.ndarray) -> pa.Array:
        if counts.shape != (self._size,):
            raise ValueError(f"counts must have shape ({self._size},), got {counts.shape}")
        children = list(self._children)
        values = pa.array(np.asarray(counts, np.int64))
        children[self._slot] = pa.ListArray.from_arrays(pa.array(np.array([0, self._size], np.int32)), values,
                                                        type=self._union_type.field(self._slot).type)
        union = pa.Array.from_buffers(self._union_type, 1, self._union_buffers, children=children)
        return pa.StructArray.from_arrays([self.first.field("shape"), self.first.field("names"), union],
                                          fields=list(self.first.type))


def _array(value: Any, name: str, shape_tail: tuple[int, ...], dtype: type = np.float64) -> np.ndarray:
    arr = np.asarray(value, dtype=dtype)
    if arr.ndim == 1 and arr.size == 0 and shape_tail:
        arr = arr.reshape((0, *shape_tail))
    if arr.ndim != 1 + len(shape_tail) or arr.shape[1:] != shape_tail:
        want = "(N" + "".join(f", {s}" for s in shape_tail) + ")"
        raise ValueError(f"{name} must be an array of shape {want}, got shape {arr.shape}")
    return arr


@dataclass(frozen=True, eq=False)
class ConsoleFrame:
    """One fused result to display: a vision frame, the ITDs of its time frame and what inference made of them.

    Parameters
    ----------
    stamp_s : float, seconds
        Capture stamp of the vision frame on the application's clock (docs/architecture.md).
    frame : int
        Frame number (the ``frame`` timeline).
    image : (H, W) or (H, W, 3) uint8, or None
        The rectified left image, grey or BGR (OpenCV's order). None leaves the last logged image in place.
    boxes : (N, 4) float, pixels, or None
        Face boxes (x, y, w, h) in the left image; None when the heads come without boxes (motion-guided): the
        circles are then drawn at the projected heads.
    faces_xyz : (N, 3) float, metres
        Head (face) centres in the scene frame.
    speaking : (N,) bool; probability : (N,) float in [0, 1]
        The speaking states and probabilities of inference (eq. audio_act).
    itds_s : (K,) float, seconds, or (K, P) with several microphone pairs
        The ITDs of the interval. With P pairs, the ITD-space pane shows the first pair's (the one ``model`` is
        fitted on) and each pair gets its own histogram in the "ITDs per pair" pane (``pair_itds_s``).
    model : Mixture1D or None
        The fitted 1-D model, its N Gaussian components in the order of the faces; None draws no curve.
    person_ids : (N,) int or None
        Stable ids of the people when a tracker gives them; None numbers the faces 0..N-1 in this frame.
    points_xyz : (M, 3) float, metres, or None
        HM3D points of the interval (motion-guided), drawn in the 3D view.
    diagnostics : mapping from key to number
        Figures of the pipeline logged as time series under ``diagnostics/<key>``. Conventional keys:
        ``fps/<stage>``, ``latency_ms/<what>``, ``queue_depth/<queue>``, ``drops/<queue>``, ``audio_overflows``.
    depth_m : (H, W) float, metres (NaN: no depth), or None
        An RGB-D camera's depth aligned to ``image``, drawn in the 3D view every :data:`DEPTH_EVERY` frames.
    lip_activity : (N,) float or None
        Each face's lip activity (the lips' cue, :class:`avcore.lips.LipTracks`; NaN: no opinion), drawn as each
        person's series under ``lips/<id>``.
    voices : sequence of (id, azimuth_rad) or None
        The voices out of view (:class:`app.hearing.Voice`), each drawn as a ray from the robot.
    """

    stamp_s: float
    frame: int
    image: np.ndarray | None
    boxes: np.ndarray | None
    faces_xyz: np.ndarray
    speaking: np.ndarray
    probability: np.ndarray
    itds_s: np.ndarray
    model: Mixture1D | None = None
    person_ids: np.ndarray | None = None
    points_xyz: np.ndarray | None = None
    diagnostics: Mapping[str, float] = field(default_factory=dict)
    depth_m: np.ndarray | None = None
    lip_activity: np.ndarray | None = None
    voices: tuple = ()
    pair_itds_s: np.ndarray | None = field(default=None, init=False)

    def __post_init__(self) -> None:
        if not (isinstance(self.stamp_s, (int, float, np.floating, np.integer)) and np.isfinite(self.stamp_s)):
            raise ValueError(f"stamp_s must be a finite number of seconds, got {self.stamp_s!r}")
        if not isinstance(self.frame, (int, np.integer)) or isinstance(self.frame, bool):
            raise TypeError(f"frame must be an int frame number, got {type(self.frame).__name__}")
        if self.image is not None:
            img = self.image
            if not isinstance(img, np.ndarray) or img.dtype != np.uint8 or not (
                img.ndim == 2 or (img.ndim == 3 and img.shape[2] == 3)
            ):
                got = f"{img.dtype} {img.shape}" if isinstance(img, np.ndarray) else type(img).__name__
                raise ValueError(f"image must be a (H, W) grey or (H, W, 3) BGR uint8 array, got {got}")
        if self.depth_m is not None and not (isinstance(self.depth_m, np.ndarray) and self.depth_m.ndim == 2
                                             and np.issubdtype(self.depth_m.dtype, np.floating)):
            raise ValueError("depth_m must be a (H, W) float array of metres (NaN where there is no depth)")
        faces = _array(self.faces_xyz, "faces_xyz", (3,))
        n = faces.shape[0]
        boxes = None if self.boxes is None else _array(self.boxes, "boxes", (4,))
        speaking = np.asarray(self.speaking)
        speaking = speaking.astype(bool) if speaking.size == 0 else speaking  # [] reads as float64
        prob = np.asarray(self.probability, dtype=np.float64)
        ids = np.arange(n) if self.person_ids is None else np.asarray(self.person_ids)
        ids = ids.astype(np.int64) if ids.size == 0 else ids
        for name, arr in (("speaking", speaking), ("probability", prob), ("person_ids", ids)):
            if arr.ndim != 1:
                raise ValueError(f"{name} must be a 1-D array with one value per face, got shape {arr.shape}")
        for name, arr in (("boxes", boxes), ("speaking", speaking), ("probability", prob), ("person_ids", ids)):
            if arr is not None and arr.shape[0] != n:
                raise ValueError(f"{name} must have one row per face ({n} faces in faces_xyz), got {arr.shape[0]}")
        if speaking.dtype != bool:
            raise TypeError(f"speaking must be an array of bool, got dtype {speaking.dtype}")
        if not np.issubdtype(ids.dtype, np.integer):
            raise TypeError(f"person_ids must be integers, got dtype {ids.dtype}")
        if len(set(ids.tolist())) != n:
            raise ValueError(f"person_ids must be distinct, got {ids.tolist()}")
        if not (np.all(np.isfinite(faces)) and (boxes is None or np.all(np.isfinite(boxes)))):
            raise ValueError("faces_xyz and boxes must be finite; drop unmatched faces before building the frame")
        if np.any(~((prob >= 0) & (prob <= 1))):
            raise ValueError(f"probability must lie in [0, 1], got {prob.tolist()}")
        if np.ndim(self.itds_s) not in (1, 2):
            raise ValueError(f"itds_s must be a (K,) or (K, P) array of seconds, got shape {np.shape(self.itds_s)}")
        itds = np.asarray(self.itds_s, dtype=np.float64)
        if itds.ndim == 2:
            object.__setattr__(self, "pair_itds_s", itds)
            itds = itds[np.isfinite(itds[:, 0]), 0] if itds.shape[1] else np.zeros(0)
        if self.model is not None:
            if not isinstance(self.model, Mixture1D):
                raise TypeError(f"model must be a Mixture1D or None, got {type(self.model).__name__}")
            if self.model.n_components != n:
                raise ValueError(f"model has {self.model.n_components} Gaussian components but there are {n} faces; "
                                 "pass the model fitted to these faces (one component per face, same order)")
        points = None if self.points_xyz is None else _array(self.points_xyz, "points_xyz", (3,))
        lips = None if self.lip_activity is None else np.asarray(self.lip_activity, dtype=np.float64).reshape(-1)
        if lips is not None and lips.shape[0] != n:
            raise ValueError(f"lip_activity must have one value per face ({n} faces in faces_xyz), got {lips.shape[0]}")
        diag = dict(self.diagnostics or {})
        for key, value in diag.items():
            if not isinstance(key, str) or not _KEY.match(key):
                raise ValueError(f"diagnostics key {key!r} must be a path like 'fps/vision' (letters, digits, _ . -)")
            if not isinstance(value, (int, float, np.integer, np.floating)) or isinstance(value, bool):
                raise TypeError(f"diagnostics[{key!r}] must be a number, got {type(value).__name__}")
        for name, value in (("faces_xyz", faces), ("boxes", boxes), ("speaking", speaking), ("probability", prob),
                            ("person_ids", ids.astype(np.int64)), ("itds_s", itds), ("points_xyz", points),
                            ("diagnostics", diag), ("lip_activity", lips)):
            object.__setattr__(self, name, value)

    @property
    def n_people(self) -> int:
        """N, the number of faces (heads) in the frame."""
        return int(self.faces_xyz.shape[0])

    @classmethod
    def from_face_guided(cls, stamp_s: float, frame: int, image: np.ndarray | None, boxes: np.ndarray,
                         faces_xyz: np.ndarray, itds_s: np.ndarray, output: Any, *,
                         person_ids: np.ndarray | None = None,
                         diagnostics: Mapping[str, float] | None = None) -> ConsoleFrame:
        """From F3D faces (boxes (N, 4) px, faces_xyz (N, 3) m) and a ``FaceGuidedOutput`` of the same faces."""
        return cls(stamp_s, frame, image, boxes, faces_xyz, output.speaking, output.probability, itds_s,
                   output.model, person_ids, None, diagnostics or {})

    @classmethod
    def from_result(cls, result: Any, diagnostics: Mapping[str, float] | None = None) -> ConsoleFrame:
        """From the pipeline's :class:`app.result.Result`: its people (a box each when face-guided), its ITDs and
        the fitted model; motion-guided, its HM3D points too."""
        people = result.people
        face = result.mode == "face"
        boxes = np.array([p.box_px for p in people], dtype=np.float64).reshape(-1, 4) if face else None
        return cls(result.stamp_s, result.index, result.image, boxes,
                   np.array([p.position_m for p in people], dtype=np.float64).reshape(-1, 3),
                   np.array([p.speaking for p in people], dtype=bool),
                   np.array([p.probability for p in people], dtype=np.float64), result.itds_s,
                   result.output.model, np.array([p.id for p in people], dtype=np.int64),
                   None if face else result.xyz, diagnostics or {}, getattr(result, "depth_m", None),
                   getattr(result, "lip_activity", None),
                   tuple((v.id, v.azimuth_rad) for v in (getattr(result, "voices", None) or ())))

    @classmethod
    def from_motion_guided(cls, stamp_s: float, frame: int, image: np.ndarray | None, points_xyz: np.ndarray,
                           itds_s: np.ndarray, output: Any, *, person_ids: np.ndarray | None = None,
                           diagnostics: Mapping[str, float] | None = None) -> ConsoleFrame:
        """From HM3D points (M, 3) m and a ``MotionGuidedOutput``: the heads are the estimated positions."""
        return cls(stamp_s, frame, image, None, output.positions, output.speaking, output.probability, itds_s,
                   output.model, person_ids, points_xyz, diagnostics or {})


class Console:
    """Logs the operator console to a Rerun recording.

    Parameters
    ----------
    rig : StereoRig
        The stereo rig (its rectified geometry: camera centres, intrinsics, image size).
    mics : MicPair
        The microphones and the affine AV correction (the ITD axis covers their reachable interval).
    recording : rr.RecordingStream or None
        Where to log; None uses the current (global or thread-local) recording of ``rr.init``.
    jpeg_quality : int in [1, 100], or None
        Images are JPEG-compressed at this quality (bounded .rrd size and viewer memory); None logs raw pixels.
    image_every : int >= 1
        Log one image out of this many frames (the overlays are logged every frame).
    itd_bin_s : float, seconds
        Width of the ITD histogram's bins.
    capture_epoch_s : float or None, seconds
        Unix time of the stamp clock's zero (``time.time() - time.monotonic()`` for live stamps): the
        ``capture_time`` timeline is then a timestamp. None makes it a duration since the clock's zero (replays,
        the simulator).
    head_radius_m : float, metres
        Radius of a drawn head.
    fov_depth_m : float, metres
        How far the bird's-eye view draws the fields of view and range rings.

    Static data (robot, microphones, cameras, bird's-eye furniture, ITD axis) is logged when the console is made.
    :meth:`log` is meant for one thread (the fusion loop): Rerun's time cursor is per thread.
    """

    def __init__(self, rig: StereoRig, mics: MicPair, *, recording: rr.RecordingStream | None = None,
                 jpeg_quality: int | None = 80, image_every: int = 1, itd_bin_s: float = 10e-6,
                 capture_epoch_s: float | None = None, head_radius_m: float = 0.09,
                 fov_depth_m: float = 6.0, array: MicArray | None = None) -> None:
        if not isinstance(rig, StereoRig):
            raise TypeError(f"rig must be a StereoRig, got {type(rig).__name__}")
        if not isinstance(mics, MicPair):
            raise TypeError(f"mics must be a MicPair, got {type(mics).__name__}")
        if jpeg_quality is not None and not (isinstance(jpeg_quality, int) and 1 <= jpeg_quality <= 100):
            raise ValueError(f"jpeg_quality must be an int in [1, 100] or None for raw images, got {jpeg_quality!r}")
        if not (isinstance(image_every, int) and image_every >= 1):
            raise ValueError(f"image_every must be an int >= 1, got {image_every!r}")
        for name, value in (("head_radius_m", head_radius_m), ("fov_depth_m", fov_depth_m)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of metres, got {value!r}")
        if capture_epoch_s is not None and not np.isfinite(capture_epoch_s):
            raise ValueError(f"capture_epoch_s must be a finite Unix time in seconds or None, got {capture_epoch_s!r}")
        self.rig = rig
        self.mics = mics
        self.recording = recording
        self.jpeg_quality = jpeg_quality
        self.image_every = image_every
        self.capture_epoch_s = capture_epoch_s
        self.head_radius_m = float(head_radius_m)
        self.fov_depth_m = float(fov_depth_m)
        self.itd_pane = geo.ItdPane.for_mics(mics, bin_s=itd_bin_s)
        self._edges_s = self.itd_pane.edges_s
        self.array = array if array is not None and array.n_pairs > 1 else None
        self._pair_panes = ([geo.ItdPane.for_mics(array.pair(k), bin_s=itd_bin_s) for k in range(array.n_pairs)]
                            if self.array is not None else [])
        self.frames_logged = 0
        self.new_part()

    def new_part(self) -> None:
        """Start afresh in a new .rrd part (:meth:`app.console.viewer.ViewerSession.next_part`): the static data again,
        and whatever is logged only once or on change (people's styles, the bars' positions, the histogram) at the next
        frame."""
        self._present: set[int] = set()
        self._styled: set[int] = set()
        self._occupied: set[str] = set()  # batched per-person entities holding instances now
        self._had_points = False
        self._had_boxes = False
        self._counts_tensor: _CountsTensor | None = None  # set with the first histogram of the part
        self._last_counts: np.ndarray | None = None  # the histogram logged last, and its ITDs off the axis
        self._last_outside = 0
        self._legend: list[str] | None = None  # the legend's lines logged last
        self.log_static()

    # ------------------------------------------------------------------ helpers
    def _log(self, path: str, *archetypes: Any, static: bool = False) -> None:
        rr.log(path, *archetypes, static=static, recording=self.recording)

    def _set_time(self, frame: ConsoleFrame) -> None:
        rr.set_time(TIMELINE_FRAME, sequence=int(frame.frame), recording=self.recording)
        if self.capture_epoch_s is None:
            rr.set_time(TIMELINE_CAPTURE, duration=float(frame.stamp_s), recording=self.recording)
        else:
            rr.set_time(TIMELINE_CAPTURE, timestamp=float(frame.stamp_s) + self.capture_epoch_s,
                        recording=self.recording)

    # ------------------------------------------------------------------ static data
    def log_static(self) -> None:
        """The rig, the microphones and the fixed parts of the panes (``static=True``: shown at every time)."""
        rig, mics = self.rig, self.mics
        self._log(SCENE, rr.ViewCoordinates.RDF, static=True)
        lo, hi = geo.robot_bounds(mics, rig)
        self._log(ROBOT, rr.Boxes3D(centers=[0.5 * (lo + hi)], half_sizes=[0.5 * (hi - lo)], colors=[(90, 90, 90)],
                                    labels=["robot"]), static=True)
        mic_xyz = np.array([mics.left, mics.right])
        self._log(MICS_3D, rr.Points3D(mic_xyz, radii=0.015, colors=[(220, 40, 40)]), static=True)
        cameras = zip((CAMERA_LEFT, CAMERA_RIGHT), geo.camera_centres(rig), (rig.proj_left, rig.proj_right),
                      strict=True)
        for path, centre, proj in cameras:
            self._log(path, rr.Transform3D(translation=centre), static=True)
            self._log(path, rr.Pinhole(image_from_camera=proj[:, :3], resolution=list(rig.image_size),
                                       camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=0.15), static=True)

        outline_lo, outline_hi = geo.birdseye(lo), geo.birdseye(hi)
        x0, x1 = sorted((outline_lo[0], outline_hi[0]))
        y0, y1 = sorted((outline_lo[1], outline_hi[1]))
        self._log(f"{BIRDSEYE}/robot", rr.LineStrips2D([[(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]],
                                                       radii=0.01, colors=[(90, 90, 90)], labels=["robot"]),
                  static=True)
        self._log(f"{BIRDSEYE}/mics", rr.Points2D(geo.birdseye(mic_xyz), radii=0.02, colors=[(220, 40, 40)]),
                  static=True)
        self._log(f"{BIRDSEYE}/fov", rr.LineStrips2D(list(geo.fov_strips_birdseye(rig, self.fov_depth_m)),
                                                     radii=0.008, colors=[(30, 90, 200), (30, 150, 220)]),
                  static=True)
        radii_m = np.arange(1.0, np.floor(self.fov_depth_m) + 0.5)
        rings = geo.range_rings_birdseye(radii_m)
        self._log(f"{BIRDSEYE}/rings", rr.LineStrips2D(list(rings), radii=0.004, colors=[(170, 170, 170)],
                                                       labels=[f"{r:g} m" for r in radii_m], show_labels=False),
                  static=True)

        pane = self.itd_pane
        lo_s, hi_s = pane.range_s
        ticks_us = np.arange(np.ceil(lo_s * 1e4), np.floor(hi_s * 1e4) + 1) * 100.0  # every 100 us
        tick_len = 0.02 * pane.height_per_fraction
        strips = [pane.xy(np.array([lo_s, hi_s]), np.zeros(2))]
        strips += [np.array([[t, 0.0], [t, tick_len]]) for t in ticks_us]
        support_s = np.array(mics.itd_interval())
        top = ITD_TOP  # the vertical scale's top, fraction of the ITDs per bin (ItdPane.for_mics)
        strips += [pane.xy(np.full(2, s), np.array([0.0, top])) for s in support_s]  # the reachable interval
        colors = [(60, 60, 60)] * (1 + ticks_us.size) + [(200, 200, 200)] * 2
        self._log(f"{ITD}/axis", rr.LineStrips2D(strips, radii=0.6, colors=colors), static=True)
        named = ticks_us[np.round(ticks_us / 100.0) % 2 == 0]  # a label every 200 us: closer, they overlap
        labels = [f"{t:+.0f} us" if t else "0" for t in named]
        self._log(f"{ITD}/axis/ticks", rr.Points2D(np.stack([named, np.full(named.size, 2.5 * tick_len)], 1),
                                                   radii=0.1, colors=[(60, 60, 60)], labels=labels), static=True)
        fractions = np.linspace(0.05, top, 4)
        self._log(f"{ITD}/axis/fraction", rr.Points2D(pane.xy(np.full(4, lo_s), fractions), radii=1.0,
                                                      colors=[(120, 120, 120)],
                                                      labels=[f"{f:g}" for f in fractions]),
                  static=True)
        self._log(COUNTS, rr.SeriesLines(names=list(COUNT_SERIES), colors=[(40, 40, 40), (214, 39, 40),
                                                                           (31, 119, 180)]), static=True)

    # ------------------------------------------------------------------ per frame
    def log(self, frame: ConsoleFrame) -> None:
        """Log one fused result on the ``frame`` and ``capture_time`` timelines.

        Every person of a frame is one instance of a few batched entities (a box, a circle, a head, a Gaussian),
        told apart by its colour and label, so that a frame replaces the people of the last one (nobody stale
        stays) and takes about a dozen ``rr.log`` calls whatever the number of people: Rerun's cost per call
        (building Arrow arrays, queueing a row) is most of the console's time.
        """
        if not isinstance(frame, ConsoleFrame):
            raise TypeError(f"frame must be a ConsoleFrame, got {type(frame).__name__}")
        if frame.image is not None and frame.image.shape[1::-1] != tuple(self.rig.image_size):
            raise ValueError(f"image must be of the rig's size {self.rig.image_size} (width, height), got "
                             f"{frame.image.shape[1::-1]}")
        if frame.depth_m is not None and frame.depth_m.shape[::-1] != tuple(self.rig.image_size):
            raise ValueError(f"depth_m must be of the rig's size {self.rig.image_size} (width, height), got "
                             f"{frame.depth_m.shape[::-1]}")
        self._set_time(frame)
        ids = [int(i) for i in frame.person_ids]
        colors = geo.pack_rgba(geo.person_colors(frame.person_ids))
        labels = [str(pid) for pid in ids]  # the rest is in the legend and the bars: short labels do not collide
        discs = geo.pack_rgba(geo.speaking_rgba(frame.probability))
        self._log_events(set(ids))
        if frame.image is not None and self.frames_logged % self.image_every == 0:
            self._log_image(frame.image)
        if frame.depth_m is not None and self.frames_logged % DEPTH_EVERY == 0:
            self._log(DEPTH, rr.DepthImage(depth_millimetres(frame.depth_m), meter=1000.0,
                                           depth_range=(300.0, self.fov_depth_m * 1000.0)))
        self._log_faces(frame, colors, labels)
        self._log_heads(frame, colors, labels, discs)
        self._log_itd_space(frame, ids, colors)
        self._log_pairs(frame, colors)
        self._log_series(frame, ids, colors)
        self._log_legend(frame, colors)
        self._log_voices(frame.voices)
        self._log_points(frame.points_xyz)
        self.frames_logged += 1

    def _log_people(self, path: str, n: int, *archetypes: Any) -> None:
        """A batched entity with one instance per person: logged when someone is there, cleared once when the last
        one goes (an empty frame after an empty frame logs nothing: the entity is already empty)."""
        if n:
            self._log(path, *archetypes)
            self._occupied.add(path)
        elif path in self._occupied:
            self._log(path, rr.Clear(recursive=False))
            self._occupied.discard(path)

    def _log_events(self, now: set[int]) -> None:
        departed = sorted(self._present - now)
        arrived = sorted(now - self._present)
        if departed or arrived:
            parts = [f"person {p} appeared" for p in arrived] + [f"person {p} left" for p in departed]
            self._log(EVENTS, rr.TextLog("; ".join(parts), level=rr.TextLogLevel.INFO))
        self._present = now

    def _log_image(self, image: np.ndarray) -> None:
        if self.jpeg_quality is None:
            self._log(IMAGE, rr.Image(image, color_model="L" if image.ndim == 2 else "BGR"))
            return
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality])
        if not ok:  # never seen with uint8 images; keep the console alive and say so
            log.warning("JPEG encoding of a %s image failed; image not logged", image.shape)
            return
        self._log(IMAGE, rr.EncodedImage(contents=buf.reshape(-1), media_type="image/jpeg"))

    def _log_faces(self, frame: ConsoleFrame, colors: np.ndarray, labels: list[str]) -> None:
        """Pane 1: a box on each face (a ring around each head when motion-guided), thick when speaking, and above
        it a bar as long as the speaking probability; nothing covers the face (its mouth shows who speaks)."""
        if frame.boxes is not None:
            boxes = frame.boxes
            parts: list[Any] = [rr.Boxes2D(mins=boxes[:, :2], sizes=boxes[:, 2:], colors=colors,
                                           radii=np.where(frame.speaking, 3.0, 1.5), draw_order=15.0)]
        else:
            centres, radii = geo.head_circles_px(self.rig, frame.faces_xyz, self.head_radius_m)
            boxes = np.concatenate([centres - radii[:, None], 2 * np.repeat(radii[:, None], 2, axis=1)], axis=1)
            parts = [rr.Ellipses2D(centers=centres, half_sizes=np.repeat(radii[:, None], 2, axis=1), colors=colors,
                                   line_radii=np.where(frame.speaking, 3.0, 1.5), draw_order=15.0)]
            if self._had_boxes:  # heads without boxes after faces with boxes: no stale box stays
                parts.append(rr.Boxes2D.cleared())
        parts.append(rr.LineStrips2D(geo.speaking_bars_px(boxes, frame.probability), colors=colors,
                                     radii=np.where(frame.speaking, 3.0, 2.0), draw_order=20.0))
        parts.append(rr.Points2D(geo.id_labels_px(boxes), radii=0.1, colors=colors, labels=labels, draw_order=20.0))
        self._had_boxes = frame.boxes is not None
        self._log_people(FACES, frame.n_people, *parts)

    def _log_heads(self, frame: ConsoleFrame, colors: np.ndarray, labels: list[str], discs: np.ndarray) -> None:
        """Pane 2 (bird's-eye view: a circle per head) and the heads of the 3D view (solid when speaking)."""
        r = self.head_radius_m
        n = frame.n_people
        flat = geo.birdseye(frame.faces_xyz)
        self._log_people(BIRDSEYE_HEADS, n,
                         rr.Ellipses2D(centers=flat, half_sizes=np.full((n, 2), r), colors=colors, labels=labels,
                                       line_radii=np.where(frame.speaking, 0.02, 0.01)),
                         rr.Points2D(flat, radii=0.6 * r, colors=discs))
        # the fill mode is one value per entity: speakers and silent heads are two entities
        for path, mask, fill in ((HEADS_SPEAKING, frame.speaking, _SOLID), (HEADS_SILENT, ~frame.speaking, _WIREFRAME)):
            k = int(np.count_nonzero(mask))
            self._log_people(path, k,
                             rr.Ellipsoids3D(centers=frame.faces_xyz[mask], half_sizes=np.full((k, 3), r),
                                             colors=colors[mask], labels=[lb for lb, m in zip(labels, mask) if m],
                                             fill_mode=fill))

    def _log_itd_space(self, frame: ConsoleFrame, ids: list[int], colors: np.ndarray) -> None:
        """Pane 3: the histogram of the interval's ITDs and each mapped face as its fitted Gaussian."""
        pane, edges = self.itd_pane, self._edges_s
        counts, outside = geo.itd_histogram(frame.itds_s, edges)
        k = frame.itds_s.size
        # the same ITDs give the same histogram (silence: none, frame after frame): the logged one still holds
        if self._last_counts is None or outside != self._last_outside or not np.array_equal(counts, self._last_counts):
            fractions = counts / k if k else np.zeros(counts.shape)
            xs, ys = geo.histogram_outline(edges, np.minimum(fractions, ITD_CLIP))
            label = f"{k} ITDs" + (f" ({outside} outside the axis)" if outside else "")
            self._log(f"{ITD}/histogram", rr.LineStrips2D(_strips_2d([pane.xy(xs, ys)]), radii=0.8,
                                                          colors=[(40, 40, 40)]))
            # the count in the pane's top right corner, away from the axis' labels and the people's
            self._log(f"{ITD}/histogram/count", rr.Points2D(pane.xy(np.array([pane.range_s[1]]), np.array([ITD_TOP])),
                                                            radii=0.1, colors=[(40, 40, 40)], labels=[label]))
            self._log_bars(counts)
            self._last_counts, self._last_outside = counts, outside
        if frame.model is None:
            self._log_people(f"{ITD}/outliers", 0)
            self._log_people(ITD_GAUSSIANS, 0)
            return
        level = geo.outlier_level(frame.model, pane.bin_s)
        lo_s, hi_s = frame.model.support
        self._log_people(f"{ITD}/outliers", 1,
                         rr.LineStrips2D(_strips_2d([pane.xy(np.array([lo_s, hi_s]), np.full(2, level))]),
                                         radii=0.5, colors=[(150, 150, 150)]))  # the pane's name explains it
        n = frame.n_people
        curves = geo.gaussian_curves(frame.model, pane.bin_s, clip_s=pane.range_s)
        mapped_s = self.mics.itd(frame.faces_xyz) if n else np.zeros(0)
        peaks = [pane.xy(x[[int(np.argmax(y))]], np.minimum(y[[int(np.argmax(y))]], ITD_CLIP))[0] if y.size
                 else pane.xy(mu, 0.0)[0]
                 for (x, y), mu in zip(curves, frame.model.means, strict=True)]
        self._log_people(ITD_GAUSSIANS, n,
                         rr.LineStrips2D(_strips_2d([pane.xy(x, np.minimum(y, ITD_CLIP)) for x, y in curves]),
                                         radii=np.where(frame.speaking, 1.5, 0.8), colors=colors),
                         rr.Points2D(pane.xy(mapped_s, np.zeros(n)), radii=4.0, colors=colors))
        # each person's label at the top of their Gaussian, clear of the axis' tick labels
        self._log_people(f"{ITD_GAUSSIANS}/labels", n,
                         rr.Points2D(np.array(peaks).reshape(-1, 2), radii=0.1, colors=colors,
                                     labels=[str(pid) for pid in ids]))  # the means are in the legend

    def _log_pairs(self, frame: ConsoleFrame, colors: np.ndarray) -> None:
        """The "ITDs per pair" pane: each pair's histogram, one row per pair (the first at the top), on the ITD
        pane's vertical scale (clipped as there), each person's mapped ITD on it as a dot, and the pair's name and
        count at the row's left end, clear of the histogram's middle."""
        if self.array is None or frame.pair_itds_s is None or frame.pair_itds_s.shape[1] != self.array.n_pairs:
            return
        strips, labels, corners, dots, dot_colors = [], [], [], [], []
        mapped = self.array.itd(frame.faces_xyz).reshape(-1, self.array.n_pairs)
        for k, pane in enumerate(self._pair_panes):
            column = frame.pair_itds_s[:, k]
            values = column[np.isfinite(column)]
            edges = pane.edges_s
            counts, _ = geo.itd_histogram(values, edges)
            xs, ys = geo.histogram_outline(edges, counts / values.size if values.size else np.zeros(counts.shape))
            row = k * _PAIR_ROW
            heights = np.minimum(ys, ITD_CLIP) / ITD_TOP * 0.8 * _PAIR_ROW
            strips.append(pane.xy(xs, heights / pane.height_per_fraction) + (0.0, row))
            i, j = self.array.pairs[k]  # type: ignore[index]
            labels.append(f"mics {i}-{j}: {values.size} ITDs")
            corners.append((pane.range_s[0] * 1e6, row - 0.5 * _PAIR_ROW))
            dots.append(np.stack([mapped[:, k] * 1e6, np.full(mapped.shape[0], row)], axis=1))
            dot_colors.append(colors)
        self._log(ITD_PAIRS_HIST, rr.LineStrips2D(_strips_2d(strips), radii=0.8, colors=[(40, 40, 40)]))
        self._log(ITD_PAIRS_LABELS, rr.Points2D(np.array(corners), radii=0.1, colors=[(40, 40, 40)], labels=labels))
        self._log(ITD_PAIRS_PEOPLE, rr.Points2D(np.concatenate(dots), radii=4.0, colors=np.concatenate(dot_colors)))

    def _log_bars(self, counts: np.ndarray) -> None:
        if self._counts_tensor is not None:
            # the bars' positions never change: sent with the first counts only (static would not do: static
            # values would hide the per-frame ones)
            self._log(ITD_BARS, rr.BarChart.from_fields(values=self._counts_tensor(counts)))
            return
        edges, pane = self._edges_s, self.itd_pane
        centres_us = 0.5 * (edges[1:] + edges[:-1]) * 1e6
        self._counts_tensor = _CountsTensor(counts)
        self._log(ITD_BARS, rr.BarChart(self._counts_tensor.first, abscissa=centres_us, color=(40, 40, 40),
                                        widths=np.full(centres_us.size, pane.bin_s * 1e6, np.float32)))

    def _log_series(self, frame: ConsoleFrame, ids: list[int], colors: np.ndarray) -> None:
        """Speaking probability per person, the counts and the diagnostics, as time series."""
        lips = frame.lip_activity
        for n, (pid, p) in enumerate(zip(ids, frame.probability.tolist(), strict=True)):
            path = f"{PEOPLE}/{pid}/speaking_probability"
            if pid not in self._styled:
                self._log(path, rr.SeriesLines(names=f"person {pid}", colors=colors[n:n + 1]), static=True)
                if lips is not None:
                    self._log(f"{LIPS}/{pid}", rr.SeriesLines(names=f"person {pid}", colors=colors[n:n + 1]),
                              static=True)
                self._styled.add(pid)
            self._log(path, rr.Scalars(p))
            if lips is not None and np.isfinite(lips[n]):  # no opinion: a gap in the line
                self._log(f"{LIPS}/{pid}", rr.Scalars(float(lips[n])))
        self._log(COUNTS, rr.Scalars([frame.n_people, np.count_nonzero(frame.speaking), frame.itds_s.size]))
        for key, value in frame.diagnostics.items():
            self._log(f"{DIAGNOSTICS}/{key}", rr.Scalars(float(value)))

    def _log_legend(self, frame: ConsoleFrame, colors: np.ndarray) -> None:
        """The legend every pane shares: one line a person in the person's colour (:func:`geo.legend_labels`), one
        row each; logged when a line changes, cleared when nobody is there."""
        means = None if frame.model is None else frame.model.means
        lines = geo.legend_labels(frame.person_ids, frame.probability, frame.speaking,
                                  np.linalg.norm(frame.faces_xyz, axis=1), means)
        if lines == self._legend:
            return
        self._legend = lines
        n = len(lines)
        # the labels are written in each person's colour; the points under them are not drawn
        self._log_people(LEGEND, n, rr.Points2D(np.stack([np.zeros(n), np.arange(n, dtype=np.float64)], 1),
                                                radii=0.0, colors=colors, labels=lines))

    def _log_voices(self, voices: tuple) -> None:
        """Each voice out of view as a ray from the robot along its direction (its distance is unknown), in the
        bird's-eye view and the 3D scene, labelled with its id; cleared when none is heard."""
        n = len(voices)
        ends = geo.voice_rays(np.array([a for _, a in voices], dtype=np.float64), VOICE_RAY_M)  # (n, 2, 3)
        labels = [f"voice {i}" for i, _ in voices]
        self._log_people(BIRDSEYE_VOICES, n, rr.LineStrips2D(geo.birdseye(ends), radii=0.02, colors=[VOICE_RGB],
                                                             labels=labels))
        self._log_people(SCENE_VOICES, n, rr.LineStrips3D(ends, radii=0.01, colors=[VOICE_RGB], labels=labels))

    def _log_points(self, points: np.ndarray | None) -> None:
        if points is not None:
            self._log(HM3D_POINTS, rr.Points3D(points, radii=0.01, colors=[(120, 120, 120)]))
            self._had_points = True
        elif self._had_points:
            self._log(HM3D_POINTS, rr.Clear(recursive=False))
            self._had_points = False
