from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from avcore.evaluation import TAU_LOC_M, EvalTotals, MatchResult, match_clusters

TRUTH = np.array([[0.0, 0.0, 2.0], [1.0, 0.0, 2.0], [-1.0, 0.0, 3.0]])


def test_tau_loc_is_the_papers_value() -> None:
    assert TAU_LOC_M == 0.35


def test_a_detection_at_a_hidden_person_is_neither_true_nor_false() -> None:
    hidden = [[0.5, 0.0, 4.0]]
    det = [[0.0, 0.05, 2.0], [0.55, 0.0, 4.1], [3.0, 0.0, 3.0]]  # a visible person, the hidden one, nobody
    plain = match_clusters(det, TRUTH[:1])
    res = match_clusters(det, TRUTH[:1], ignore_xyz=hidden)
    assert (plain.tp, plain.fp, plain.ignored) == (1, 2, 0)
    assert (res.tp, res.fp, res.fn, res.ignored) == (1, 1, 0, 1)
    assert res.tp + res.fp + res.ignored == len(det)
    # a hidden person missed is no false negative; a detection nearer a visible person than a hidden one is matched
    near = match_clusters([[0.1, 0.0, 2.0]], TRUTH[:1], ignore_xyz=[[0.3, 0.0, 2.0]])
    assert (near.tp, near.fp, near.ignored) == (1, 0, 0)
    alone = match_clusters([[0.5, 0.0, 4.0]], np.zeros((0, 3)), ignore_xyz=hidden)
    assert (alone.tp, alone.fp, alone.fn, alone.ignored) == (0, 0, 0, 1)
    totals = EvalTotals()
    totals.add(res)
    totals.add(alone)
    assert totals.ignored == 2 and totals.fp == 1


def test_perfect_detection() -> None:
    res = match_clusters(TRUTH[::-1], TRUTH)
    assert (res.fp, res.fn, res.tp) == (0, 0, 3)
    assert res.pairs == ((0, 2), (1, 1), (2, 0))
    np.testing.assert_array_equal(res.errors_m, np.zeros(3))


def test_localisation_errors_are_euclidean_distances_of_the_pairs() -> None:
    det = TRUTH + np.array([[0.03, 0.04, 0.0], [0.0, 0.0, -0.1], [0.1, 0.1, 0.1]])
    res = match_clusters(det, TRUTH)
    assert res.tp == 3
    np.testing.assert_allclose(res.errors_m, [0.05, 0.1, math.sqrt(0.03)])


def test_detection_beyond_tau_loc_is_a_false_positive_and_its_truth_a_false_negative() -> None:
    det = np.array([[0.0, 0.0, 2.0], [1.5, 0.0, 2.0]])  # the second is 0.5 m from its nearest truth
    res = match_clusters(det, TRUTH[:2])
    assert (res.fp, res.fn, res.tp) == (1, 1, 1)
    assert res.pairs == ((0, 0),)


def test_detection_at_exactly_tau_loc_is_a_false_positive() -> None:
    # Section 7: "if it is not closer than a threshold tau_loc we mark it as a false positive".
    det = np.array([[0.0, 0.0, 2.0 + 0.25]])
    assert match_clusters(det, TRUTH[:1], tau_loc=0.25).fp == 1
    assert match_clusters(det, TRUTH[:1], tau_loc=0.2501).tp == 1


def test_two_detections_on_one_truth_the_closest_is_the_true_positive() -> None:
    det = np.array([[0.2, 0.0, 2.0], [0.05, 0.0, 2.0], [1.0, 0.0, 2.0]])
    res = match_clusters(det, TRUTH[:2])
    assert (res.fp, res.fn, res.tp) == (1, 0, 2)
    assert res.pairs == ((0, 1), (1, 2))
    np.testing.assert_allclose(res.errors_m, [0.05, 0.0])


def test_detection_goes_to_its_nearest_truth_even_if_another_truth_is_left_unmatched() -> None:
    # Both detections are nearest to truth 0 (and within tau_loc of truth 1 for the first): the protocol assigns
    # each detection to its nearest truth, it does not search for the best one-to-one assignment.
    truth = np.array([[0.0, 0.0, 2.0], [0.3, 0.0, 2.0]])
    det = np.array([[0.1, 0.0, 2.0], [0.0, 0.0, 2.0]])
    res = match_clusters(det, truth)
    assert (res.fp, res.fn, res.tp) == (1, 1, 1)
    assert res.pairs == ((0, 1),)


def test_tie_goes_to_the_lower_index() -> None:
    truth = np.array([[-0.1, 0.0, 2.0], [0.1, 0.0, 2.0]])
    res = match_clusters([[0.0, 0.0, 2.0]], truth)
    assert res.pairs == ((0, 0),)
    assert (res.fp, res.fn, res.tp) == (0, 1, 1)


@pytest.mark.parametrize(
    ("det", "truth", "expected"),
    [
        (np.zeros((0, 3)), TRUTH, (0, 3, 0)),
        (TRUTH, np.zeros((0, 3)), (3, 0, 0)),
        (np.zeros((0, 3)), np.zeros((0, 3)), (0, 0, 0)),
        ([], [], (0, 0, 0)),
    ],
)
def test_empty_inputs(det: object, truth: object, expected: tuple[int, int, int]) -> None:
    res = match_clusters(det, truth)
    assert (res.fp, res.fn, res.tp) == expected
    assert res.errors_m.shape == (0,)
    assert res.pairs == ()


def test_empty_inputs_with_speaking_states() -> None:
    res = match_clusters(np.zeros((0, 3)), TRUTH, detected_speaking=[], truth_speaking=[True, False, True])
    assert (res.fn, res.audio_tp, res.audio_fn, res.audio_fp, res.audio_tn) == (3, 0, 0, 0, 0)


def test_audio_states_over_true_positive_pairs() -> None:
    truth = np.array([[x, 0.0, 2.0] for x in (-1.5, -0.5, 0.5, 1.5)])
    det = np.vstack([truth[::-1], [[0.0, 0.0, 5.0]]])  # reversed order, plus a far false positive
    truth_speaking = np.array([True, True, False, False])
    # det rows: truth 3, 2, 1, 0, false positive
    det_speaking = np.array([False, True, False, True, True])
    res = match_clusters(det, truth, detected_speaking=det_speaking, truth_speaking=truth_speaking)
    assert (res.fp, res.fn, res.tp) == (1, 0, 4)
    # truth 0: speaks, detected speaking -> TP; truth 1: speaks, detected silent -> FN;
    # truth 2: silent, detected speaking -> FP; truth 3: silent, detected silent -> TN. The visual FP is ignored.
    assert (res.audio_tp, res.audio_fn, res.audio_fp, res.audio_tn) == (1, 1, 1, 1)


def test_audio_counts_are_zero_without_speaking_states() -> None:
    res = match_clusters(TRUTH, TRUTH)
    assert (res.audio_tp, res.audio_fn, res.audio_fp, res.audio_tn) == (0, 0, 0, 0)


def test_unmatched_truth_does_not_count_in_audio() -> None:
    res = match_clusters(
        TRUTH[:1], TRUTH, detected_speaking=[True], truth_speaking=np.array([True, True, True])
    )
    assert (res.tp, res.fn, res.audio_tp, res.audio_fn) == (1, 2, 1, 0)


@pytest.mark.parametrize(
    ("kwargs", "error", "match"),
    [
        ({"detected_xyz": [[0.0, np.nan, 1.0]], "truth_xyz": TRUTH}, ValueError, "detected_xyz"),
        ({"detected_xyz": TRUTH, "truth_xyz": [[np.inf, 0.0, 1.0]]}, ValueError, "truth_xyz"),
        ({"detected_xyz": [0.0, 0.0, 1.0], "truth_xyz": TRUTH}, ValueError, r"detected_xyz must be an \(n, 3\)"),
        ({"detected_xyz": TRUTH, "truth_xyz": np.zeros((2, 2))}, ValueError, r"truth_xyz .*shape \(2, 2\)"),
        ({"detected_xyz": TRUTH, "truth_xyz": TRUTH, "tau_loc": 0.0}, ValueError, "tau_loc"),
        ({"detected_xyz": TRUTH, "truth_xyz": TRUTH, "tau_loc": float("nan")}, ValueError, "tau_loc"),
        (
            {"detected_xyz": TRUTH, "truth_xyz": TRUTH, "detected_speaking": [True] * 3},
            ValueError,
            "detected_speaking was given without truth_speaking",
        ),
        (
            {"detected_xyz": TRUTH, "truth_xyz": TRUTH, "truth_speaking": [True] * 3},
            ValueError,
            "truth_speaking was given without detected_speaking",
        ),
        (
            {"detected_xyz": TRUTH, "truth_xyz": TRUTH, "detected_speaking": [True] * 2, "truth_speaking": [True] * 3},
            ValueError,
            r"detected_speaking must have shape \(3,\).*got shape \(2,\)",
        ),
        (
            {"detected_xyz": TRUTH, "truth_xyz": TRUTH, "detected_speaking": [True] * 3, "truth_speaking": [1, 0, 1]},
            TypeError,
            "truth_speaking must be an array of bool",
        ),
    ],
)
def test_bad_inputs_raise(kwargs: dict, error: type[Exception], match: str) -> None:
    det = kwargs.pop("detected_xyz")
    truth = kwargs.pop("truth_xyz")
    with pytest.raises(error, match=match):
        match_clusters(det, truth, **kwargs)


def test_totals_accumulate_the_tables_figures() -> None:
    totals = EvalTotals()
    truth = TRUTH[:2]
    # Interval 1: both found, 0.1 and 0.3 m off; truth 0 speaks and is detected speaking, truth 1 silent but
    # detected speaking.
    totals.add(
        match_clusters(
            truth + [[0.1, 0, 0], [0, 0.3, 0]], truth, detected_speaking=[True, True], truth_speaking=[True, False]
        )
    )
    # Interval 2: one found exactly (speaking, detected silent), one missed, one far false positive.
    totals.add(
        match_clusters(
            [[0.0, 0.0, 2.0], [5.0, 0.0, 2.0]], truth, detected_speaking=[False, True], truth_speaking=[True, True]
        )
    )
    assert (totals.n_intervals, totals.tp, totals.fn, totals.fp) == (2, 3, 1, 1)
    assert totals.visual_tp_rate == pytest.approx(0.75)
    assert totals.visual_fn_rate == pytest.approx(0.25)
    assert totals.ale_m == pytest.approx((0.1 + 0.3 + 0.0) / 3)
    assert (totals.audio_tp, totals.audio_fn, totals.audio_fp, totals.audio_tn) == (1, 1, 1, 0)
    assert totals.audio_tp_rate == pytest.approx(0.5)
    d = totals.as_dict()
    assert json.loads(json.dumps(d)) == d
    assert d["tp"] == 3 and d["ale_m"] == pytest.approx(0.4 / 3)


def test_empty_totals_have_undefined_rates() -> None:
    totals = EvalTotals()
    assert math.isnan(totals.visual_tp_rate) and math.isnan(totals.ale_m) and math.isnan(totals.audio_tp_rate)
    d = totals.as_dict()
    assert d["visual_tp_rate"] is None and d["ale_m"] is None
    json.dumps(d, allow_nan=False)
    with pytest.raises(TypeError, match="MatchResult"):
        totals.add({"tp": 1})  # type: ignore[arg-type]


coords = st.floats(-3.0, 3.0, allow_nan=False, width=32)
clouds = st.integers(0, 6).flatmap(lambda n: hnp.arrays(np.float64, (n, 3), elements=coords))


@settings(max_examples=200, deadline=None)
@given(det=clouds, truth=clouds, tau=st.floats(0.05, 2.0))
def test_protocol_invariants(det: np.ndarray, truth: np.ndarray, tau: float) -> None:
    res = match_clusters(det, truth, tau_loc=tau)
    assert isinstance(res, MatchResult)
    assert res.tp + res.fn == len(truth)
    assert res.tp + res.fp == len(det)
    assert len(res.pairs) == res.tp == res.errors_m.size
    assert len({g for g, _ in res.pairs}) == res.tp and len({d for _, d in res.pairs}) == res.tp
    assert np.all(res.errors_m < tau)
    for (g, d), err in zip(res.pairs, res.errors_m):
        assert err == pytest.approx(np.linalg.norm(det[d] - truth[g]))
    # Reordering the detections changes neither the counts nor the errors.
    perm = np.random.default_rng(0).permutation(len(det))
    again = match_clusters(det[perm], truth, tau_loc=tau)
    assert (again.fp, again.fn, again.tp) == (res.fp, res.fn, res.tp)
    np.testing.assert_allclose(np.sort(again.errors_m), np.sort(res.errors_m))
