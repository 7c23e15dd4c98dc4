"""What the console draws of one fused result (:class:`ConsoleFrame`), checked at the door: the arrays' shapes are
the console's contract with the pipeline and the replays."""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from app.console.entities import ENTITY_KEY
from avcore.mixture import Mixture1D

__all__ = ["ConsoleFrame"]


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
            if not isinstance(key, str) or not ENTITY_KEY.match(key):
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
