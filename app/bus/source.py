"""The laptop side (``avhear run --source bus``): the robot's cameras and microphones from the bus as a pipeline
source, with the robot's rig (asked of its queryable) unless the user gives one.

Subscriber callbacks run in Zenoh's threads and only decode and hand over (bounded queues that drop the oldest
item, counted); the pipeline's grabber pairs the two cameras by stamp (ApproximateTime, as for two live cameras).
A payload that does not decode is counted in ``bad_payloads`` and skipped. When the robot stops publishing, the
source says so once, counts the gap, and goes on as soon as frames come again (Zenoh reconnects by itself).
"""
from __future__ import annotations

import json
import logging
import threading
import time
from collections.abc import Iterator
from typing import Any

import numpy as np

from app.bus.messages import AUDIO_BLOCK, COMPRESSED_IMAGE, decode
from app.bus.ros2 import Convention, RosNode
from app.bus.sensors import AUDIO_KEY, LEFT_KEY, RIG_KEY, RIGHT_KEY, _stamp, frame_from_messages
from app.config import RigConfig, rig_from_dict
from app.sources.contract import SourceBase
from app.errors import UserError
from app.events import AudioBlock, StereoFrame
from app.queues import DropOldestQueue
from avcore.sync import ApproximateTime

log = logging.getLogger(__name__)

__all__ = ["BusSource", "Presence", "ReceivedSource", "ask_rig"]


def ask_rig(session: Any, key: str, timeout_s: float, namespace: str) -> tuple[RigConfig, float, tuple[int, ...]]:
    """The rig that ``avhear sensors`` answers on ``key``: (rig, samplerate_hz, channels), or a :class:`UserError`
    saying what to start or give when nothing answers within ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        for reply in session.get(key, timeout=1.0):
            if reply.ok is None:
                continue
            try:
                info = json.loads(reply.ok.payload.to_bytes())
                return (rig_from_dict(info["rig"], f"the robot's rig ({key})"), float(info["samplerate_hz"]),
                        tuple(int(c) for c in info["channels"]))
            except (ValueError, KeyError, TypeError) as exc:
                raise UserError(f"the robot's rig on {key} does not read: {exc}") from None
        time.sleep(0.2)
    where = (f"in the namespace {namespace!r} (does the robot run with --bus-namespace {namespace}?)" if namespace
             else "without a namespace (does the robot run with a --bus-namespace?)")
    raise UserError(f"no robot answered on {key} within {timeout_s:g} s {where}: start `avhear sensors` there "
                    "(on another machine, reach it with --bus-connect), or give its rig with --rig")


class Presence:
    """Whether the robot's frames come: a gap is counted, and said once, when none came for ``gap_s`` after the
    robot had been seen; its return is said too. A gap is never counted before the robot was seen."""

    def __init__(self, gap_s: float) -> None:
        self.gap_s, self.gaps = gap_s, 0
        self._last: float | None = None
        self._away = False

    def seen(self, arrived: bool) -> bool:
        """Call once per wait for a frame: ``arrived`` whether one came. Returns ``arrived``."""
        now = time.monotonic()
        if not arrived:
            if self._last is not None and not self._away and now - self._last > self.gap_s:
                self._away = True
                self.gaps += 1
                log.warning("no camera frames from the robot for %.1f s: waiting for it", now - self._last)
            return False
        if self._away:
            log.warning("the robot's sensors are back after %.1f s", now - (self._last or now))
            self._away = False
        self._last = now
        return True


class ReceivedSource(SourceBase):
    """What the bus's sources share: a subclass's Zenoh callbacks fill ``_images`` with (stream 0 or 1, stamp,
    message) for ``_pairing`` and ``_audio`` with blocks (bounded queues that drop the oldest), its ``_frame`` makes
    a frame of a pair, ``_presence`` counts the robot's absences, and :meth:`close` releases ``_subscribers`` and
    ``node``."""

    images_received = 0
    bad_payloads = 0

    realtime = True
    _images: DropOldestQueue
    _audio: DropOldestQueue
    _pairing: ApproximateTime
    _presence: Presence
    _subscribers: list
    node: Any

    @property
    def gaps(self) -> int:
        return self._presence.gaps

    @property
    def overflows(self) -> int:
        return self._audio.dropped

    @property
    def frames_dropped(self) -> int:
        return self._images.dropped + sum(self._pairing.dropped_counts)

    def frames(self, stop: threading.Event) -> Iterator[StereoFrame]:
        """The two image streams paired by stamp, each pair made a frame by the subclass's ``_frame(index, stamp,
        first message, second message)`` (ValueError: counted in ``bad_payloads`` and skipped). A stream whose
        stamps go back (the robot started again, on another clock) restarts the pairing."""
        index = 0
        last = [-np.inf, -np.inf]
        while not stop.is_set():
            item = self._images.get(timeout=0.05)
            self._check_silence()
            if not self._presence.seen(item is not None):
                continue
            self.images_received += 1
            side, stamp, msg = item
            if stamp < last[side]:
                self._pairing.reset()
                last = [-np.inf, -np.inf]
            last[side] = stamp
            for first, second in self._pairing.push(side, stamp, (stamp, msg)):
                try:
                    frame = self._frame(index, first[0], first[1], second[1])
                except ValueError:
                    self.bad_payloads += 1
                    continue
                yield frame
                index += 1

    def _frame(self, index: int, stamp: float, first: Any, second: Any) -> StereoFrame:  # pragma: no cover
        raise NotImplementedError

    def _check_silence(self) -> None:
        """Called each time a stream waits for its next item (cheap): a subclass may raise a :class:`UserError` for a
        stream that never started (a wrong topic name)."""

    def audio(self, stop: threading.Event) -> Iterator[AudioBlock]:
        while not stop.is_set():
            block = self._audio.get(timeout=0.05)
            self._check_silence()
            if block is not None:
                yield block

    def close(self) -> None:
        for sub in self._subscribers:
            sub.undeclare()
        self._subscribers = []
        self.node.close()


class BusSource(ReceivedSource):
    """A pipeline source fed by the bus (see module docstring).

    convention : the key convention, ROS domain and namespace (:mod:`app.bus.ros2`).
    left_key, right_key, audio_key : topics of the two rectified camera streams (sensor_msgs/CompressedImage) and
        the audio (avhear_msgs/AudioBlock), relative to the namespace unless they start with ``/``; default: those of
        ``avhear sensors``.
    rig : the rig calibration; None asks the robot's queryable (``avhear sensors`` answers), waiting
        ``rig_timeout_s``.
    gap_s : seconds without a camera frame after which the robot counts as gone (until frames come again).
    """

    def __init__(self, session: Any, *, convention: Convention | None = None, rig: RigConfig | None = None,
                 left_key: str | None = None, right_key: str | None = None, audio_key: str | None = None,
                 rig_timeout_s: float = 10.0, gap_s: float = 1.0, queue_size: int = 64) -> None:
        convention = convention or Convention()
        ns = convention.namespace.strip("/")
        self.session = session
        self.node = RosNode(session, convention, name="avhear")
        topics = (left_key or LEFT_KEY, right_key or RIGHT_KEY, audio_key or AUDIO_KEY)
        self.keys = tuple(convention.topic(t) for t in topics)  # ROS topic names, for messages
        self.bad_payloads = 0
        self.images_received = 0
        self._presence = Presence(gap_s)
        self._samplerate: float | None = None
        self._n_channels: int | None = None
        self.channels: tuple[int, int] = (0, 1)
        if rig is None:
            rig, self._samplerate, self.channels = ask_rig(session, convention.plain(RIG_KEY), rig_timeout_s, ns)
        if rig.stereo is None or (rig.microphones is None and rig.array is None):
            raise UserError("the rig needs a 'stereo' section and a 'microphones' or 'array' section (give --rig "
                            "with both)")
        self.rig, self.mics = rig.stereo, rig.microphones
        if rig.array is not None:  # every pair of the robot's array; mics and channels are its first pair
            pair = rig.array.pairs[0]  # type: ignore[index]
            self.mics = rig.array.pair(0)
            self.channels = (rig.array.channels[pair[0]], rig.array.channels[pair[1]])  # type: ignore[index]
            self.array = rig.array if rig.array.n_pairs > 1 else None
        self._images: DropOldestQueue[tuple[int, float, Any]] = DropOldestQueue(queue_size, "bus-images")
        self._audio: DropOldestQueue[AudioBlock] = DropOldestQueue(4 * queue_size, "bus-audio")
        self._pairing = ApproximateTime(2, queue_size=4, max_interval_s=0.02)
        self._blocks = 0
        self._subscribers = [
            self.node.subscriber(topics[0], COMPRESSED_IMAGE, lambda s: self._on_image(0, s)),
            self.node.subscriber(topics[1], COMPRESSED_IMAGE, lambda s: self._on_image(1, s)),
            self.node.subscriber(topics[2], AUDIO_BLOCK, self._on_audio),
        ]

    # -- Zenoh's threads: decode and hand over ---------------------------------------------------------------

    def _on_image(self, side: int, sample: Any) -> None:
        try:
            msg = decode(sample.payload.to_bytes(), "sensor_msgs/msg/CompressedImage")
        except ValueError:
            self.bad_payloads += 1
            return
        self._images.put((side, _stamp(msg.header), msg))

    def _on_audio(self, sample: Any) -> None:
        try:
            msg = decode(sample.payload.to_bytes(), AUDIO_BLOCK)
            samples = np.asarray(msg.samples, dtype=np.float32).reshape(-1, int(msg.n_channels))
        except ValueError:
            self.bad_payloads += 1
            return
        if self._samplerate is None:
            self._samplerate = float(msg.samplerate_hz)
        self._n_channels = int(msg.n_channels)
        self._audio.put(AudioBlock(self._blocks, int(msg.first_sample), _stamp(msg.header), samples,
                                   int(msg.samplerate_hz)))
        self._blocks += 1

    # -- the Source contract -----------------------------------------------------------------------------------

    @property
    def samplerate_hz(self) -> float:
        """From the robot's rig answer, or from the first audio block (the pipeline reads it after that block)."""
        if self._samplerate is None:
            raise RuntimeError("the audio format is not known before the first audio block")
        return self._samplerate

    def audio_format(self, timeout_s: float = 10.0) -> tuple[float, int]:
        """(samplerate_hz, n_channels) of the robot's audio, from its first block (waiting up to ``timeout_s``)."""
        deadline = time.monotonic() + timeout_s
        while self._n_channels is None:
            if time.monotonic() > deadline:
                raise UserError(f"no audio on {self.keys[2]} within {timeout_s:g} s: is the robot's microphone "
                                "published there (--audio-key)?")
            time.sleep(0.02)
        return self.samplerate_hz, self._n_channels

    def _frame(self, index: int, stamp: float, first: Any, second: Any) -> StereoFrame:
        return frame_from_messages(index, first, second)

