"""The results publisher: a sink that puts every fused result on the bus (keys and types: :mod:`app.bus.messages`).

The fusion thread only hands the result over (a bounded queue that drops the oldest when the bus is slower than the
results, counted in ``dropped``): serialising and sending happen in the publisher's own thread, so that a slow bus
or subscriber never stalls the pipeline.
"""
from __future__ import annotations

import logging
import threading
from typing import Any

from app.bus.messages import Topics
from app.queues import DropOldestQueue
from app.sinks.results_file import result_record

log = logging.getLogger(__name__)

__all__ = ["ResultPublisher"]


class ResultPublisher:
    """Publishes on ``session`` (a zenoh.Session); :meth:`publish` from any thread, :meth:`close` at the end."""

    def __init__(self, session: Any, *, namespace: str = "", queue_size: int = 64) -> None:
        self.session = session
        self.topics = Topics(namespace)
        self.published = 0
        self._queue: DropOldestQueue[dict[str, Any]] = DropOldestQueue(queue_size, "bus")
        self._publishers: dict[str, Any] = {}
        self._stop = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="avhear-bus-publisher", daemon=True)
        self._thread.start()

    @property
    def dropped(self) -> int:
        return self._queue.dropped

    def publish(self, result: Any) -> None:
        """Hand one :class:`app.result.Result` over; never blocks."""
        if self._error is not None:
            raise RuntimeError(f"the bus publisher failed: {self._error}") from self._error
        self._queue.put(result_record(result))

    def _run(self) -> None:
        try:
            while not (self._stop.is_set() and len(self._queue) == 0):
                record = self._queue.get(timeout=0.05)
                if record is None:
                    continue
                for key, payload in self.topics.messages(record):
                    pub = self._publishers.get(key)
                    if pub is None:
                        pub = self._publishers[key] = self.session.declare_publisher(key)
                    pub.put(payload)
                self.published += 1
        except BaseException as exc:  # reported by the next publish() and by close()
            log.exception("the bus publisher failed")
            self._error = exc

    def close(self, timeout_s: float = 2.0) -> None:
        """Send what is queued (at most ``timeout_s``), then undeclare the publishers."""
        self._stop.set()
        self._thread.join(timeout_s)
        for pub in self._publishers.values():
            try:
                pub.undeclare()
            except Exception:  # noqa: BLE001 - the session may be closing already
                pass
        self._publishers.clear()
