"""Timestamp synchronisers of the paper's section 6 (System Architecture), as pure objects fed with stamps.

The paper's implementation used the two strategies of the RSB event synchroniser:

- :class:`ApproximateTime` matches one message per topic (the left and right camera frames) so that the time spread
  of each set is minimal. It is the adaptive algorithm of ROS ``message_filters``' ApproximateTime policy
  (wiki.ros.org/message_filters/ApproximateTime and its C++ policy ``sync_policies/approximate_time``), which RSB's
  strategy is based on -- not the epsilon ("slop") matcher of the ROS Python port.
- :class:`TimeFrame` gives each event of a primary stream (a vision result) every event of a secondary stream (the
  ITDs) whose stamp lies within ``+-window_s`` of the primary's stamp.

Both are plain objects: no threads, no locks, no clocks. The caller pushes ``(stamp, item)`` and receives whatever the
push completed; stamps are seconds on one clock (docs/architecture.md). A stamp that breaks an object's ordering
assumption is rejected with ``ValueError`` and leaves the object unchanged, so that a running pipeline can count it and
go on.
"""
from __future__ import annotations

import logging
import math
from bisect import bisect_left, bisect_right
from collections import deque
from collections.abc import Iterator, Sequence
from numbers import Integral, Real
from typing import Any, NamedTuple

import numpy as np

from avcore.itd.pairs import FrameBins

__all__ = ["ApproximateTime", "FrameItdWindow", "TimeFrame"]

logger = logging.getLogger(__name__)


def _check_stamp(stamp: object, name: str = "stamp") -> float:
    if isinstance(stamp, bool) or not isinstance(stamp, Real):
        raise TypeError(f"{name} must be a real number of seconds, got {type(stamp).__name__}")
    value = float(stamp)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number of seconds, got {stamp!r}")
    return value


def _check_duration(value: object, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, Real):
        raise TypeError(f"{name} must be a real number of seconds, got {type(value).__name__}")
    out = float(value)
    if not (math.isfinite(out) and out >= 0):
        raise ValueError(f"{name} must be a finite, non-negative number of seconds, got {value!r}")
    return out


def _check_count(value: object, name: str, minimum: int) -> int:
    if isinstance(value, bool) or not isinstance(value, Integral):
        raise TypeError(f"{name} must be an integer, got {type(value).__name__}")
    if value < minimum:
        raise ValueError(f"{name} must be at least {minimum}, got {value!r}")
    return int(value)


class _Message(NamedTuple):
    stamp: float
    item: Any


class ApproximateTime:
    """Match one message per topic with the smallest time spread: the adaptive ApproximateTime policy of ROS.

    The *size* of a set is the difference between its latest and its earliest stamp. After the last published set
    (or at the start), the latest of the topics' oldest queued messages is the *pivot*: every set that can still be
    formed contains it or a later message of its topic, so the next set is the one of minimal size that contains the
    pivot. Candidates are examined by repeatedly retiring the earliest queued message; a candidate is published as
    soon as no message still to come can make a smaller set -- when the pivot itself is the earliest message, or when
    the interval ``[pivot, next earliest]`` is already larger than the candidate. Messages older than a published set
    are dropped. The resulting sets satisfy the properties of the ROS documentation:

    1. each message is used at most once (some are dropped);
    2. sets do not cross: for two sets S, T, ``S[i] <= T[i]`` for every topic i, or the reverse;
    3. sets are contiguous: between two consecutive sets at least one topic has no dropped message;
    4. each set has minimal size among the sets contiguous to the previous one (the sets containing the pivot);
    5. the output depends only on the stamps, not on the arrival order, provided that each topic's messages arrive
       in stamp order and the queues are large enough.

    In full (every part, and why): docs/architecture.md ("Pairing two cameras by stamp").
    """

    def __init__(
        self,
        n_topics: int,
        queue_size: int,
        *,
        max_interval_s: float | None = None,
        lower_bounds_s: float | Sequence[float] | None = None,
        age_penalty: float = 0.0,
    ) -> None:
        self.n_topics = _check_count(n_topics, "n_topics", 2)
        self.queue_size = _check_count(queue_size, "queue_size", 1)
        self.max_interval_s = None if max_interval_s is None else _check_duration(max_interval_s, "max_interval_s")
        self.age_penalty = _check_duration(age_penalty, "age_penalty")
        if lower_bounds_s is None:
            bounds = [0.0] * self.n_topics
        elif isinstance(lower_bounds_s, Real) and not isinstance(lower_bounds_s, bool):
            bounds = [_check_duration(lower_bounds_s, "lower_bounds_s")] * self.n_topics
        else:
            values = list(lower_bounds_s)  # type: ignore[arg-type]
            if len(values) != self.n_topics:
                raise ValueError(
                    f"lower_bounds_s must hold one bound per topic ({self.n_topics}), got {len(values)}"
                )
            bounds = [_check_duration(v, f"lower_bounds_s[{i}]") for i, v in enumerate(values)]
        self.lower_bounds_s: tuple[float, ...] = tuple(bounds)
        self.reset()

    def reset(self) -> None:
        """Forget every queued message, the candidate and the stamp history (e.g. after a source restarts)."""
        n = self.n_topics
        self._queues: list[deque[_Message]] = [deque() for _ in range(n)]
        # Messages retired from the queues while examining candidates for the current pivot; they go back to the
        # front of their queue when the candidate is published or abandoned.
        self._past: list[list[_Message]] = [[] for _ in range(n)]
        self._candidate: tuple[_Message, ...] | None = None
        self._candidate_start = 0.0
        self._candidate_end = 0.0
        self._pivot: int | None = None
        self._pivot_time = 0.0
        self._has_dropped = [False] * n
        self._last_stamp: list[float | None] = [None] * n
        self._dropped = [0] * n
        self._bound_violations = [0] * n

    # ------------------------------------------------------------------ public surface

    @property
    def dropped_counts(self) -> tuple[int, ...]:
        """Per topic, the messages that left the synchroniser without being part of an emitted set."""
        return tuple(self._dropped)

    @property
    def bound_violations(self) -> tuple[int, ...]:
        """Per topic, the messages that arrived closer to their predecessor than ``lower_bounds_s``."""
        return tuple(self._bound_violations)

    @property
    def queued_counts(self) -> tuple[int, ...]:
        """Per topic, the messages held (not yet emitted or dropped)."""
        return tuple(len(q) + len(p) for q, p in zip(self._queues, self._past))

    def push(self, topic: int, stamp: float, item: Any) -> list[tuple]:
        """Add one message and return the sets it completed, oldest first.

        Parameters
        ----------
        topic : int in [0, n_topics)
        stamp : float, seconds
            Not earlier than the previous stamp of the same topic (topics may interleave arbitrarily).
        item : any object, returned as is in an emitted set.

        Returns
        -------
        list of tuples, each holding ``n_topics`` items ordered by topic.
        """
        if isinstance(topic, bool) or not isinstance(topic, Integral):
            raise TypeError(f"topic must be an integer, got {type(topic).__name__}")
        if not 0 <= topic < self.n_topics:
            raise ValueError(f"topic must be in [0, {self.n_topics}), got {topic}")
        topic = int(topic)
        t = _check_stamp(stamp)
        previous = self._last_stamp[topic]
        if previous is not None:
            if t < previous:
                raise ValueError(
                    f"stamp {t!r} on topic {topic} is earlier than that topic's previous stamp {previous!r}; "
                    "ApproximateTime needs each topic's messages in stamp order (the message was ignored)"
                )
            if t - previous < self.lower_bounds_s[topic]:
                if self._bound_violations[topic] == 0:
                    logger.warning(
                        "topic %d: messages %.6g s apart, closer than lower_bounds_s=%.6g s; sets may not be "
                        "optimal (logged once per topic)", topic, t - previous, self.lower_bounds_s[topic],
                    )
                self._bound_violations[topic] += 1
        self._last_stamp[topic] = t

        out: list[tuple] = []
        queue = self._queues[topic]
        queue.append(_Message(t, item))
        if all(self._queues):
            self._process(out)
        elif self._pivot is not None:
            # A candidate waits for an empty queue. The new message cannot complete a set, but it can prove the
            # candidate optimal: the virtual search looks past the queues' fronts. (ROS resumes only when an empty
            # queue receives a message; resuming here too publishes some sets earlier, not different ones, and
            # makes what has been published after the last push independent of the arrival order.)
            self._virtual_search(out)
            if self._pivot is None:
                self._process(out)
        if len(queue) + len(self._past[topic]) > self.queue_size:
            # Overflow: abandon the candidate search, drop the topic's oldest message, and mark the topic as a bad
            # pivot until a set without it as the latest head has been seen (ROS's has_dropped_messages).
            self._recover_all()
            queue.popleft()
            self._dropped[topic] += 1
            self._has_dropped[topic] = True
            if self._pivot is not None:
                self._candidate = None
                self._pivot = None
                self._process(out)
        return out

    # ------------------------------------------------------------------ the algorithm

    def _heads(self, virtual: bool) -> tuple[int, float, int, float]:
        """(start topic, start stamp, end topic, end stamp) over the queues' oldest messages.

        Ties: the start is the lowest topic, the end the highest, as in ROS. With ``virtual``, an empty queue stands
        for its earliest possible next message: its last retired stamp plus the topic's lower bound, and never
        earlier than the pivot (messages before the pivot's stamp could not improve the candidate anyway).
        """
        times = []
        for i, queue in enumerate(self._queues):
            if queue:
                times.append(queue[0].stamp)
            else:
                assert virtual and self._past[i], "an empty queue outside the virtual search"
                times.append(max(self._past[i][-1].stamp + self.lower_bounds_s[i], self._pivot_time))
        start = min(range(len(times)), key=lambda i: (times[i], i))
        end = max(range(len(times)), key=lambda i: (times[i], i))
        return start, times[start], end, times[end]

    def _retire(self, topic: int) -> None:
        self._past[topic].append(self._queues[topic].popleft())

    def _drop_front(self, topic: int) -> None:
        self._queues[topic].popleft()
        self._dropped[topic] += 1

    def _make_candidate(self, start: float, end: float) -> None:
        self._candidate = tuple(q[0] for q in self._queues)
        self._candidate_start = start
        self._candidate_end = end
        # The messages retired so far are older than the new candidate on their topic: they can no longer be used.
        for i, past in enumerate(self._past):
            self._dropped[i] += len(past)
            past.clear()

    def _recover_all(self) -> None:
        for queue, past in zip(self._queues, self._past):
            queue.extendleft(reversed(past))
            past.clear()

    def _publish(self, out: list[tuple]) -> None:
        candidate = self._candidate
        assert candidate is not None
        self._recover_all()
        for queue, message in zip(self._queues, candidate):
            # The candidate's messages are the oldest held on each topic (older ones were dropped).
            removed = queue.popleft()
            assert removed is message
        out.append(tuple(m.item for m in candidate))
        self._candidate = None
        self._pivot = None

    def _worse(self, end: float, start: float) -> bool:
        """True when a set spanning [start, end] is not better than the candidate (sizes compared with age penalty)."""
        return (end - self._candidate_end) * (1.0 + self.age_penalty) >= start - self._candidate_start

    def _process(self, out: list[tuple]) -> None:
        while all(self._queues):
            start_i, start, end_i, end = self._heads(virtual=False)
            for i in range(self.n_topics):
                if i != end_i:
                    # A dropped message of topic i could not have been better than the ones now queued.
                    self._has_dropped[i] = False
            if self._pivot is None:
                if self.max_interval_s is not None and end - start > self.max_interval_s:
                    self._drop_front(start_i)
                    continue
                if self._has_dropped[end_i]:
                    # A topic that dropped messages would be an unreliable pivot.
                    self._drop_front(start_i)
                    continue
                self._make_candidate(start, end)
                self._pivot = end_i
                self._pivot_time = end
                self._retire(start_i)
            else:
                if not self._worse(end, start):
                    self._make_candidate(start, end)  # the pivot stays
                self._retire(start_i)

            if start_i == self._pivot:
                # Every set containing the pivot has been examined.
                self._publish(out)
            elif self._worse(end, self._pivot_time):
                # Any later set contains [pivot, end], already too large: the candidate is optimal.
                self._publish(out)
            elif not all(self._queues):
                self._virtual_search(out)

    def _virtual_search(self, out: list[tuple]) -> None:
        """Try to prove the candidate optimal with the earliest stamps the empty queues can still receive.

        Retires messages provisionally, standing in for each empty queue with its earliest possible next stamp;
        publishes if even those optimistic sets are too large, otherwise undoes the provisional retirements.
        """
        moves = [0] * self.n_topics
        while True:
            start_i, start, _, end = self._heads(virtual=True)
            if self._worse(end, self._pivot_time):
                self._publish(out)
                return
            if not self._worse(end, start):
                for i, count in enumerate(moves):
                    for _ in range(count):
                        self._queues[i].appendleft(self._past[i].pop())
                return
            # Here start < pivot time, so start_i is a non-empty queue (virtual stamps are >= the pivot's).
            self._retire(start_i)
            moves[start_i] += 1


class _Pending(NamedTuple):
    stamp: float
    item: Any


class TimeFrame:
    """Attach to each primary event the secondary events within ``+-window_s`` of its stamp (RSB's TimeFrame).

    In the paper (section 6) the primary stream is the vision results (F3D faces of one stereo frame) and the
    secondary stream the ITDs, many of which fall within one vision frame. A primary stamped t is *complete* once the
    secondary stream has passed ``t + window_s``: a secondary later than ``t + window_s`` has been pushed, or
    :meth:`advance` said that none earlier will come (use it when the ITD worker stays quiet, e.g. in silence), or
    :meth:`flush` is called at the end of the stream. It is then returned with every secondary s such that
    ``t - window_s <= s <= t + window_s``, in stamp order.

    Each stream must be pushed in stamp order (the two streams may interleave arbitrarily). Memory is bounded:
    secondaries older than any pending or future primary can use are dropped at once; ``max_secondaries`` caps the
    buffer (e.g. while no primary has arrived yet) and ``max_pending`` the primaries waiting for their window, the
    oldest being dropped and counted in :attr:`dropped_secondaries` / :attr:`dropped_primaries`.

    Parameters
    ----------
    window_s : float, seconds, >= 0
        Half width of the time frame around each primary stamp.
    after_s : float, seconds, >= 0, or None
        How far the frame reaches after the stamp when it is not ``window_s``: 0 collects ``[t - window_s, t]``, the
        past only, and completes a primary as soon as the secondaries pass its stamp (low latency).
    max_secondaries, max_pending : int
        Buffer caps.
    """

    def __init__(self, window_s: float, *, after_s: float | None = None, max_secondaries: int = 4096,
                 max_pending: int = 256) -> None:
        self.window_s = _check_duration(window_s, "window_s")
        self.after_s = self.window_s if after_s is None else _check_duration(after_s, "after_s")
        self.max_secondaries = _check_count(max_secondaries, "max_secondaries", 1)
        self.max_pending = _check_count(max_pending, "max_pending", 1)
        self.reset()

    def reset(self) -> None:
        """Forget every buffered event and the stamp history."""
        self._pending: deque[_Pending] = deque()
        self._sec_stamps: list[float] = []
        self._sec_items: list[Any] = []
        self._last_primary: float | None = None
        self._horizon: float | None = None  # no secondary earlier than this will be pushed
        self._dropped_primaries = 0
        self._dropped_secondaries = 0

    @property
    def dropped_primaries(self) -> int:
        """Primaries dropped because more than ``max_pending`` waited for their window."""
        return self._dropped_primaries

    @property
    def dropped_secondaries(self) -> int:
        """Secondaries dropped by the ``max_secondaries`` cap (not those no primary could use)."""
        return self._dropped_secondaries

    @property
    def n_pending(self) -> int:
        """Primaries waiting for the secondary stream to pass the end of their window."""
        return len(self._pending)

    @property
    def n_buffered(self) -> int:
        """Secondaries held for pending or future primaries."""
        return len(self._sec_stamps)

    def push_primary(self, stamp: float, item: Any) -> list[tuple[Any, list[Any]]]:
        """Add a primary event; returns the primaries completed (this one, if its window has already passed).

        stamp : float, seconds, not earlier than the previous primary's.
        Returns ``[(primary_item, [secondary items within +-window_s])]``, oldest primary first.
        """
        t = _check_stamp(stamp)
        if self._last_primary is not None and t < self._last_primary:
            raise ValueError(
                f"primary stamp {t!r} is earlier than the previous primary stamp {self._last_primary!r}; "
                "TimeFrame needs primaries in stamp order (the event was ignored)"
            )
        self._last_primary = t
        self._pending.append(_Pending(t, item))
        if len(self._pending) > self.max_pending:
            self._pending.popleft()
            self._dropped_primaries += 1
        out = self._complete()
        self._prune()
        return out

    def push_secondary(self, stamp: float, item: Any) -> list[tuple[Any, list[Any]]]:
        """Add a secondary event; returns the primaries it completed, oldest first.

        stamp : float, seconds, not earlier than the previous secondary's (nor than a stamp given to
        :meth:`advance`).
        """
        s = _check_stamp(stamp)
        if self._horizon is not None and s < self._horizon:
            raise ValueError(
                f"secondary stamp {s!r} is earlier than {self._horizon!r}, the latest secondary stamp or advance(); "
                "TimeFrame needs secondaries in stamp order (the event was ignored)"
            )
        self._horizon = s
        self._sec_stamps.append(s)
        self._sec_items.append(item)
        out = self._complete()
        self._prune()
        if len(self._sec_stamps) > self.max_secondaries:
            excess = len(self._sec_stamps) - self.max_secondaries
            del self._sec_stamps[:excess]
            del self._sec_items[:excess]
            self._dropped_secondaries += excess
        return out

    def advance(self, stamp: float) -> list[tuple[Any, list[Any]]]:
        """Declare that no secondary stamped earlier than ``stamp`` (seconds) will come; returns completed primaries.

        Stamps earlier than the current horizon are allowed and change nothing.
        """
        s = _check_stamp(stamp)
        if self._horizon is None or s > self._horizon:
            self._horizon = s
        out = self._complete()
        self._prune()
        return out

    def flush(self) -> list[tuple[Any, list[Any]]]:
        """Complete every pending primary with the secondaries received so far (end of stream)."""
        out = [self._result(p) for p in self._pending]
        self._pending.clear()
        self._prune()
        return out

    def _result(self, primary: _Pending) -> tuple[Any, list[Any]]:
        lo = bisect_left(self._sec_stamps, primary.stamp - self.window_s)
        hi = bisect_right(self._sec_stamps, primary.stamp + self.after_s)
        return primary.item, self._sec_items[lo:hi]

    def _complete(self) -> list[tuple[Any, list[Any]]]:
        out = []
        if self._horizon is None:
            return out
        while self._pending and self._pending[0].stamp + self.after_s < self._horizon:
            out.append(self._result(self._pending.popleft()))
        return out

    def _prune(self) -> None:
        # Primaries come in stamp order, so no pending or future primary can use a secondary older than this floor.
        if self._pending:
            floor = self._pending[0].stamp - self.window_s
        elif self._last_primary is not None:
            floor = self._last_primary - self.window_s
        else:
            return
        k = bisect_left(self._sec_stamps, floor)
        if k:
            del self._sec_stamps[:k]
            del self._sec_items[:k]


class FrameItdWindow:
    """The single 32 ms frames' ITDs (and their frequency bands' peaks) kept for the vision frames still to come.

    Blocks come as the ITD worker extracts them (``push``, times on the stream clock, with the frames' bins on every
    pair of an array when there are several); a vision frame asks for those within ``span_s`` of its stamp
    (``near``). Vision frames come in stamp order, so a block wholly older than a
    frame's span is never needed again and ``near`` drops it. Without vision frames (a camera that vanished) the
    blocks stay bounded: those more than ``keep_s`` older than the newest are dropped and counted in ``cut``.
    """

    def __init__(self, span_s: float, keep_s: float = 30.0) -> None:
        self.span_s = _check_duration(span_s, "span_s")
        self.keep_s = _check_duration(keep_s, "keep_s")
        self.cut = 0
        # (first, last time, frame times, frame ITDs, band times, band ITDs, bins)
        self._blocks: deque[tuple[float, float, np.ndarray, np.ndarray, np.ndarray, np.ndarray, FrameBins | None]] \
            = deque()

    def __iter__(self) -> Iterator[tuple[float, float, np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                         FrameBins | None]]:
        return iter(self._blocks)

    def __len__(self) -> int:
        return len(self._blocks)

    def push(self, times_s: np.ndarray, itds_s: np.ndarray, band_times_s: np.ndarray,
             band_itds_s: np.ndarray, bins: FrameBins | None = None) -> None:
        """One block of frames: their centre times and ITDs, the times and ITDs of their bands' peaks, and the same
        frames' bins (times on the same clock; None: none). The bins cover every frame, the ITDs only those that
        passed the energy gate, so a block of silence may bring bins alone."""
        times = np.asarray(times_s, float)
        spans = [times] + ([bins.times_s] if bins is not None and len(bins) else [])
        if not any(t.size for t in spans):
            return
        first = min(float(t[0]) for t in spans if t.size)
        last = max(float(t[-1]) for t in spans if t.size)
        self._blocks.append((first, last, times, np.asarray(itds_s, float), np.asarray(band_times_s, float),
                             np.asarray(band_itds_s, float), bins))
        while self._blocks[0][1] < last - self.keep_s:
            self.cut += len(self._blocks.popleft()[3])

    def near(self, stamp_s: float) -> tuple[np.ndarray | None, np.ndarray | None, FrameBins | None]:
        """The frames' ITDs, the bands' peaks and the frames' bins within ``span_s`` of ``stamp_s`` (None where
        there are none)."""
        span = self.span_s
        while self._blocks and self._blocks[0][1] < stamp_s - span:
            self._blocks.popleft()
        blocks = [b for b in self._blocks if b[0] <= stamp_s + span]
        with_itds = [b for b in blocks if b[2].size]
        frames = bands = None
        if with_itds:
            frames = np.concatenate([itds[np.abs(times - stamp_s) <= span] for _, _, times, itds, *_ in with_itds])
            bands = np.concatenate([b_itds[np.abs(b_times - stamp_s) <= span]
                                    for *_, b_times, b_itds, _ in with_itds])
        bins = [b[6].within(stamp_s, span) for b in blocks if b[6] is not None]
        return frames, bands, FrameBins.concatenate(bins) if bins else None
