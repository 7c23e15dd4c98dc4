"""The robot side (``avhear sensors``): a source's two cameras and its microphones on the bus, and its rig.

Each stereo frame goes out as two sensor_msgs/CompressedImage (JPEG of the rectified image, the capture stamp in
the header) on the topics :data:`LEFT_KEY` and :data:`RIGHT_KEY`; each audio block as an ``avhear_msgs/AudioBlock``
(:mod:`app.bus.messages`) on :data:`AUDIO_KEY`, all channels; in either key convention (:mod:`app.bus.ros2`: under
rmw_zenoh the robot is a ROS 2 node ``avhear_sensors``). A queryable on :data:`RIG_KEY` answers with the rig
calibration (the stereo rig, the microphone pair, and the microphone array when the source has several
microphones) and the audio format as JSON, so that the laptop side needs nothing but the robot's address.

Stamps are the source's own (``time.monotonic()`` of the robot for live devices): the laptop's synchronisers pair
and window them as they would in one process, and the time frames stay right across the network.
"""
from __future__ import annotations

import json
import logging
import threading
import time
from dataclasses import replace
from typing import Any

import cv2
import numpy as np

from app.bus import convert
from app.bus.messages import (AUDIO_BLOCK, AUDIO_INFO, AUDIO_STAMPED, CAMERA_INFO, COMPRESSED_IMAGE, IMAGE, RosTopics,
                              encode, make_header, typestore)
from app.bus.ros2 import Convention, RosNode, published_topics
from app.config import RigConfig, rig_to_dict
from app.events import AudioBlock, StereoFrame
from avcore.depth import depth_millimetres

log = logging.getLogger(__name__)

__all__ = ["AUDIO_KEY", "LEFT_KEY", "RIGHT_KEY", "RIG_KEY", "RosDriverPublisher", "SensorPublisher", "image_message"]

LEFT_KEY = "stereo/left/image_rect_color/compressed"
RIGHT_KEY = "stereo/right/image_rect_color/compressed"
AUDIO_KEY = "audio/blocks"
RIG_KEY = "avhear/rig"


def image_message(image: np.ndarray, stamp_s: float, frame_id: str, quality: int = 90) -> bytes:
    ok, jpeg = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
    if not ok:
        raise ValueError(f"cannot JPEG-encode an image of shape {image.shape}")
    msg = typestore().types[COMPRESSED_IMAGE](header=make_header(stamp_s, frame_id), format="jpeg", data=jpeg.ravel())
    return encode(msg, COMPRESSED_IMAGE)


def audio_message(block: AudioBlock) -> bytes:
    samples = np.asarray(block.samples, dtype=np.float32)
    msg = typestore().types[AUDIO_BLOCK](header=make_header(block.stamp_s, "avhear_mics"),
                                        samplerate_hz=int(block.samplerate_hz), n_channels=int(samples.shape[1]),
                                        first_sample=int(block.first_sample), samples=samples.ravel())
    return encode(msg, AUDIO_BLOCK)


class SensorPublisher:
    """Publishes ``source`` (the pipeline's Source contract: ``frames(stop)``, ``audio(stop)``, ``rig``, ``mics``,
    ``samplerate_hz``, ``channels``) on ``session`` in ``convention`` until the source ends or ``stop``: the two
    rectified cameras and avhear's audio blocks (module docstring); :class:`RosDriverPublisher` publishes as ROS
    drivers do instead."""

    node_name = "avhear_sensors"

    def __init__(self, session: Any, source: Any, *, convention: Convention | None = None,
                 jpeg_quality: int = 90) -> None:
        self.node = RosNode(session, convention or Convention(), name=self.node_name)
        self.session, self.source, self.jpeg_quality = session, source, jpeg_quality
        self.frames = self.audio_blocks = self.bytes = 0
        self.errors: list[str] = []
        self.info = json.dumps(self._rig_answer())
        self._queryable = session.declare_queryable(self.node.convention.plain(RIG_KEY), self._answer)

    def _rig_answer(self) -> dict[str, Any]:
        source = self.source
        rig = RigConfig(stereo=source.rig, microphones=source.mics, array=getattr(source, "array", None))
        return {"rig": rig_to_dict(rig), "samplerate_hz": float(source.samplerate_hz),
                "channels": list(source.channels)}

    def _answer(self, query: Any) -> None:
        query.reply(query.key_expr, self.info.encode())

    def _clock_offset(self) -> float:
        """What moves the source's stamps onto the robot's: a robot stamps at capture on its monotonic clock."""
        return time.monotonic() - self.source.clock()

    def topics(self) -> dict[str, tuple[str, str]]:
        """{name: (topic, ROS type)} of what :meth:`run` publishes."""
        return {"left": (LEFT_KEY, COMPRESSED_IMAGE), "right": (RIGHT_KEY, COMPRESSED_IMAGE),
                "audio": (AUDIO_KEY, AUDIO_BLOCK)}

    def taken(self, timeout_s: float = 2.0, settle_s: float = 0.5, empty_s: float = 2.0,
              within_s: float = 4.0) -> list[str]:
        """The topics :meth:`run` would publish that another node publishes already, as the graph's liveliness
        tokens tell (rmw_zenoh's keys; under the bridge's keys nothing can tell: empty). A session that has just
        met the router may not have its declarations yet, so the graph is read until two readings ``settle_s``
        apart agree, an empty graph only after ``empty_s`` (at most ``within_s`` in all)."""
        convention = self.node.convention
        if not convention.native:
            return []
        start = time.monotonic()
        there = published_topics(self.session, convention.domain, timeout_s)
        while time.monotonic() - start < within_s:
            time.sleep(settle_s)
            again = published_topics(self.session, convention.domain, timeout_s)
            if again == there and (there or time.monotonic() - start >= empty_s):
                break
            there = again
        return [convention.topic(topic) for topic, _ in self.topics().values() if convention.topic(topic) in there]

    def _declare(self) -> None:
        self._pubs = {name: self.node.publisher(topic, typename) for name, (topic, typename) in self.topics().items()}

    def _send_frame(self, frame: StereoFrame, offset: float) -> int:
        left = image_message(frame.left, frame.stamp_s + offset, "avhear_left", self.jpeg_quality)
        right = image_message(frame.right, frame.right_stamp_s + offset, "avhear_right", self.jpeg_quality)
        self._pubs["left"].put(left)
        self._pubs["right"].put(right)
        return len(left) + len(right)

    def _send_audio(self, block: AudioBlock, offset: float) -> int:
        payload = audio_message(replace(block, stamp_s=block.stamp_s + offset))
        self._pubs["audio"].put(payload)
        return len(payload)

    def run(self, stop: threading.Event, duration_s: float | None = None) -> None:
        """Publish until the source ends, ``duration_s`` of wall time, or ``stop``; device errors are collected in
        :attr:`errors` and end the run."""
        self._declare()
        offset = self._clock_offset()

        def frames() -> None:
            for frame in self.source.frames(stop):
                self.bytes += self._send_frame(frame, offset)
                self.frames += 1

        def audio() -> None:
            for block in self.source.audio(stop):
                self.bytes += self._send_audio(block, offset)
                self.audio_blocks += 1

        def guard(fn: Any, name: str) -> None:
            try:
                fn()
            except Exception as exc:  # noqa: BLE001 - a device fault ends the run; reported by the command
                self.errors.append(f"{name}: {exc}")
            finally:
                stop.set()

        threads = [threading.Thread(target=guard, args=(fn, name), name=f"avhear-sensors-{name}", daemon=True)
                   for fn, name in ((frames, "cameras"), (audio, "audio"))]
        for t in threads:
            t.start()
        stop.wait(duration_s)
        stop.set()
        for t in threads:
            t.join(2.0)
        for pub in self._pubs.values():
            pub.undeclare()

    def close(self) -> None:
        self._queryable.undeclare()
        self.node.close()


class RosDriverPublisher(SensorPublisher):
    """A robot made of an RGB-D source (the simulated room's ``camera="rgbd"``) that publishes as ROS 2 drivers do
    (:class:`app.bus.ros_source.RosTopics`): realsense2_camera's colour (rgb8), aligned depth (16UC1 millimetres)
    and CameraInfo, audio_common's AudioDataStamped (S16LE) and its AudioInfo, at the start and every second
    (audio_capture's every 5 s: a laptop that joins waits up to that long; this stand-in answers sooner, the
    laptop's wait is the same code). Stamps are ROS time (the system clock). The rig it answers holds the
    microphones in the colour camera's optical frame and no stereo section: the laptop reads the camera from its
    CameraInfo, as it would a RealSense's."""

    node_name = "camera"
    info_period_s = 1.0

    def __init__(self, session: Any, source: Any, **kwargs: Any) -> None:
        super().__init__(session, source, **kwargs)
        self._last_info = -np.inf

    def _rig_answer(self) -> dict[str, Any]:
        source = self.source
        dx = 0.5 * source.rig.baseline_m  # the scene frame's origin is midway between the pair; the colour is left
        array = getattr(source, "array", None)
        rig = RigConfig(stereo=None,
                        microphones=replace(source.mics, left=_moved(source.mics.left, dx),
                                            right=_moved(source.mics.right, dx)),
                        array=None if array is None else replace(array, positions=tuple(
                            _moved(p, dx) for p in array.positions)))
        return {"rig": rig_to_dict(rig), "samplerate_hz": float(source.samplerate_hz),
                "channels": list(source.channels)}

    def _clock_offset(self) -> float:
        return time.time() - self.source.clock()

    def topics(self) -> dict[str, tuple[str, str]]:
        t = RosTopics()  # the drivers' own names
        return {"colour": (t.colour, IMAGE), "depth": (t.depth, IMAGE), "camera_info": (t.camera_info, CAMERA_INFO),
                "audio": (t.audio, AUDIO_STAMPED), "audio_info": (t.audio_info, AUDIO_INFO)}

    def _declare(self) -> None:
        super()._declare()
        self._k = self.source.rig.proj_left[:, :3].copy()

    def _send_frame(self, frame: StereoFrame, offset: float) -> int:
        if frame.depth_m is None:
            raise ValueError("the source is no RGB-D camera: its frames have no depth")
        stamp = frame.stamp_s + offset
        frame_id = "camera_color_optical_frame"
        payloads = [("colour", encode(convert.image_message(frame.left, "rgb8", stamp, frame_id), IMAGE)),
                    ("depth", encode(convert.image_message(depth_millimetres(frame.depth_m), "16UC1", stamp,
                                                           frame_id), IMAGE)),
                    ("camera_info", encode(convert.camera_info(self._k, tuple(self.source.rig.image_size), stamp,
                                                               frame_id), CAMERA_INFO))]
        for name, payload in payloads:
            self._pubs[name].put(payload)
        return sum(len(p) for _, p in payloads)

    def _send_audio(self, block: AudioBlock, offset: float) -> int:
        stamped, info = convert.audio_messages(block.samples, block.stamp_s + offset, block.samplerate_hz)
        payload = encode(stamped, AUDIO_STAMPED)
        self._pubs["audio"].put(payload)
        now = time.monotonic()
        if now - self._last_info >= self.info_period_s:
            self._pubs["audio_info"].put(encode(info, AUDIO_INFO))
            self._last_info = now
        return len(payload)


def _moved(position: Any, dx: float) -> tuple[float, float, float]:
    """A position of the rig's scene frame in its left camera's optical frame (``dx``: half the baseline)."""
    x, y, z = (float(v) for v in position)
    return (x + dx, y, z)


def frame_from_messages(index: int, left: Any, right: Any) -> StereoFrame:
    """A stereo frame from two decoded CompressedImage messages; raises ValueError on an undecodable image."""
    images = []
    for msg in (left, right):
        img = cv2.imdecode(np.frombuffer(bytes(msg.data), np.uint8), cv2.IMREAD_COLOR)
        if img is None:
            raise ValueError(f"an image of format {msg.format!r} does not decode")
        images.append(img)
    return StereoFrame(index, _stamp(left.header), images[0], images[1], _stamp(right.header))


def _stamp(h: Any) -> float:
    return h.stamp.sec + h.stamp.nanosec * 1e-9
