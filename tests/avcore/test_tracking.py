from __future__ import annotations

import numpy as np
import pytest

from avcore.tracking import NearestTracker


def test_ids_follow_people_and_survive_order_changes() -> None:
    tr = NearestTracker()
    a = np.array([[-0.5, 0, 2.0], [0.0, 0, 2.5], [0.6, 0, 2.2]])
    first = tr.update(a)
    assert first.tolist() == [0, 1, 2]
    moved = a[::-1] + 0.05  # reported in another order, a little moved
    assert tr.update(moved).tolist() == [2, 1, 0]


def test_newcomer_missed_detection_and_forgetting() -> None:
    tr = NearestTracker(max_missed=2)
    tr.update([[0, 0, 2], [1, 0, 2]])
    assert tr.update([[0, 0, 2]]).tolist() == [0]  # person 1 missed once
    assert tr.update([[0, 0, 2], [1.02, 0, 2]]).tolist() == [0, 1]  # and found again with its id
    assert tr.update([[0, 0, 2], [-1, 0, 3]]).tolist() == [0, 2]  # a newcomer gets a new id
    for _ in range(3):
        tr.update([[0, 0, 2]])
    assert tr.update([[1, 0, 2]]).tolist() == [3]  # person 1 was forgotten


def test_gate_and_two_close_people() -> None:
    tr = NearestTracker(gate_m=0.3)
    tr.update([[0, 0, 2], [0.5, 0, 2]])
    # both moved towards each other: each keeps the nearest identity, never both the same one
    ids = tr.update([[0.2, 0, 2], [0.35, 0, 2]])
    assert sorted(ids.tolist()) == [0, 1] and ids[0] == 0
    assert tr.update(np.empty((0, 3))).shape == (0,)
    with pytest.raises(ValueError, match="positions"):
        tr.update(np.zeros((2, 2)))


def test_a_person_back_within_the_memory_keeps_their_id() -> None:
    """With stamps, a person who leaves and comes back to about the same place within memory_s (10 s) keeps their
    id, however many updates passed; after longer, they are someone new."""
    tr = NearestTracker(memory_s=10.0)
    assert tr.update([[0, 0, 2], [1, 0, 2]], 0.0).tolist() == [0, 1]
    for k in range(1, 250):  # person 1 away for 8.3 s at 30 updates a second
        assert tr.update([[0, 0, 2]], k / 30).tolist() == [0]
    assert tr.update([[0, 0, 2], [1.1, 0, 2]], 250 / 30).tolist() == [0, 1]
    for k in range(251, 600):  # away again, 11.6 s
        tr.update([[0, 0, 2]], k / 30)
    assert tr.update([[0, 0, 2], [1.0, 0, 2]], 600 / 30).tolist() == [0, 2]
    with pytest.raises(ValueError, match="memory_s"):
        NearestTracker(memory_s=0.0)
