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

from app.bus.messages import AUDIO_BLOCK, COMPRESSED_IMAGE, encode, make_header, typestore
from app.bus.ros2 import Convention, RosNode
from app.config import RigConfig, rig_to_dict
from app.events import AudioBlock, StereoFrame

log = logging.getLogger(__name__)

__all__ = ["AUDIO_KEY", "LEFT_KEY", "RIGHT_KEY", "RIG_KEY", "SensorPublisher", "image_message"]

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
    ``samplerate_hz``, ``channels``) on ``session`` in ``convention`` until the source ends or ``stop``."""

    def __init__(self, session: Any, source: Any, *, convention: Convention | None = None,
                 jpeg_quality: int = 90) -> None:
        self.node = RosNode(session, convention or Convention(), name="avhear_sensors")
        self.session, self.source, self.jpeg_quality = session, source, jpeg_quality
        self.frames = self.audio_blocks = self.bytes = 0
        self.errors: list[str] = []
        rig = RigConfig(stereo=source.rig, microphones=source.mics, array=getattr(source, "array", None))
        self.info = json.dumps({"rig": rig_to_dict(rig), "samplerate_hz": float(source.samplerate_hz),
                                "channels": list(source.channels)})
        self._queryable = session.declare_queryable(self.node.convention.plain(RIG_KEY), self._answer)

    def _answer(self, query: Any) -> None:
        query.reply(query.key_expr, self.info.encode())

    def run(self, stop: threading.Event, duration_s: float | None = None) -> None:
        """Publish until the source ends, ``duration_s`` of wall time, or ``stop``; device errors are collected in
        :attr:`errors` and end the run."""
        pub_l = self.node.publisher(LEFT_KEY, COMPRESSED_IMAGE)
        pub_r = self.node.publisher(RIGHT_KEY, COMPRESSED_IMAGE)
        pub_a = self.node.publisher(AUDIO_KEY, AUDIO_BLOCK)
        # a robot stamps at capture on its monotonic clock: the simulator's or a recording's own stamps are moved there
        offset = time.monotonic() - self.source.clock()

        def frames() -> None:
            for frame in self.source.frames(stop):
                left = image_message(frame.left, frame.stamp_s + offset, "avhear_left", self.jpeg_quality)
                right = image_message(frame.right, frame.right_stamp_s + offset, "avhear_right", self.jpeg_quality)
                pub_l.put(left)
                pub_r.put(right)
                self.frames += 1
                self.bytes += len(left) + len(right)

        def audio() -> None:
            for block in self.source.audio(stop):
                payload = audio_message(replace(block, stamp_s=block.stamp_s + offset))
                pub_a.put(payload)
                self.audio_blocks += 1
                self.bytes += len(payload)

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
        for pub in (pub_l, pub_r, pub_a):
            pub.undeclare()

    def close(self) -> None:
        self._queryable.undeclare()
        self.node.close()


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
