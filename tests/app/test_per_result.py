"""Speaking states per result x person (app.eval.per_result), on timelines made by hand."""
from __future__ import annotations

import numpy as np
import pytest

from app.eval.per_result import result_counts

STAMPS = np.arange(0.0, 10.0, 0.1)  # 100 results, one every 0.1 s


def _states(*called: tuple[float, float]) -> np.ndarray:
    s = np.zeros((STAMPS.size, 1), dtype=int)
    for a, b in called:
        s[(STAMPS >= a - 1e-9) & (STAMPS < b - 1e-9), 0] = 1
    return s


def test_a_late_speaking_state_is_forgiven_at_the_edges_only() -> None:
    speech = [[(2.0, 4.0)]]
    c = result_counts(STAMPS, _states((2.2, 4.2)), np.ones((100, 1), bool), speech, half_span_s=0.05)
    assert (c.tp, c.fp, c.fn) == (18, 2, 2)
    assert c.precision == pytest.approx(0.9) and c.recall == pytest.approx(0.9)
    assert c.precision_forgiven == 1.0 and c.recall_forgiven == 1.0
    assert (c.utterances, c.heard, c.false_stretches) == (1, 1, 0)


def test_a_call_far_from_the_own_speech_is_a_false_stretch() -> None:
    speech = [[(2.0, 4.0)]]
    c = result_counts(STAMPS, _states((2.0, 4.0), (4.1, 4.3), (7.0, 7.5)), np.ones((100, 1), bool), speech,
                      half_span_s=0.05)
    assert c.false_stretches == 1  # 4.1-4.3 lies within 0.3 s of the speech, 7.0-7.5 does not
    assert c.calls == 27 and c.calls_near_speech == 22
    assert c.precision_forgiven == pytest.approx(22 / 27)
    assert c.false_stretches_per_utterance == 1.0


def test_a_miss_inside_the_speech_costs_the_forgiven_recall() -> None:
    speech = [[(2.0, 4.0), (6.0, 8.0)]]
    c = result_counts(STAMPS, _states((2.0, 4.0)), np.ones((100, 1), bool), speech, half_span_s=0.05)
    assert (c.utterances, c.heard) == (2, 1)
    assert c.inner == 28 and c.inner_called == 14 and c.recall_forgiven == 0.5


def test_people_out_of_view_and_faces_not_found() -> None:
    speech = [[(2.0, 4.0)]]
    states = _states((2.0, 4.0))
    states[25:30, 0] = -1  # not found: judged silent, and it ends no stretch
    visible = np.ones((100, 1), bool)
    visible[:20, 0] = False  # out of view before 2 s: a call there counts for nothing
    states[5:10, 0] = 1
    c = result_counts(STAMPS, states, visible, speech, half_span_s=0.05)
    assert c.fp == 0 and c.fn == 5 and c.false_stretches == 1  # the unseen run still is a false stretch of a face
    assert c.heard == 1  # 15 of 20 results called speaking


def test_stamps_in_any_order() -> None:
    speech = [[(2.0, 4.0)]]
    order = np.random.default_rng(0).permutation(100)
    a = result_counts(STAMPS, _states((2.2, 4.2), (7, 8)), np.ones((100, 1), bool), speech, half_span_s=0.05)
    b = result_counts(STAMPS[order], _states((2.2, 4.2), (7, 8))[order], np.ones((100, 1), bool), speech,
                      half_span_s=0.05)
    assert a == b
