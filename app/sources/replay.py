"""A replayable stream: recorded or simulated frames and audio, delivered on one clock in real time or as fast as
possible, from any start. :class:`app.sources.sim.SimSource` and :class:`app.sources.recording.Recording` derive
from :class:`ReplayStream`; :class:`app.sources.StreamAdapter` turns one into the pipeline's Source."""
from __future__ import annotations

import time
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from app.events import AudioBlock, StereoFrame
from avcore.geometry import MicPair
from avcore.stereo import StereoRig
from avcore.evaluation import FrameTruth

__all__ = ["ReplayStream", "StreamStats"]


@dataclass
class StreamStats:
    """What a stream delivered: frames, frames dropped because they were late (real-time only), audio blocks."""

    frames: int = 0
    frames_dropped: int = 0
    blocks: int = 0


class ReplayStream:
    """Frames and audio blocks on one clock, from anything that can give frame ``k`` and samples ``[a, b)``: the
    simulated room and a recording. Not itself a :class:`app.sources.contract.Source`: :class:`StreamAdapter`
    makes one of it for the pipeline.

    Subclasses provide ``stereo``, ``mics``, ``fps``, ``samplerate_hz``, ``n_channels``, ``frame_stamps_s`` (n,) and
    ``right_stamps_s`` (n,) seconds, ``audio_start_s``, ``n_samples``, ``_images(k)`` (called with increasing ``k``
    within one stream), ``_samples(a, b)`` -> (b - a, C) float32, and ``truth(k)``; an RGB-D source also
    ``_depth(k, colour)`` (its ``_images`` gives (colour, None)).
    """

    stereo: StereoRig
    mics: MicPair | None
    fps: float
    samplerate_hz: int
    n_channels: int
    frame_stamps_s: np.ndarray
    right_stamps_s: np.ndarray
    audio_start_s: float
    n_samples: int
    block_size: int = 512

    def __init__(self) -> None:
        self.stats = StreamStats()

    # -------------------------------------------------------------- to implement
    def _images(self, k: int) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - abstract
        raise NotImplementedError

    def _samples(self, a: int, b: int) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def _depth(self, k: int, colour: np.ndarray) -> np.ndarray | None:
        """Frame ``k``'s depth aligned to its colour image (an RGB-D source), or None (a stereo one)."""
        return None

    def truth(self, k: int) -> FrameTruth | None:
        """The ground truth of frame ``k``, or None when unknown."""
        return None

    def _reset(self) -> None:
        """Called at the start of every stream (a recording rewinds its videos)."""

    # -------------------------------------------------------------- derived
    @property
    def n_frames(self) -> int:
        return int(self.frame_stamps_s.shape[0])

    @property
    def start_s(self) -> float:
        """The earliest stamp of the source (first frame or first sample), on its own clock."""
        first = [self.audio_start_s] if self.n_samples else []
        if self.n_frames:
            first.append(float(min(self.frame_stamps_s[0], self.right_stamps_s[0])))
        return min(first) if first else 0.0

    @property
    def duration_s(self) -> float:
        """From the earliest stamp to the end of the last frame or sample, seconds."""
        ends = [self.audio_start_s + self.n_samples / self.samplerate_hz] if self.n_samples else []
        if self.n_frames:
            ends.append(float(self.frame_stamps_s[-1]) + 1.0 / self.fps)
        return (max(ends) - self.start_s) if ends else 0.0

    def frames(self, *, realtime: bool = False, start_s: float | None = None) -> Iterator[StereoFrame]:
        """Only the frames (for a grabber thread); see :meth:`stream`."""
        yield from self._run(realtime, start_s, want_frames=True, want_audio=False,  # type: ignore[misc]
                             block_size=None)

    def audio_blocks(self, *, realtime: bool = False, start_s: float | None = None,
                     block_size: int | None = None) -> Iterator[AudioBlock]:
        """Only the audio blocks (for an audio thread); see :meth:`stream`."""
        yield from self._run(realtime, start_s, want_frames=False, want_audio=True,  # type: ignore[misc]
                             block_size=block_size)

    def stream(self, *, realtime: bool = False, start_s: float | None = None,
               block_size: int | None = None) -> Iterator[StereoFrame | AudioBlock]:
        """Frames and audio blocks merged in delivery order.

        realtime : deliver each item at its time on ``time.monotonic()`` (frames at their stamp, blocks once their
            last sample is captured) and drop frames that are more than one frame period late; else as fast as
            possible.
        start_s : in real time, the instant on ``time.monotonic()`` at which the source's earliest stamp is
            delivered (default: now); threads that consume :meth:`frames` and :meth:`audio_blocks` separately pass
            the same. The stamps are always the source's own (0-based for the simulator).
        block_size : samples per audio block (default the source's ``block_size``).
        """
        return self._run(realtime, start_s, want_frames=True, want_audio=True, block_size=block_size)

    def _run(self, realtime: bool, start_s: float | None, *, want_frames: bool, want_audio: bool,
             block_size: int | None) -> Iterator[StereoFrame | AudioBlock]:
        bs = int(block_size or self.block_size)
        if bs < 1:
            raise ValueError(f"block_size must be a positive number of samples, got {block_size!r}")
        if want_frames:
            self._reset()  # rewinds the videos; an audio-only stream in another thread leaves them alone
            self.stats.frames = self.stats.frames_dropped = 0
        if want_audio:
            self.stats.blocks = 0
        # in real time each item is delivered when its stamp comes, counted on the monotonic clock from clock0
        clock0 = time.monotonic() if start_s is None else float(start_s)
        period = 1.0 / self.fps
        fs = self.samplerate_hz
        k = 0 if want_frames else self.n_frames
        a = 0 if want_audio else self.n_samples
        block = 0
        while k < self.n_frames or a < self.n_samples:
            frame_due = float(self.frame_stamps_s[k]) if k < self.n_frames else np.inf
            b = min(a + bs, self.n_samples)
            audio_due = self.audio_start_s + b / fs if a < self.n_samples else np.inf
            if audio_due <= frame_due:
                if realtime:
                    _sleep_until(clock0 + audio_due - self.start_s)
                samples = self._samples(a, b)
                self.stats.blocks += 1
                yield AudioBlock(block, a, self.audio_start_s + a / fs, samples, fs)
                block += 1
                a = b
                continue
            if realtime:
                late = time.monotonic() - (clock0 + frame_due - self.start_s)
                if late > period:
                    self.stats.frames_dropped += 1
                    k += 1
                    continue
                _sleep_until(clock0 + frame_due - self.start_s)
            left, right = self._images(k)
            self.stats.frames += 1
            yield StereoFrame(k, frame_due, left, right, float(self.right_stamps_s[k]), self._depth(k, left))
            k += 1


def _sleep_until(deadline: float) -> None:
    delay = deadline - time.monotonic()
    if delay > 0:
        time.sleep(delay)
