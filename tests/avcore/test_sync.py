from __future__ import annotations

import itertools
import logging
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from avcore.itd import FrameBins
from avcore.sync import ApproximateTime, FrameItdWindow, TimeFrame

PROPERTY = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def run(sync: ApproximateTime, arrivals: list[tuple[int, float]]) -> list[tuple]:
    """Push (topic, stamp) pairs with the stamp as item; return every emitted set in order."""
    out: list[tuple] = []
    for topic, stamp in arrivals:
        out += sync.push(topic, stamp, stamp)
    return out


# ---------------------------------------------------------------------------------------------------------------
# ApproximateTime: the documented cases (issue 6 and the ROS policy's own test suite, same inputs and outputs)


def test_issue_example_last_pair_waits() -> None:
    sync = ApproximateTime(n_topics=2, queue_size=10)
    per_push = [sync.push(t, s, (t, s)) for t, s in [(0, 0.0), (1, 1.0), (0, 3.0), (1, 4.0), (0, 6.0), (1, 7.0)]]
    assert per_push == [[], [], [((0, 0.0), (1, 1.0))], [], [((0, 3.0), (1, 4.0))], []]
    assert sync.queued_counts == (1, 1)  # (6, 7) waits: a topic-0 message at 7 would be a better partner
    assert sync.push(0, 9.0, (0, 9.0)) == [((0, 6.0), (1, 7.0))]


ROS_TWO_TOPIC_CASES = {
    # name: (arrivals as (stamp, topic), expected sets, queue size)
    "exact_match": ([(0, 0), (0, 1), (3, 0), (3, 1), (6, 0), (6, 1)], [(0, 0), (3, 3), (6, 6)], 10),
    "imperfect_match": ([(0, 0), (1, 1), (2, 0), (3, 0), (5, 1), (6, 0), (7, 1)], [(0, 1), (6, 5)], 10),
    "acceleration": ([(0, 0), (7, 1), (12, 0), (15, 1), (17, 0), (18, 1)], [(12, 7), (17, 18)], 10),
    "dropped_queue_1": (
        [(0, 0), (1, 1), (3, 1), (4, 0), (7, 1), (8, 0), (10, 0), (11, 1), (13, 0), (14, 1)], [(4, 3), (10, 11)], 1
    ),
    "dropped_queue_2": (
        [(0, 0), (1, 1), (3, 1), (4, 0), (7, 1), (8, 0), (10, 0), (11, 1), (13, 0), (14, 1)],
        [(0, 1), (4, 3), (8, 7), (10, 11)],
        2,
    ),
    "long_queue": (
        [(i, 0) for i in range(9)] + [(3, 1), (9, 0), (10, 0), (11, 0), (12, 0), (10, 1), (13, 0)], [(10, 10)], 5
    ),
    "double_publish": ([(0, 0), (1, 1), (3, 1), (3, 0)], [(0, 1), (3, 3)], 10),
}


@pytest.mark.parametrize("name", sorted(ROS_TWO_TOPIC_CASES))
def test_ros_policy_cases(name: str) -> None:
    arrivals, expected, queue_size = ROS_TWO_TOPIC_CASES[name]
    sync = ApproximateTime(2, queue_size)
    assert run(sync, [(topic, float(stamp)) for stamp, topic in arrivals]) == [tuple(map(float, e)) for e in expected]


def test_ros_four_topics_and_early_publish() -> None:
    arrivals = [(0, 0), (1, 1), (2, 2), (3, 3), (5, 0), (5, 3), (6, 1), (6, 2), (8, 0), (9, 1), (10, 2), (11, 3),
                (10, 0), (13, 0), (14, 1)]
    sync = ApproximateTime(4, 10)
    assert run(sync, [(t, float(s)) for s, t in arrivals]) == [(0, 1, 2, 3), (5, 6, 6, 5), (10, 9, 10, 11)]
    # Early publish: once topic 0 jumps to 7, no message can improve (0, 1, 2, 3).
    sync = ApproximateTime(4, 10)
    assert run(sync, [(0, 0.0), (1, 1.0), (2, 2.0), (3, 3.0)]) == []
    assert sync.push(0, 7.0, 7.0) == [(0.0, 1.0, 2.0, 3.0)]


@pytest.mark.parametrize("bound, expected", [(1.5, [(0, 1), (3, 4)]), (2.0, [(0, 1), (3, 4), (6, 7)])])
def test_ros_rate_bound(bound: float, expected: list[tuple]) -> None:
    arrivals = [(0, 0.0), (1, 1.0), (0, 3.0), (1, 4.0), (0, 6.0), (1, 7.0)]
    sync = ApproximateTime(2, 10, lower_bounds_s=[bound, 0.0])
    assert run(sync, arrivals) == [tuple(map(float, e)) for e in expected]


def test_lower_bound_publishes_earlier_not_differently() -> None:
    arrivals = [(0, 0.0), (1, 1.0), (0, 3.0), (1, 4.0)]
    plain = ApproximateTime(2, 10)
    bounded = ApproximateTime(2, 10, lower_bounds_s=3.0)
    assert [plain.push(t, s, s) for t, s in arrivals] == [[], [], [(0.0, 1.0)], []]
    assert [bounded.push(t, s, s) for t, s in arrivals] == [[], [(0.0, 1.0)], [], [(3.0, 4.0)]]


def test_waiting_candidate_is_published_when_a_busy_topic_proves_it() -> None:
    # Candidate (1.75, 2.0, 1.75): topic 2's message at 2.25 proves that no later set can be smaller. ROS would only
    # notice at the next message of topic 0; here the push that brings the proof publishes.
    sync = ApproximateTime(3, 10)
    assert run(sync, [(0, 1.75), (2, 1.75), (1, 2.0)]) == []
    assert sync.push(2, 2.25, 2.25) == [(1.75, 2.0, 1.75)]


def test_a_virtual_search_that_proves_nothing_puts_back_what_it_retired() -> None:
    # Candidate (2.0, 3.0, 2.0) with pivot topic 1; topic 0 is empty. The virtual search stands in 3.0 for topic 0,
    # retires topic 2's 2.0 for the set [2.0, 3.0] (no smaller), then finds [3.0, 3.0] smaller: it proves nothing and
    # must put back exactly the one message it retired. Topic 2's 3.0 then completes the zero-width set.
    sync = ApproximateTime(3, 10)
    assert run(sync, [(2, 2.0), (1, 3.0), (0, 2.0)]) == []
    assert sync.queued_counts == (1, 1, 1)
    assert sync.push(0, 3.0, 3.0) == []
    assert sync.push(2, 3.0, 3.0) == [(3.0, 3.0, 3.0)]
    assert sync.dropped_counts == (1, 0, 1)
    assert sync.queued_counts == (0, 0, 0)


def test_max_interval_drops_sets_too_far_apart() -> None:
    # Topic 1 starts 3 s after topic 0: without a maximum the two are paired anyway.
    arrivals = [(0, 0.0), (1, 3.0), (0, 9.0), (1, 9.5), (0, 12.0)]
    assert run(ApproximateTime(2, 10), arrivals) == [(0.0, 3.0), (9.0, 9.5)]
    sync = ApproximateTime(2, 10, max_interval_s=2.0)
    assert run(sync, arrivals) == [(9.0, 9.5)]
    assert sync.dropped_counts == (1, 1)


def test_a_drop_for_max_interval_goes_on_to_the_set_behind_it() -> None:
    # Topic 0's 0.0 is 5 s before topic 1's 5.0: dropped, and the same push goes on to publish (5.0, 5.0).
    sync = ApproximateTime(2, 10, max_interval_s=1.0)
    assert [sync.push(t, s, s) for t, s in [(0, 0.0), (0, 5.0), (1, 5.0)]] == [[], [], [(5.0, 5.0)]]
    assert sync.dropped_counts == (1, 0)


def test_age_penalty_prefers_earlier_sets() -> None:
    # Sizes 1.0 for (0, 1) and 0.95 for the later (1.95, 1): a penalty of 0.1 makes the later one the worse.
    arrivals = [(0, 0.0), (1, 1.0), (0, 1.95)]
    assert run(ApproximateTime(2, 10), arrivals) == [(1.95, 1.0)]
    assert run(ApproximateTime(2, 10, age_penalty=0.1), arrivals) == [(0.0, 1.0)]


def test_items_are_returned_as_given() -> None:
    sync = ApproximateTime(3, 4)
    left, right, third = object(), object(), object()
    sync.push(2, 0.0, third)
    sync.push(0, 0.01, left)
    assert sync.push(1, 0.02, right) == []
    # Three equal stamps make a set of size 0 that nothing can beat: it comes out with the one it completed.
    assert sync.push(0, 0.5, "n0") + sync.push(1, 0.5, "n1") + sync.push(2, 0.5, "n2") == [
        (left, right, third), ("n0", "n1", "n2")]


def test_bad_input_is_rejected_and_leaves_state_unchanged() -> None:
    # each message begins with the argument's own name (a mutated name inside the text would still match a search)
    with pytest.raises(ValueError, match="^n_topics must be at least 2"):
        ApproximateTime(1, 10)
    with pytest.raises(ValueError, match="^queue_size must be at least 1"):
        ApproximateTime(2, 0)
    with pytest.raises(TypeError, match="^queue_size must be an integer, got float"):
        ApproximateTime(2, 2.5)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="^max_interval_s must be a finite"):
        ApproximateTime(2, 10, max_interval_s=-1.0)
    with pytest.raises(ValueError, match="^age_penalty must be a finite"):
        ApproximateTime(2, 10, age_penalty=-0.1)
    with pytest.raises(TypeError, match="^age_penalty must be a real number"):
        ApproximateTime(2, 10, age_penalty="0.1")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="^lower_bounds_s must be a finite"):
        ApproximateTime(2, 10, lower_bounds_s=-0.1)
    with pytest.raises(ValueError, match="lower_bounds_s must hold one bound per topic"):
        ApproximateTime(2, 10, lower_bounds_s=[0.1])
    with pytest.raises(ValueError, match=r"lower_bounds_s\[1\]"):
        ApproximateTime(2, 10, lower_bounds_s=[0.1, math.nan])
    sync = ApproximateTime(2, 10)
    sync.push(0, 1.0, "a")
    with pytest.raises(ValueError, match=r"topic must be in \[0, 2\), got 2"):
        sync.push(2, 1.0, "x")
    with pytest.raises(ValueError, match="topic must be in"):
        sync.push(-1, 1.0, "x")
    with pytest.raises(TypeError, match="^topic must be an integer, got bool$"):
        sync.push(True, 1.0, "x")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="stamp must be a finite"):
        sync.push(1, math.nan, "x")
    with pytest.raises(ValueError, match="stamp must be a finite"):
        sync.push(1, math.inf, "x")
    with pytest.raises(TypeError, match="stamp must be a real number"):
        sync.push(1, "1.0", "x")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="earlier than that topic's previous stamp 1.0; ApproximateTime needs each "
                                         "topic's messages in stamp order"):
        sync.push(0, 0.5, "x")
    assert sync.queued_counts == (1, 0)
    assert sync.push(1, 1.1, "b") == []
    assert sync.push(0, 3.0, "c") == [("a", "b")]


def test_lower_bound_violation_is_logged_once_and_counted(caplog: pytest.LogCaptureFixture) -> None:
    """Messages 0.01, 0.02 and 0.02 s apart on a topic bounded at 0.03 s violate it three times: counted three
    times, logged once, with the first gap; messages exactly 0.25 s apart on a topic bounded at 0.25 s do not
    (0.25 is exact in binary)."""
    sync = ApproximateTime(2, 10, lower_bounds_s=[0.03, 0.25])
    with caplog.at_level(logging.WARNING, logger="avcore.sync"):
        for stamp in (1.0, 1.01, 1.03, 1.05, 1.1):
            sync.push(0, stamp, stamp)
        for stamp in (0.0, 0.25, 0.5):
            sync.push(1, stamp, stamp)
    assert sync.bound_violations == (3, 0)
    logged = [r.getMessage() for r in caplog.records if "lower_bounds_s" in r.getMessage()]
    assert logged == ["topic 0: messages 0.01 s apart, closer than lower_bounds_s=0.03 s; sets may not be optimal "
                      "(logged once per topic)"]


# ---------------------------------------------------------------------------------------------------------------
# ApproximateTime: properties


@st.composite
def streams(draw: st.DrawFn, bounded: bool = False) -> tuple[list[list[float]], list[float]]:
    """Per-topic stamp lists (sorted, in steps of 0.25 s so that ties occur) and per-topic lower bounds."""
    n_topics = draw(st.integers(2, 3))
    topics, bounds = [], []
    for _ in range(n_topics):
        bound_steps = draw(st.integers(0, 3)) if bounded else 0
        gaps = draw(st.lists(st.integers(bound_steps, 8), min_size=0, max_size=6))
        first = draw(st.integers(0, 8))
        topics.append([0.25 * v for v in itertools.accumulate([first] + gaps)])
        bounds.append(0.25 * bound_steps)
    return topics, bounds


def arrival_order(topics: list[list[float]], labels: list[int]) -> list[tuple[int, float]]:
    """The k-th occurrence of topic i in ``labels`` delivers topic i's k-th stamp: in order within each topic."""
    counters = [0] * len(topics)
    out = []
    for topic in labels:
        out.append((topic, topics[topic][counters[topic]]))
        counters[topic] += 1
    return out


def labels_of(topics: list[list[float]]) -> list[int]:
    return [i for i, stamps in enumerate(topics) for _ in stamps]


def tagged_run(sync: ApproximateTime, arrivals: list[tuple[int, float]]) -> list[tuple]:
    """Run with items (topic, index within topic, stamp) so that identity and order can be checked."""
    counters: dict[int, int] = {}
    out: list[tuple] = []
    for topic, stamp in arrivals:
        index = counters.get(topic, 0)
        counters[topic] = index + 1
        out += sync.push(topic, stamp, (topic, index, stamp))
    return out


@PROPERTY
@given(data=st.data(), bounded=st.booleans(), age_penalty=st.sampled_from([0.0, 0.1]),
       max_interval=st.sampled_from([None, 0.5, 1.0]))
def test_output_does_not_depend_on_arrival_order(data: st.DataObject, bounded: bool, age_penalty: float,
                                                 max_interval: float | None) -> None:
    topics, bounds = data.draw(streams(bounded=bounded))
    labels = labels_of(topics)
    in_time_order = sorted(arrival_order(topics, labels), key=lambda a: (a[1], a[0]))
    shuffled = arrival_order(topics, data.draw(st.permutations(labels)))
    kwargs = {"max_interval_s": max_interval, "lower_bounds_s": bounds, "age_penalty": age_penalty}
    queue_size = max(1, len(labels))  # large enough: nothing dropped for lack of room
    reference = tagged_run(ApproximateTime(len(topics), queue_size, **kwargs), in_time_order)
    assert tagged_run(ApproximateTime(len(topics), queue_size, **kwargs), shuffled) == reference


@PROPERTY
@given(data=st.data(), queue_size=st.integers(1, 4), max_interval=st.sampled_from([None, 0.5, 1.0]),
       bounded=st.booleans())
def test_conservation_and_set_structure(data: st.DataObject, queue_size: int, max_interval: float | None,
                                        bounded: bool) -> None:
    topics, bounds = data.draw(streams(bounded=bounded))
    n = len(topics)
    arrivals = arrival_order(topics, data.draw(st.permutations(labels_of(topics))))
    sync = ApproximateTime(n, queue_size, max_interval_s=max_interval, lower_bounds_s=bounds)
    sets: list[tuple] = []
    pushed = [0] * n
    for topic, stamp in arrivals:
        sets += sync.push(topic, stamp, (topic, pushed[topic], stamp))
        pushed[topic] += 1
        assert all(count <= queue_size for count in sync.queued_counts)  # bounded queues
    used = [item for s in sets for item in s]
    assert len(used) == len(set(used))  # every message at most once
    for s in sets:
        assert [item[0] for item in s] == list(range(n))  # one item per topic, ordered by topic
        spread = max(item[2] for item in s) - min(item[2] for item in s)
        if max_interval is not None:
            assert spread <= max_interval
    for earlier, later in itertools.pairwise(sets):
        assert all(a[1] < b[1] for a, b in zip(earlier, later))  # sets in increasing order, never crossing
    assert [len(sets) + d + q for d, q in zip(sync.dropped_counts, sync.queued_counts)] == pushed


@PROPERTY
@given(data=st.data(), bounded=st.booleans())
def test_sets_are_contiguous_and_of_minimal_size(data: st.DataObject, bounded: bool) -> None:
    """The ROS documentation's properties 4 and 5, checked by brute force on the whole stream.

    After each published set S, the remaining messages are those after S on each topic; the pivot is the latest of
    their oldest stamps; the next set must have the smallest size among all sets containing the pivot.
    """
    topics, bounds = data.draw(streams(bounded=bounded))
    n = len(topics)
    arrivals = arrival_order(topics, data.draw(st.permutations(labels_of(topics))))
    sets = tagged_run(ApproximateTime(n, max(1, len(arrivals)), lower_bounds_s=bounds), arrivals)
    previous = [-1] * n
    for s in sets:
        remaining = [list(range(previous[i] + 1, len(topics[i]))) for i in range(n)]
        heads = [topics[i][r[0]] for i, r in enumerate(remaining)]
        pivot = max(range(n), key=lambda i: (heads[i], i))
        choices = [r if i != pivot else r[:1] for i, r in enumerate(remaining)]
        best = min(max(topics[i][k] for i, k in enumerate(c)) - min(topics[i][k] for i, k in enumerate(c))
                   for c in itertools.product(*choices))
        size = max(item[2] for item in s) - min(item[2] for item in s)
        assert size == best
        indices = [item[1] for item in s]
        assert any(indices[i] == previous[i] + 1 for i in range(n))  # contiguous: one topic skipped nothing
        previous = indices


@PROPERTY
@given(data=st.data())
def test_everything_is_emitted_when_streams_are_identical(data: st.DataObject) -> None:
    """Topics carrying the same stamps (synchronised cameras) are matched exactly, every frame, in any order."""
    stamps = [0.25 * v for v in itertools.accumulate(data.draw(st.lists(st.integers(1, 8), min_size=1, max_size=8)))]
    topics = [stamps, stamps]
    arrivals = arrival_order(topics, data.draw(st.permutations(labels_of(topics))))
    sync = ApproximateTime(2, len(stamps) + 1, lower_bounds_s=0.25)  # room for one topic to run ahead
    assert run(sync, arrivals) == [(s, s) for s in stamps]


# ---------------------------------------------------------------------------------------------------------------
# TimeFrame


def collect(tf: TimeFrame, events: list[tuple[str, float, object]]) -> list[list[tuple]]:
    """Feed ('p' | 's', stamp, item) events; return what each push returned, then what flush returned."""
    out = []
    for kind, stamp, item in events:
        out.append(tf.push_primary(stamp, item) if kind == "p" else tf.push_secondary(stamp, item))
    out.append(tf.flush())
    return out


def test_time_frame_documented_case() -> None:
    tf = TimeFrame(window_s=0.25)
    assert tf.push_secondary(0.5, "itd 0.5") == []  # before the window: never attached to the primary at 1.0
    assert tf.push_secondary(0.75, "itd 0.75") == []
    assert tf.push_primary(1.0, "faces 1.0") == []
    assert tf.push_secondary(1.125, "itd 1.125") == []
    assert tf.push_secondary(1.25, "itd 1.25") == []  # at the edge: included, and a later one may still come
    assert tf.n_pending == 1
    assert tf.push_secondary(1.375, "itd 1.375") == [("faces 1.0", ["itd 0.75", "itd 1.125", "itd 1.25"])]
    assert tf.n_pending == 0


def test_time_frame_primary_after_its_window_completes_at_once() -> None:
    tf = TimeFrame(window_s=0.25)
    for s in (0.0, 0.25, 0.5, 0.75, 1.0):
        tf.push_secondary(s, s)
    assert tf.push_primary(0.5, "late vision") == [("late vision", [0.25, 0.5, 0.75])]
    assert tf.push_primary(0.75, "edge") == []  # 1.0 is the edge of its window: not yet complete
    assert tf.flush() == [("edge", [0.5, 0.75, 1.0])]
    assert tf.flush() == []


def test_time_frame_advance_completes_in_silence() -> None:
    tf = TimeFrame(window_s=0.25)
    tf.push_secondary(0.0, "a")
    assert tf.push_primary(0.125, "p") == []
    assert tf.advance(0.25) == []
    assert tf.advance(0.5) == [("p", ["a"])]
    assert tf.advance(0.1) == []  # going back is harmless
    with pytest.raises(ValueError, match="earlier than 0.5"):
        tf.push_secondary(0.45, "too late")


def test_time_frame_memory_is_bounded_on_a_long_stream() -> None:
    tf = TimeFrame(window_s=0.2)
    completed = 0
    largest = 0
    for k in range(6000):  # 60 s of ITDs at 100 Hz, vision at 12.5 Hz arriving 80 ms late
        t = k * 0.01
        completed += len(tf.push_secondary(t, k))
        if k % 8 == 0 and k >= 8:
            completed += len(tf.push_primary(t - 0.08, k))
        largest = max(largest, tf.n_buffered)
    assert completed + tf.n_pending == 749
    assert largest <= 60  # a few windows' worth, not the whole stream
    assert tf.dropped_secondaries == 0 and tf.dropped_primaries == 0


def test_time_frame_caps() -> None:
    tf = TimeFrame(window_s=0.1, max_secondaries=5, max_pending=2)
    for k in range(8):
        tf.push_secondary(float(k), k)
    assert tf.n_buffered == 5 and tf.dropped_secondaries == 3
    for t in (10.0, 11.0, 12.0):
        tf.push_primary(t, t)
    assert tf.dropped_primaries == 1
    assert [p for p, _ in tf.flush()] == [11.0, 12.0]


def test_time_frame_bad_input() -> None:
    with pytest.raises(ValueError, match="window_s"):
        TimeFrame(window_s=-0.1)
    with pytest.raises(ValueError, match="window_s"):
        TimeFrame(window_s=math.nan)
    with pytest.raises(ValueError, match="max_pending"):
        TimeFrame(0.1, max_pending=0)
    tf = TimeFrame(0.1)
    tf.push_primary(1.0, "p")
    tf.push_secondary(1.0, "s")
    with pytest.raises(ValueError, match="stamp must be a finite"):
        tf.push_primary(math.nan, "x")
    with pytest.raises(ValueError, match="stamp must be a finite"):
        tf.push_secondary(math.inf, "x")
    with pytest.raises(ValueError, match="primary stamp 0.5 is earlier"):
        tf.push_primary(0.5, "x")
    with pytest.raises(ValueError, match="secondary stamp 0.5 is earlier"):
        tf.push_secondary(0.5, "x")
    assert tf.flush() == [("p", ["s"])]


@st.composite
def time_frame_streams(draw: st.DrawFn) -> tuple[float, list[tuple[str, float, object]]]:
    window = 0.125 * draw(st.integers(0, 6))
    primaries = [0.125 * v for v in itertools.accumulate(draw(st.lists(st.integers(0, 6), max_size=8)))]
    secondaries = [0.125 * v for v in itertools.accumulate(draw(st.lists(st.integers(0, 4), max_size=20)))]
    labels = draw(st.permutations(["p"] * len(primaries) + ["s"] * len(secondaries)))
    events, ip, is_ = [], 0, 0
    for kind in labels:
        if kind == "p":
            events.append(("p", primaries[ip], ("p", ip)))
            ip += 1
        else:
            events.append(("s", secondaries[is_], ("s", is_)))
            is_ += 1
    return window, events


@PROPERTY
@given(time_frame_streams())
def test_time_frame_gives_exactly_the_secondaries_in_the_window(case: tuple) -> None:
    window, events = case
    results = collect(TimeFrame(window), events)
    primaries = [(stamp, item) for kind, stamp, item in events if kind == "p"]
    secondaries = [(stamp, item) for kind, stamp, item in events if kind == "s"]
    emitted = [pair for step in results for pair in step]
    assert [p for p, _ in emitted] == [item for _, item in primaries]  # each primary once, in order
    for (stamp, _), (_, attached) in zip(primaries, emitted):
        assert attached == [item for s, item in secondaries if stamp - window <= s <= stamp + window]
    # Completion happens at the first event after which the secondary stream has passed stamp + window.
    for (stamp, item) in primaries:
        pushed_at = next(k for k, e in enumerate(events) if e[2] == item)
        passed_at = next((k for k, e in enumerate(events) if e[0] == "s" and e[1] > stamp + window), len(events))
        done_at = next(k for k, step in enumerate(results) if any(p == item for p, _ in step))
        assert done_at == max(pushed_at, passed_at)


def test_frame_itd_window_gives_the_frames_near_a_stamp_and_forgets_the_past() -> None:

    w = FrameItdWindow(0.2, keep_s=1.0)
    for start in np.arange(0.0, 3.0, 0.5):  # blocks of 16 frames every 0.5 s
        times = start + np.arange(16) * 0.032
        w.push(times, times * 1e-4, times, -times * 1e-4)
    assert w.cut > 0 and all(b[1] >= 3.0 - 1.5 for b in w)  # bounded without vision frames
    frames, bands, bins = w.near(2.3)
    assert frames is not None and bands is not None and bins is None  # no bins pushed (one pair)
    assert np.all(np.abs(frames / 1e-4 - 2.3) <= 0.2 + 1e-9) and np.all(np.abs(-bands / 1e-4 - 2.3) <= 0.2 + 1e-9)
    n = len(w)
    w.near(2.9)  # a later frame: blocks wholly before 2.7 s are not needed again
    assert len(w) < n
    assert w.near(10.0) == (None, None, None)


def test_frame_itd_window_gives_the_bins_of_the_frames_near_a_stamp() -> None:
    w = FrameItdWindow(0.2)
    freqs = np.array([100.0, 200.0])
    for start in (0.0, 0.5):
        times = start + np.arange(16) * 0.032
        bins = np.broadcast_to(times[:, None, None], (16, 3, 2)).astype(np.complex64)  # a bin's value: its time
        w.push(times, times, times[:0], times[:0], FrameBins(times, bins, freqs))
    _, _, near = w.near(0.5)
    assert near is not None and near.bins.shape[1:] == (3, 2) and np.array_equal(near.freqs_hz, freqs)
    expected = np.concatenate([start + np.arange(16) * 0.032 for start in (0.0, 0.5)])
    expected = expected[np.abs(expected - 0.5) <= 0.2]
    assert np.allclose(near.times_s, expected) and np.allclose(near.bins.real[:, 0, 0], expected)
    # a block of silence: no frame passed the energy gate, the bins still come
    times = 2.0 + np.arange(16) * 0.032
    w.push(times[:0], times[:0], times[:0], times[:0], FrameBins(times, np.ones((16, 3, 2), np.complex64), freqs))
    frames, bands, near = w.near(2.2)
    assert frames is None and bands is None and near is not None and len(near) == np.sum(np.abs(times - 2.2) <= 0.2)


def test_a_past_only_time_frame_completes_at_its_stamp() -> None:
    """after_s = 0 (low latency): a primary at t collects the secondaries of [t - window, t] and is complete as soon
    as a secondary later than t arrives, not t + window."""
    tf = TimeFrame(window_s=0.4, after_s=0.0)
    for s in (0.55, 0.7, 0.95):
        assert tf.push_secondary(s, s) == []
    assert tf.push_primary(1.0, "frame") == []  # nothing after 1.0 yet: it might still come
    assert tf.push_secondary(1.02, 1.02) == [("frame", [0.7, 0.95])]  # 0.55 is before 1.0 - 0.4; 1.02 after
    with pytest.raises(ValueError, match="after_s"):
        TimeFrame(window_s=0.2, after_s=-0.1)


def test_a_time_frame_names_a_primary_out_of_order_and_counts_every_dropped_one() -> None:
    tf = TimeFrame(window_s=0.1, max_pending=1)
    tf.push_primary(1.0, "a")
    with pytest.raises(ValueError, match=r"^primary stamp 0\.5 is earlier than the previous primary stamp 1\.0; "
                                         r"TimeFrame needs primaries in stamp order \(the event was ignored\)$"):
        tf.push_primary(0.5, "late")
    tf.push_primary(2.0, "b")
    tf.push_primary(3.0, "c")
    assert tf.dropped_primaries == 2 and tf.n_pending == 1


def _window_with_blocks(span_s: float, keep_s: float = 30.0) -> FrameItdWindow:
    """Blocks of two frames at 0, 0.25 | 0.5, 0.75 | 1.0, 1.25 s (binary fractions: comparisons are exact), each
    frame's ITD its time in ms and its band's the negative."""
    w = FrameItdWindow(span_s, keep_s)
    for start in (0.0, 0.5, 1.0):
        times = [start, start + 0.25]
        w.push(times, [1e3 * t for t in times], times, [-1e3 * t for t in times])
    return w


def test_frames_exactly_a_span_away_are_near() -> None:
    """|t - stamp| <= span: a frame or a band exactly ``span_s`` from the stamp counts, and so does a block that
    ends or begins exactly there."""
    frames, bands, _ = _window_with_blocks(0.25).near(0.5)
    assert frames.tolist() == [250.0, 500.0, 750.0] and bands.tolist() == [-250.0, -500.0, -750.0]
    frames, bands, _ = _window_with_blocks(0.25).near(0.75)
    assert frames.tolist() == [500.0, 750.0, 1000.0] and bands.tolist() == [-500.0, -750.0, -1000.0]
    assert frames.dtype == np.float64 and bands.dtype == np.float64  # lists of numbers are kept as floats


def test_the_window_keeps_blocks_exactly_keep_s_old_and_counts_every_frame_it_cuts() -> None:
    assert FrameItdWindow(0.2).keep_s == 30.0  # half a minute without vision frames
    w = _window_with_blocks(0.1, keep_s=0.5)
    # the blocks end at 0.25, 0.75 and 1.25 s: each kept while it ended exactly 0.5 s before the newest, the first
    # cut when the third came
    assert [b[1] for b in w] == [0.75, 1.25] and w.cut == 2
    w.push([2.0, 2.25], [1.0, 2.0], [2.0], [3.0])
    assert [b[1] for b in w] == [2.25] and w.cut == 6
    with pytest.raises(ValueError, match="^keep_s must be"):
        FrameItdWindow(0.2, keep_s=-1.0)


def test_itds_given_as_integers_come_back_as_floats() -> None:
    w = FrameItdWindow(1.0)
    w.push([1, 2], [3, 4], [1], [5])
    frames, bands, _ = w.near(1)
    assert frames.dtype == np.float64 and bands.dtype == np.float64 and frames.tolist() == [3.0, 4.0]


def test_a_time_frame_names_each_wrong_argument_and_accepts_buffers_of_one() -> None:
    tf = TimeFrame(0.1)
    assert (tf.max_secondaries, tf.max_pending, tf.after_s) == (4096, 256, 0.1)
    for kwargs, message in [
        ({"window_s": -0.1}, "window_s must be a finite, non-negative number of seconds, got -0.1"),
        ({"window_s": 0.1, "after_s": -1.0}, "after_s must be a finite, non-negative number of seconds, got -1.0"),
        ({"window_s": 0.1, "max_secondaries": 0}, "max_secondaries must be at least 1, got 0"),
        ({"window_s": 0.1, "max_pending": 0}, "max_pending must be at least 1, got 0"),
    ]:
        with pytest.raises(ValueError, match=f"^{message}$"):
            TimeFrame(**kwargs)
    with pytest.raises(TypeError, match="^max_secondaries must be an integer, got float$"):
        TimeFrame(0.1, max_secondaries=2.0)  # type: ignore[arg-type]
    one = TimeFrame(0.1, max_secondaries=1, max_pending=1)
    assert (one.max_secondaries, one.max_pending) == (1, 1)
    one.push_secondary(0.0, "s")
    with pytest.raises(ValueError, match=r"^secondary stamp -1\.0 is earlier than 0\.0, the latest secondary stamp or "
                                         r"advance\(\); TimeFrame needs secondaries in stamp order \(the event was "
                                         r"ignored\)$"):
        one.push_secondary(-1.0, "late")


def test_wrong_kinds_of_time_are_named_with_their_type() -> None:
    with pytest.raises(TypeError, match="^stamp must be a real number of seconds, got str$"):
        ApproximateTime(2, 10).push(0, "0.5", "x")  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="^span_s must be a real number of seconds, got str$"):
        FrameItdWindow("0.2")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="^span_s must be a finite, non-negative number of seconds, got -0.2$"):
        FrameItdWindow(-0.2)
    with pytest.raises(ValueError, match="^keep_s must be a finite, non-negative number of seconds, got nan$"):
        FrameItdWindow(0.2, math.nan)


def test_a_time_frame_holds_exactly_max_secondaries() -> None:
    tf = TimeFrame(0.1, max_secondaries=2)
    tf.push_secondary(0.0, "s0")
    tf.push_secondary(0.1, "s1")
    assert tf.n_buffered == 2 and tf.dropped_secondaries == 0
    tf.push_secondary(0.2, "s2")
    assert tf.n_buffered == 2 and tf.dropped_secondaries == 1
