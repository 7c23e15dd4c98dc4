"""Scoring one run of a scenario against the simulator's truth (:func:`score_run`): per spoken number
(:class:`~app.eval.counts.UtteranceCounts`, the paper's unit), per visible person and 0.4 s interval with a timing
reference, per result and person with the edges forgiven (:mod:`app.eval.per_result`); the faces found, the F3D
error, the ITDs' accuracy (:func:`speech_line`) and the voices out of view.

The protocol in full (what one count is and why, the matching, the split of false alarms): docs/architecture.md
("Scoring the scenarios").
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from app.eval.counts import (
    INTERVAL_S,
    VOICE_SILENT_HOLD_S,
    VOICE_TOLERANCE_DEG,
    IdentityCounts,
    LipCue,
    SpeakingCounts,
    Timeline,
    UtteranceCounts,
    VoiceCounts,
    identity_counts,
    json_number,
)
from app.eval.per_result import ResultCounts, result_counts
from app.pipeline import PipelineConfig
from app.result import Result
from avcore.calibration import fit_av_calibration_report
from avcore.evaluation import TAU_LOC_M, FrameTruth, match_clusters
from avcore.geometry import MicPair
from avcore.itd import ItdTrack, extract_itds, geometry_options
from sim.scenario import Scenario

log = logging.getLogger(__name__)

__all__ = ["INTERVAL_S", "ITD_TOLERANCE_S", "LATERAL_ITD_S", "TIMING_REFERENCE_S", "ScenarioScore", "score_run",
           "speech_line", "voice_counts"]

Positions = Callable[[float], np.ndarray]

ITD_TOLERANCE_S = 40e-6
"""An extracted ITD is accurate when within 40 us of the talker's true ITD."""
TIMING_REFERENCE_S = 0.025
"""The timing reference of the per-interval view: the truth itself with each spoken number held this much longer at
both ends (less than one 32 ms frame of the ITD extractor)."""
LATERAL_ITD_S = 50e-6
"""Talkers whose true ITD is at least this far from zero count for the pull towards zero."""


@dataclass
class ScenarioScore:
    """The figures of one scenario (summed or pooled over its seeds)."""

    scenario: str
    inference: str
    seeds: list[int]
    duration_s: float
    counts: SpeakingCounts = field(default_factory=SpeakingCounts)
    utterances: UtteranceCounts = field(default_factory=UtteranceCounts)
    per_result: ResultCounts = field(default_factory=ResultCounts)  # per result x visible person (per_result.py)
    timing_reference: SpeakingCounts = field(default_factory=SpeakingCounts)
    n_intervals: int = 0
    n_frames: int = 0
    frames_all_found: int = 0
    visible_faces: int = 0
    faces_found: int = 0
    f3d_errors_m: list[float] = field(default_factory=list, repr=False)
    f3d_depths_m: list[tuple[float, float]] = field(default_factory=list, repr=False)  # (true, found) depth per face
    people_errors_m: list[float] = field(default_factory=list, repr=False)  # every result's matched people
    people_errors_paper_m: list[float] = field(default_factory=list, repr=False)  # motion: against their points
    identity: IdentityCounts = field(default_factory=lambda: IdentityCounts())
    itd_errors_s: list[float] = field(default_factory=list, repr=False)
    itd_true_s: list[float] = field(default_factory=list, repr=False)
    n_itds: int = 0
    speech: str = ""
    faces: str = ""
    timeline: Timeline | None = field(default=None, repr=False)  # of a single run; None once seeds are merged
    self_calibration: list[dict[str, Any]] = field(default_factory=list)  # per seed: where the first pair ended
    voices: VoiceCounts | None = None  # several pairs, face-guided: the voices out of view
    lips: LipCue | None = None  # with the lips' cue: each found visible face's lip activity against the truth

    @property
    def all_found_share(self) -> float:
        return self.frames_all_found / self.n_frames if self.n_frames else math.nan

    @property
    def face_recall(self) -> float:
        return self.faces_found / self.visible_faces if self.visible_faces else math.nan

    @property
    def f3d_median_m(self) -> float:
        return float(np.median(self.f3d_errors_m)) if self.f3d_errors_m else math.nan

    @property
    def depth_error_1_3m(self) -> float:
        """Median |found - true| / true depth of the faces found 1 to 3 m away (the one-camera target's range)."""
        d = np.asarray(self.f3d_depths_m, dtype=np.float64).reshape(-1, 2)
        near = (d[:, 0] >= 1.0) & (d[:, 0] <= 3.0)
        return float(np.median(np.abs(d[near, 1] - d[near, 0]) / d[near, 0])) if near.any() else math.nan

    @property
    def people_ale_m(self) -> float:
        """The mean localisation error of the people found (matched within tau_loc), over every result: against
        the faces (face-guided) or the moving bodies' centres (motion-guided)."""
        return float(np.mean(self.people_errors_m)) if self.people_errors_m else math.nan

    @property
    def people_ale_paper_m(self) -> float:
        """Motion-guided: the mean localisation error of the people found against the paper's truth (section 7.1),
        each person's mean of the result's HM3D points that lie on them (NaN face-guided: the faces are the truth)."""
        return float(np.mean(self.people_errors_paper_m)) if self.people_errors_paper_m else math.nan

    @property
    def itd_accuracy(self) -> float:
        e = np.abs(self.itd_errors_s)
        return float(np.mean(e <= ITD_TOLERANCE_S)) if e.size else math.nan

    @property
    def itd_bias_s(self) -> float:
        return float(np.median(self.itd_errors_s)) if self.itd_errors_s else math.nan

    @property
    def itd_pull_s(self) -> float:
        """Median pull of the ITDs towards zero for talkers off to the side (|true| >= 50 us), seconds."""
        true = np.asarray(self.itd_true_s)
        side = np.abs(true) >= LATERAL_ITD_S
        pull = -np.asarray(self.itd_errors_s)[side] * np.sign(true[side])
        return float(np.median(pull)) if pull.size else math.nan

    def merge(self, other: ScenarioScore) -> None:
        """Add the figures of another seed of the same scenario."""
        self.seeds += other.seeds
        self.timeline = None
        self.duration_s += other.duration_s
        self.counts.add(other.counts)
        self.utterances.add(other.utterances)
        self.per_result.add(other.per_result)
        self.timing_reference.add(other.timing_reference)
        for name in ("n_intervals", "n_frames", "frames_all_found", "visible_faces", "faces_found", "n_itds"):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.f3d_errors_m += other.f3d_errors_m
        self.f3d_depths_m += other.f3d_depths_m
        self.people_errors_m += other.people_errors_m
        self.people_errors_paper_m += other.people_errors_paper_m
        self.identity.add(other.identity)
        self.itd_errors_s += other.itd_errors_s
        self.itd_true_s += other.itd_true_s
        self.self_calibration += other.self_calibration
        if other.voices is not None:
            self.voices = other.voices if self.voices is None else self.voices.add(other.voices)
        if other.lips is not None:
            self.lips = other.lips if self.lips is None else self.lips.add(other.lips)

    def as_dict(self) -> dict[str, Any]:
        n_spoken = self.utterances.tp + self.utterances.fn
        return {
            "scenario": self.scenario,
            "inference": self.inference,
            "seeds": list(self.seeds),
            "duration_s": self.duration_s,
            "n_intervals": self.n_intervals,
            "speaking": self.counts.as_dict(),
            "speaking_per_utterance": self.utterances.as_dict(),
            "speaking_per_result": self.per_result.as_dict(),
            "speaking_timing_reference": self.timing_reference.as_dict(),
            "n_frames": self.n_frames,
            "frames_all_faces_found": json_number(self.all_found_share),
            "face_recall": json_number(self.face_recall),
            "f3d_median_error_m": json_number(self.f3d_median_m),
            "f3d_depth_error_1_3m": json_number(self.depth_error_1_3m),
            "people_ale_m": json_number(self.people_ale_m),
            "people_ale_paper_m": json_number(self.people_ale_paper_m),
            "identity": self.identity.as_dict(),
            "itd_windows_one_talker": len(self.itd_errors_s),
            "itd_accuracy_40us": json_number(self.itd_accuracy),
            "itd_median_bias_us": json_number(self.itd_bias_s * 1e6),
            "itd_median_pull_to_zero_us": json_number(self.itd_pull_s * 1e6),
            "itds_extracted": self.n_itds,
            "speech_clips": self.speech,
            "face_images": self.faces,
            **({"self_calibration": self.self_calibration} if self.self_calibration else {}),
            **({"voices_out_of_view": dict(self.voices.as_dict(), false_voice_stretches_per_spoken_number=json_number(
                self.voices.false_stretches / n_spoken if n_spoken else math.nan))} if self.voices is not None else {}),
            **({"lip_cue_alone": self.lips.as_dict()} if self.lips is not None else {}),
        }



def voice_counts(scenario: Scenario, fused: Sequence[Result]) -> VoiceCounts | None:
    """:class:`VoiceCounts` of a run whose results carry voices (None when they do not: one pair, motion)."""
    if not fused or all(r.voices is None for r in fused):
        return None
    out = VoiceCounts()
    in_false = False
    for r in fused:
        t = float(r.stamp_s)
        unseen = ~scenario.visible(t)
        talking = np.flatnonzero(scenario.speaking_at([t])[0] & unseen)
        azimuths = np.array([v.azimuth_rad for v in (r.voices or ())])
        if talking.size:
            out.talking += 1
            where = scenario.positions(t)[talking[0]]
            if azimuths.size:
                error = np.degrees(np.abs(np.angle(np.exp(1j * (azimuths - math.atan2(where[0], where[2]))))))
                out.errors_deg.append(float(error.min()))
                out.found += int(error.min() <= VOICE_TOLERANCE_DEG)
        elif not (scenario.speaking_at([t], hold_s=VOICE_SILENT_HOLD_S)[0] & unseen).any():
            out.quiet += 1
            out.false += int(azimuths.size > 0)
            out.false_stretches += int(azimuths.size > 0 and not in_false)
            in_false = azimuths.size > 0
            continue
        in_false = False
    return out


# ---------------------------------------------------------------------------------------------------------------
# running



def speech_line(scenario: Scenario, fused: Sequence[Result], mics: MicPair, *, reach_s: float,
                match_m: float = 0.3, least: int = 200) -> MicPair | None:
    """The correction c1, c0 of eq. (itd_up) that the scenario's own speech gives on the first pair: the ITDs of
    every result where one person talks alone (no other sound within ``reach_s`` of its stamp, the reach of its
    time frame's windows), each paired with that talker's face as found (within ``match_m`` of the truth), fitted
    as section 5.3 fits the loudspeaker's minute (:func:`fit_av_calibration_report`). None with fewer than
    ``least`` ITDs, or when the talkers' faces span too few directions to fix a scale (one person who stays
    still: the fit refuses it as it refuses such a loudspeaker minute).

    This is the line a self-calibration that learns from people talking can reach at best, given the truth of who
    talks: the loudspeaker's differs from it (a voice leaves from the mouth, the loudspeaker from a hand in front
    of the face; speech and white noise meet the room's reflections differently), so the gap between the two says
    how much of a self-calibration's distance to the loudspeaker is the speech's own.
    """
    faces: list[np.ndarray] = []
    itds: list[float] = []
    for r in fused:
        t = r.stamp_s
        near = [e for e in scenario.events if e.start_s < t + reach_s and e.end_s > t - reach_s]
        if len(near) != 1 or near[0].kind != "speech" or not r.xyz.shape[0] or not r.itds_s.shape[0]:
            continue
        d = np.linalg.norm(r.xyz - scenario.positions(t)[near[0].actor], axis=1)
        if d.min() > match_m:
            continue
        x = r.itds_s[:, 0]
        x = x[np.isfinite(x)]
        faces += [r.xyz[int(np.argmin(d))]] * x.size
        itds += x.tolist()
    if len(itds) < least:
        return None
    try:
        return fit_av_calibration_report(np.asarray(faces), np.asarray(itds), mics).mics
    except ValueError:  # the faces' span is too small for c1 (calibration._check_span)
        return None


# ---------------------------------------------------------------------------------------------------------------
# scoring


@dataclass(frozen=True)
class TruthTable:
    """The scenario's ground truth at every instant the scoring looks at, asked of the scenario once: the camera
    frames, the results (motion-guided results are stamped at interval centres, between frames), the middle of each
    spoken number and the ITD windows in which one person speaks. ``at(t)`` answers for those instants only."""

    times_s: np.ndarray
    truths: tuple[FrameTruth, ...]

    @classmethod
    def of(cls, scenario: Scenario, *times_s: Sequence[float] | np.ndarray) -> TruthTable:
        t = np.unique(np.concatenate([np.asarray(x, dtype=np.float64).reshape(-1) for x in times_s]))
        return cls(t, tuple(scenario.truth(float(v)) for v in t))

    def at(self, t_s: float) -> FrameTruth:
        i = int(np.searchsorted(self.times_s, t_s))
        if i == self.times_s.size or self.times_s[i] != t_s:
            raise KeyError(f"the truth table has no instant {t_s!r} s (build it with every instant to score)")
        return self.truths[i]


@dataclass
class _Judged:
    """What the results said per interval (K) and person (N): frames found and judged speaking, results with a
    face of nobody judged speaking, results; and per result (R, N) the state (-1 not found, 0 silent, 1 speaking)."""

    found: np.ndarray
    judged: np.ndarray
    false_speaking: np.ndarray
    results_per: np.ndarray
    states: np.ndarray
    stamps: np.ndarray
    id_matches: list = field(default_factory=list)  # per result: (true person, avhear id) pairs
    n_true: list = field(default_factory=list)  # per result: visible true people
    n_found: list = field(default_factory=list)  # per result: avhear's people


def _truth_per_interval(truths: list, frame_interval: np.ndarray, n_intervals: int, n_people: int
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(K, N) visible and speaking in most of the interval's frames, and speaking in any; (K,) frames."""
    vis_votes = np.zeros((n_intervals, n_people))
    speak_votes = np.zeros((n_intervals, n_people))
    frames_per = np.zeros(n_intervals)
    for k, tr in zip(frame_interval, truths):
        vis_votes[k] += tr.visible
        speak_votes[k] += tr.speaking
        frames_per[k] += 1
    half = frames_per[:, None] / 2
    return vis_votes > half, speak_votes > half, speak_votes > 0, frames_per


def _judge(table: TruthTable, n_people: int, fused: Sequence[Result], n_intervals: int, score: ScenarioScore,
           face_figures: bool, positions_at: Positions | None = None,
           points_truth: Callable[[Result], np.ndarray] | None = None) -> _Judged:
    """Match every result's people to the truth of its instant (the faces, or ``positions_at(stamp)``); with
    ``face_figures``, also the per-frame visual figures (the F3D faces) into ``score``; with ``points_truth``
    (result -> (N, 3), NaN where unknown) the matched people's errors against it too; the visible matched faces'
    lip activity into ``score.lips`` where the results carry it."""
    ordered = sorted(fused, key=lambda f: f.stamp_s)
    out = _Judged(np.zeros((n_intervals, n_people)), np.zeros((n_intervals, n_people)), np.zeros(n_intervals),
                  np.zeros(n_intervals), np.full((len(ordered), n_people), -1),
                  np.array([r.stamp_s for r in ordered]))
    for j, r in enumerate(ordered):
        k = min(int(r.stamp_s / INTERVAL_S + 1e-9), n_intervals - 1)
        tr = table.at(r.stamp_s)
        xyz, judged_speaking = r.positions, r.speaking
        truth_xyz = tr.positions_m if positions_at is None else positions_at(r.stamp_s)
        match = match_clusters(xyz, truth_xyz, tau_loc=TAU_LOC_M)
        out.results_per[k] += 1
        matched = set()
        ids = np.asarray(r.person_ids).ravel()
        visible = tr.visible & np.isfinite(truth_xyz).all(axis=1)
        out.id_matches.append([(int(g), int(ids[d])) for g, d in match.pairs if visible[g]])
        out.n_true.append(int(visible.sum()))
        out.n_found.append(int(xyz.shape[0]))
        for g, d in match.pairs:
            out.found[k, g] += 1
            out.judged[k, g] += bool(judged_speaking[d])
            out.states[j, g] = int(bool(judged_speaking[d]))
            matched.add(d)
        out.false_speaking[k] += bool(any(judged_speaking[d] for d in range(xyz.shape[0]) if d not in matched))
        score.people_errors_m += [float(e) for e in match.errors_m]
        if points_truth is not None and match.pairs:
            paper = points_truth(r)
            score.people_errors_paper_m += [float(np.linalg.norm(xyz[d] - paper[g])) for g, d in match.pairs
                                            if np.isfinite(paper[g]).all()]
        if r.lip_activity is not None and score.lips is not None:
            for g, d in match.pairs:
                if tr.visible[g]:
                    (score.lips.talking if tr.speaking[g] else score.lips.silent).append(float(r.lip_activity[d]))
        if face_figures:
            vis = np.flatnonzero(tr.visible)
            hit = {g for g, _ in match.pairs}
            score.n_frames += 1
            score.visible_faces += int(vis.size)
            score.faces_found += sum(int(g in hit) for g in vis)
            score.frames_all_found += int(all(g in hit for g in vis))
            score.f3d_errors_m += [float(e) for (g, _), e in zip(match.pairs, match.errors_m) if tr.visible[g]]
            score.f3d_depths_m += [(float(truth_xyz[g, 2]), float(xyz[d, 2])) for g, d in match.pairs if tr.visible[g]]
    return out


def score_run(scenario: Scenario, fused: Sequence[Result], audio: np.ndarray, samplerate_hz: float, mics: MicPair,
              config: PipelineConfig, *, frame_stamps_s: np.ndarray, positions_at: Positions | None = None,
              points_truth: Callable[[Result], np.ndarray] | None = None) -> ScenarioScore:
    """Score the fused results of one run of ``scenario`` (see the module docstring for the protocol).

    fused : the results in any order (stamps in seconds from the scenario's start); what counts of each is its
    people's positions and speaking states (:attr:`Result.positions`, ``speaking``). audio : (n, 2) the microphone
    signals (left, right), full scale 1. frame_stamps_s : (F,) the stamps of the camera frames, seconds.
    positions_at : where the people are for the matching, ``stamp -> (N, 3)`` metres; default the faces of
    :meth:`Scenario.truth` (see :func:`evaluate_scenario` for the motion-guided truth). points_truth : the
    paper's truth of a motion-guided result, ``result -> (N, 3)`` (each person's mean of its own points), scored
    as a second error of the people matched.
    """
    motion = config.inference == "motion"
    n_people = len(scenario.actors)
    score = ScenarioScore(scenario.name, config.inference, [scenario.seed], float(scenario.duration_s))
    n_intervals = math.ceil(scenario.duration_s / INTERVAL_S - 1e-9)
    score.n_intervals = n_intervals
    score.lips = LipCue(config.lip_still_below) if config.lips else None
    track, one_talker = _itd_windows(scenario, audio, samplerate_hz, mics, config)
    speech = [e for e in scenario.events if e.kind == "speech"]
    table = TruthTable.of(scenario, frame_stamps_s, [r.stamp_s for r in fused],
                          [0.5 * (e.start_s + e.end_s) for e in speech], [track.times_s[i] for i, _ in one_talker])
    truths = [table.at(float(t)) for t in frame_stamps_s]
    frame_interval = np.minimum((np.asarray(frame_stamps_s) / INTERVAL_S + 1e-9).astype(int), n_intervals - 1)
    visible, speaking, spoke, frames_per = _truth_per_interval(truths, frame_interval, n_intervals, n_people)
    j = _judge(table, n_people, fused, n_intervals, score, face_figures=not motion, positions_at=positions_at,
               points_truth=points_truth)
    score.counts = _interval_counts(visible, speaking, spoke, j.found, j.judged, j.false_speaking, j.results_per)
    score.identity = identity_counts(j.id_matches, j.n_true, j.n_found)
    # the timing reference: the truth itself, each speaking state held TIMING_REFERENCE_S longer at both ends
    held = scenario.speaking_at(frame_stamps_s, hold_s=TIMING_REFERENCE_S)
    seen = np.array([tr.visible for tr in truths], dtype=bool).reshape(-1, n_people)
    ref_found, ref_judged = np.zeros((n_intervals, n_people)), np.zeros((n_intervals, n_people))
    np.add.at(ref_found, frame_interval, seen)
    np.add.at(ref_judged, frame_interval, seen & held)
    score.timing_reference = _interval_counts(visible, speaking, spoke, ref_found, ref_judged, np.zeros(n_intervals),
                                              frames_per)
    frame_period_s = float(np.median(np.diff(frame_stamps_s))) if len(frame_stamps_s) > 1 else 1 / 30
    half_span = INTERVAL_S / 2 if motion else frame_period_s / 2  # the time one result stands for
    score.utterances, missed, false_stretches = _utterance_counts(speech, table, j.stamps, j.states, half_span)
    score.timeline = Timeline(scenario, j.stamps, j.states, half_span, tuple(missed), tuple(false_stretches))
    if not motion:  # what a robot acts on: each result and visible person, the edges of the speech forgiven
        visible = np.array([table.at(float(t)).visible for t in j.stamps], dtype=bool).reshape(-1, n_people)
        own = [[(e.start_s, e.end_s) for e in speech if e.actor == i] for i in range(n_people)]
        score.per_result = result_counts(j.stamps, j.states, visible, own, half_span_s=half_span)
    # the ITD accuracy: eq. (itd) at the talker's mouth, with the pair's correction
    score.itd_true_s = [mics.c1 * float(table.at(float(track.times_s[i])).itds_s[actor]) + mics.c0
                        for i, actor in one_talker]
    score.itd_errors_s = [float(track.itds_s[i]) - true for (i, _), true in zip(one_talker, score.itd_true_s)]
    score.n_itds = len(track.itds_s)
    return score


def _interval_counts(visible: np.ndarray, speaking: np.ndarray, spoke: np.ndarray, found: np.ndarray,
                     judged: np.ndarray, false_speaking: np.ndarray, results_per: np.ndarray) -> SpeakingCounts:
    """Count per visible person and interval (see the module docstring). visible, speaking, spoke : (K, N) bool,
    the truth per interval (spoke: speaking in at least one frame); found, judged : (K, N) results in which each
    person was found / judged speaking; false_speaking, results_per : (K,) results with a face of nobody judged
    speaking / all results."""
    c = SpeakingCounts()
    unseen_talks = np.any(speaking & ~visible, axis=1)
    for k in range(visible.shape[0]):
        for i in range(visible.shape[1]):
            if not visible[k, i]:
                continue
            is_found = bool(found[k, i] > 0)
            said = bool(is_found and judged[k, i] > found[k, i] / 2)
            if speaking[k, i]:
                c.tp += said
                c.fn += not said
                c.fn_missed_face += not is_found
                c.fn_overlap += (not said) and int(speaking[k].sum()) > 1
            else:
                c.fp += said
                c.tn += not said
                c.fp_partly_spoken += said and bool(spoke[k, i])
                if unseen_talks[k]:
                    c.silent_while_unseen_talks += 1
                    c.fp_while_unseen_talks += said
        if results_per[k] and false_speaking[k] > results_per[k] / 2:
            c.fp += 1
            c.fp_false_face += 1
    return c


def _utterance_counts(speech: Sequence[Any], table: TruthTable, stamps_s: np.ndarray, states: np.ndarray,
                      half_span_s: float) -> tuple[UtteranceCounts, list[tuple[int, float, float]],
                                                   list[tuple[int, float, float]]]:
    """Count per spoken number (see :class:`UtteranceCounts`). speech : the scenario's speech events, in order;
    stamps_s : (R,) result stamps; states : (R, N) -1 not
    found, 0 judged silent, 1 judged speaking; each result covers +- ``half_span_s`` around its stamp. Also returns
    the missed numbers and the false stretches, each as (person, start, end) seconds."""
    out = UtteranceCounts()
    missed: list[tuple[int, float, float]] = []
    false_stretches: list[tuple[int, float, float]] = []
    for e in speech:
        if not table.at(0.5 * (e.start_s + e.end_s)).visible[e.actor]:
            continue
        during = (stamps_s + half_span_s > e.start_s) & (stamps_s - half_span_s < e.end_s)
        st = states[during, e.actor]
        st = st[st >= 0]
        if st.size and np.sum(st == 1) >= st.size / 2:
            out.tp += 1
        else:
            out.fn += 1
            missed.append((e.actor, e.start_s, e.end_s))
            out.fn_missed_face += int(st.size == 0)
            out.fn_overlap += any(o.actor != e.actor and o.start_s < e.end_s and o.end_s > e.start_s for o in speech)
    for i in range(states.shape[1]):
        own = [(e.start_s, e.end_s) for e in speech if e.actor == i]
        found = np.flatnonzero(states[:, i] >= 0)
        run: list[int] = []
        for j in list(found) + [-1]:  # -1 closes the last run
            if j >= 0 and states[j, i] == 1:
                run.append(j)
                continue
            if run:
                a, b = stamps_s[run[0]] - half_span_s, stamps_s[run[-1]] + half_span_s
                if not any(s < b and t > a for s, t in own):
                    out.fp += 1
                    false_stretches.append((i, float(a), float(b)))
                run = []
    return out, missed, false_stretches


def _itd_windows(scenario: Scenario, audio: np.ndarray, samplerate_hz: float, mics: MicPair,
                 config: PipelineConfig) -> tuple[ItdTrack, list[tuple[int, int]]]:
    """The ITDs of the pair's signals (the extractor and settings of the pipeline's ITD worker), and the windows in
    which exactly one person sounds, and it is speech: (window index, that person)."""
    extra = geometry_options(config.itd_method, mics.distance_m, mics.speed_of_sound)
    track = extract_itds(audio[:, 0], audio[:, 1], samplerate_hz, method=config.itd_method,
                         window_s=config.window_s, hop_s=config.hop_s, energy_threshold=config.energy_threshold,
                         max_itd_s=1.2 * mics.max_itd_s, **extra)
    half = config.window_s / 2
    windows = []
    for i, t in enumerate(track.times_s):
        events = [e for e in scenario.events if e.start_s < t + half and e.end_s > t - half]
        if len({e.actor for e in events}) == 1 and all(e.kind == "speech" for e in events):
            windows.append((i, events[0].actor))
    return track, windows
