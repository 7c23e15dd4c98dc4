"""The speaking-state timeline figure of `avhear eval scenarios --timeline DIR`."""
from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.cli import main
from app.errors import UserError
from app.eval.figure import draw_timeline, save_timeline
from app.pipeline import PipelineConfig
from app.plotting import GREEN, RED
from app.eval.scoring import score_run
from sim.scenario import make_scenario

FPS = 30.0


def _timeline(make, judge):  # type: ignore[no-untyped-def]
    scenario = make_scenario("S2", clip_durations_s=[[0.5] * 10] * 3, duration_s=6.0, seed=3)
    stamps = np.arange(int(scenario.duration_s * FPS)) / FPS
    fused = []
    for t in stamps:
        tr = scenario.truth(float(t))
        fused.append(make(float(t), tr.positions_m[tr.visible], judge(tr)[tr.visible]))
    silence = np.zeros((int(scenario.duration_s * 16000), 2))
    score = score_run(scenario, fused, silence, 16000.0, scenario.mics, PipelineConfig(), frame_stamps_s=stamps)
    assert score.timeline is not None
    return score.timeline


def _pixels(img: np.ndarray, colour: tuple[int, int, int], below: int = 70) -> int:
    """Pixels of exactly ``colour`` under the legend."""
    return int(np.count_nonzero(np.all(img[below:] == np.array(colour, np.uint8), axis=-1)))


def test_timeline_marks_misses_and_false_stretches_only_where_they_are(people_result: Callable[..., object]) -> None:
    right = _timeline(people_result, lambda tr: tr.speaking)
    assert right.missed == () and right.false_stretches == ()
    img = draw_timeline(right, "right")
    assert img.shape == (76 + 3 * (2 * 20 + 26) + 44, 1600, 3)
    assert _pixels(img, GREEN) > 1000 and _pixels(img, RED) == 0  # speaking drawn, nothing red

    deaf = _timeline(people_result, lambda tr: np.zeros_like(tr.speaking))  # every number missed, no false stretch
    numbers = [e for e in deaf.scenario.events if e.kind == "speech"]
    assert len(deaf.missed) == len(numbers) and deaf.false_stretches == ()
    img = draw_timeline(deaf, "deaf")
    assert _pixels(img, RED) > 1000 and _pixels(img, GREEN) == 0

    wrong = _timeline(people_result, lambda tr: ~tr.speaking)  # also every pause judged speaking: false stretches above the lane
    assert len(wrong.missed) == len(numbers) and len(wrong.false_stretches) > 0
    assert _pixels(draw_timeline(wrong, "wrong"), RED) > _pixels(img, RED)


def test_eval_scenarios_saves_a_timeline_per_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "timelines"
    assert main(["eval", "scenarios", "--scenario", "S1", "--duration", "3", "--no-calibrate",
                 "--timeline", str(out)]) == 0
    img = cv2.imread(str(out / "S1_seed0.png"))
    assert img is not None and img.shape[1] == 1600
    printed = capsys.readouterr()
    assert "timeline saved" in printed.err
    # the table says which data the room ran on: real digits (../shared/data's or the copies avhear ships)
    assert "Data: " in printed.out and "faces, digits speech" in printed.out


def test_timeline_to_an_unwritable_place_is_a_clear_error(people_result: Callable[..., object], tmp_path: Path) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    with pytest.raises(UserError, match="cannot create the folder"):
        save_timeline(_timeline(people_result, lambda tr: tr.speaking), blocker / "S2_seed0.png", "title")
