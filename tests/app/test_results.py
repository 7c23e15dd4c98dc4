"""`--results-jsonl`: every fused result as one JSON line, in the README's schema, kept however the run stops."""
from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from app.cli import main
from app.result import Result


def _result(*, probability: list[float], speaking: list[bool], xyz: list[list[float]] | None = None,
            itd_means: list[float] | None = None) -> Result:
    """A face-guided result of ``len(probability)`` people as the pipeline hands it to the sinks."""
    n = len(probability)
    output = SimpleNamespace(speaking=np.array(speaking), probability=np.array(probability),
                             itd_means=np.array(itd_means if itd_means is not None else [0.0] * n))
    return Result(stamp_s=1.0, index=30, image=np.zeros((4, 4, 3), np.uint8),
                        boxes=np.tile([10, 20, 30, 30], (n, 1)),
                        xyz=np.array(xyz if xyz is not None else [[0.0, 0.0, 2.0]] * n), itds_s=np.zeros(0),
                        output=output, latency_s=float("nan"), person_ids=np.arange(n))


def _lines(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_demo_writes_one_line_per_result(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out, stats = tmp_path / "deep" / "results.jsonl", tmp_path / "stats.json"
    assert main(["demo", "--duration", "2", "--fast", "--headless", "--results-jsonl", str(out),
                 "--stats-json", str(stats)]) == 0
    rows = _lines(out)
    assert len(rows) == json.loads(stats.read_text())["results"] > 40
    assert "latency p95 n/a (as fast as possible)" in capsys.readouterr().out
    stamps = [r["stamp_s"] for r in rows]
    assert stamps == sorted(stamps)
    assert {r["mode"] for r in rows} == {"face"}
    people = [p for r in rows for p in r["people"]]
    assert people, "the simulated room has people in view"
    for p in people:
        assert set(p) >= {"id", "position_m", "speaking", "probability", "itd_mean_s", "box_px"}
        assert len(p["position_m"]) == 3 and 0.5 < p["position_m"][2] < 6  # in front of the rig, metres
        assert 0.0 <= p["probability"] <= 1.0 and (p["probability"] > 0.5) == p["speaking"]
    assert any(p["speaking"] for p in people) and not all(p["speaking"] for p in people)
    assert sum(r["n_itds"] for r in rows) > 0


def test_motion_guided_results_have_positions(tmp_path: Path) -> None:
    out = tmp_path / "results.jsonl"
    assert main(["demo", "--duration", "2", "--fast", "--headless", "--motion", "--results-jsonl", str(out)]) == 0
    rows = _lines(out)
    assert rows and {r["mode"] for r in rows} == {"motion"}
    assert all("box_px" not in p for r in rows for p in r["people"])


def test_an_unwritable_results_path_fails_before_the_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["demo", "--duration", "2", "--fast", "--headless", "--results-jsonl", str(blocker / "r.jsonl")]) == 2
    captured = capsys.readouterr()
    assert (f"cannot write the results file {blocker / 'r.jsonl'}: File exists; choose another --results-jsonl "
            "path") in captured.err and "Traceback" not in captured.err
    assert "results in" not in captured.out  # refused before the work, not after it


def test_a_recording_gives_the_same_results_in_real_time_and_as_fast_as_possible(tmp_path: Path) -> None:
    """Real time paces the frames and changes no answer. A real-time source skips the frames that come late (as a
    camera drops them, or the frames' queue drops its oldest), and then the vote and the tracker see other frames and
    may answer otherwise: on a machine too loaded to keep up (the run's stats count both) the comparison is
    skipped, with the count."""
    folder = tmp_path / "s2"
    # 10 FPS: in real time the pipeline has 100 ms a frame, far more than it needs on an idle machine
    assert main(["simulate", "S2", "-o", str(folder), "--duration", "4", "--fps", "10"]) == 0
    states = {}
    for mode in ("realtime", "fast"):
        out, stats = tmp_path / f"{mode}.jsonl", tmp_path / f"{mode}.json"
        flags = ["--fast"] if mode == "fast" else []
        assert main(["run", "--source", f"replay:{folder}", "--headless", "--results-jsonl", str(out),
                     "--stats-json", str(stats), *flags]) == 0
        figures = json.loads(stats.read_text())
        lost = figures["late_frames"] + figures["drops"]["frames"]
        if mode == "realtime" and lost:
            pytest.skip(f"{lost} of 40 frames came late on this loaded machine: real time skipped or dropped them")
        rows = _lines(out)  # real time is stamped on the monotonic clock, a fast replay from 0
        states[mode] = [(round(r["stamp_s"] - rows[0]["stamp_s"], 3), [(p["id"], p["speaking"]) for p in r["people"]])
                        for r in rows]
    assert len(states["fast"]) == 40  # 4 s at 10 FPS
    assert any(s for _, people in states["fast"] for _, s in people)
    assert states["realtime"] == states["fast"]


@pytest.mark.parametrize(("probability", "speaking"), [(0.50003, True), (0.5, True), (0.50007, False),
                                                        (0.49996, False), (0.99999, True), (0.0, False)])
def test_the_written_probability_is_above_one_half_exactly_when_speaking(probability: float, speaking: bool) -> None:
    """Rounding to 4 decimals must not break the schema's promise (0.50003 would be written as 0.5)."""
    result = _result(probability=[probability], speaking=[speaking])
    person = result.as_dict()["people"][0]
    assert person["speaking"] is speaking
    assert (person["probability"] > 0.5) == speaking
    assert person["probability"] == pytest.approx(probability, abs=2e-4)


def test_the_results_file_says_where_the_people_are(tmp_path: Path) -> None:
    """The written values against the simulated room's truth: each person's position is the nearest true face's
    (x > 0 is to the right), and a speaking person's `itd_mean_s` has the sign and size of the delay between the
    microphones at their true place, computed here from the distances to the pair (-6 cm and +6 cm on x, the
    default pair) and the speed of sound: positive when the sound reaches the right microphone first."""
    from app.sources.sim import SimSource

    out = tmp_path / "r.jsonl"
    assert main(["demo", "--scenario", "S2", "--duration", "4", "--fast", "--headless", "--results-jsonl",
                 str(out)]) == 0
    room = SimSource.from_preset("S2", duration_s=4.0, seed=0)
    left, right = np.array([-0.06, 0.0, 0.0]), np.array([0.06, 0.0, 0.0])
    placed = itds = 0
    for row in _lines(out):
        truth = room.truth(row["index"])
        for person in row["people"]:
            p = np.array(person["position_m"])
            d = np.linalg.norm(truth.positions_m - p, axis=1)
            nearest = truth.positions_m[int(np.argmin(d))]
            assert d.min() < 0.15, (row["index"], p, truth.positions_m)
            if abs(nearest[0]) > 0.2:  # someone clearly to one side (S2's middle person sits at x = 0)
                assert np.sign(p[0]) == np.sign(nearest[0])
            placed += 1
            if person["speaking"] and person["itd_mean_s"] is not None:
                delay = (np.linalg.norm(nearest - left) - np.linalg.norm(nearest - right)) / 343.0
                assert person["itd_mean_s"] == pytest.approx(delay, abs=60e-6), (row["index"], nearest)
                itds += 1
    sides = {np.sign(x) for x in room.truth(0).positions_m[:, 0]}
    assert placed > 200 and itds > 20 and sides >= {-1.0, 1.0}  # people on both sides, and talkers heard


# a line that `avhear demo --results-jsonl` wrote on 2026-11-26, before the results file was read from
# `Result.people`: the schema may gain fields, never rename or retype one
WRITTEN_ON_2026_11_26 = (
    '{"stamp_s":1.3,"index":39,"mode":"face","n_itds":0,"latency_s":null,"people":[{"id":0,"position_m":'
    '[-0.7491,-0.1438,1.9],"speaking":false,"probability":0.0,"itd_mean_s":-0.0001279613494114315,"box_px":'
    '[89,168,58,58]},{"id":1,"position_m":[0.0011,-0.0947,2.3976],"speaking":false,"probability":0.0,'
    '"itd_mean_s":1.581809815972392e-07,"box_px":[310,194,47,47]}]}')


def _shape(value: object) -> object:
    """The schema of a JSON value: its keys in order and its types, recursively (lists by their first item)."""
    if isinstance(value, dict):
        return [(k, _shape(v)) for k, v in value.items()]
    if isinstance(value, list):
        return ["list", _shape(value[0]) if value else None]
    return "number" if isinstance(value, (int, float)) and not isinstance(value, bool) else type(value).__name__


def test_the_results_file_keeps_its_schema(tmp_path: Path) -> None:
    out = tmp_path / "r.jsonl"
    assert main(["demo", "--duration", "2", "--fast", "--headless", "--results-jsonl", str(out)]) == 0
    old = json.loads(WRITTEN_ON_2026_11_26)
    rows = [r for r in _lines(out) if r["people"] and r["latency_s"] is None]
    assert rows
    for row in rows:
        assert [k for k, _ in _shape(row)] == [k for k, _ in _shape(old)]
        for person in row["people"]:  # the old fields first, as they were; new ones after them
            old_person = _shape(old["people"][0])
            assert _shape(person)[:len(old_person)] == old_person
            assert dict(_shape(person))["voice_id"] == "str"
