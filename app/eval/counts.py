"""The counts the scenario evaluation keeps (:mod:`app.eval.scoring` fills them): speaking states per person and
0.4 s interval and per spoken number, the people's identities over time, the lips' cue alone and the voices out of
view. Each adds to another of its kind (seeds, scenarios) and gives its JSON-ready figures (``as_dict``)."""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from sim.presets import INTERVAL_S

if TYPE_CHECKING:
    from sim.scenario import Scenario

__all__ = ["INTERVAL_S", "IdentityCounts", "LipCue", "SpeakingCounts", "Timeline", "UtteranceCounts",
           "VOICE_SILENT_HOLD_S", "VOICE_TOLERANCE_DEG", "VoiceCounts", "identity_counts", "json_number"]


class _Counts:
    """Integer counters that add up field by field, and the paper's TP % = TP / (TP + FN)."""

    tp: int
    fn: int

    def add(self, other: _Counts) -> None:
        for name in self.__dataclass_fields__:  # type: ignore[attr-defined]
            setattr(self, name, getattr(self, name) + getattr(other, name))

    @property
    def tp_rate(self) -> float:
        """TP / (TP + FN), the paper's TP %."""
        n = self.tp + self.fn
        return self.tp / n if n else math.nan


@dataclass
class SpeakingCounts(_Counts):
    """Speaking-state counts of section 7.3 (see the module docstring for what one count is)."""

    tp: int = 0
    fn: int = 0
    fp: int = 0
    tn: int = 0
    fn_missed_face: int = 0
    fp_false_face: int = 0
    # FP in an interval in which the same person speaks in some of the frames, but fewer than half: the speech
    # smeared over the pause by the ITD window (W = 150 ms) and the fusion's time frame (+- 0.2 s, section 6), a
    # matter of timing; the rest of the FP (``fp_wholly_silent``) fall where the person says nothing at all
    fp_partly_spoken: int = 0
    # FN in an interval where someone else speaks too (overlapping speech, S5)
    fn_overlap: int = 0
    # silent visible people during intervals in which an unseen person speaks (S4), and how many were judged speaking
    silent_while_unseen_talks: int = 0
    fp_while_unseen_talks: int = 0

    @property
    def fp_rate(self) -> float:
        """FP among the silent visible person-intervals that were associated with a person: FP / (FP + TN)."""
        n = self.fp - self.fp_false_face + self.tn
        return (self.fp - self.fp_false_face) / n if n else math.nan

    @property
    def fp_wholly_silent(self) -> int:
        """FP of people who say nothing in any frame of the interval (no false face, not partly spoken)."""
        return self.fp - self.fp_false_face - self.fp_partly_spoken

    @property
    def unseen_fp_rate(self) -> float:
        """Share of silent visible people judged speaking while a person outside the view speaks."""
        n = self.silent_while_unseen_talks
        return self.fp_while_unseen_talks / n if n else math.nan

    def as_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {name: getattr(self, name) for name in self.__dataclass_fields__}
        d.update(tp_rate=json_number(self.tp_rate), fp_rate=json_number(self.fp_rate),
                 unseen_fp_rate=json_number(self.unseen_fp_rate), fp_wholly_silent=self.fp_wholly_silent)
        return d


@dataclass
class UtteranceCounts(_Counts):
    """Speaking states counted per spoken number (the paper's caption calls its total "the number of counts").

    tp / fn : spoken numbers of visible people judged speaking / silent (in at least / fewer than half of the
    results during the number in which the face was found; ``fn_missed_face``: found in none; ``fn_overlap``: missed
    numbers during which someone else spoke too). fp : stretches of consecutive results in which a found person was
    judged speaking that overlap none of that person's numbers.
    """

    tp: int = 0
    fn: int = 0
    fn_missed_face: int = 0
    fn_overlap: int = 0
    fp: int = 0

    def as_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {name: getattr(self, name) for name in self.__dataclass_fields__}
        d["tp_rate"] = json_number(self.tp_rate)
        return d


@dataclass(frozen=True, eq=False)
class Timeline:
    """One run's speaking states over time, for the timeline figure (:mod:`app.eval.figure`).

    stamps_s : (R,) the results' stamps; states : (R, N) per result and person, -1 not found, 0 judged silent,
    1 judged speaking; half_span_s : the time one result stands for (half a frame; half an interval for the
    motion-guided variant); missed : the spoken numbers counted FN, as (person, start, end) seconds;
    false_stretches : the stretches counted FP per spoken number, (person, start, end).
    """

    scenario: Scenario
    stamps_s: np.ndarray
    states: np.ndarray
    half_span_s: float
    missed: tuple[tuple[int, float, float], ...]
    false_stretches: tuple[tuple[int, float, float], ...]


@dataclass
class IdentityCounts:
    """Who is who over time, the multi-object tracking scores: IDF1 (Ristani et al. 2016, "Performance measures and
    a data set for multi-target, multi-camera tracking": the one-to-one map between true people and avhear's ids
    that agrees in the most results; IDTP the agreements, IDFN the visible people the map misses, IDFP avhear's
    people it does not explain) and identity switches (CLEAR MOT, Bernardin and Stiefelhagen 2008: a person matched
    to another id than at their previous match). Summed over seeds, each seed with its own map."""

    idtp: int = 0
    idfp: int = 0
    idfn: int = 0
    id_switches: int = 0

    @property
    def idf1(self) -> float:
        d = 2 * self.idtp + self.idfp + self.idfn
        return 2 * self.idtp / d if d else math.nan

    def add(self, other: IdentityCounts) -> None:
        self.idtp += other.idtp
        self.idfp += other.idfp
        self.idfn += other.idfn
        self.id_switches += other.id_switches

    def as_dict(self) -> dict[str, Any]:
        return {"idf1": json_number(self.idf1), "id_switches": self.id_switches, "idtp": self.idtp, "idfp": self.idfp,
                "idfn": self.idfn}


def identity_counts(matches: Sequence[Sequence[tuple[int, int]]], n_true: Sequence[int], n_found: Sequence[int]
                    ) -> IdentityCounts:
    """:class:`IdentityCounts` of a run. matches : per result (in time order) its (true person, avhear id) pairs
    matched within tau_loc; n_true : per result the visible true people; n_found : per result avhear's people."""
    from scipy.optimize import linear_sum_assignment

    pairs = [p for m in matches for p in m]
    out = IdentityCounts()
    if pairs:
        truths = sorted({g for g, _ in pairs})
        ids = sorted({i for _, i in pairs})
        together = np.zeros((len(truths), len(ids)))
        for g, i in pairs:
            together[truths.index(g), ids.index(i)] += 1
        rows, cols = linear_sum_assignment(-together)
        out.idtp = int(together[rows, cols].sum())
    out.idfn = int(sum(n_true)) - out.idtp
    out.idfp = int(sum(n_found)) - out.idtp
    last: dict[int, int] = {}
    for m in matches:
        for g, i in m:
            out.id_switches += int(g in last and last[g] != i)
            last[g] = i
    return out



@dataclass
class LipCue:
    """The lips' cue alone as a speaking detector (no sound): each found visible face's lip activity in every result
    (:attr:`app.result.Result.lip_activity`, NaN: no opinion), apart by whether the person speaks at that instant.
    AUC: the chance that a talker's activity is above a non-talker's (ties half; over the faces with an opinion);
    at the veto's threshold ``still_below``, the shares of talkers and of others whose lips move."""

    still_below: float
    talking: list[float] = field(default_factory=list, repr=False)
    silent: list[float] = field(default_factory=list, repr=False)

    def add(self, other: LipCue) -> LipCue:
        return LipCue(self.still_below, self.talking + other.talking, self.silent + other.silent)

    def as_dict(self) -> dict[str, Any]:
        t, s = np.asarray(self.talking, dtype=np.float64), np.asarray(self.silent, dtype=np.float64)
        n = t.size + s.size
        t, s = t[np.isfinite(t)], s[np.isfinite(s)]
        auc = math.nan
        if t.size and s.size:
            from scipy.stats import rankdata

            ranks = rankdata(np.concatenate([t, s]))[:t.size]  # Mann-Whitney: average ranks for ties
            auc = (ranks.sum() - t.size * (t.size + 1) / 2) / (t.size * s.size)
        return {"face_results": n, "no_opinion_share": json_number((n - t.size - s.size) / n if n else math.nan),
                "auc": json_number(auc), "still_below": self.still_below,
                "talkers_moving": json_number(float(np.mean(t >= self.still_below)) if t.size else math.nan),
                "others_moving": json_number(float(np.mean(s >= self.still_below)) if s.size else math.nan)}


def json_number(x: float) -> float | None:
    """``x`` rounded to 6 decimals for the JSON, None for NaN."""
    return None if math.isnan(x) else round(float(x), 6)


VOICE_TOLERANCE_DEG = 15.0  # a voice out of view counts as found within this of its talker's azimuth
VOICE_SILENT_HOLD_S = 0.4  # a result counts as "nobody unseen talks" when none does within this of its stamp


@dataclass
class VoiceCounts:
    """The voices out of view against the truth, per result: ``talking`` results where a person out of view speaks,
    ``found`` of them with a voice within :data:`VOICE_TOLERANCE_DEG` of that person's azimuth (``errors_deg`` the
    nearest voice's error in each); ``quiet`` results where nobody out of view speaks within
    :data:`VOICE_SILENT_HOLD_S`, ``false`` of them with a voice, ``false_stretches`` the runs of such results in a row
    (an invented voice, counted once however long it lasts, as a false stretch of speaking is)."""

    talking: int = 0
    found: int = 0
    quiet: int = 0
    false: int = 0
    errors_deg: list[float] = field(default_factory=list, repr=False)
    false_stretches: int = 0

    def add(self, other: VoiceCounts) -> VoiceCounts:
        return VoiceCounts(self.talking + other.talking, self.found + other.found, self.quiet + other.quiet,
                           self.false + other.false, self.errors_deg + other.errors_deg,
                           self.false_stretches + other.false_stretches)

    def as_dict(self) -> dict[str, Any]:
        median = float(np.median(self.errors_deg)) if self.errors_deg else math.nan
        within_10 = float(np.mean(np.asarray(self.errors_deg) <= 10.0)) if self.errors_deg else math.nan
        return {"results_unseen_talking": self.talking, "found_within_15deg": self.found,
                "found_share": json_number(self.found / self.talking if self.talking else math.nan),
                "median_azimuth_error_deg": json_number(median), "within_10deg_share": json_number(within_10),
                "results_nobody_unseen_talking": self.quiet, "false_voice_results": self.false,
                "false_voice_stretches": self.false_stretches}
