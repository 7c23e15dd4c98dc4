"""The real-time process of docs/architecture.md: grabber, vision, audio, ITD worker and fusion threads (paper section
6).

```
source.frames() --> [grabber] --q--> [vision: F3D faces | HM3D points] (--q--> [lips]) --+
                                                                                         +--q--> [fusion: TimeFrame
source.audio()  --> [audio] --q--> [ITD worker] <=pipe=> (process: (WPE) PairsItdStream) +   -> inference]
                                                                                                --> on_result
        [audio] --q--> [voices-in] ==pipe==> (process: VoiceSeparator) ==pipe==> [voices] --> on_voice
                             ^--q-- the results' people (their places, who speaks)
```

The ITD worker hands each audio block to a process of its own (:mod:`app.itd_process`) and waits for its messages;
with ``dereverb`` that process first takes the room's late reverberation out of the array's microphones
(:class:`avcore.dereverb.SignalDereverberator`): its ITDs then come half a 32-ms frame later, on the same clock.

With the lips' cue (face-guided), the face mesh reads the lips in a thread of its own after vision's, so that the
mesh of one frame runs while the next frame's faces are found (OpenCV's DNN lets go of the GIL).

With ``voices`` on, every audio block and every result's people also go through the voices-in thread to a process
of its own (:mod:`app.voices_process`; why a process: :mod:`app.child_process`), which steers a stream at each
person (:mod:`avcore.separation`); the voices thread hands its chunks to ``on_voice``.

Every queue is a :class:`~app.queues.DropOldestQueue`: producers never block (a slow consumer loses the oldest
items, counted in the stats). The fusion thread alone owns the TimeFrame synchroniser (RSB's strategy, section 6:
each vision result collects the ITDs of its time frame) and the inference object, so they need no locks.

Failure handling: a bad frame (wrong shape, unreadable) or a block with NaN samples is counted and skipped; an
exception in a worker is stored, stops the pipeline and is re-raised by :meth:`Pipeline.run` in the main thread;
Ctrl-C (or :meth:`Pipeline.stop`, e.g. from a SIGTERM handler) stops every thread within about a second.
"""
from __future__ import annotations

import logging
import signal
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from app.pipeline_config import DEFAULT_ITD_METHOD, PipelineConfig
from app.sources.contract import Source
from app.errors import UserError
from app.events import AudioBlock, StereoFrame
from app.hearing import SelfCalibrating, Vision, hearing_mode
from app.itd_process import AudioMessage, EnvelopeMessage, FrameItdsMessage, ItdMessage, ItdProcess
from app.queues import DropOldestQueue
from app.result import Result
from app.signals import stop_on_signals
from app.voices_process import VoicesProcess
from avcore.faces import FaceDetector
from avcore.geometry import MicArray
from avcore.itd import FrameBins
from avcore.mic_check import MicCheck
from avcore.separation import VoiceChunk
from avcore.speaking import RescueContinuity
from avcore.stereo import StereoRig
from avcore.sync import FrameItdWindow, TimeFrame
from avcore.tracking import NearestTracker
from avcore.voices import direction_vector

log = logging.getLogger(__name__)

__all__ = ["DEFAULT_ITD_METHOD", "Pipeline", "PipelineConfig", "PipelineStats", "Source"]


@dataclass(frozen=True, eq=False)
class PeopleMessage:
    """A result's people for the voices' process: ids (N,), places (N, 3) metres, speaking (N,) bool; the voices out
    of view among them, put :data:`UNSEEN_VOICE_M` along their direction."""

    stamp_s: float
    ids: np.ndarray
    positions_m: np.ndarray
    speaking: np.ndarray


UNSEEN_VOICE_M = 2.0  # a voice out of view is steered at this distance along its direction (far field beyond it)

FusionMessage = Vision | AudioMessage


def _array(source: Any) -> MicArray:
    """The source's microphones as an array: its ``array``, or its pair on its two ``channels`` as an array of one
    pair (one path for one pair or many)."""
    array = getattr(source, "array", None)
    return array if array is not None else MicArray.from_pair(source.mics, tuple(source.channels))


_FRAME_ITDS_KEEP_S = 30.0  # seconds of single-frame ITDs kept at most (more than audio runs ahead of vision)


@dataclass
class PipelineStats:
    """Counters of a run (thread-safe enough: each counter has one writer)."""

    started_s: float = 0.0
    ended_s: float = 0.0
    frames: int = 0
    bad_frames: int = 0
    vision_results: int = 0
    audio_blocks: int = 0
    bad_audio_blocks: int = 0
    audio_gaps: int = 0
    itds: int = 0
    results: int = 0
    stage_time_s: dict[str, float] = field(default_factory=dict)
    latencies_s: list[float] = field(default_factory=list)
    drops: dict[str, int] = field(default_factory=dict)
    overflows: int = 0
    late_frames: int = 0
    out_of_order: int = 0  # frames and ITDs stamped before what the fusion already took: counted and dropped
    interrupted: bool = False
    self_calibration: list[dict[str, Any]] | None = None  # per pair, at the end of a self-calibrating run
    microphones: list[str] = field(default_factory=list)  # what the sound says of the rig file's microphones
    voice_chunks: int = 0  # chunks of the people's voices handed out (config.voices)
    voice_latencies_s: list[float] = field(default_factory=list)  # real time: out minus its first sample's capture

    @property
    def duration_s(self) -> float:
        return max(self.ended_s - self.started_s, 1e-9)

    def as_dict(self) -> dict[str, Any]:
        lat = np.asarray(self.latencies_s[-10_000:])
        return {
            "duration_s": round(self.duration_s, 3),
            "fps": round(self.results / self.duration_s, 2),
            "frames": self.frames,
            "bad_frames": self.bad_frames,
            "vision_results": self.vision_results,
            "results": self.results,
            "itds": self.itds,
            "audio_blocks": self.audio_blocks,
            "bad_audio_blocks": self.bad_audio_blocks,
            "audio_gaps": self.audio_gaps,
            "latency_ms_p50": round(float(np.percentile(lat, 50)) * 1e3, 2) if lat.size else None,
            "latency_ms_p95": round(float(np.percentile(lat, 95)) * 1e3, 2) if lat.size else None,
            "stage_ms_per_item": {k: round(v * 1e3, 3) for k, v in self.stage_time_s.items()},
            "drops": dict(self.drops),
            "overflows": self.overflows,
            "late_frames": self.late_frames,
            "out_of_order": self.out_of_order,
            "interrupted": self.interrupted,
            "self_calibration": self.self_calibration,
            "microphones": list(self.microphones),
            "voice_chunks": self.voice_chunks,
            "voice_latency_ms_p95": (round(float(np.percentile(self.voice_latencies_s[-10_000:], 95)) * 1e3, 2)
                                     if self.voice_latencies_s else None),
        }

    def summary(self) -> str:
        d = self.as_dict()
        latency = ("latency p95 n/a (as fast as possible)" if d["latency_ms_p95"] is None
                   else f"latency p95 {d['latency_ms_p95']} ms")
        return (f"{d['results']} results in {d['duration_s']} s ({d['fps']} per s), {latency}, "
                f"{d['itds']} ITDs, drops {sum(d['drops'].values())}, "
                f"audio overflows {d['overflows']}, late frames skipped {d['late_frames']}, bad frames "
                f"{d['bad_frames']}" + (f", out of order {d['out_of_order']}" if d["out_of_order"] else ""))


class _Stop(Exception):
    """Raised inside a worker when the pipeline stops."""


class Pipeline:
    """Runs a :class:`Source` through vision, ITD extraction and fusion in threads; calls ``on_result`` from the
    fusion thread for every fused result (so that all Rerun logging happens in one thread), and with
    ``config.voices`` ``on_voice`` from the voices thread for every :class:`avcore.separation.VoiceChunk`.

    ``clock`` is the clock of the source's stamps (default the source's own ``clock``).
    """

    def __init__(self, source: Source, config: PipelineConfig | None = None,
                 on_result: Callable[[Result], None] | None = None, *,
                 detector: FaceDetector | None = None, clock: Callable[[], float] | None = None,
                 on_voice: Callable[[VoiceChunk], None] | None = None) -> None:
        self.source = source
        self.config = config if config is not None else PipelineConfig()
        self.on_result, self.on_voice = on_result, on_voice
        self.clock = clock if clock is not None else getattr(source, "clock", time.monotonic)
        self.stats = PipelineStats()
        self._stop = threading.Event()
        self._errors: list[tuple[str, BaseException]] = []
        c = self.config
        self.mode = hearing_mode(c)
        # the faces' detector, when the mode looks for faces (None: motion-guided)
        self.detector = detector if detector is not None else self.mode.detector()
        self._q_frames: DropOldestQueue[StereoFrame] = DropOldestQueue(self.mode.frame_capacity, "frames")
        self._q_audio: DropOldestQueue[AudioBlock] = DropOldestQueue(c.audio_queue, "audio")
        self._q_fusion: DropOldestQueue[FusionMessage] = DropOldestQueue(c.fusion_queue, "fusion")
        # with the lips read in a thread of their own, vision's results go through it to the fusion
        self._q_lips: DropOldestQueue[Vision] | None = (
            DropOldestQueue(c.frame_queue, "lips") if self.mode.reads_lips else None)
        self._seen = "vision" if self._q_lips is None else "lips"  # the stage whose results the fusion takes
        # the audio and the results' people, to the voices' process (see _voices_in_loop)
        self._q_voices: DropOldestQueue[AudioBlock | PeopleMessage] | None = (
            DropOldestQueue(c.audio_queue + c.fusion_queue, "voices") if c.voices else None)
        self._done = {name: threading.Event()
                      for name in ("grabber", "audio", "vision", "lips", "itd", "fusion", "voices-in", "voices")}
        # (times, ITDs, band times, band ITDs) blocks of the single frames, fusion thread
        self._frame_itds = FrameItdWindow(c.decision_window_s or c.frame_window_s, keep_s=_FRAME_ITDS_KEEP_S)
        self._vote = self.mode.vote()
        self._continuity = RescueContinuity(c.rescue_gap_s) if c.rescue_gap_s is not None else None
        self._fused = 0  # vision frames fused (results emitted lag them by the vote)
        # a live source must never wait; a replay as fast as possible waits for room rather than lose data
        self._backpressure = not source.realtime
        self._vision_clock: float | None = None  # stamp of the last frame vision took (the ITD worker's pace)
        self._first_audio_stamp: float | None = None
        self._sync: TimeFrame | None = None  # the fusion thread's synchroniser, for its drop counts
        self._hearing: Any = None  # the fusion thread's hearing, for the self-calibration's state
        self._mic_check: MicCheck | None = None  # the fusion thread's check of the rig's microphones
        self._mic_said: set[tuple[int, str]] = set()
        self._voices: VoicesProcess | None = None  # the voices' separator, in a process of its own while running
        self._itd: ItdProcess | None = None  # the ITDs, likewise
        self._voices_flushed = False  # the voices' process said it was done

    # -- control ---------------------------------------------------------------------------------------------

    def queue_depths(self) -> dict[str, int]:
        """Items waiting in each queue now (for the diagnostics pane)."""
        return {q.name: len(q) for q in self._queues()}

    def _queues(self) -> list[DropOldestQueue]:
        return [q for q in (self._q_frames, self._q_lips, self._q_audio, self._q_fusion, self._q_voices)
                if q is not None]

    def self_calibration_state(self) -> list[dict[str, Any]] | None:
        """Where the self-calibration stands, per pair (:meth:`app.hearing.SelfCalibrating.state`); None without
        it. For the sinks, which run on the fusion thread that owns the hearing."""
        hearing = self._hearing
        return hearing.state() if isinstance(hearing, SelfCalibrating) else None

    def stop(self) -> None:
        """Ask every thread to finish (safe from a signal handler)."""
        self._stop.set()

    def run(self, duration_s: float | None = None, *, whole: bool = False) -> PipelineStats:
        """Run until the source ends, ``duration_s`` of wall time passes, :meth:`stop` or Ctrl-C.

        Re-raises the first exception of a worker thread after all threads have been joined. With ``whole`` (an
        evaluation, whose figures would be a cut run's), Ctrl-C or SIGTERM raises ``KeyboardInterrupt`` once the
        threads are joined, instead of returning the stats with ``interrupted`` set. In the main thread, Ctrl-C
        (SIGINT) only sets a flag while the run waits, rather than raising wherever the interpreter happens to be.
        """
        workers = [
            ("voices", self._voices_loop), ("voices-in", self._voices_in_loop), ("fusion", self._fusion_loop),
            ("itd", self._itd_loop),
            ("lips", self._lips_loop), ("vision", self._vision_loop), ("audio", self._audio_loop),
            ("grabber", self._grab_loop),
        ]
        if self._q_lips is None:
            workers.remove(("lips", self._lips_loop))
        if self._q_voices is None:
            workers = [w for w in workers if not w[0].startswith("voices")]
        threads = [threading.Thread(target=self._guard, args=(name, fn), name=f"avhear-{name}", daemon=True)
                   for name, fn in workers]
        self.stats.started_s = time.perf_counter()
        ctrl_c = threading.Event()
        try:
            if _audio_format_known(self.source):  # the processes start with the threads (a robot's: its 1st block)
                self._itd = self._start_itd()
                self._voices = self._start_voices() if self._q_voices is not None else None
            with stop_on_signals(ctrl_c, (signal.SIGINT,)):
                for t in threads:
                    t.start()
                deadline = None if duration_s is None else time.perf_counter() + duration_s
                last = "fusion" if self._q_voices is None else "voices"
                while not self._done[last].wait(0.05):
                    if ctrl_c.is_set() or self._stop.is_set() or (
                            deadline is not None and time.perf_counter() >= deadline):
                        break
        except KeyboardInterrupt:
            self.stats.interrupted = True
        finally:
            self.stats.interrupted = self.stats.interrupted or ctrl_c.is_set()
            self._stop.set()
            for t in reversed(threads):  # reverse start order: producers first
                if t.ident is None:  # never started: a process could not start
                    continue
                t.join(self.config.join_timeout_s)
                if t.is_alive():
                    log.warning("thread %s did not stop within %.1f s", t.name, self.config.join_timeout_s)
            self._end_children(threads)
            self.stats.ended_s = time.perf_counter()
            self.stats.drops = {q.name: q.dropped for q in self._queues()}
            sync = self._sync
            self.stats.drops.update({
                "itds_unmatched": sync.dropped_secondaries if sync is not None else 0,  # TimeFrame's cap
                "frames_unmatched": sync.dropped_primaries if sync is not None else 0,
                "frame_itds": self._frame_itds.cut,
            })
            self.stats.overflows = int(self.source.overflows)  # audio lost at the input
            self.stats.late_frames = int(self.source.frames_dropped)  # skipped by a real-time source
        if self._errors:
            name, exc = self._errors[0]
            if isinstance(exc, UserError):  # a bad recording or device: the message says what to do
                raise exc
            raise RuntimeError(f"the {name} thread failed: {exc}") from exc
        if whole and self.stats.interrupted:
            raise KeyboardInterrupt
        return self.stats

    def _end_children(self, threads: list[threading.Thread]) -> None:
        """The ITDs' and the voices' processes: released for a next run where their stage ended cleanly (every
        block answered; every voice flushed), closed otherwise."""
        failed = {name for name, _ in self._errors} | {t.name.removeprefix("avhear-") for t in threads if t.is_alive()}
        for child, clean in ((self._itd, "itd" not in failed and self._done["itd"].is_set()),
                             (self._voices, self._voices_flushed)):
            if child is not None and clean:
                child.release()
            elif child is not None:
                child.close()
        self._itd, self._voices, self._voices_flushed = None, None, False

    def _guard(self, name: str, fn: Callable[[], None]) -> None:
        try:
            fn()
        except _Stop:
            pass
        except BaseException as exc:  # stored and re-raised by run() in the main thread
            if not isinstance(exc, UserError):  # a user's error is reported once, by whoever called run()
                log.exception("%s thread failed", name)
            self._errors.append((name, exc))
            self._stop.set()
        finally:
            self._done[name].set()

    def _offer(self, q: DropOldestQueue, item: Any) -> None:
        while self._backpressure and not self._stop.is_set() and not q.wait_for_room(0.05):
            pass
        q.put(item)

    def _timed(self, stage: str, start: float, count: int) -> None:
        elapsed = time.perf_counter() - start
        prev = self.stats.stage_time_s.get(stage, 0.0)
        self.stats.stage_time_s[stage] = prev + (elapsed - prev) / max(count, 1)  # running mean per item

    def _take(self, q: DropOldestQueue, upstream: str) -> Any:
        """The next item of ``q``; raises _Stop when the pipeline stops or upstream is done and ``q`` is empty."""
        while True:
            if self._stop.is_set():
                raise _Stop
            item = q.get(timeout=0.05)
            if item is not None:
                return item
            if self._done[upstream].is_set() and len(q) == 0:
                raise _Stop

    # -- threads ---------------------------------------------------------------------------------------------

    def _grab_loop(self) -> None:
        for frame in self.source.frames(self._stop):
            if self._stop.is_set():
                return
            self.stats.frames += 1
            self._offer(self._q_frames, frame)

    def _audio_loop(self) -> None:
        for block in self.source.audio(self._stop):
            if self._stop.is_set():
                return
            self._offer(self._q_audio, block)
            if self._q_voices is not None:
                self._offer(self._q_voices, block)

    def _vision_loop(self) -> None:
        rig = self.source.rig
        n = 0
        while True:
            frame = self._take(self._q_frames, "grabber")
            self._vision_clock = frame.stamp_s
            t0 = time.perf_counter()
            if not _good_frame(frame, rig):
                self.stats.bad_frames += 1
                continue
            try:
                vision = self.mode.vision(frame, rig, self.detector)
            except ValueError as exc:
                log.debug("bad frame %d: %s", frame.index, exc)
                self.stats.bad_frames += 1
                continue
            if vision is None:  # motion-guided: the interval is not complete yet
                continue
            self._offer(self._q_fusion if self._q_lips is None else self._q_lips, vision)
            n += 1
            self.stats.vision_results = n
            self._timed("vision", t0, n)

    def _lips_loop(self) -> None:
        """Vision's results with each face's lips read (:meth:`app.hearing.FaceGuided.read_lips`), in order."""
        assert self._q_lips is not None
        n = 0
        while True:
            vision = self._take(self._q_lips, "vision")
            t0 = time.perf_counter()
            vision = self.mode.read_lips(vision)
            self._offer(self._q_fusion, vision)
            n += 1
            self._timed("lips", t0, n)

    def _start_itd(self) -> ItdProcess:
        c = self.config
        return ItdProcess(array=_array(self.source), samplerate_hz=self.source.samplerate_hz, itd_method=c.itd_method,
                          window_s=c.window_s, hop_s=c.hop_s, energy_threshold=c.energy_threshold,
                          frame_itds=self.mode.frame_itds, envelope=self.mode.envelope is not None,
                          dereverb=c.dereverb)

    def _start_voices(self) -> VoicesProcess:
        c, array = self.config, _array(self.source)
        return VoicesProcess(mic_positions_m=array.positions, samplerate_hz=self.source.samplerate_hz,
                             learn_delay_s=c.voice_delay_s, speed_of_sound=array.speed_of_sound,
                             max_wait_s=None if self._backpressure else c.voice_delay_s + 1.0)

    def _itd_loop(self) -> None:
        """Each audio block to the ITD process (:class:`app.itd_process.ItdProcess`; a robot's starts at its first
        block, when its audio format is known), its messages to the fusion."""
        array = _array(self.source)
        n = 0
        while True:
            block = self._take(self._q_audio, "audio")
            if self._itd is None:
                self._itd = self._start_itd()
            self._wait_for_vision(block.stamp_s)
            t0 = time.perf_counter()
            samples = np.asarray(block.samples, dtype=np.float64)
            if samples.ndim != 2 or samples.shape[1] <= max(array.channels):
                self.stats.bad_audio_blocks += 1
                continue
            if not np.all(np.isfinite(samples)):
                self.stats.bad_audio_blocks += 1
                samples = np.nan_to_num(samples, nan=0.0, posinf=0.0, neginf=0.0)
            messages, gap = self._itd.push(block.stamp_s, samples)
            self.stats.audio_gaps += gap
            for message in messages:
                self._offer(self._q_fusion, message)
                self.stats.itds += isinstance(message, ItdMessage)
            n += 1
            self.stats.audio_blocks = n
            self._timed("itd", t0, n)

    def _wait_for_vision(self, stamp: float) -> None:
        """A replay as fast as possible: hold the audio at ``stamp`` until vision has taken the frames up to
        ``stamp - max_audio_lead_s`` (or has none left), so that the ITDs wait in this thread, not in a buffer
        that would have to drop them. Real time: never wait."""
        if not self._backpressure:
            return
        lead = self.config.max_audio_lead_s
        if self._first_audio_stamp is None:
            self._first_audio_stamp = stamp
        first = self._first_audio_stamp
        while not self._stop.is_set() and not self._done["vision"].is_set():
            seen = self._vision_clock if self._vision_clock is not None else first
            if stamp - seen <= lead:
                return
            time.sleep(0.005)

    def _fusion_loop(self) -> None:
        sync = self._sync = self.mode.time_frame()
        hearing = self._hearing = self.mode.hearing(_array(self.source))
        # faces tell where the sound should come from: the rig file's microphones are checked against it
        self._mic_check = MicCheck(hearing.array) if self.config.inference == "face" else None
        tracker = NearestTracker()
        while True:
            if self._stop.is_set():
                if not self._errors:  # stopped by the user: what the workers have done still goes out
                    for name in (self._seen, "itd"):
                        self._done[name].wait(self.config.join_timeout_s / 2)
                    self._finish(sync, hearing, tracker)
                raise _Stop
            message = self._q_fusion.get(timeout=0.05)
            if message is None:
                if self._done[self._seen].is_set() and self._done["itd"].is_set() and len(self._q_fusion) == 0:
                    self._finish(sync, hearing, tracker)
                    return
                continue
            for vision, itds in self._handle(message, sync):
                self._fuse(hearing, tracker, vision, itds)

    def _handle(self, message: FusionMessage, sync: TimeFrame) -> list:
        """One message of the fusion queue into the synchroniser; returns the vision frames it completes. A frame
        or an ITD stamped before what the synchroniser has already taken (a clock that stepped back, a late or
        repeated message) is counted in ``stats.out_of_order`` and dropped: it never ends a run."""
        try:
            if isinstance(message, Vision):
                return sync.push_primary(message.stamp_s, message)
            if isinstance(message, ItdMessage):
                return sync.push_secondary(message.stamp_s, (message.stamp_s, message.itd_s))
        except ValueError as exc:
            self.stats.out_of_order += 1
            log.debug("dropped: %s", exc)
            return []
        if isinstance(message, EnvelopeMessage):
            if self.mode.envelope is not None:
                self.mode.envelope.push(message.stamp_s + message.times_s, message.powers)
            return []
        if isinstance(message, FrameItdsMessage):
            t0, single, bands, bins = message.stamp_s, message.frames, message.bands, message.bins
            if bins is not None:
                bins = FrameBins(t0 + bins.times_s, bins.bins, bins.freqs_hz)
            self._frame_itds.push(t0 + single.times_s, single.itds_s, t0 + bands.times_s, bands.itds_s, bins)
            return []
        # the audio clock moved on without ITDs (silence): frames before it are complete
        return sync.advance(message.stamp_s)

    def _finish(self, sync: TimeFrame, hearing: Any, tracker: NearestTracker) -> None:
        """The source is over or the user stopped: the messages still queued, then the frames still waiting for
        ITDs (with the ITDs there are), then the results still waiting for their vote."""
        while (message := self._q_fusion.get(timeout=0)) is not None:
            for vision, itds in self._handle(message, sync):
                self._fuse(hearing, tracker, vision, itds)
        for vision, itds in sync.flush():
            self._fuse(hearing, tracker, vision, itds)
        for voted in self._vote.flush():
            self._emit_voted(*voted)
        self._say_mics()
        self.stats.self_calibration = hearing.state() if isinstance(hearing, SelfCalibrating) else None
        for line in _far_from_the_rig(self.stats.self_calibration or []):
            self.stats.microphones.append(line)
            log.warning("%s", line)

    def _say_mics(self) -> None:
        """Say once (a warning, and in the stats) each thing the sound shows wrong with the rig's microphones."""
        if self._mic_check is None:
            return
        for finding in self._mic_check.findings():
            if (finding.pair, finding.kind) not in self._mic_said:
                self._mic_said.add((finding.pair, finding.kind))
                self.stats.microphones.append(finding.message())
                log.warning("%s", finding.message())

    def _fuse(self, hearing: Any, tracker: NearestTracker, vision: Vision, itds: list[tuple[float, float]]) -> None:
        t0 = time.perf_counter()
        stamp, frame = vision.stamp_s, vision.frame
        times = np.array([t for t, _ in itds], dtype=np.float64)
        a = np.array([v for _, v in itds], dtype=np.float64).reshape(times.size, hearing.array.n_pairs)  # (K, P)
        output = self.mode.step(hearing, vision, a, times, lambda: self._frame_itds.near(stamp))
        if self._mic_check is not None:
            self._mic_check.push(vision.xyz, a)
            if self._fused % 150 == 149:
                self._say_mics()
        ids = tracker.update(self.mode.people_xyz(vision, output), vision.stamp_s)
        rescued = getattr(output, "rescued", None)
        if self._continuity is not None and rescued is not None:
            speaking, probability = self._continuity.update(stamp, ids, output.speaking, output.probability, rescued)
            output = replace(output, speaking=speaking, probability=probability)
        result = Result(stamp, frame.index, frame.left, vision.boxes, vision.xyz, a, output, float("nan"), ids,
                        frame.depth_m, self.mode.people_lips(vision, output),
                        self.mode.voices(hearing.array, vision, a, tracker.new_id))
        for voted in self._vote.push(result, ids, output.speaking, output.probability):
            self._emit_voted(*voted)  # the result whose vote this one completed (itself without a vote)
        self._fused += 1
        self._timed("fusion", t0, self._fused)

    def _emit_voted(self, result: Result, speaking: np.ndarray, probability: np.ndarray) -> None:
        self._emit(replace(result, output=replace(result.output, speaking=speaking, probability=probability)))

    def _emit(self, result: Result) -> None:
        # a replay as fast as possible runs ahead of its stamps: latency is only defined in real time
        latency = self.clock() - result.stamp_s if not self._backpressure else float("nan")
        result = replace(result, latency_s=latency)
        if latency == latency:
            self.stats.latencies_s.append(latency)
        if len(self.stats.latencies_s) > 100_000:
            del self.stats.latencies_s[:50_000]
        if self.on_result is not None:
            self.on_result(result)
        self.stats.results += 1
        if self._q_voices is not None:
            self._offer(self._q_voices, _people(result))

    def _voices_in_loop(self) -> None:
        """The audio and the results' people, in the order they came, to the voices' process
        (:class:`app.voices_process.VoicesProcess`), whose separator holds the audio until the people of
        ``voice_delay_s`` earlier are known: nothing here holds up the audio or the fusion (in a replay as fast as
        possible, the audio runs ahead of the results by up to ``max_audio_lead_s``; in real time a frame waits at
        most a second more for them). A stop waits for the fusion's last results, then ends every stream. A
        robot's process starts at its first audio block, when its audio format is known."""
        assert self._q_voices is not None
        channels = list(_array(self.source).channels)
        early: list[PeopleMessage] = []  # people before the first audio block
        while True:
            item = self._q_voices.get(timeout=0.05)
            if item is None:
                upstream_done = self._done["audio"].is_set() and self._done["fusion"].is_set()
                if (upstream_done or self._stop.is_set()) and len(self._q_voices) == 0:
                    if self._stop.is_set() and not upstream_done:
                        self._done["fusion"].wait(self.config.join_timeout_s / 2)
                        if len(self._q_voices):
                            continue
                    if self._voices is not None:
                        self._voices.end()
                    return
                continue
            if isinstance(item, PeopleMessage):
                if self._voices is None:
                    early.append(item)
                    continue
                self._voices.push_people(item.stamp_s, item.ids, item.positions_m, item.speaking)
                continue
            samples = np.asarray(item.samples)
            if samples.ndim != 2 or samples.shape[1] <= max(channels):
                continue  # counted by the ITD worker
            if self._voices is None:
                self._voices = self._start_voices()
                for people in early:
                    self._voices.push_people(people.stamp_s, people.ids, people.positions_m, people.speaking)
            self._voices.push_audio(item.stamp_s, samples[:, channels])

    def _voices_loop(self) -> None:
        """Each person's voice as the voices' process makes it, to ``on_voice``, until it has flushed every
        stream."""
        while self._voices is None:  # not started yet, or never: no audio came
            if self._done["voices-in"].wait(0.05) and self._voices is None:
                return
        while (chunks := self._voices.receive()) is not None:
            for chunk in chunks:
                self._emit_voice(chunk)
        self._voices_flushed = True

    def _emit_voice(self, chunk: VoiceChunk) -> None:
        if not self._backpressure:
            self.stats.voice_latencies_s.append(self.clock() - chunk.stamp_s)
            if len(self.stats.voice_latencies_s) > 100_000:
                del self.stats.voice_latencies_s[:50_000]
        if self.on_voice is not None:
            self.on_voice(chunk)
        self.stats.voice_chunks += 1


def _people(result: Result) -> PeopleMessage:
    """The people of ``result`` and its voices out of view, for the voices' process."""
    ids, positions, speaking = list(result.person_ids), list(result.positions), list(result.speaking)
    for voice in result.voices or ():
        ids.append(voice.id)
        elevation = 0.0 if voice.elevation_rad is None else voice.elevation_rad
        positions.append(UNSEEN_VOICE_M * direction_vector(np.array(voice.azimuth_rad), np.array(elevation)))
        speaking.append(True)
    return PeopleMessage(result.stamp_s, np.asarray(ids, dtype=np.int64),
                         np.asarray(positions, dtype=np.float64).reshape(-1, 3), np.asarray(speaking, dtype=bool))


def _audio_format_known(source: Any) -> bool:
    """Whether the source knows its sample rate before its first audio block (a robot on the bus does not)."""
    try:
        source.samplerate_hz
    except RuntimeError:
        return False
    return True


def _far_from_the_rig(state: list[dict[str, Any]], turn_deg: float = 15.0,
                      scale: tuple[float, float] = (0.75, 1.25)) -> list[str]:
    """What a self-calibration learned that the rig file should say instead: an array turned more than ``turn_deg``
    from its placement, a pair whose c1 (the ITDs' scale) is outside ``scale``."""
    out = []
    yaw = next((s.get("array_yaw_deg") for s in state if s.get("array_yaw_deg") is not None), None)
    if yaw is not None and abs(yaw) > turn_deg:
        out.append(f"the microphone array hears as if turned {yaw:+.0f} degrees about the vertical from where the rig "
                   f"file places it: its array: rotation should probably turn it by {yaw:+.0f} degrees")
    for k, s in enumerate(state):
        c1 = s.get("c1")
        if s.get("inliers") and c1 is not None and not scale[0] <= c1 <= scale[1]:
            out.append(f"pair {k}: the ITDs are {c1:.2f} times the rig file's geometry's: the microphones are about "
                       f"{c1:.2f} times as far apart as it says")
    return out


def _good_frame(frame: Any, rig: StereoRig) -> bool:
    """A usable frame: two uint8 images of the rig's size, an RGB-D camera's uint8 colour image and a float depth
    image of that size, or one camera's uint8 image (no right image, no depth)."""
    size = tuple(rig.image_size)
    depth = getattr(frame, "depth_m", None)
    second = depth if depth is not None else getattr(frame, "right", None)
    for img in (getattr(frame, "left", None), second) if second is not None else (getattr(frame, "left", None),):
        if not isinstance(img, np.ndarray) or img.ndim not in (2, 3) or img.shape[1::-1] != size:
            return False
        if img.dtype != (np.float32 if img is depth else np.uint8):
            return False
    return True
