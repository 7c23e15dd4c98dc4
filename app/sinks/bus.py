"""The results publisher: a sink that puts every fused result on the bus (topics and types: :mod:`app.bus.messages`;
keys and, under rmw_zenoh, the node's and its publishers' liveliness tokens: :mod:`app.bus.ros2`).

The fusion thread only hands the result over (a bounded queue that drops the oldest when the bus is slower than the
results, counted in ``dropped``): serialising and sending happen in the publisher's own thread, so that a slow bus
or subscriber never stalls the pipeline.
"""
from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import Any

from app.bus.messages import Topics
from app.bus.ros2 import Convention, Endpoint, RosNode
from app.queues import DropOldestQueue

log = logging.getLogger(__name__)

__all__ = ["RIG_LINK_EVERY_S", "ResultPublisher"]

RIG_LINK_EVERY_S = 1.0  # the rig's static link is sent again this often (no latched topic here)


class ResultPublisher:
    """Publishes on ``session`` (a zenoh.Session); :meth:`publish` from any thread, :meth:`close` at the end."""

    def __init__(self, session: Any, *, convention: Convention | None = None, queue_size: int = 64) -> None:
        self.session = session
        self.node = RosNode(session, convention or Convention())
        self.topics = Topics()
        self.published = 0
        self._queue: DropOldestQueue[dict[str, Any]] = DropOldestQueue(queue_size, "bus")
        self._publishers: dict[str, Endpoint] = {}
        self._stop = threading.Event()
        self._error: BaseException | None = None
        self._camera_frame: Callable[[], str | None] | None = None
        self._rig_in_camera_m = (0.0, 0.0, 0.0)
        self._linked_at = -float("inf")
        self._thread = threading.Thread(target=self._run, name="avhear-bus-publisher", daemon=True)
        self._thread.start()

    @property
    def dropped(self) -> int:
        return self._queue.dropped

    def link_rig(self, camera_frame: Callable[[], str | None], rig_in_camera_m: tuple[float, float, float]) -> None:
        """Link the rig's frame to the camera's optical frame on ``tf_static`` (:meth:`app.bus.messages.Topics.
        rig_link`) once ``camera_frame()`` names it, and again every :data:`RIG_LINK_EVERY_S`."""
        self._camera_frame, self._rig_in_camera_m = camera_frame, tuple(float(v) for v in rig_in_camera_m)

    def publish(self, result: Any) -> None:
        """Hand one :class:`app.result.Result` over; never blocks."""
        if self._error is not None:
            raise RuntimeError(f"the bus publisher failed: {self._error}") from self._error
        self._queue.put(result.as_dict())

    def _run(self) -> None:
        try:
            while not (self._stop.is_set() and len(self._queue) == 0):
                record = self._queue.get(timeout=0.05)
                if record is None:
                    continue
                messages = self.topics.messages(record)
                frame = self._camera_frame() if self._camera_frame is not None else None
                if frame and time.monotonic() - self._linked_at >= RIG_LINK_EVERY_S:
                    messages.append(self.topics.rig_link(record["stamp_s"], frame, self._rig_in_camera_m))
                    self._linked_at = time.monotonic()
                for topic, typename, payload in messages:
                    pub = self._publishers.get(topic)
                    if pub is None:
                        pub = self._publishers[topic] = self._declare(topic, typename)
                    pub.put(payload)
                self.published += 1
        except BaseException as exc:  # reported by the next publish() and by close()
            log.exception("the bus publisher failed")
            self._error = exc

    def _declare(self, topic: str, typename: str | None) -> Endpoint:
        if typename is None:  # the JSON: not a ROS message, the same key in both conventions
            return Endpoint(self.session.declare_publisher(self.node.convention.plain(topic)))
        return self.node.publisher(topic, typename)

    def close(self, timeout_s: float = 2.0) -> None:
        """Send what is queued (at most ``timeout_s``), then undeclare the publishers and the node."""
        self._stop.set()
        self._thread.join(timeout_s)
        for pub in self._publishers.values():
            pub.undeclare()
        self._publishers.clear()
        self.node.close()
