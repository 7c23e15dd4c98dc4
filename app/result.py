"""What the pipeline hands to every sink: one :class:`Result` a fused frame, with its :class:`Person` list.

The results file, the bus, the console and the Python API (``avhear.results``) all read ``result.people``; the
method's own output (``result.output``: the fitted model, the counts) stays with the result for the console's
ITD pane. The data flow: sources -> pipeline -> Result -> sinks (docs/architecture.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Any

import numpy as np

__all__ = ["Person", "Result", "voice_id"]

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
        """The result as one line of the results file (schema: :mod:`app.sinks.results_file`), what every sink
        that writes or sends results takes."""
        return _record(self)


def voice_id(person: int) -> str:
    """The voice of person ``person``: ``v<N>`` (ROS4HRI's voice id on the bus; its stream with the voices on)."""
    return f"v{int(person)}"


def _num(x: Any) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _probability(p: Any, speaking: bool) -> float:
    """``p`` to 4 decimals, still above 0.5 exactly when ``speaking`` (0.50003 would round to 0.5)."""
    q = round(float(p), 4)
    if speaking and q <= 0.5:
        return 0.5001
    if not speaking and q > 0.5:
        return 0.5
    return q


def _record(result: Result) -> dict[str, Any]:
    """``result`` as the JSON-ready dict of the results file's schema (:mod:`app.sinks.results_file`)."""
    people = []
    for p in result.people:
        person: dict[str, Any] = {
            "id": p.id,
            "position_m": [round(float(v), 4) for v in p.position_m],
            "speaking": p.speaking,
            "probability": _probability(p.probability, p.speaking),
            "itd_mean_s": _num(p.itd_s[0]),  # the first pair's
        }
        if p.box_px is not None:
            person["box_px"] = list(p.box_px)
        if p.lip_activity is not None:
            person["lip_activity"] = None if p.lip_activity != p.lip_activity else round(float(p.lip_activity), 4)
        person["voice_id"] = voice_id(p.id)  # fields are added at the end
        people.append(person)
    for v in result.voices or ():  # a voice out of view: a person without a face or position
        people.append({"id": v.id, "position_m": None, "speaking": True, "probability": None, "itd_mean_s": None,
                       "azimuth_deg": round(math.degrees(v.azimuth_rad), 1),
                       "elevation_deg": None if v.elevation_rad is None else round(math.degrees(v.elevation_rad), 1),
                       "voice_id": voice_id(v.id)})
    record = {
        "stamp_s": round(float(result.stamp_s), 6),
        "index": int(result.index),
        "mode": result.mode,
        "n_itds": result.n_itds,
        "latency_s": _num(result.latency_s),
        "people": people,
    }
    return record
