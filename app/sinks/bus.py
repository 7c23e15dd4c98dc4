"""The results publisher: a sink that puts every fused result on the bus (topics and types: :mod:`app.bus.messages`;
keys and, under rmw_zenoh, the node's and its publishers' liveliness tokens: :mod:`app.bus.ros2`).

The fusion thread only hands the result over, and the voices thread each chunk of a person's voice (bounded queues
that drop the oldest when the bus is slower, counted in ``dropped``): serialising and sending happen in the
publisher's own thread, so that a slow bus or subscriber never stalls the pipeline.
"""
from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from app.bus.messages import Topics
from app.bus.ros2 import Convention, Endpoint, RosNode
from app.queues import DropOldestQueue
from avcore.separation import VoiceChunk

if TYPE_CHECKING:
    from app.speech.transcriber import Words

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
        self._voices: DropOldestQueue[Any] = DropOldestQueue(16 * queue_size, "bus voices")  # chunks and words
        self.voice_chunks = 0
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
        return self._queue.dropped + self._voices.dropped

    def link_rig(self, camera_frame: Callable[[], str | None], rig_in_camera_m: tuple[float, float, float]) -> None:
        """Link the rig's frame to the camera's optical frame on ``tf_static`` (:meth:`app.bus.messages.Topics.
        rig_link`) once ``camera_frame()`` names it, and again every :data:`RIG_LINK_EVERY_S`."""
        self._camera_frame, self._rig_in_camera_m = camera_frame, tuple(float(v) for v in rig_in_camera_m)

    def publish(self, result: Any) -> None:
        """Hand one :class:`app.result.Result` over; never blocks."""
        if self._error is not None:
            raise RuntimeError(f"the bus publisher failed: {self._error}") from self._error
        self._queue.put(result.as_dict())

    def publish_words(self, stamp_s: float, words: Words) -> None:
        """Hand a person's words over (its voice's ``speech``: incremental or final); never blocks."""
        self._voices.put((stamp_s, words))

    def publish_voice(self, chunk: VoiceChunk) -> None:
        """Hand a chunk of a person's voice over (its voice's ``audio`` topic); never blocks."""
        if self._error is not None:
            raise RuntimeError(f"the bus publisher failed: {self._error}") from self._error
        self._voices.put(chunk)

    def _run(self) -> None:
        try:
            while not (self._stop.is_set() and len(self._queue) == 0 and len(self._voices) == 0):
                while (chunk := self._voices.get(timeout=0)) is not None:
                    if isinstance(chunk, tuple):  # (stamp, Words)
                        stamp, w = chunk
                        self._put(*self.topics.speech(stamp, w.person_id, w.text, w.final, w.confidence))
                        continue
                    self._put(*self.topics.voice_audio(chunk.person_id, chunk.samples))
                    self.voice_chunks += 1
                record = self._queue.get(timeout=0.01)
                if record is None:
                    continue
                messages = self.topics.messages(record)
                frame = self._camera_frame() if self._camera_frame is not None else None
                if frame and time.monotonic() - self._linked_at >= RIG_LINK_EVERY_S:
                    messages.append(self.topics.rig_link(record["stamp_s"], frame, self._rig_in_camera_m))
                    self._linked_at = time.monotonic()
                for topic, typename, payload in messages:
                    self._put(topic, typename, payload)
                self.published += 1
        except BaseException as exc:  # reported by the next publish() and by close()
            log.exception("the bus publisher failed")
            self._error = exc

    def _put(self, topic: str, typename: str | None, payload: bytes) -> None:
        pub = self._publishers.get(topic)
        if pub is None:
            pub = self._publishers[topic] = self._declare(topic, typename)
        pub.put(payload)

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
