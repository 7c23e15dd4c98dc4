"""app.result: the Result every sink reads and its people."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from app.result import Result


def _result(output: SimpleNamespace, boxes: np.ndarray | None, xyz: np.ndarray) -> Result:
    return Result(stamp_s=2.0, index=60, image=np.zeros((2, 2, 3), np.uint8), boxes=boxes, xyz=xyz,
                  itds_s=np.zeros((5, 6)), output=output, latency_s=0.4, person_ids=np.array([7, 3]))


def test_face_guided_people_with_several_pairs() -> None:
    """Each person carries its mean ITD on every pair (NAO's six), its face and its box; in output's order."""
    pair_means = np.arange(12, dtype=float).reshape(2, 6) * 1e-5
    out = SimpleNamespace(speaking=np.array([True, False]), probability=np.array([0.8, 0.1]),
                          itd_means=pair_means[:, 0], pair_itd_means=pair_means)
    faces = np.array([[-0.5, 0.0, 2.0], [0.6, -0.1, 2.4]])
    result = _result(out, np.array([[10.4, 20.0, 30.0, 30.0], [50, 60, 20, 20]]), faces)
    a, b = result.people
    assert (a.id, b.id) == (7, 3) and a.speaking and not b.speaking
    assert (a.probability, b.probability) == (0.8, 0.1)
    np.testing.assert_array_equal(b.position_m, faces[1])
    assert b.itd_s.shape == (6,)
    np.testing.assert_array_equal(b.itd_s, pair_means[1])
    assert a.box_px == (10, 20, 30, 30) and result.mode == "face" and result.n_itds == 5
    assert result.people is result.people  # built once


def test_motion_guided_people_are_the_clusters() -> None:
    """Motion-guided, the people are the clusters' means (not the HM3D points) and have no box."""
    out = SimpleNamespace(speaking=np.array([False, True]), probability=np.array([0.2, 0.9]),
                          itd_means=np.array([-1e-4, 2e-4]), positions=np.array([[0.1, 0, 2], [0.9, 0, 3]]))
    result = _result(out, None, np.random.default_rng(0).normal(size=(40, 3)))
    a, b = result.people
    assert result.mode == "motion" and a.box_px is None and b.box_px is None
    np.testing.assert_array_equal(b.position_m, [0.9, 0, 3])
    assert a.itd_s.shape == (1,) and a.itd_s[0] == -1e-4


def test_one_results_line_holds_the_results_values(tmp_path) -> None:  # noqa: ANN001
    """The line of app.sinks.results_file for one result, value by value (the stamp to the microsecond, positions to
    0.1 mm, probabilities to 1e-4), written compactly, counted, and refused once the file is closed."""
    import json

    from app.sinks.results_file import ResultsWriter

    out = SimpleNamespace(speaking=np.array([True, False]), probability=np.array([0.83337, 0.2]),
                          itd_means=np.array([-1.2e-4, 2.5e-4]), pair_itd_means=None)
    result = Result(stamp_s=12.3456789, index=370, image=np.zeros((2, 2, 3), np.uint8),
                    boxes=np.array([[10.4, 20.0, 30.0, 30.0], [50, 60, 20, 20]]),
                    xyz=np.array([[-0.51234, 0.0, 2.0], [0.6, -0.1, 2.4]]), itds_s=np.zeros(7), output=out,
                    latency_s=float("nan"), person_ids=np.array([7, 3]))
    record = result.as_dict()
    assert record["stamp_s"] == 12.345679 and record["index"] == 370 and record["mode"] == "face"
    assert record["n_itds"] == 7 and record["latency_s"] is None
    first = record["people"][0]
    assert first == {"id": 7, "position_m": [-0.5123, 0.0, 2.0], "speaking": True, "probability": 0.8334,
                     "itd_mean_s": -1.2e-4, "box_px": [10, 20, 30, 30], "voice_id": "v7"}
    path = tmp_path / "a" / "b" / "r.jsonl"  # folders created, however deep
    writer = ResultsWriter(path)
    writer.write(result)
    writer.write(result)
    assert writer.written == 2
    writer.close()
    lines = path.read_text(encoding="utf-8").splitlines()
    assert len(lines) == 2 and json.loads(lines[0]) == record and ", " not in lines[0]  # compact: one short line
    try:
        writer.write(result)
    except ValueError as exc:
        assert str(exc) == f"the results file {path} is closed"
    else:
        raise AssertionError("a closed results file took a line")


def test_the_lips_activity_on_the_line_to_1e_4_and_null_without_an_opinion() -> None:
    from dataclasses import replace


    out = SimpleNamespace(speaking=np.array([True, False]), probability=np.array([0.9, 0.2]),
                          itd_means=np.array([-1.2e-4, 2.5e-4]), pair_itd_means=None)
    result = Result(stamp_s=1.0, index=30, image=np.zeros((2, 2, 3), np.uint8),
                    boxes=np.array([[10, 20, 30, 30], [50, 60, 20, 20]]), xyz=np.array([[-0.5, 0, 2], [0.6, 0, 2.4]]),
                    itds_s=np.zeros(4), output=out, latency_s=0.1, person_ids=np.array([7, 3]),
                    lip_activity=np.array([0.0123456, np.nan]))
    first, second = result.as_dict()["people"]
    assert first["lip_activity"] == 0.0123 and second["lip_activity"] is None and "lip_activity" in second
    assert "lip_activity" not in replace(result, lip_activity=None).as_dict()["people"][0]  # lips not read


def test_a_voice_out_of_view_is_a_person_of_the_line_without_a_face_or_position() -> None:
    """A voice out of view follows the people in view on the results line: its id, speaking, its direction in
    degrees to 0.1, and null where it has nothing (position, probability, mean ITD; elevation with a flat array)."""
    from app.hearing import Voice

    out = SimpleNamespace(speaking=np.array([True, False]), probability=np.array([0.9, 0.2]),
                          itd_means=np.array([-1.2e-4, 2.5e-4]), pair_itd_means=None)
    result = Result(stamp_s=1.0, index=30, image=np.zeros((2, 2, 3), np.uint8),
                    boxes=np.array([[10, 20, 30, 30], [50, 60, 20, 20]]), xyz=np.array([[-0.5, 0, 2], [0.6, 0, 2.4]]),
                    itds_s=np.zeros((4, 6)), output=out, latency_s=0.1, person_ids=np.array([7, 3]),
                    voices=(Voice(9, np.radians(-53.04), None), Voice(11, np.radians(80.26), np.radians(12.26))))
    people = result.as_dict()["people"]
    assert [p["id"] for p in people] == [7, 3, 9, 11] and len(result.people) == 2  # the API's people are in view
    assert people[2] == {"id": 9, "position_m": None, "speaking": True, "probability": None, "itd_mean_s": None,
                         "azimuth_deg": -53.0, "elevation_deg": None, "voice_id": "v9"}
    assert (people[3]["azimuth_deg"], people[3]["elevation_deg"]) == (80.3, 12.3)
