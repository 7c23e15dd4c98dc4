"""Voices out of view in the application: with NAO's array, S4's talker outside the cameras' view is in the results
as a person without a face or position, with its direction and one id that no person in view has; with one pair
there is no direction to give."""
from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from app.cli import main
from sim.scenario import make_scenario


def test_s4s_talker_out_of_view_is_a_voice_in_its_direction(tmp_path: Path) -> None:
    pytest.importorskip("pyroomacoustics")
    out = tmp_path / "r.jsonl"
    assert main(["run", "--source", "sim:S4", "--mics", "nao", "--duration", "5", "--fast", "--headless",
                 "--results-jsonl", str(out)]) == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    voices = [p for r in rows for p in r["people"] if p["position_m"] is None]
    seen = {p["id"] for r in rows for p in r["people"] if p["position_m"] is not None}
    scenario = make_scenario("S4", clip_durations_s=[[0.5] * 10] * 3, seed=0)
    unseen = scenario.actors[0].path.at(0.0)  # the talker outside the view, 53 degrees to the left (a still place)
    truth = math.degrees(math.atan2(unseen[0], unseen[2]))
    assert len(voices) >= 10  # they count first
    assert len({v["id"] for v in voices}) == 1 and not {v["id"] for v in voices} & seen
    assert all(v["speaking"] and "box_px" not in v for v in voices)
    assert all(abs(v["azimuth_deg"] - truth) < 20 for v in voices)
    assert sorted(abs(v["azimuth_deg"] - truth) for v in voices)[len(voices) // 2] < 8
    assert all(v["elevation_deg"] is None for v in voices)
    # no voice while the talker out of view is silent (0.4 s either side: a result's ITDs span +-0.2 s)
    from app.sources.sim import SimSource

    timing = SimSource.from_preset("S4", duration_s=5.0, seed=0, mics="nao").scenario
    silent = [r for r in rows if not timing.speaking_at([r["stamp_s"]], hold_s=0.4)[0][0]]
    assert len(silent) > 50 and all(p["position_m"] is not None for r in silent for p in r["people"])


def test_one_pair_gives_no_voices(tmp_path: Path) -> None:
    pytest.importorskip("pyroomacoustics")
    out = tmp_path / "r.jsonl"
    assert main(["run", "--source", "sim:S4", "--duration", "2", "--fast", "--headless", "--results-jsonl",
                 str(out)]) == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    assert rows and all(p["position_m"] is not None for r in rows for p in r["people"])


def test_the_bins_claim_nobody_while_a_voice_out_of_view_holds_the_itds() -> None:
    """With several pairs, a result whose ITDs hold a voice no visible face explains is decided without the frames'
    bins (a bin of that voice agrees best with the visible person nearest its direction and would claim them);
    a result whose ITDs are the face's own keeps them. ITDs computed from distances written out, not by
    ``MicArray.itd``."""
    from types import SimpleNamespace

    import numpy as np

    from app.hearing import FaceGuided, Vision
    from app.pipeline import PipelineConfig
    from avcore.geometry import SPEED_OF_SOUND, MicArray

    array = MicArray.preset("respeaker4")
    mics = np.asarray(array.positions)

    def itds_from(point: list[float]) -> np.ndarray:  # left minus right arrival, every pair, 6 windows
        d = np.linalg.norm(mics - np.asarray(point), axis=1) / SPEED_OF_SOUND
        return np.tile([d[i] - d[j] for i, j in array.pairs], (6, 1))

    seen: list = []
    out = SimpleNamespace(speaking=np.array([False]), rescued=None, bin_share=None)  # what the learners read
    hearing = SimpleNamespace(array=array, step=lambda *a, **o: seen.append(a[5]) or out)  # a[5]: the frames' bins
    mode = FaceGuided(PipelineConfig())
    face = np.array([[0.3, 0.0, 2.0]])
    vision = Vision(1.0, None, np.array([[300, 200, 40, 40]]), face)  # type: ignore[arg-type]
    unseen = [2.0 * np.sin(np.radians(-60)), 0.0, 2.0 * np.cos(np.radians(-60))]
    near = lambda: (None, None, "the bins")  # noqa: E731
    assert mode.step(hearing, vision, itds_from(unseen), np.zeros(6), near) is out and seen[-1] is None
    assert mode.step(hearing, vision, itds_from(face[0]), np.zeros(6), near) is out and seen[-1] == "the bins"
