"""Opening a source by name: the simulated room, a recording folder, live devices or a webcam (``--source``)."""
from __future__ import annotations

import importlib
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from app.config import load_rig, require_live_rig
from app.sources.contract import SourceBase
from app.errors import UserError
from app.events import AudioBlock, StereoFrame
from app.sources.live import DEFAULT_FOV_DEG, LiveConfig, LiveSource, camera_size, webcam_rig
from app.sources.recording import open_recording
from app.sources.replay import ReplayStream
from avcore.geometry import MicArray, MicPair

__all__ = ["StreamAdapter", "open_source"]


class StreamAdapter(SourceBase):
    """A :class:`~app.sources.replay.ReplayStream` (the simulator or a recording) as a pipeline source.

    realtime : deliver at capture pace on ``time.monotonic()`` (a live-like demo), or as fast as possible (then
    the pipeline applies back-pressure and loses nothing). Both threads share one start time, so frames and audio
    are on one clock.
    """

    def __init__(self, stream: ReplayStream, *, realtime: bool, channels: tuple[int, int] = (0, 1),
                 duration_s: float | None = None) -> None:
        if stream.stereo is None:
            raise UserError("the source has no stereo calibration: add a 'stereo' section to its rig.yaml")
        self.stream = stream
        self.rig = stream.stereo
        self.mics = stream.mics if stream.mics is not None else MicPair()
        self.samplerate_hz = float(stream.samplerate_hz)
        self.channels = channels
        # several microphones (the simulator with --mics): every pair's channels are the array's
        array = getattr(stream, "array", None)
        self.array = array if array is not None and array.n_pairs > 1 else None
        if self.array is not None:
            pair = self.array.pairs[0]
            self.channels = (self.array.channels[pair[0]], self.array.channels[pair[1]])
        self.realtime = realtime
        # the stream ends after duration_s seconds of its own clock (everything stamped before start + duration)
        self.end_s = np.inf if duration_s is None else stream.start_s + float(duration_s)
        self._start_s: float | None = None
        self._lock = threading.Lock()

    def _start(self) -> float | None:
        """The stream's start on the monotonic clock, set by whichever thread starts first (real time only)."""
        if not self.realtime:
            return None
        with self._lock:
            if self._start_s is None:
                prepare = getattr(self.stream, "prepare", None)
                if prepare is not None:  # the simulator's first frame, before its clock starts
                    prepare()
                self._start_s = time.monotonic()
            return self._start_s

    def clock(self) -> float:
        """Now on the stream's own clock: its earliest stamp when the real-time delivery started (the stamps stay
        the simulator's or the recording's; see :class:`~app.sources.contract.Source`)."""
        start = self._start()
        if start is None:
            return time.monotonic()  # as fast as possible: no latency is measured
        return time.monotonic() - start + self.stream.start_s

    @property
    def frames_dropped(self) -> int:
        """Frames the source skipped because they were late (real-time delivery)."""
        return int(self.stream.stats.frames_dropped)

    def frames(self, stop: threading.Event) -> Iterator[StereoFrame]:
        for frame in self.stream.frames(realtime=self.realtime, start_s=self._start()):
            if stop.is_set() or frame.stamp_s >= self.end_s:
                return
            yield frame

    def audio(self, stop: threading.Event) -> Iterator[AudioBlock]:
        for block in self.stream.audio_blocks(realtime=self.realtime, start_s=self._start()):
            if stop.is_set() or block.stamp_s >= self.end_s:
                return
            yield block

    def close(self) -> None:
        """Close a replayed recording's files (the simulator holds none)."""
        close = getattr(self.stream, "close", None)
        if close is not None:
            close()


def open_source(spec: str, *, realtime: bool, duration_s: float | None = None, seed: int = 0,
                rig_path: str | None = None, live: LiveConfig | None = None, mics: str = "pair",
                bodies: bool = False, camera: str = "stereo", fov_deg: float = DEFAULT_FOV_DEG, lips: bool = False,
                mic_spacing_m: float | None = None, progress=None  # noqa: ANN001
                ) -> StreamAdapter | LiveSource:
    """``sim:PRESET`` (S1..S6, calibration), ``replay:FOLDER``, ``live`` (with ``rig_path`` and ``live``) or
    ``webcam`` (:func:`webcam`); ``mics`` names the simulated room's (or the webcam's) microphones
    (:data:`avcore.geometry.ARRAY_PRESETS`); ``bodies`` draws the simulated people with arms, hands and a table,
    ``camera`` is the simulated stereo pair, RGB-D camera or one camera, ``lips`` opens the simulated people's
    mouths as they speak (:class:`app.sources.sim.SimSource`)."""
    kind, _, arg = spec.partition(":")
    if kind == "sim":
        try:
            importlib.import_module("pyroomacoustics")
        except ImportError as exc:
            raise UserError("the simulated room needs pyroomacoustics: pip install -e '.[sim]'") from exc
        from app.sources.sim import SimSource, check_simulated_duration  # the simulator only for a simulated room
        from sim.scenario import PRESETS

        preset = arg or "S2"
        if preset not in PRESETS:
            raise UserError(f"unknown scenario {preset!r}; choose one of {', '.join(PRESETS)}")
        check_simulated_duration(duration_s)
        return StreamAdapter(SimSource.from_preset(preset, duration_s=duration_s, seed=seed, mics=mics,
                                                   bodies=bodies, camera=camera, lips=lips, progress=progress),
                             realtime=realtime)
    if kind == "replay":
        if not arg:
            raise UserError("give the recording folder: --source replay:recordings/NAME")
        rec = open_recording(arg)
        return StreamAdapter(rec, realtime=realtime, channels=(rec.channels["left"], rec.channels["right"]),
                             duration_s=duration_s)
    if kind == "live":
        if rig_path is None:
            raise UserError("a live run needs the rig calibration: --rig rig.yaml (avhear calibrate stereo makes one)")
        rig = require_live_rig(rig_path)
        return LiveSource(live or LiveConfig(), rig.stereo, rig.microphones, rig.array)
    if kind == "webcam":
        return webcam(live or LiveConfig(right=None), rig_path=rig_path, fov_deg=fov_deg, mics=mics,
                      mic_spacing_m=mic_spacing_m)
    raise UserError(f"unknown source {spec!r}: use sim:S2, replay:FOLDER, live, webcam, bus or ros")


def webcam(config: LiveConfig, *, rig_path: str | None = None, fov_deg: float = DEFAULT_FOV_DEG,
           mics: str = "laptop", mic_spacing_m: float | None = None) -> LiveSource:
    """One camera (``config.left``) and the input device, with no calibration session: the camera's intrinsics from
    the size of the images it delivers and ``fov_deg`` (:func:`app.sources.live.webcam_rig`), or from the left
    camera of ``rig_path``'s stereo section; the microphones from ``rig_path`` when it has them, else the preset
    ``mics`` placed in the camera's frame (``laptop``: two microphones ``mic_spacing_m`` apart, 10 cm by default,
    either side of the camera)."""
    rig = load_rig(Path(rig_path)) if rig_path is not None else None
    if rig is not None and rig.stereo is not None:
        stereo = rig.stereo
    else:  # a camera that cannot be read is a DeviceError (one line)
        stereo = webcam_rig(camera_size(config.left), fov_deg)
    if rig is not None and (rig.microphones is not None or rig.array is not None):
        return LiveSource(config, stereo, rig.microphones, rig.array)
    array = MicArray.preset(mics)
    if mic_spacing_m is not None:
        if mics != "laptop":
            raise UserError(f"--mic-spacing sets the laptop's two microphones apart; --mics {mics} has its own shape")
        half = mic_spacing_m / 2.0
        array = MicArray(((-half, 0.0, 0.0), (half, 0.0, 0.0)), channels=array.channels)
    return LiveSource(config, stereo, None, array)
