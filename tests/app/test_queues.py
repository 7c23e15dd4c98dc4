from __future__ import annotations

import threading

import pytest
from hypothesis import given
from hypothesis import strategies as st

from app.queues import DropOldestQueue


@given(st.integers(1, 8), st.lists(st.integers(), max_size=40))
def test_drop_oldest_keeps_the_newest(maxsize: int, items: list[int]) -> None:
    q: DropOldestQueue[int] = DropOldestQueue(maxsize)
    for i in items:
        q.put(i)
    kept = []
    while (x := q.get(timeout=0)) is not None:
        kept.append(x)
    assert kept == items[-maxsize:] if items else kept == []
    assert q.dropped == max(0, len(items) - maxsize)
    assert q.put_count == len(items)


def test_get_times_out_and_wait_for_room() -> None:
    q: DropOldestQueue[int] = DropOldestQueue(1)
    assert q.get(timeout=0.01) is None
    q.put(1)
    assert not q.wait_for_room(0.01)
    threading.Timer(0.05, q.get).start()
    assert q.wait_for_room(2.0)
    with pytest.raises(ValueError, match="maxsize"):
        DropOldestQueue(0)
