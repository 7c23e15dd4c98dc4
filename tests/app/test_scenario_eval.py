"""`avhear eval scenarios` (issue 5, section 4): the scenarios of section 7.3 through the real pipeline, scored.

The protocol is checked on its own (perfect and wrong detections built from the truth, no simulation), then short
S1 and S2 runs go through the whole command, and a short calibration preset through the c1, c0 fit.
"""
from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pytest

from app.cli import main
from app.pipeline import PipelineConfig
from app.result import Result
from app.eval.scenarios import PAPER_SCENARIOS, calibrate_on_preset
from app.eval.scoring import INTERVAL_S, ScenarioScore, score_run, speech_line
from app.sources.sim import load_clip_bank
from sim.scenario import FrameTruth, Scenario, make_scenario

FPS = 30.0


def _scenario(name: str, duration_s: float = 8.0) -> Scenario:
    return make_scenario(name, clip_durations_s=[[0.5] * 10] * 3, duration_s=duration_s, seed=3)


def _frames(make: Callable[..., Result], scenario: Scenario, judge: Callable[[FrameTruth], np.ndarray]
            ) -> tuple[list[Result], np.ndarray]:
    """One fused result per camera frame: the visible people at their true positions, speaking as ``judge`` says."""
    stamps = np.arange(int(scenario.duration_s * FPS)) / FPS
    fused = []
    for t in stamps:
        tr = scenario.truth(float(t))
        vis = tr.visible
        fused.append(make(float(t), tr.positions_m[vis] + 0.01, judge(tr)[vis]))
    return fused, stamps


def _score(scenario: Scenario, fused: list[Result], stamps: np.ndarray) -> ScenarioScore:
    silence = np.zeros((int(scenario.duration_s * 16000), 2))
    return score_run(scenario, fused, silence, 16000.0, scenario.mics, PipelineConfig(), frame_stamps_s=stamps)


def _truth_counts(scenario: Scenario, stamps: np.ndarray) -> tuple[int, int]:
    """(speaking, silent) visible person-intervals by the majority rule, counted independently of score_run."""
    k = (stamps / INTERVAL_S + 1e-9).astype(int)
    speaking = silent = 0
    for interval in np.unique(k):
        truths = [scenario.truth(float(t)) for t in stamps[k == interval]]
        vis = np.mean([tr.visible for tr in truths], axis=0) > 0.5
        spk = np.mean([tr.speaking for tr in truths], axis=0) > 0.5
        speaking += int(np.sum(vis & spk))
        silent += int(np.sum(vis & ~spk))
    return speaking, silent


def test_perfect_detections_score_every_speaking_count_as_tp(people_result: Callable[..., Result]) -> None:
    scenario = _scenario("S2")
    fused, stamps = _frames(people_result, scenario, lambda tr: tr.speaking)
    score = _score(scenario, fused, stamps)
    c = score.counts
    speaking, silent = _truth_counts(scenario, stamps)
    assert speaking > 0 and silent > 0
    assert (c.tp, c.fn, c.fp, c.tn) == (speaking, 0, 0, silent)
    assert score.n_intervals == 20 and score.n_frames == len(stamps)
    numbers = [e for e in scenario.events if e.kind == "speech"]
    u = score.utterances
    assert (u.tp, u.fn, u.fp) == (len(numbers), 0, 0)
    assert score.all_found_share == 1.0
    assert score.f3d_median_m == pytest.approx(0.01 * np.sqrt(3))
    assert score.itd_errors_s == [] and score.n_itds == 0  # silence: no ITD passes the energy gate
    r = score.per_result  # the same truth per result and person: every count right, nothing forgiven to need
    assert r.precision == r.recall == r.precision_forgiven == r.recall_forgiven == 1.0
    assert r.utterances == len(numbers) and r.heard == len(numbers) and r.false_stretches == 0
    assert r.tp + r.fp + r.fn + r.tn == sum(int(scenario.truth(float(t)).visible.sum()) for t in stamps)


def test_wrong_states_and_missed_faces_are_counted(people_result: Callable[..., Result]) -> None:
    scenario = _scenario("S2")
    fused, stamps = _frames(people_result, scenario, lambda tr: ~tr.speaking)  # everything inverted
    c = _score(scenario, fused, stamps).counts
    speaking, silent = _truth_counts(scenario, stamps)
    assert (c.tp, c.fn, c.fp, c.tn) == (0, speaking, silent, 0)
    assert c.fn_missed_face == 0 and c.fp_false_face == 0
    u = _score(scenario, fused, stamps).utterances
    assert u.tp == 0 and u.fn == sum(e.kind == "speech" for e in scenario.events) and u.fp > 0
    r = _score(scenario, fused, stamps).per_result
    assert r.tp == 0 and r.recall == 0.0 and r.heard == 0 and r.recall_forgiven == 0.0
    assert r.precision_forgiven < 0.3  # the calls that touch the own numbers (+-0.3 s) are forgiven, no more
    # nobody detected at all: every speaking count is a missed face, and there is nothing to call a false positive
    empty = [people_result(f.stamp_s, np.zeros((0, 3)), np.zeros(0, bool)) for f in fused]
    c = _score(scenario, empty, stamps).counts
    assert (c.tp, c.fn, c.fn_missed_face, c.fp, c.tn) == (0, speaking, speaking, 0, silent)
    # a face where nobody is, always speaking: one false-face FP per interval
    ghost = [people_result(f.stamp_s, np.vstack([f.xyz, [[0.0, 0.5, 4.0]]]), np.append(f.speaking, True))
             for f in _frames(people_result, scenario, lambda tr: tr.speaking)[0]]
    c = _score(scenario, ghost, stamps).counts
    assert c.fp == c.fp_false_face == 20 and c.tp == speaking


def test_timing_reference_scores_the_truth_held_longer(people_result: Callable[..., Result], monkeypatch: pytest.MonkeyPatch) -> None:
    """The per-interval timing reference counts what a detector that knows the truth, but holds each number
    TIMING_REFERENCE_S longer at both ends, would score; held 0 s it is the truth's own counts."""
    import app.eval.scoring as scenario_eval

    scenario = _scenario("S2")
    speech = [e for e in scenario.events if e.kind == "speech"]
    speaking, silent = _truth_counts(scenario, np.arange(int(scenario.duration_s * FPS)) / FPS)
    for hold in (scenario_eval.TIMING_REFERENCE_S, 0.2, 0.0):
        def held(tr: FrameTruth, hold: float = hold) -> np.ndarray:
            return np.array([any(e.actor == i and e.start_s - hold < tr.time_s < e.end_s + hold for e in speech)
                             for i in range(len(scenario.actors))])

        monkeypatch.setattr(scenario_eval, "TIMING_REFERENCE_S", hold)
        fused, stamps = _frames(people_result, scenario, held)
        score = _score(scenario, fused, stamps)
        r = score.timing_reference
        assert (r.tp, r.fn, r.fp, r.tn) == (score.counts.tp, score.counts.fn, score.counts.fp, score.counts.tn)
        assert r.tp == speaking and r.fn == 0 and r.fp + r.tn == silent
        if hold == 0.2:
            assert r.fp > 0  # held as long as the fusion's time frame: pauses turn into false alarms
        if hold == 0.0:
            assert r.fp == 0


def test_false_alarms_split_into_partly_spoken_and_wholly_silent_intervals(people_result: Callable[..., Result]) -> None:
    """An FP falls either in an interval where the person speaks in some (fewer than half) of the frames, a matter
    of timing, or in one where they say nothing at all; counted here independently of score_run."""
    scenario = _scenario("S2")
    speech = [e for e in scenario.events if e.kind == "speech"]

    def held(tr: FrameTruth) -> np.ndarray:  # the truth held 0.2 s longer: false alarms from timing alone
        return np.array([any(e.actor == i and e.start_s - 0.2 < tr.time_s < e.end_s + 0.2 for e in speech)
                         for i in range(len(scenario.actors))])

    for judge in (held, lambda tr: ~tr.speaking):
        fused, stamps = _frames(people_result, scenario, judge)
        c = _score(scenario, fused, stamps).counts
        k = (stamps / INTERVAL_S + 1e-9).astype(int)
        partly = wholly = 0
        for interval in np.unique(k):
            truths = [scenario.truth(float(t)) for t in stamps[k == interval]]
            vis = np.mean([tr.visible for tr in truths], axis=0) > 0.5
            share = np.mean([tr.speaking for tr in truths], axis=0)
            said = np.mean([judge(tr) for tr in truths], axis=0) > 0.5
            false_alarm = vis & (share <= 0.5) & said
            partly += int(np.sum(false_alarm & (share > 0)))
            wholly += int(np.sum(false_alarm & (share == 0)))
        assert partly > 0 and wholly + partly == c.fp
        assert (c.fp_partly_spoken, c.fp_wholly_silent) == (partly, wholly)
        assert c.as_dict()["fp_wholly_silent"] == wholly


def test_missed_numbers_during_someone_elses_speech_are_counted_as_overlap(people_result: Callable[..., Result]) -> None:
    scenario = _scenario("S5", duration_s=15.0)
    fused, stamps = _frames(people_result, scenario, lambda tr: np.zeros_like(tr.speaking))  # nobody ever judged speaking
    u = _score(scenario, fused, stamps).utterances
    speech = [e for e in scenario.events if e.kind == "speech"]
    visible = [e for e in speech if scenario.visible(0.5 * (e.start_s + e.end_s))[e.actor]]
    overlapped = [e for e in visible
                  if any(o.actor != e.actor and o.start_s < e.end_s and o.end_s > e.start_s for o in speech)]
    assert u.tp == 0 and u.fn == len(visible)
    assert 0 < len(overlapped) < len(visible)  # S5's talkers are independent: some numbers overlap, not all
    assert u.fn_overlap == len(overlapped)
    # S2's people count in turns: a miss there is never an overlap
    s2 = _scenario("S2")
    fused, stamps = _frames(people_result, s2, lambda tr: np.zeros_like(tr.speaking))
    u2 = _score(s2, fused, stamps).utterances
    assert u2.fn > 0 and u2.fn_overlap == 0


def test_s4_counts_the_unseen_talker_apart(people_result: Callable[..., Result]) -> None:
    scenario = _scenario("S4", duration_s=10.0)
    assert not scenario.truth(1.0).visible[0]  # person0 sits outside the field of view
    fused, stamps = _frames(people_result, scenario, lambda tr: np.ones_like(tr.speaking))  # every visible person "speaks"
    c = _score(scenario, fused, stamps).counts
    assert c.silent_while_unseen_talks > 0
    assert c.fp_while_unseen_talks == c.silent_while_unseen_talks  # all of them were turned into speakers
    assert c.unseen_fp_rate == 1.0


def test_eval_scenarios_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "scenarios", "--scenario", "S2", "--duration", "4", "--no-calibrate", "--json"]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["protocol"]["interval_s"] == INTERVAL_S and out["inference"] == "face" and out["seeds"] == [0]
    from app.hearing import detector_name
    from app.pipeline import PipelineConfig

    assert out["face_detector"] == detector_name(PipelineConfig()) and out["tflite_runtime"] == "opencv"
    (row,) = out["results"]
    assert row["scenario"] == "S2" and row["n_intervals"] == 10 and row["n_frames"] == 120
    s = row["speaking"]
    # three seated people, all visible: every person-interval is one of TP, FN, FP, TN
    assert s["tp"] + s["fn"] + s["fp"] + s["tn"] == 3 * 10
    assert s["tp"] + s["fn"] > 0 and s["fn_missed_face"] <= s["fn"] and s["fp_false_face"] == 0
    ref = row["speaking_timing_reference"]  # the same person-intervals, judged by the truth held 25 ms longer
    assert ref["tp"] + ref["fn"] == s["tp"] + s["fn"] and ref["fn"] == 0
    assert ref["tp"] + ref["fn"] + ref["fp"] + ref["tn"] == 3 * 10
    u = row["speaking_per_utterance"]
    # every number said in these 4 s is a TP or an FN (all three people are visible)
    bank = load_clip_bank(16000)
    said = [e for e in make_scenario("S2", clip_durations_s=bank.durations_s, duration_s=4.0, seed=0).events
            if e.kind == "speech"]
    assert len(said) >= 3 and u["tp"] + u["fn"] == len(said)
    assert f"S2 seed 0: per spoken number TP {u['tp']}, FN {u['fn']}, FP {u['fp']} " in captured.err  # as the table
    assert 0.0 <= row["frames_all_faces_found"] <= 1.0 and row["f3d_median_error_m"] < 0.1
    assert 0.0 < row["people_ale_m"] < 0.05  # the people found lie within centimetres of the faces
    assert row["identity"]["idf1"] > 0.9 and row["identity"]["id_switches"] <= 1
    assert row["itd_windows_one_talker"] > 0 and 0.0 <= row["itd_accuracy_40us"] <= 1.0
    assert out["paper"]["S2"] == PAPER_SCENARIOS["S2"] == {"fp": 22, "fn": 31, "tp": 176}
    assert "tp_at_least_95" in out["targets"]["per_interval"]["S2"]
    assert "tp_at_least_95" in out["targets"]["per_spoken_number"]["S2"]
    assert "S2 seed 0" in captured.err  # progress on stderr, the JSON alone on stdout


def test_eval_scenarios_runs_s6_which_the_paper_has_not(capsys: pytest.CaptureFixture[str]) -> None:
    """S6 has no row in the paper's table: its JSON and its table say so (and the lips' table comes only with the
    lips read: test_reading_the_lips_reports_the_lips_alone runs S6's JSON with them)."""
    assert main(["eval", "scenarios", "--scenario", "S6", "--duration", "3", "--no-calibrate", "--lips",
                 "--read-lips", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (row,) = out["results"]
    assert row["scenario"] == "S6" and out["paper"] == {"S6": None}
    target = out["targets"]["per_spoken_number"]["S6"]
    assert target["paper_fp_per_speaking_count"] is None and target["fp_at_most_half_paper"] is None
    lips = row["lip_cue_alone"]  # the lips alone, scored as a speaking detector
    assert lips["face_results"] > 100 and 0.0 <= lips["auc"] <= 1.0 and lips["still_below"] == 0.012
    assert main(["eval", "scenarios", "--scenario", "S6", "--duration", "3", "--no-calibrate", "--lips",
                 "--no-read-lips"]) == 0
    table = capsys.readouterr().out
    assert "S6     paper: not in it" in table
    assert "The lips alone" not in table  # moving mouths, but not read: no table of the lips alone


def test_eval_scenarios_table(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "scenarios", "--scenario", "S1", "--duration", "3", "--no-calibrate"]) == 0
    out = capsys.readouterr().out
    assert "section 7.3" in out and "paper (NAO, published)" in out and "avhear face-guided" in out
    assert "149  (86.6%)" in out  # the paper's S1 row
    assert "Per spoken number" in out and "Front end per scenario" in out and "Targets (beyond the paper's table)" in out
    assert "truth held +-25 ms" in out  # the per-interval timing reference row
    assert "per interval      S1:" in out and "; truth held +-25 ms: " in out  # and beside the per-interval target
    assert "FP partly spoken" in out and "FP wholly silent" in out and "; FP/spk wholly silent: " in out


def test_eval_scenarios_motion_guided(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "scenarios", "--scenario", "S1", "--duration", "3", "--no-calibrate", "--motion", "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)["results"]
    s = row["speaking"]
    assert row["inference"] == "motion" and row["n_intervals"] == 8
    # one person, visible in every interval: each interval is one of TP, FN, FP, TN (plus any false cluster)
    assert s["tp"] + s["fn"] + s["fp"] - s["fp_false_face"] + s["tn"] == 8
    assert row["n_frames"] == 0 and row["f3d_median_error_m"] is None  # no F3D faces in the motion-guided variant
    assert 0.0 < row["people_ale_m"] < 0.15  # against the moving body's centre
    # against the paper's truth, the mean of the person's own points: Algorithm 1's cluster mean is that mean
    # when the person's points are grouped whole, as one person's are
    assert 0.0 <= row["people_ale_paper_m"] < 0.02


def test_eval_scenarios_runs_the_papers_algorithm_1_beside_avhears(capsys: pytest.CaptureFixture[str]) -> None:
    """--motion-variant paper runs Algorithm 1 as written and names it so; without --motion it is refused."""
    assert main(["eval", "scenarios", "--scenario", "S1", "--duration", "3", "--no-calibrate", "--motion",
                 "--motion-variant", "paper"]) == 0
    out = capsys.readouterr().out
    assert "paper's Alg. 1 (here)" in out and "avhear motion-guided" not in out and "body [m]" in out
    assert main(["eval", "scenarios", "--scenario", "S1", "--motion-variant", "paper"]) == 2
    assert "add --motion" in capsys.readouterr().err
    from app.hearing import hearing_mode
    from app.pipeline import PipelineConfig
    from avcore.geometry import MicPair
    from avcore.inference import MotionGuidedParams

    def params(variant: str) -> MotionGuidedParams:
        config = PipelineConfig(inference="motion", motion_variant=variant)  # type: ignore[arg-type]
        return hearing_mode(config).hearing(MicPair()).params

    assert params("paper") == MotionGuidedParams.paper() and params("avhear") == MotionGuidedParams()


def test_calibration_on_the_preset_shrinks_the_residuals() -> None:
    fit = calibrate_on_preset(duration_s=6.0)  # a short zig-zag; the command uses the preset's 40 s
    assert fit.n_pairs > 100 and 0.4 < fit.mics.c1 < 1.2
    assert fit.median_abs_after_s < fit.median_abs_before_s
    assert set(fit.as_dict()) >= {"c1", "c0_us", "median_abs_residual_after_us"}


def test_a_laptops_pair_is_calibrated_on_its_own_microphones() -> None:
    """The calibration fits the pair the robot has: a laptop's two microphones 10 cm apart (their largest ITD about
    290 us, against the default pair's 350) get their own c1, c0; an array of several pairs gets none, and a
    correction cannot be given to one."""
    from app.eval.scenarios import evaluate_scenario
    from avcore.geometry import MicArray

    fit = calibrate_on_preset(duration_s=6.0, mic_array="laptop")
    laptop = MicArray.preset("laptop").pair(0)
    assert fit.mics.left == laptop.left and fit.mics.right == laptop.right
    assert fit.median_abs_after_s < fit.median_abs_before_s and 0.4 < fit.mics.c1 < 1.2
    with pytest.raises(ValueError, match="several"):
        calibrate_on_preset(duration_s=6.0, mic_array="nao")
    with pytest.raises(ValueError, match="one pair"):
        evaluate_scenario("S1", mics=fit.mics, mic_array="nao")


def test_eval_scenarios_bad_arguments(capsys: pytest.CaptureFixture[str]) -> None:
    for argv, option in ((["--seed", "-1"], "--seed"), (["--itd-method", "nope"], "--itd-method")):
        with pytest.raises(SystemExit) as stop:  # refused when parsed
            main(["eval", "scenarios", *argv])
        assert stop.value.code == 2 and f"argument {option}" in capsys.readouterr().err
    assert main(["eval", "scenarios", "--duration", "0.5"]) == 2
    assert "--duration" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["eval", "scenarios", "--vote-frames", "4"])
    assert "argument --vote-frames: expected an odd number" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["eval", "scenarios", "--scenario", "S9"])
    assert "invalid choice" in capsys.readouterr().err


def test_eval_scenarios_frame_itds_switch() -> None:
    from app.cli import build_parser

    parser = build_parser()
    assert parser.parse_args(["eval", "scenarios"]).frame_itds is True
    assert parser.parse_args(["eval", "scenarios", "--no-frame-itds"]).frame_itds is False
    assert parser.parse_args(["eval", "scenarios"]).vote_frames == 9
    assert parser.parse_args(["eval", "scenarios", "--vote-frames", "1"]).vote_frames == 1


def test_motion_guided_results_are_matched_to_the_positions_given(people_result: Callable[..., Result]) -> None:
    """The motion-guided scoring matches people to ``positions_at`` (the centres of the moving bodies), not to the
    faces: results 0.45 m below the faces (beyond tau_loc) are the people there, and nobody at the faces."""
    scenario = _scenario("S2")
    below = np.array([0.0, 0.45, 0.0])
    stamps = (np.arange(int(scenario.duration_s / INTERVAL_S)) + 0.5) * INTERVAL_S
    fused = []
    for t in stamps:
        tr = scenario.truth(float(t))
        fused.append(people_result(float(t), tr.positions_m[tr.visible] + below, tr.speaking[tr.visible]))
    silence = np.zeros((int(scenario.duration_s * 16000), 2))
    frames = np.arange(int(scenario.duration_s * FPS)) / FPS

    def score(positions_at: Callable[[float], np.ndarray] | None) -> ScenarioScore:
        return score_run(scenario, fused, silence, 16000.0, scenario.mics, PipelineConfig(inference="motion"),
                         frame_stamps_s=frames, positions_at=positions_at)

    at_bodies = score(lambda t: scenario.positions(t) + below).counts
    assert at_bodies.tp > 0 and at_bodies.fn_missed_face == 0 and at_bodies.fp_false_face == 0
    at_faces = score(None).counts
    assert at_faces.tp == 0 and at_faces.fn_missed_face == at_faces.fn == at_bodies.tp + at_bodies.fn


def test_evaluate_scenario_scores_motion_on_the_moving_bodies(monkeypatch: pytest.MonkeyPatch) -> None:
    """evaluate_scenario runs the real pipeline and hands the real scoring the simulated source's body centres
    (motion-guided; face-guided, none). The scorer is observed, not replaced: the score is the run's."""
    from app.eval import scenarios

    seen: dict[str, object] = {}
    real = scenarios.score_run

    def observe(*args: object, positions_at: object = None, **kwargs: object) -> ScenarioScore:
        seen["positions_at"] = positions_at
        return real(*args, positions_at=positions_at, **kwargs)

    monkeypatch.setattr(scenarios, "score_run", observe)
    motion = scenarios.evaluate_scenario("S1", 0, duration_s=3.0, config=PipelineConfig(inference="motion"),
                                         bodies=True)
    body = seen["positions_at"](1.5)  # type: ignore[operator]
    face = make_scenario("S1", clip_durations_s=[[0.5] * 10], duration_s=3.0).positions(1.5)
    assert body.shape == (1, 3) and 0.1 < body[0, 1] - face[0, 1] < 0.4  # on the chest, below the face
    u = motion.utterances
    assert u.tp + u.fn >= 2 and u.tp >= 1  # the person counts aloud and is heard where the body is
    faces = scenarios.evaluate_scenario("S1", 0, duration_s=3.0, config=PipelineConfig(inference="face"),
                                        bodies=True)
    assert seen["positions_at"] is None
    assert faces.utterances.tp + faces.utterances.fn == u.tp + u.fn  # the same spoken numbers, scored on faces


def test_eval_scenarios_draws_bodies_unless_told_otherwise(monkeypatch: pytest.MonkeyPatch) -> None:
    import app.eval.scenarios as scenarios_module

    asked: list[bool] = []

    def stop(name: str, seed: int, **kwargs: object) -> ScenarioScore:
        asked.append(bool(kwargs["bodies"]))
        raise SystemExit(0)

    monkeypatch.setattr(scenarios_module, "evaluate_scenario", stop)  # the command imports it when it runs
    for argv, bodies in ((["--motion"], True), ([], True), (["--motion", "--no-bodies"], False)):
        with pytest.raises(SystemExit):
            main(["eval", "scenarios", "--scenario", "S1", "--no-calibrate", *argv])
        assert asked[-1] is bodies


def test_identity_scores_as_the_mot_literature_defines_them() -> None:
    """Person 0 is tracked as id 7 then as id 8 (one switch); person 1 as id 9, missed in the last result, where a
    false person appears. The best map (0 -> 7 or 8, 1 -> 9) agrees in 5 matches: IDF1 = 10 / (10 + 4 + 3)."""
    from app.eval.counts import identity_counts

    matches = [[(0, 7), (1, 9)], [(0, 7), (1, 9)], [(0, 8), (1, 9)], [(0, 8)]]
    got = identity_counts(matches, n_true=[2, 2, 2, 2], n_found=[2, 2, 2, 3])
    assert (got.idtp, got.idfn, got.idfp, got.id_switches) == (5, 3, 4, 1)
    assert got.idf1 == pytest.approx(10 / 17)
    perfect = identity_counts([[(0, 3)], [(0, 3)]], n_true=[1, 1], n_found=[1, 1])
    assert perfect.idf1 == 1.0 and perfect.id_switches == 0


def test_voices_out_of_view_are_scored_against_the_unseen_talkers_azimuth() -> None:
    """S4's person 0 sits out of view 53 degrees to the left: a result while they speak counts as found when a voice
    lies within 15 degrees of them; a voice while nobody out of view speaks (0.4 s either side) is false, and such
    results in a row are one invented voice."""
    import math
    from types import SimpleNamespace

    from app.eval.scoring import voice_counts

    scenario = make_scenario("S4", clip_durations_s=[[0.6] * 10] * 3, seed=0)
    first = next(e for e in scenario.events if e.kind == "speech" and e.actor == 0)
    quiet_t = next(t for t in np.arange(0.0, scenario.duration_s, 0.05)
                   if not scenario.speaking_at([t], hold_s=0.4)[0][0])
    where = scenario.actors[0].path.at(0.0)
    truth = math.atan2(where[0], where[2])

    def result(t: float, *azimuths_deg: float) -> SimpleNamespace:
        return SimpleNamespace(stamp_s=t, voices=tuple(SimpleNamespace(azimuth_rad=math.radians(a))
                                                       for a in azimuths_deg))

    talking = 0.5 * (first.start_s + first.end_s)
    runs = [result(talking, math.degrees(truth) + 10.0), result(talking, math.degrees(truth) - 20.0, 40.0),
            result(talking), result(quiet_t, 30.0), result(quiet_t)]
    counts = voice_counts(scenario, runs)
    assert (counts.talking, counts.found, counts.quiet, counts.false) == (3, 1, 2, 1)
    assert counts.errors_deg == pytest.approx([10.0, 20.0])
    assert counts.as_dict()["found_share"] == pytest.approx(1 / 3, abs=1e-6)
    assert counts.as_dict()["within_10deg_share"] == pytest.approx(1 / 2)  # 10 degrees off is within, 20 is not
    assert voice_counts(scenario, [SimpleNamespace(stamp_s=1.0, voices=None)]) is None
    # an invented voice is counted once per run of results in a row: quiet with a voice, twice; quiet without; quiet
    # with a voice again; someone out of view talking (not quiet) ends a run too
    runs = [result(quiet_t, 30.0), result(quiet_t, 31.0), result(quiet_t), result(quiet_t, 30.0), result(talking, 5.0),
            result(quiet_t, 30.0)]
    counts = voice_counts(scenario, runs)
    assert (counts.quiet, counts.false, counts.false_stretches) == (5, 4, 3)
    assert counts.add(counts).false_stretches == 6
    from app.eval.counts import UtteranceCounts
    from app.eval.scoring import ScenarioScore

    score = ScenarioScore("S4", "face", [0], 20.0, utterances=UtteranceCounts(tp=50, fn=10), voices=counts)
    assert score.as_dict()["voices_out_of_view"]["false_voice_stretches_per_spoken_number"] == pytest.approx(3 / 60)


def test_one_person_moving_at_both_sides_of_the_body_is_one_person_with_one_id() -> None:
    """S1's one person sways and moves both arms: their moving points gather at both edges of the body, two strips a
    third of a metre apart. Algorithm 1 finds one person in every result, with one id (IDF1 1, no switch): with the
    body's width left out (``body_width_m=None``) it found two in most results (docs/experiments.md)."""
    from app.eval import scenarios
    from avcore import inference

    seen: list[int] = []
    step = inference.MotionGuidedHearing.step

    def counted(self: inference.MotionGuidedHearing, *args: object) -> inference.MotionGuidedOutput:
        out = step(self, *args)
        seen.append(out.n)
        return out

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(inference.MotionGuidedHearing, "step", counted)
        score = scenarios.evaluate_scenario("S1", 0, duration_s=8.0, config=PipelineConfig(inference="motion"),
                                            bodies=True)
    assert len(seen) >= 15 and set(seen) == {1}
    assert score.identity.idf1 == 1.0 and score.identity.id_switches == 0


def test_the_lips_alone_are_scored_as_a_speaking_detector() -> None:
    """AUC by hand: talker 0.02 is above two of the three opinions of the others and level with one (2.5), 0.03 above
    all three (3): 5.5 of 6; a NaN is no opinion; moving = at or above the veto's threshold."""
    from app.eval.counts import LipCue

    cue = LipCue(0.012, [0.02, 0.03, math.nan], [0.001, 0.02, math.nan, 0.005])
    v = cue.as_dict()
    assert v["face_results"] == 7 and v["no_opinion_share"] == pytest.approx(2 / 7)
    assert v["auc"] == pytest.approx(5.5 / 6)
    assert v["talkers_moving"] == 1.0 and v["others_moving"] == pytest.approx(1 / 3)
    both = cue.add(LipCue(0.012, [0.0], []))
    assert both.as_dict()["talkers_moving"] == pytest.approx(2 / 3) and both.as_dict()["face_results"] == 8
    assert LipCue(0.012).as_dict()["auc"] is None


def test_reading_the_lips_reports_the_lips_alone(capsys: pytest.CaptureFixture[str]) -> None:
    """The table of the lips alone, with the lips read by default (the face mesh is installed); its JSON and the
    table without the lips read: test_eval_scenarios_runs_s6_which_the_paper_has_not."""
    assert main(["eval", "scenarios", "--scenario", "S6", "--duration", "3", "--no-calibrate", "--lips"]) == 0
    assert "The lips alone (no sound)" in capsys.readouterr().out


def test_the_speechs_own_line_is_fitted_on_people_talking_alone(people_result: Callable[..., Result]) -> None:
    """speech_line: the ITDs of results where one person talks alone, paired with that talker's face, give the
    line they were drawn on; results with two sounds near them (their ITDs drawn on another line), or silence, or
    a talker whose face was not found, are left out; too few ITDs give None."""
    scenario = _scenario("S5", duration_s=12.0)  # S5: people talk over each other and clap
    mics = scenario.mics
    rng = np.random.default_rng(0)
    fused, alone = [], 0
    for t in np.arange(int(scenario.duration_s * FPS)) / FPS:
        tr = scenario.truth(float(t))
        near = [e for e in scenario.events if e.start_s < t + 0.35 and e.end_s > t - 0.35]
        r = people_result(float(t), tr.positions_m[tr.visible], tr.speaking[tr.visible])
        if len(near) == 1 and near[0].kind == "speech":
            raw = float(mics.raw_itd(tr.positions_m[near[0].actor]))
            itds = 0.85 * raw + 3e-6 + rng.normal(0.0, 2e-6, 12)
            alone += tr.visible[near[0].actor]
        else:  # two sounds, a clap, or silence: ITDs on a line far from the speech's
            itds = 0.6 * rng.uniform(-1, 1, 12) * mics.max_itd_s - 40e-6
        fused.append(replace(r, itds_s=itds.reshape(-1, 1)))
    assert alone > 30  # the check below is not vacuous: people do talk alone in view
    line = speech_line(scenario, fused, mics, reach_s=0.35)
    assert line is not None
    assert line.c1 == pytest.approx(0.85, abs=0.01) and line.c0 == pytest.approx(3e-6, abs=1e-6)
    hidden = [replace(r, xyz=r.xyz + 1.0) for r in fused]  # every face found 1.7 m from its person
    assert speech_line(scenario, hidden, mics, reach_s=0.35) is None
    # one still person talking (S1): every face in one direction gives no scale, so no line (not an error)
    still = make_scenario("S1", clip_durations_s=[[0.5] * 10] * 3, duration_s=12.0, seed=3)
    one = [replace(people_result(float(t), still.truth(float(t)).positions_m, np.ones(1, bool)),
                   itds_s=np.full((12, 1), 100e-6)) for t in np.arange(int(12.0 * FPS)) / FPS]
    assert speech_line(still, one, mics, reach_s=0.35) is None
