"""The evaluation protocol of the paper's section 7 ("Results"): matching detected clusters to the ground truth.

For one time interval, :func:`match_clusters` compares the detected AV objects with the ground-truth ones and counts
false positives, false negatives and true positives, the localisation error of each true positive, and the
auditory-state confusion over the true positives. :class:`EvalTotals` sums those counts over the intervals of a
sequence and gives the figures of the paper's tables 1 and 2 (section 7.1): visual TP rate, average localisation
error (ALE), auditory TP rate and FP count.

The protocol, quoted from section 7 and implemented literally:

1. For each detected cluster find its nearest ground-truth cluster (Euclidean distance between the means). If it is
   not closer than ``tau_loc`` it is a *false positive*; otherwise the detection is *assigned* to that ground truth.
2. A ground-truth cluster with no detection assigned is a *false negative*.
3. For every other ground-truth cluster, the closest of its assigned detections is a *true positive* and the other
   assigned ones are *false positives*.
4. The localisation error of a true positive is the distance between the two means; the auditory state is compared
   over the true-positive pairs.

Section 7 uses ``tau_loc = 0.35 m`` in all experiments. For the auditory state the paper's sentence reads "false
positive if detected audible when silent, false positive if detected silent when audible", an evident slip: table 2
has FP, FN and TP columns, so a speaker detected silent is an auditory *false negative* here, and TP % is
``TP / (TP + FN)`` as in table 1. Silent people detected silent are counted as true negatives (not in the tables).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from avcore._validate import as_points

__all__ = [
    "FrameTruth", "TAU_LOC_M", "MatchResult", "match_clusters", "EvalTotals"]

TAU_LOC_M = 0.35
"""The paper's matching threshold tau_loc (section 7), metres."""


@dataclass(frozen=True, eq=False)
class FrameTruth:
    """The ground truth of one instant, for ``N`` actors (what a simulator or an annotator knows; recordings carry
    it in truth.csv).

    time_s : seconds from the scenario's start; positions_m : (N, 3) face centres, scene frame, metres;
    visible : (N,) bool -- the whole face box projects inside both images and no nearer person hides its centre;
    speaking : (N,) bool -- a speech event of the actor covers the instant (at the source, not at the microphones);
    sounding : (N,) bool -- any sound of the actor (speech, clap, loudspeaker noise);
    boxes_left : (N, 4) float -- the face box (x, y, w, h) projected into the left image, pixels (NaN behind the rig);
    itds_s : (N,) float -- the ITD of eq. (itd) of each actor's mouth (its loudspeaker for "noise"), seconds.
    """

    time_s: float
    positions_m: np.ndarray
    visible: np.ndarray
    speaking: np.ndarray
    sounding: np.ndarray
    boxes_left: np.ndarray
    itds_s: np.ndarray
    names: tuple[str, ...] = ()


@dataclass(frozen=True, eq=False)
class MatchResult:
    """The outcome of matching one interval's detections to its ground truth (section 7).

    Attributes
    ----------
    fp, fn, tp : int
        Visual false positives (detections beyond ``tau_loc`` of every ground truth, plus the extra detections
        assigned to an already matched ground truth), false negatives (ground truths with no detection assigned)
        and true positives (matched pairs). ``tp + fn`` is the number of ground truths and ``tp + fp + ignored``
        the number of detections.
    errors_m : (tp,) float, metres
        The localisation error of each true positive: the Euclidean distance between the two positions, in the
        order of ``pairs``.
    pairs : tuple of (truth index, detected index)
        The true-positive pairs, sorted by truth index.
    audio_tp, audio_fn, audio_fp, audio_tn : int
        The auditory-state confusion over the true-positive pairs: truth speaking and detected speaking (TP),
        truth speaking and detected silent (FN), truth silent and detected speaking (FP), both silent (TN). All
        zero when the speaking states were not given.
    ignored : int
        Detections whose nearest person is one of ``ignore_xyz`` (present, but too hidden to be in the ground
        truth): neither true nor false positives. Zero when no ``ignore_xyz`` was given.
    """

    fp: int
    fn: int
    tp: int
    errors_m: np.ndarray
    pairs: tuple[tuple[int, int], ...]
    audio_tp: int = 0
    audio_fn: int = 0
    audio_fp: int = 0
    audio_tn: int = 0
    ignored: int = 0


def _as_speaking(values: object, n: int, name: str, points_name: str) -> np.ndarray:
    """Return ``values`` as a ``(n,)`` bool array, or raise: bool only, never coerced from numbers."""
    arr = np.asarray(values)
    if arr.size == 0 and arr.ndim == 1:
        arr = arr.astype(bool)  # an empty list has dtype float64; there is nothing to coerce
    if arr.dtype != np.bool_:
        raise TypeError(f"{name} must be an array of bool (True = speaking), got dtype {arr.dtype}")
    if arr.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), one state per row of {points_name}, got shape {arr.shape}")
    return arr


def match_clusters(
    detected_xyz: object,
    truth_xyz: object,
    *,
    detected_speaking: object | None = None,
    truth_speaking: object | None = None,
    tau_loc: float = TAU_LOC_M,
    ignore_xyz: object | None = None,
) -> MatchResult:
    """Match the detected AV objects of one interval to the ground truth with the protocol of section 7.

    Parameters
    ----------
    detected_xyz : (D, 3) float, metres
        Positions of the detected clusters (scene frame). ``D`` may be 0.
    truth_xyz : (G, 3) float, metres
        Positions of the ground-truth objects. ``G`` may be 0.
    detected_speaking : (D,) bool, optional
        Detected speaking state of each detection.
    truth_speaking : (G,) bool, optional
        True speaking state of each ground truth. Give both speaking arrays or neither.
    tau_loc : float, metres
        A detection whose nearest ground truth is not closer than ``tau_loc`` is a false positive (section 7:
        "if it is not closer than a threshold tau_loc we mark it as a false positive"; a detection at exactly
        ``tau_loc`` is therefore a false positive). Default 0.35 m, the paper's value.
    ignore_xyz : (H, 3) float, metres, optional
        People who are present but too hidden to be in the ground truth (``Interval.hidden_xyz``): a detection
        whose nearest person, visible or hidden, is one of these and closer than ``tau_loc`` is neither a true nor
        a false positive (``MatchResult.ignored``), the "difficult" objects of the PASCAL VOC protocol. Missing
        them is not a false negative either. The paper's protocol is ``None`` (every detection far from the
        ground truth is a false positive).

    Returns
    -------
    MatchResult

    Ties (two ground truths at the same distance from a detection, or two detections at the same distance from
    their ground truth) go to the lower index, so that the result is deterministic.
    """
    det = as_points(detected_xyz, "detected_xyz")
    tru = as_points(truth_xyz, "truth_xyz")
    is_number = isinstance(tau_loc, (int, float, np.floating, np.integer)) and not isinstance(tau_loc, bool)
    if not (is_number and math.isfinite(tau_loc) and tau_loc > 0):
        raise ValueError(f"tau_loc must be a positive distance in metres, got {tau_loc!r}")
    if (detected_speaking is None) != (truth_speaking is None):
        given, missing = (
            ("detected_speaking", "truth_speaking") if truth_speaking is None else ("truth_speaking", "detected_speaking")
        )
        raise ValueError(f"{given} was given without {missing}; give both speaking arrays or neither")
    with_audio = detected_speaking is not None
    if with_audio:
        det_speak = _as_speaking(detected_speaking, det.shape[0], "detected_speaking", "detected_xyz")
        tru_speak = _as_speaking(truth_speaking, tru.shape[0], "truth_speaking", "truth_xyz")

    hidden = np.zeros((0, 3)) if ignore_xyz is None else as_points(ignore_xyz, "ignore_xyz")
    n_det, n_tru = det.shape[0], tru.shape[0]
    to_hidden = np.zeros(n_det, dtype=bool)
    if n_det and hidden.shape[0]:
        d_hidden = np.linalg.norm(det[:, None, :] - hidden[None, :, :], axis=-1).min(axis=1)
        d_truth = (np.linalg.norm(det[:, None, :] - tru[None, :, :], axis=-1).min(axis=1) if n_tru
                   else np.full(n_det, np.inf))
        to_hidden = (d_hidden < tau_loc) & (d_hidden < d_truth)
    ignored = int(np.count_nonzero(to_hidden))
    if n_tru == 0 or n_det == ignored:
        return MatchResult(fp=n_det - ignored, fn=n_tru, tp=0, errors_m=np.zeros(0), pairs=(), ignored=ignored)

    dist = np.linalg.norm(det[:, None, :] - tru[None, :, :], axis=-1)  # (D, G) metres
    nearest = np.argmin(dist, axis=1)  # (D,) first minimum on ties
    nearest_dist = dist[np.arange(n_det), nearest]
    assigned = (nearest_dist < tau_loc) & ~to_hidden

    fp = int(np.count_nonzero(~assigned & ~to_hidden))
    pairs: list[tuple[int, int]] = []
    errors: list[float] = []
    for g in range(n_tru):
        candidates = np.flatnonzero(assigned & (nearest == g))
        if candidates.size == 0:
            continue  # a false negative, counted below
        best = int(candidates[np.argmin(dist[candidates, g])])
        pairs.append((g, best))
        errors.append(float(dist[best, g]))
        fp += candidates.size - 1
    tp = len(pairs)

    audio = {"audio_tp": 0, "audio_fn": 0, "audio_fp": 0, "audio_tn": 0}
    if with_audio:
        for g, d in pairs:
            truth_on, detected_on = bool(tru_speak[g]), bool(det_speak[d])
            key = {
                (True, True): "audio_tp",
                (True, False): "audio_fn",
                (False, True): "audio_fp",
                (False, False): "audio_tn",
            }[(truth_on, detected_on)]
            audio[key] += 1
    return MatchResult(
        fp=fp, fn=n_tru - tp, tp=tp, errors_m=np.asarray(errors, dtype=np.float64), pairs=tuple(pairs), **audio,
        ignored=ignored,
    )


@dataclass
class EvalTotals:
    """Counts summed over the intervals of a sequence: the rows of the paper's tables 1 and 2 (section 7.1).

    Use :meth:`add` once per interval. Rates whose denominator is zero are ``nan`` (``None`` in :meth:`as_dict`).

    Attributes
    ----------
    n_intervals : int
        Number of results added.
    fp, fn, tp : int
        Visual counts (table 1).
    errors_m : list of float, metres
        The localisation error of every true positive, in the order added (``ale_m`` is their mean).
    audio_tp, audio_fn, audio_fp, audio_tn : int
        Auditory-state counts over the true-positive pairs (table 2 reports FP, FN and TP).
    ignored : int
        Detections at people too hidden to be in the ground truth (``match_clusters(ignore_xyz=...)``).
    """

    n_intervals: int = 0
    fp: int = 0
    fn: int = 0
    tp: int = 0
    audio_tp: int = 0
    audio_fn: int = 0
    audio_fp: int = 0
    audio_tn: int = 0
    ignored: int = 0
    errors_m: list[float] = field(default_factory=list, repr=False)

    def add(self, result: MatchResult) -> None:
        """Add the counts of one interval."""
        if not isinstance(result, MatchResult):
            raise TypeError(f"result must be a MatchResult from match_clusters, got {type(result).__name__}")
        self.n_intervals += 1
        self.fp += result.fp
        self.fn += result.fn
        self.tp += result.tp
        self.errors_m.extend(float(e) for e in result.errors_m)
        self.audio_tp += result.audio_tp
        self.audio_fn += result.audio_fn
        self.audio_fp += result.audio_fp
        self.audio_tn += result.audio_tn
        self.ignored += result.ignored

    @property
    def n_truth(self) -> int:
        """Number of ground-truth objects seen (``tp + fn``)."""
        return self.tp + self.fn

    @property
    def visual_tp_rate(self) -> float:
        """``tp / (tp + fn)``: the TP percentage of table 1, as a fraction."""
        return self.tp / self.n_truth if self.n_truth else math.nan

    @property
    def visual_fn_rate(self) -> float:
        """``fn / (tp + fn)``: the FN percentage of table 1, as a fraction."""
        return self.fn / self.n_truth if self.n_truth else math.nan

    @property
    def ale_m(self) -> float:
        """Average localisation error of all true positives, metres (the ALE column of table 1)."""
        return float(np.mean(self.errors_m)) if self.errors_m else math.nan

    @property
    def audio_tp_rate(self) -> float:
        """``audio_tp / (audio_tp + audio_fn)``: the TP percentage of table 2, as a fraction."""
        n = self.audio_tp + self.audio_fn
        return self.audio_tp / n if n else math.nan

    @property
    def audio_fn_rate(self) -> float:
        """``audio_fn / (audio_tp + audio_fn)``: the FN percentage of table 2, as a fraction."""
        n = self.audio_tp + self.audio_fn
        return self.audio_fn / n if n else math.nan

    def as_dict(self) -> dict[str, int | float | None]:
        """Counts and rates as a JSON-ready dict (undefined rates are ``None``)."""

        def clean(x: float) -> float | None:
            return None if math.isnan(x) else x

        return {
            "n_intervals": self.n_intervals,
            "fp": self.fp,
            "fn": self.fn,
            "tp": self.tp,
            "visual_tp_rate": clean(self.visual_tp_rate),
            "visual_fn_rate": clean(self.visual_fn_rate),
            "ale_m": clean(self.ale_m),
            "audio_fp": self.audio_fp,
            "audio_fn": self.audio_fn,
            "audio_tp": self.audio_tp,
            "audio_tn": self.audio_tn,
            "audio_tp_rate": clean(self.audio_tp_rate),
            "audio_fn_rate": clean(self.audio_fn_rate),
        }
