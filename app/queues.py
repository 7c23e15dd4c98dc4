"""Bounded queues between the pipeline's threads: a slow consumer drops the oldest item, never blocks a producer."""
from __future__ import annotations

import collections
import threading
from typing import Generic, TypeVar

T = TypeVar("T")


class DropOldestQueue(Generic[T]):
    """A bounded FIFO whose ``put`` never blocks: when full, the oldest item is dropped and counted.

    The audio callback and the camera grabber must never wait for a slow consumer (docs/architecture.md); memory stays
    bounded by ``maxsize``. ``get`` blocks up to ``timeout`` seconds and returns ``None`` when nothing came.
    A replay run as fast as possible may call :meth:`wait_for_room` first: back-pressure, so nothing is lost.
    """

    def __init__(self, maxsize: int, name: str = "") -> None:
        if maxsize < 1:
            raise ValueError(f"maxsize must be >= 1, got {maxsize}")
        self.name = name
        self.maxsize = maxsize
        self._items: collections.deque[T] = collections.deque()
        self._cond = threading.Condition()
        self.dropped = 0
        self.put_count = 0

    def wait_for_room(self, timeout: float) -> bool:
        """Wait up to ``timeout`` seconds until the queue is not full; whether it is not."""
        with self._cond:
            return self._cond.wait_for(lambda: len(self._items) < self.maxsize, timeout)

    def put(self, item: T) -> None:
        """Append ``item``; when full, drop the oldest item and count it. Never waits."""
        with self._cond:
            if len(self._items) >= self.maxsize:
                self._items.popleft()
                self.dropped += 1
            self._items.append(item)
            self.put_count += 1
            self._cond.notify_all()

    def get(self, timeout: float | None = None) -> T | None:
        with self._cond:
            if not self._items:
                self._cond.wait(timeout)
            if not self._items:
                return None
            item = self._items.popleft()
            self._cond.notify_all()  # a producer may wait for room
            return item

    def __len__(self) -> int:
        with self._cond:
            return len(self._items)
