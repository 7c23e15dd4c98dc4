"""What the pipeline hands to every sink: one :class:`Result` a fused frame, with its :class:`Person` list.

The results file, the bus, the console and the Python API (``avhear.results``) all read ``result.people``; the
method's own output (``result.output``: the fitted model, the counts) stays with the result for the console's
ITD pane. The data flow: sources -> pipeline -> Result -> sinks (docs/architecture.md).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

__all__ = ["Person", "Result"]

_NO_IMAGE = np.zeros((0, 0), dtype=np.uint8)


@dataclass(frozen=True, eq=False)
class Person:
    """One person of a result.

    id : stable while the person is tracked (avcore.tracking). position_m : (3,) the scene frame (x right, y down,
    z forward), metres: the face (face-guided) or the person's cluster (motion-guided). speaking : the speaking
    state (eq. audio_act, after the vote); probability : in [0, 1], above 0.5 exactly when speaking.
    itd_s : (P,) the person's mean ITD on each of the P microphone pairs, seconds (P = 1 for one pair).
    box_px : (x, y, w, h) of the face in the left image, pixels; None when motion-guided.
    lip_activity : how much the lips moved over the last 0.4 s (:class:`avcore.lips.LipTracks`); None without the
    lips' cue, NaN where the face gives no opinion (just seen, turned away).
    """

    id: int
    position_m: np.ndarray
    speaking: bool
    probability: float
    itd_s: np.ndarray
    box_px: tuple[int, int, int, int] | None = None
    lip_activity: float | None = None


@dataclass(frozen=True, eq=False)
class Result:
    """One fused result.

    stamp_s : capture time of the vision result (a frame, or an interval's centre) on the source's clock.
    index : its frame number. image : the left image (h, w[, 3]) uint8. boxes : (N, 4) face boxes in pixels (None
    when motion-guided). xyz : (N, 3) metres, the faces (face-guided) or the HM3D points (motion-guided).
    itds_s : (K, P) the ITDs of its time frame, one row per window and one column per pair (NaN: the pair has
    none); one column with one pair. output : the method's FaceGuidedOutput or MotionGuidedOutput. latency_s : result time
    minus capture stamp (nan for a source replayed as fast as possible). person_ids : (N,) stable ids of the people
    of ``output``. depth_m : an RGB-D camera's depth aligned to ``image``, metres (NaN: none), or None.
    lip_activity : (N,) each face's lip activity with the lips' cue (:class:`avcore.lips.LipTracks`), or None.
    voices : the voices out of view (:class:`app.hearing.Voice`: an id and a direction) with several microphone
    pairs; None with one pair (no direction) or motion-guided.
    """

    stamp_s: float
    index: int
    image: np.ndarray
    boxes: np.ndarray | None
    xyz: np.ndarray
    itds_s: np.ndarray
    output: Any
    latency_s: float
    person_ids: np.ndarray
    depth_m: np.ndarray | None = None
    lip_activity: np.ndarray | None = None
    voices: tuple | None = None

    @property
    def mode(self) -> str:
        """"face" (Algorithm 2: ``xyz`` are the faces, ``boxes`` their boxes) or "motion" (Algorithm 1: ``xyz`` are
        the HM3D points, the people are ``output.positions``)."""
        return "face" if self.boxes is not None else "motion"

    @property
    def positions(self) -> np.ndarray:
        """(N, 3) metres, the people: the F3D faces (face-guided) or each AV cluster's mean (motion-guided, eq.
        hat_svect), in the order of ``output``'s arrays and ``person_ids``."""
        xyz = self.xyz if self.boxes is not None else self.output.positions
        return np.asarray(xyz, dtype=np.float64).reshape(-1, 3)

    @property
    def speaking(self) -> np.ndarray:
        """(N,) bool, each person's speaking state (eq. audio_act)."""
        return np.asarray(self.output.speaking, dtype=bool).reshape(-1)

    @property
    def n_itds(self) -> int:
        """K, the ITD windows of the time frame."""
        return int(np.asarray(self.itds_s).shape[0])

    @cached_property
    def people(self) -> tuple[Person, ...]:
        """The people of this result, in the order of ``output`` (built once, on first use)."""
        out = self.output
        positions = self.positions
        pair_means = getattr(out, "pair_itd_means", None)
        means = (np.asarray(pair_means, dtype=np.float64) if pair_means is not None
                 else np.asarray(out.itd_means, dtype=np.float64).reshape(-1, 1))
        speaking = self.speaking
        probability = np.asarray(out.probability, dtype=np.float64).reshape(-1)
        boxes = None if self.boxes is None else np.asarray(self.boxes).reshape(-1, 4)
        lips = None if self.lip_activity is None else np.asarray(self.lip_activity, dtype=np.float64).reshape(-1)
        return tuple(
            Person(int(pid), positions[n], bool(speaking[n]), float(probability[n]), means[n],
                   None if boxes is None else tuple(int(v) for v in boxes[n]),
                   None if lips is None else float(lips[n]))
            for n, pid in enumerate(np.asarray(self.person_ids).ravel()))

    def without_image(self) -> Result:
        """The same result without its image, for a sink that keeps many (the evaluation)."""
        return replace(self, image=_NO_IMAGE, depth_m=None)

    def as_dict(self) -> dict[str, Any]:
        """The result as one line of the results file (schema: :mod:`app.sinks.results_file`)."""
        from app.sinks.results_file import result_record

        return result_record(self)
