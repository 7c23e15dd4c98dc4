"""A ROS 2 robot as it is (``avhear run --source ros``): an RGB-D camera and a microphone's topics, named as their
drivers name them, as a pipeline source.

Default topics (:class:`app.bus.messages.RosTopics`, each renamed by a flag): realsense2_camera 4.x with
``align_depth.enable:=true`` publishes ``/camera/camera/color/image_raw`` (sensor_msgs/Image, rgb8),
``/camera/camera/aligned_depth_to_color/image_raw`` (16UC1 millimetres, aligned to the colour image, with the colour
image's stamp) and ``/camera/camera/color/camera_info``; audio_common's ``audio_capture`` (``format:=wave``)
publishes ``/audio/audio_stamped`` (AudioDataStamped, S16LE) and, every 5 s, ``/audio/audio_info``. A colour topic
whose name ends in ``/compressed`` is read as sensor_msgs/CompressedImage (image_transport's naming).

The camera's intrinsics come from its CameraInfo (:meth:`StereoRig.rgbd`: the scene frame is the colour camera's
optical frame, x right, y down, z forward) unless the rig file has a ``stereo`` section; the microphones and their
place in that frame come from the rig file. The source waits (``info_timeout_s``) for the CameraInfo and the first
AudioInfo before it starts.

Clocks: ROS stamps are the robot's system time; :meth:`clock` is this machine's (``time.time()``), as ROS time is.
A stream whose first stamp is more than ``clock_tolerance_s`` away from now is on another clock (audio_capture stamps
on GStreamer's monotonic clock): it is moved onto this one by the offset its first message shows, once, with a
notice. Colour and depth are paired by stamp; audio samples are numbered by count, and a stamp later than the count
says by more than half a message counts a lost message and skips the numbering ahead.
"""
from __future__ import annotations

import logging
import threading
import time
from typing import Any

import cv2
import numpy as np

from app.bus.convert import AudioFormat, audio_format, audio_samples, camera_matrix, image_from_msg, stamp_s
from app.bus.messages import AUDIO_INFO, AUDIO_STAMPED, CAMERA_INFO, COMPRESSED_IMAGE, IMAGE, RosTopics, decode
from app.bus.ros2 import Convention, RosNode, published_topics
from app.bus.sensors import RIG_KEY
from app.bus.source import Presence, ReceivedSource, ask_rig
from app.config import RigConfig
from app.errors import UserError
from app.events import AudioBlock, StereoFrame
from app.queues import DropOldestQueue
from avcore.depth import as_depth_m
from avcore.stereo import StereoRig
from avcore.sync import ApproximateTime

log = logging.getLogger(__name__)

__all__ = ["RosSource"]


class _Rebase:
    """Moves a stream's stamps onto this machine's clock when its first one shows it is on another."""

    def __init__(self, name: str, tolerance_s: float) -> None:
        self.name, self.tolerance_s, self.offset_s = name, tolerance_s, None

    def __call__(self, stamp: float, now: float) -> float:
        if self.offset_s is None:
            self.offset_s = now - stamp if abs(now - stamp) > self.tolerance_s else 0.0
            if self.offset_s:
                log.warning("the %s is stamped on another clock (%.1f s from this one's): moved onto it", self.name,
                            self.offset_s)
        return stamp + self.offset_s


class RosSource(ReceivedSource):
    """The robot's RGB-D camera and microphones from their ROS 2 topics (module docstring)."""

    def __init__(self, session: Any, rig: RigConfig | None = None, *, convention: Convention | None = None,
                 topics: RosTopics | None = None, info_timeout_s: float = 10.0, gap_s: float = 1.0,
                 clock_tolerance_s: float = 10.0, queue_size: int = 64, router: str | None = None) -> None:
        self._started = time.monotonic()
        self.convention = convention = convention or Convention()
        self.router, self.info_timeout_s = router, info_timeout_s
        self._heard: set[str] = set()  # the streams that have sent something: "colour", "depth", "audio"
        self._silence_checked = False
        self.session = session
        if rig is None:  # a robot made of `avhear sensors --ros` answers with its microphones
            try:
                rig = ask_rig(session, convention.plain(RIG_KEY), info_timeout_s, convention.namespace.strip("/"))[0]
            except UserError:
                raise self._no_router() or UserError(
                    "where are the robot's microphones? Give them with --rig mics.yaml (a microphones or array "
                    "section, in the colour camera's frame: README, 'A ROS 2 robot'); a robot made of `avhear sensors "
                    f"--ros` answers with its own, and none answered within {info_timeout_s:g} s") from None
        if rig.microphones is None and rig.array is None:
            raise UserError("the rig file needs a 'microphones' or 'array' section: where the robot's microphones "
                            "are, in the colour camera's optical frame (x right, y down, z forward, metres)")
        self.topics = topics = topics or RosTopics()
        self.node = RosNode(session, convention, name="avhear")
        self.keys = (convention.topic(topics.colour), convention.topic(topics.depth))  # for messages
        self.bad_payloads = self.images_received = self.audio_gaps = 0
        self._presence = Presence(gap_s)
        self._rebase = {k: _Rebase(k, clock_tolerance_s) for k in ("colour camera", "depth camera", "microphone")}
        self._pairing = ApproximateTime(2, queue_size=4, max_interval_s=0.02)
        self._images: DropOldestQueue[tuple[int, float, Any]] = DropOldestQueue(queue_size, "ros-images")
        self._audio: DropOldestQueue[AudioBlock] = DropOldestQueue(4 * queue_size, "ros-audio")
        self._info: dict[str, Any] = {}
        self._ready = threading.Condition()
        self._format: AudioFormat | None = None
        self._next_sample = self._blocks = 0
        self._audio_t0: float | None = None
        self.camera_frame: str | None = None  # the camera's optical frame (CameraInfo's or the images' frame_id)
        self._colour_type = colour_type = (COMPRESSED_IMAGE if topics.colour.rstrip("/").endswith("/compressed")
                                           else IMAGE)
        subs = [(topics.colour, colour_type, lambda s: self._on_image(0, s, colour_type)),
                (topics.depth, IMAGE, lambda s: self._on_image(1, s, IMAGE)),
                (topics.audio_info, AUDIO_INFO, lambda s: self._on_info("audio", s, AUDIO_INFO)),
                (topics.audio, AUDIO_STAMPED, self._on_audio)]
        if rig.stereo is None:
            subs.append((topics.camera_info, CAMERA_INFO, lambda s: self._on_info("camera", s, CAMERA_INFO)))
        self._subscribers = [self.node.subscriber(topic, kind, callback) for topic, kind, callback in subs]
        try:
            stereo = rig.stereo or self._camera(info_timeout_s, convention)
            self._format = self._audio_info(info_timeout_s, convention)
        except BaseException:
            self.close()
            raise
        self.rig, self.mics, self.array = stereo, rig.microphones, None
        self.channels: tuple[int, int] = (0, 1)
        if rig.array is not None:
            pair = rig.array.pairs[0]  # type: ignore[index]
            self.mics = rig.array.pair(0)
            self.channels = (rig.array.channels[pair[0]], rig.array.channels[pair[1]])  # type: ignore[index]
            self.array = rig.array if rig.array.n_pairs > 1 else None
        wanted = max(rig.array.channels) + 1 if rig.array is not None else 2  # type: ignore[union-attr]
        if self._format.channels < wanted:
            raise UserError(f"the microphone publishes {self._format.channels} channels; the rig's microphones need "
                            f"{wanted}")
        self.samplerate_hz = float(self._format.samplerate_hz)

    # -- waiting for the drivers' info messages ----------------------------------------------------------------

    def _wait_for(self, what: str, timeout_s: float) -> Any:
        with self._ready:
            self._ready.wait_for(lambda: what in self._info, timeout=timeout_s)
            return self._info.get(what)

    def _camera(self, timeout_s: float, convention: Convention) -> StereoRig:
        info = self._wait_for("camera", timeout_s)
        if info is None:
            raise self._silent(self.topics.camera_info, CAMERA_INFO, "--camera-info-topic", "no CameraInfo",
                               "is the camera driver running (same --ros-domain, --ros-keys)? Or give the camera's "
                               "intrinsics in the rig file's stereo section")
        try:
            k, size = camera_matrix(info)
        except ValueError as exc:
            raise UserError(f"{convention.topic(self.topics.camera_info)}: {exc}") from None
        self.camera_frame = info.header.frame_id or None
        return StereoRig.rgbd(k, size)

    def _audio_info(self, timeout_s: float, convention: Convention) -> AudioFormat:
        info = self._wait_for("audio", timeout_s)
        if info is None:
            raise self._silent(self.topics.audio_info, AUDIO_INFO, "--audio-info-topic", "no AudioInfo",
                               "is audio_capture running (it publishes one every 5 s)?")
        try:
            return audio_format(info)
        except ValueError as exc:
            raise UserError(f"{convention.topic(self.topics.audio_info)}: {exc}") from None

    # -- a topic that stays silent: say which, and what there is ----------------------------------------------

    def _silent(self, topic: str, typename: str, flag: str, nothing: str, hint: str = "") -> UserError:
        """The one-line error for ``topic`` silent since the start: nothing answers at the router's endpoint, or no
        node publishes the topic (the topics of its type that exist, from the graph's liveliness tokens), or it is
        published and nothing came."""
        waited = time.monotonic() - self._started
        no_router = self._no_router()
        if no_router is not None:
            return no_router
        full = self.convention.topic(topic)
        where = f"{nothing} on {full} within {waited:.0f} s"
        if not self.convention.native:
            return UserError(f"{where}: {hint + ' ' if hint else ''}Name the topic with {flag} (`ros2 topic list` on "
                             "the robot lists them; under --ros-keys bridge avhear cannot)")
        topics = published_topics(self.session, self.convention.domain)
        if full in topics:
            return UserError(f"{where}, though {full} is published ({', '.join(sorted(topics[full]))}): is it of "
                             f"type {typename}? {hint}".rstrip())
        alike = sorted(t for t, types in topics.items() if typename in types)
        there = (f"the {typename} topics published: {', '.join(alike)}" if alike else
                 f"no node publishes a {typename} topic ({len(topics)} topics published in domain "
                 f"{self.convention.domain})")
        return UserError(f"{where}: no node publishes it; {there}. Name the right one with {flag}")

    def _no_router(self) -> UserError | None:
        """The error for an rmw_zenoh router that the session was to join and that does not answer, else None."""
        if self.router is None or list(self.session.info.routers_zid()):
            return None
        return UserError(f"nothing answers at {self.router}, where rmw_zenoh's router should be: start it on the "
                         "robot's machine (`ros2 run rmw_zenoh_cpp rmw_zenohd`), or name another with "
                         "AVHEAR_ROS_ROUTER=tcp/HOST:7447 (a robot's own Zenoh peers: --bus-connect)")

    def _check_silence(self) -> None:
        """Called while a stream waits: once ``info_timeout_s`` has passed since the start, a stream that has sent
        nothing and that no node publishes is a user's mistake (a wrong topic name), never a silent success; one that
        a node publishes (its type as asked) is said and waited for."""
        if self._silence_checked:
            return
        if len(self._heard) == 3:
            self._silence_checked = True
            return
        if time.monotonic() - self._started < self.info_timeout_s:
            return
        self._silence_checked = True
        t = self.topics
        published = published_topics(self.session, self.convention.domain) if self.convention.native else {}
        for stream, topic, typename, flag in (("colour", t.colour, self._colour_type, "--colour-topic"),
                                              ("depth", t.depth, IMAGE, "--depth-topic"),
                                              ("audio", t.audio, AUDIO_STAMPED, "--audio-topic")):
            if stream in self._heard:
                continue
            if typename in published.get(self.convention.topic(topic), ()):  # its driver is there: a slow start
                log.warning("nothing has come on %s in %.0f s, though a node publishes it: waiting for it",
                            self.convention.topic(topic), time.monotonic() - self._started)
                continue
            raise self._silent(topic, typename, flag, f"no {stream} messages")

    # -- Zenoh's threads: decode and hand over ---------------------------------------------------------------

    def _on_info(self, what: str, sample: Any, typename: str) -> None:
        try:
            msg = decode(sample.payload.to_bytes(), typename)
        except ValueError:
            self.bad_payloads += 1
            return
        with self._ready:
            self._info[what] = msg
            self._ready.notify_all()

    def _on_image(self, side: int, sample: Any, typename: str) -> None:
        try:
            msg = decode(sample.payload.to_bytes(), typename)
        except ValueError:
            self.bad_payloads += 1
            return
        self._heard.add(("colour", "depth")[side])
        stamp = self._rebase[("colour camera", "depth camera")[side]](stamp_s(msg.header), time.time())
        if side == 0 and self.camera_frame is None:
            self.camera_frame = msg.header.frame_id or None
        self._images.put((side, stamp, msg))

    def _on_audio(self, sample: Any) -> None:
        fmt = self._format
        if fmt is None:  # before the AudioInfo: the stream has not started for avhear
            return
        try:
            msg = decode(sample.payload.to_bytes(), AUDIO_STAMPED)
            samples = audio_samples(msg, fmt)
        except ValueError:
            self.bad_payloads += 1
            return
        self._heard.add("audio")
        if samples.shape[0] == 0:
            return
        fs = fmt.samplerate_hz
        stamp = self._rebase["microphone"](stamp_s(msg.header), time.time() - samples.shape[0] / fs)
        if self._audio_t0 is None:
            self._audio_t0 = stamp
        expected = self._audio_t0 + self._next_sample / fs
        if stamp - expected > 0.5 * samples.shape[0] / fs:  # a message (or more) was lost on the way
            self.audio_gaps += 1
            self._next_sample = int(round((stamp - self._audio_t0) * fs))
        first = self._next_sample
        self._audio.put(AudioBlock(self._blocks, first, self._audio_t0 + first / fs, samples, fs))
        self._next_sample += samples.shape[0]
        self._blocks += 1

    # -- the Source contract -----------------------------------------------------------------------------------

    def clock(self) -> float:
        """ROS time: this machine's system clock."""
        return time.time()

    def audio_format(self, timeout_s: float = 10.0) -> tuple[float, int]:
        """(samplerate_hz, n_channels) of the robot's audio (known from its AudioInfo)."""
        assert self._format is not None
        return self.samplerate_hz, self._format.channels

    def _frame(self, index: int, stamp: float, colour: Any, depth: Any) -> StereoFrame:
        if hasattr(colour, "encoding"):
            image = image_from_msg(colour)
        else:
            image = cv2.imdecode(np.frombuffer(bytes(colour.data), np.uint8), cv2.IMREAD_COLOR)
            if image is None:
                raise ValueError(f"a compressed image of format {colour.format!r} does not decode")
        depth_m = as_depth_m(image_from_msg(depth))
        if depth_m.shape != image.shape[:2]:
            raise ValueError(f"the depth image is {depth_m.shape[::-1]}, the colour image {image.shape[1::-1]}: "
                             "is the depth aligned to the colour image (align_depth.enable:=true)?")
        return StereoFrame(index, stamp, image, None, stamp, depth_m=depth_m)

