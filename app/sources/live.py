"""The live source: two OpenCV cameras (or one side-by-side stereo camera, or one camera alone: a webcam) and a
`sounddevice` input stream.

Frames are stamped with ``time.monotonic()`` when grabbed (both cameras are grabbed before either is decoded, so
their stamps differ by the grab time only; two separate cameras are paired by ApproximateTime), rectified with the
rig, and delivered at the cameras' pace. Audio blocks are copied and enqueued by the PortAudio callback, which
never blocks (python-sounddevice's own advice) and counts overflows; their stamps come from the stream's ADC time
mapped onto the monotonic clock.
"""
from __future__ import annotations

import logging
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from app.sources.limits import DEFAULT_FOV_DEG
from app.sources.contract import SourceBase
from app.errors import UserError
from app.events import AudioBlock, StereoFrame
from app.queues import DropOldestQueue
from app.sound import DeviceError, load_sounddevice
from avcore.geometry import MicArray, MicPair
from avcore.stereo import StereoRig
from avcore.sync import ApproximateTime

log = logging.getLogger(__name__)

__all__ = ["DEFAULT_FOV_DEG", "LiveConfig", "LiveSource", "camera_size", "webcam_rig"]



@dataclass(frozen=True)
class LiveConfig:
    """Devices of a live run.

    left, right : OpenCV camera indices or paths/URLs of the two cameras; ``right=None`` with ``side_by_side``
        means one camera delivering both images side by side (left half, right half); ``right=None`` alone, one
        camera (faces located by their size: :mod:`avcore.mono`).
    fps : the frame rate asked of the cameras.
    audio_device : a sounddevice input device (index or name substring); None for the default input.
    samplerate_hz, n_channels : the input stream; channels : the (left, right) microphone channels (0-based);
    array_channels : with a microphone array in the rig file, the channel of each of its microphones (None: the rig
    file's).
    block_frames : samples per callback.
    max_failed_reads : consecutive failed grabs before the camera counts as gone.
    max_silent_s : seconds without an audio block from a running stream before the input counts as gone (a
        PulseAudio input may take a few seconds to deliver its first block); a stream that PortAudio stopped counts
        as gone after a few blocks' time.
    """

    left: int | str = 0
    right: int | str | None = 1
    side_by_side: bool = False
    fps: float = 30.0
    audio_device: int | str | None = None
    samplerate_hz: int = 16_000
    n_channels: int = 2
    channels: tuple[int, int] = (0, 1)
    array_channels: tuple[int, ...] | None = None
    block_frames: int = 512
    max_failed_reads: int = 30
    max_silent_s: float = 5.0

    @property
    def one_camera(self) -> bool:
        return self.right is None and not self.side_by_side

    def __post_init__(self) -> None:
        if self.side_by_side and self.right is not None:
            raise ValueError("give two cameras (left and right) or one side-by-side camera (right=None, "
                             "side_by_side=True)")
        if self.array_channels is not None and (len(set(self.array_channels)) != len(self.array_channels)
                                                or not all(0 <= c < self.n_channels for c in self.array_channels)):
            raise ValueError(f"the array's channels must be different channel numbers below n_channels="
                             f"{self.n_channels} (--audio-channels), got {list(self.array_channels)}")
        if not all(0 <= c < self.n_channels for c in self.channels) or self.channels[0] == self.channels[1]:
            raise ValueError(f"channels must be two different channel numbers below n_channels={self.n_channels}, "
                             f"got {self.channels}")


class LiveSource(SourceBase):
    """Cameras and microphones for :class:`app.pipeline.Pipeline` (see module docstring)."""

    realtime = True

    def __init__(self, config: LiveConfig, rig: StereoRig, mics: MicPair | None, array: MicArray | None = None
                 ) -> None:
        """With ``array`` (the rig's ``array`` section) every pair of it is used, its channels those of the rig file
        or of ``config.array_channels``; otherwise the pair ``mics`` on ``config.channels``."""
        self.config = config
        self.rig = rig
        self.samplerate_hz = float(config.samplerate_hz)
        self.channels = config.channels
        if array is not None and config.array_channels is not None:
            if len(config.array_channels) != len(array.positions):
                raise UserError(f"--mic-channels gives {len(config.array_channels)} channels but the rig's array has "
                                f"{len(array.positions)} microphones: give one channel per microphone")
            array = MicArray(array.positions, array.pairs, array.speed_of_sound, array.c1, array.c0,
                             config.array_channels)
        if array is not None:
            if max(array.channels) >= config.n_channels:  # type: ignore[arg-type]
                raise UserError(f"the rig's array uses channels {list(array.channels)} but the input stream has "
                                f"{config.n_channels}: raise --audio-channels")
            self.array = array if array.n_pairs > 1 else None
            pair = array.pairs[0]  # type: ignore[index]
            self.channels = (array.channels[pair[0]], array.channels[pair[1]])  # type: ignore[index]
            mics = array.pair(0)
        assert mics is not None
        self.mics = mics
        self.overflows = 0
        self.failed_reads = 0

    # -- video -------------------------------------------------------------------------------------------------

    def _open(self, device: int | str) -> cv2.VideoCapture:
        cap = cv2.VideoCapture(device)
        if not cap.isOpened():
            raise DeviceError(f"cannot open camera {device!r}: check that it is plugged in and not used by another "
                              "program (on Linux: ls /dev/video*)")
        w, h = self.rig.image_size
        cap.set(cv2.CAP_PROP_FRAME_WIDTH, 2 * w if self.config.side_by_side else w)
        cap.set(cv2.CAP_PROP_FRAME_HEIGHT, h)
        cap.set(cv2.CAP_PROP_FPS, self.config.fps)
        return cap

    def frames(self, stop: threading.Event) -> Iterator[StereoFrame]:
        cfg = self.config
        caps = [self._open(cfg.left)] if cfg.right is None else [self._open(cfg.left), self._open(cfg.right)]
        pair = ApproximateTime(2, queue_size=4, max_interval_s=0.5 / cfg.fps)
        index = 0
        failed = 0
        try:
            while not stop.is_set():
                stamps = []
                ok = True
                for cap in caps:  # grab all first: the exposures are as close in time as the driver allows
                    ok &= cap.grab()
                    stamps.append(time.monotonic())
                images = [cap.retrieve()[1] if ok else None for cap in caps]
                if not ok or any(img is None for img in images):
                    failed += 1
                    self.failed_reads += 1
                    if failed >= cfg.max_failed_reads:
                        raise DeviceError(f"the camera stopped delivering frames ({failed} failed reads in a row): "
                                          "check its cable and that no other program uses it")
                    stop.wait(0.01)
                    continue
                failed = 0
                if cfg.one_camera:
                    pairs = [(stamps[0], images[0], None)]
                elif cfg.side_by_side:
                    half = images[0].shape[1] // 2
                    pairs = [(stamps[0], images[0][:, :half], images[0][:, half:])]
                else:  # two cameras: ApproximateTime pairs their frames by stamp
                    sets = pair.push(0, stamps[0], (stamps[0], images[0])) + pair.push(1, stamps[1],
                                                                                       (stamps[1], images[1]))
                    pairs = [(max(sl, sr), left, right) for (sl, left), (sr, right) in sets]
                for stamp, left, right in pairs:
                    if left.shape[1::-1] != tuple(self.rig.image_size):
                        if index == 0:
                            log.warning("the cameras deliver %s images, the rig is calibrated for %s: resizing "
                                        "(calibrate at the size the cameras deliver)", left.shape[1::-1],
                                        tuple(self.rig.image_size))
                        left = cv2.resize(left, tuple(self.rig.image_size))
                        right = None if right is None else cv2.resize(right, tuple(self.rig.image_size))
                    if right is not None:  # one camera's image stays as taken: its faces' pixels are rectified
                        left, right = self.rig.rectify(left, right)
                    yield StereoFrame(index, stamp, left, right, stamp)
                    index += 1
        finally:
            for cap in caps:
                cap.release()

    # -- audio -------------------------------------------------------------------------------------------------

    def audio(self, stop: threading.Event) -> Iterator[AudioBlock]:
        sd = load_sounddevice()
        cfg = self.config
        blocks: DropOldestQueue[tuple[float, np.ndarray]] = DropOldestQueue(256, "audio-callback")
        offset: list[float] = []  # monotonic - stream time, measured once

        def callback(indata: np.ndarray, frames: int, time_info: Any, status: Any) -> None:
            # runs in PortAudio's thread: copy, stamp, enqueue; never block, never raise
            if status.input_overflow:
                self.overflows += 1
            if not offset:
                offset.append(time.monotonic() - time_info.currentTime)
            blocks.put((time_info.inputBufferAdcTime + offset[0], indata.copy()))

        try:
            stream = sd.InputStream(device=cfg.audio_device, channels=cfg.n_channels, samplerate=cfg.samplerate_hz,
                                    blocksize=cfg.block_frames, dtype="float32", callback=callback)
        except Exception as exc:  # PortAudioError, ValueError for a bad device: the user's to fix
            raise DeviceError(f"cannot open the audio input {cfg.audio_device!r} with {cfg.n_channels} channels at "
                              f"{cfg.samplerate_hz} Hz ({exc}); list the devices with "
                              "'python -m sounddevice'") from exc
        with stream:
            silent_s = 0.0
            n_blocks = first_sample = 0
            while not stop.is_set():
                item = blocks.get(timeout=0.1)
                if item is None:
                    # PortAudio calls back every block_frames samples (32 ms by default) while the device is there;
                    # errors in its thread do not reach here, so a silent callback is how a vanished device shows
                    silent_s += 0.1
                    if silent_s >= (cfg.max_silent_s if stream.active else 0.3):
                        state = "stopped" if not stream.active else f"sent nothing for {silent_s:.1f} s"
                        raise DeviceError(f"the audio input {cfg.audio_device!r} {state}: was the device "
                                          "unplugged? (list the devices with 'python -m sounddevice')")
                    continue
                silent_s = 0.0
                samples = item[1]
                yield AudioBlock(n_blocks, first_sample, item[0], samples, cfg.samplerate_hz)
                n_blocks += 1
                first_sample += samples.shape[0]
        self.overflows += blocks.dropped


def camera_size(device: int | str) -> tuple[int, int]:
    """(width, height) of the images camera ``device`` delivers (one frame read, then released); DeviceError when it
    cannot be opened or read."""
    cap = cv2.VideoCapture(device)
    try:
        ok, img = cap.read() if cap.isOpened() else (False, None)
        if not ok or img is None:
            raise DeviceError(f"cannot read camera {device!r}: check that it is plugged in and not used by another "
                              "program (avhear devices lists the cameras)")
        return int(img.shape[1]), int(img.shape[0])
    finally:
        cap.release()


def webcam_rig(image_size: tuple[int, int], fov_deg: float) -> StereoRig:
    """One camera known by its image size and horizontal field of view (no calibration): the focal length
    ``(w / 2) / tan(fov / 2)`` pixels on both axes, the principal point at the image's centre, no distortion; as a
    rig whose left camera it is (:meth:`StereoRig.rgbd`: the scene frame is the camera's own)."""
    if not 10.0 <= fov_deg <= 170.0:
        raise ValueError(f"the field of view must be between 10 and 170 degrees, got {fov_deg!r}")
    w, h = image_size
    f = 0.5 * w / np.tan(np.radians(fov_deg) / 2.0)
    k = np.array([[f, 0.0, (w - 1) / 2.0], [0.0, f, (h - 1) / 2.0], [0.0, 0.0, 1.0]])
    return StereoRig.rgbd(k, (w, h))
