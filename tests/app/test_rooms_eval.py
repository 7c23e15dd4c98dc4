"""`avhear eval rooms`: a drawn room through the real pipeline, scored per result x person, beside the paper's."""
from __future__ import annotations

import json

import numpy as np
import pytest

from app.cli import main
from app.eval.rooms import evaluate_room, method_config
from app.pipeline import PipelineConfig


def test_a_short_room_runs_through_the_pipeline_and_is_scored() -> None:
    score = evaluate_room(0, duration_s=6.0)
    c = score.counts
    assert score.rooms[0]["seed"] == 0 and score.rooms[0]["people"] == 2
    assert c.utterances >= 1 and c.tp + c.fn > 0 and c.tp + c.fp + c.fn + c.tn > 100
    assert score.face_recall > 0.9  # both faces found in nearly every result
    assert score.median_error_m < 0.05


def test_the_papers_method_is_algorithm_2_as_written() -> None:
    cfg = method_config(PipelineConfig(lips=True), "paper")
    assert (cfg.face_variant, cfg.itd_method, cfg.frame_itds, cfg.vote_frames, cfg.lips, cfg.dereverb) == \
        ("paper", "correlogram", False, 1, False, False)
    assert method_config(PipelineConfig(), "avhear") == PipelineConfig()
    assert PipelineConfig().rescue_gap_s == 0.1 and method_config(PipelineConfig(), "all-rescues") == \
        PipelineConfig(rescue_gap_s=None)
    with pytest.raises(ValueError, match="method must be one of"):
        method_config(PipelineConfig(), "mine")


def test_eval_rooms_refuses_motion_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "rooms", "--motion"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "leave out --motion" in err[0]


def test_eval_rooms_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "rooms", "--seed", "3", "--duration", "6", "--method", "paper", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (row,) = out["results"]
    assert row["method"] == "paper" and row["seeds"] == [3] and out["protocol"]["forgive_s"] == 0.3
    assert 0.0 <= row["speaking"]["precision_forgiven"] <= 1.0


def test_far_faces_film_the_same_room_in_half_the_pixels() -> None:
    """`eval rooms --far-faces`: the same room, people and sound, filmed at 320 x 240 with the same view: every face
    half as wide in pixels (16-45 px, as faces twice as far away in the default camera)."""
    from app.sources.sim import SimSource
    from sim.scenario import FACE_WIDTH_M

    full, far = (SimSource.from_room(0, duration_s=5.0, image_scale=s) for s in (1.0, 0.5))
    assert far.meta["room"] == dict(full.meta["room"], image_size=[320, 240])
    assert next(iter(far.frames())).left.shape == (240, 320, 3)
    assert np.array_equal(far.audio.samples, full.audio.samples)
    for face in far.meta["room"]["faces_m"]:
        widths = [rig.focal_px * FACE_WIDTH_M / face[2] for rig in (full.stereo, far.stereo)]
        assert widths[1] == pytest.approx(widths[0] / 2) and 16 <= widths[1] <= 45


def test_a_room_is_heard_with_the_pair_it_is_given() -> None:
    """`eval rooms --calibrate` hears the room with the fitted pair: a correction far from the truth (every ITD
    mapped at half its size) moves the faces' voices, so the same room scores otherwise."""
    from app.sources.sim import SimSource

    nominal = SimSource.from_room(0, duration_s=6.0).mics
    wrong = evaluate_room(0, duration_s=6.0, mics=nominal.with_correction(0.5, 0.0)).counts
    assert vars(wrong) != vars(evaluate_room(0, duration_s=6.0).counts)
    with pytest.raises(ValueError, match="applies to one pair"):
        evaluate_room(0, duration_s=6.0, mic_array="respeaker4", mics=nominal)


def test_eval_rooms_calibrate_refuses_an_array_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["eval", "rooms", "--calibrate", "--mics", "respeaker4"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--calibrate fits one microphone pair" in err[0] and "respeaker4" in err[0]


def test_eval_rooms_calibrate_hears_every_room_with_the_fit(monkeypatch: pytest.MonkeyPatch,
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    """`eval rooms --calibrate`: the fit (here a stand-in for the preset's 40 s run) is said under the table and in
    the JSON, and each room is heard with it."""
    import app.eval.rooms as rooms
    import app.eval.scenarios as scenarios
    from app.sources.sim import SimSource

    fit = scenarios.CalibrationFit(SimSource.from_room(3, duration_s=6.0).mics.with_correction(0.8, -1e-6), 500,
                                   0.99, 16e-6, 10e-6)
    monkeypatch.setattr(scenarios, "calibrate_on_preset", lambda **kw: fit)
    heard = []
    real = rooms.evaluate_room
    monkeypatch.setattr(rooms, "evaluate_room", lambda seed, **kw: heard.append(kw["mics"]) or real(seed, **kw))
    argv = ["eval", "rooms", "--seed", "3", "--duration", "6", "--method", "avhear", "--calibrate"]
    assert main(argv) == 0
    out = capsys.readouterr()
    assert "calibration preset (section 5.3)" in out.err and "c1 = 0.8000, c0 = -1.0 us." in out.out
    assert main(argv + ["--json"]) == 0
    assert json.loads(capsys.readouterr().out)["calibration"]["c1"] == 0.8
    assert heard == [fit.mics, fit.mics]
    assert main(argv[:-1] + ["--json"]) == 0 and json.loads(capsys.readouterr().out)["calibration"] is None
    assert heard[-1] is None
