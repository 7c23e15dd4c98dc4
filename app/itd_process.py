"""The ITD worker's arithmetic (paper section 6's auditory stream) and the process it runs in.

:class:`ItdWorker` turns the audio blocks, in order, into the fusion thread's messages: the sound's envelope for the
lips, the single frames' ITDs, bands and bins for the speaking test, each window's ITD vector, and the audio clock.
With ``dereverb`` the array's microphones first go through :class:`avcore.dereverb.SignalDereverberator`, and the
ITDs come half a 32-ms frame later on the same clock. A block that does not follow the last one (lost samples)
restarts the streams at its stamp.

:class:`ItdProcess` runs one in a child process (:mod:`app.child_process`: with several pairs the ITDs are many
small numpy steps a frame, which in a thread beside vision, the fusion and Rerun held everything up), as a call per
block: the pipeline's ITD thread sends ``("block", stamp, samples)`` and waits for ``("itds", messages, gap)``,
so the messages keep their order and the thread its pace; ``("end",)`` ends the run.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from app.child_process import Inbox, Outbox, Stage
from avcore.dereverb import SignalDereverberator
from avcore.geometry import MicArray
from avcore.itd import FrameBins, ItdTrack, PairsItdStream
from avcore.lips import frame_powers

__all__ = ["ClockMessage", "EnvelopeMessage", "FrameItdsMessage", "ItdMessage", "ItdProcess", "ItdWorker",
           "serve_itds"]

ITD_MAX_HZ = 5000.0  # the widest band an ITD method takes (avcore.itd): the dereverberation's bins stop there


@dataclass(frozen=True)
class ItdMessage:
    """One window's ITD, stamped at the window's centre: a float, or with several pairs a (P,) vector (NaN where a
    pair's energy gate rejected the window)."""

    stamp_s: float
    itd_s: float | np.ndarray


@dataclass(frozen=True, eq=False)
class FrameItdsMessage:
    """A block of single frames' ITDs and their bands' peaks, and with several pairs the frames' bins; their times
    are relative to ``stamp_s``."""

    stamp_s: float
    frames: ItdTrack
    bands: ItdTrack
    bins: FrameBins | None = None


@dataclass(frozen=True, eq=False)
class EnvelopeMessage:
    """A block's sound power in frames of 10 ms (:func:`avcore.lips.frame_powers`), their times relative to
    ``stamp_s``: what the lips are compared with."""

    stamp_s: float
    times_s: np.ndarray
    powers: np.ndarray


@dataclass(frozen=True)
class ClockMessage:
    """The audio clock: every window centred before ``stamp_s`` has been extracted."""

    stamp_s: float


AudioMessage = ItdMessage | FrameItdsMessage | EnvelopeMessage | ClockMessage


class ItdWorker:
    """From ``(n, C)`` blocks of every channel (``array.channels`` name the microphones'), in order, to the fusion's
    messages. ``frame_itds``: the single frames' ITDs, bands and bins; ``envelope``: the blocks' sound power."""

    def __init__(self, array: MicArray, samplerate_hz: float, *, itd_method: str, window_s: float, hop_s: float,
                 energy_threshold: float, frame_itds: bool, envelope: bool, dereverb: bool) -> None:
        self.array, self.samplerate_hz = array, float(samplerate_hz)
        self.frame_itds, self.envelope = frame_itds, envelope
        self._window_s, self._hop_s = window_s, hop_s
        self._options = dict(method=itd_method, window_s=window_s, hop_s=hop_s, energy_threshold=energy_threshold)
        self._columns = sorted(set(array.channels))  # the microphones the ITDs take, dereverberated together
        self._dereverb = (SignalDereverberator(samplerate_hz, len(self._columns), max_hz=ITD_MAX_HZ)
                          if dereverb else None)
        self._stream: PairsItdStream | None = None
        self._start_s = self._expected_s = 0.0
        self._held = 0  # samples the dereverberation holds back from the ITD stream

    def push(self, stamp_s: float, samples: np.ndarray) -> tuple[list[AudioMessage], bool]:
        """One block's messages in the order the fusion takes them, and whether samples were lost before it."""
        gap = False
        if self._stream is None or abs(stamp_s - self._expected_s) > self._hop_s:
            gap = self._stream is not None  # samples were lost (an overflow, a dropped block): restart here
            # the bins' look (avcore.speaking.bin_shares) asks every pair at once, one pair as well
            self._stream = PairsItdStream(self.array, self.samplerate_hz, frame_itds=self.frame_itds,
                                          frame_bins=self.frame_itds, **self._options)
            if self._dereverb is not None:
                self._dereverb.gap()
            self._start_s, self._held = stamp_s, 0
        self._expected_s = stamp_s + samples.shape[0] / self.samplerate_hz
        out: list[AudioMessage] = []
        if self.envelope:  # before the ITDs that complete a frame, so that its lips find the sound there
            out.append(EnvelopeMessage(stamp_s, *frame_powers(samples[:, list(self.array.channels)],
                                                              self.samplerate_hz)))
        if self._dereverb is not None:  # the same samples, each at its place, half a frame later
            clean = self._dereverb.push(samples[:, self._columns])
            self._held += samples.shape[0] - clean.shape[0]
            samples = np.zeros((clean.shape[0], samples.shape[1]))
            samples[:, self._columns] = clean
        times, itds = self._stream.push(samples)
        if self.frame_itds:  # before the windows' ITDs, which complete vision frames: frames run ahead of windows
            frames, bands = self._stream.pop_frame_itds(), self._stream.pop_band_itds()
            bins = self._stream.pop_frame_bins()
            if len(frames[0]) or len(bins):
                out.append(FrameItdsMessage(self._start_s, _vectors(*frames), _vectors(*bands), bins))
        out.extend(ItdMessage(self._start_s + float(t), itd) for t, itd in zip(times, itds))
        # the audio clock: windows centred before this time are all extracted
        out.append(ClockMessage(self._expected_s - self._held / self.samplerate_hz - self._window_s / 2))
        return out, gap


def _vectors(times: np.ndarray, itds: np.ndarray) -> ItdTrack:
    """Several pairs' ITD vectors (K, P) as a track (no confidence or energy: they are per pair)."""
    nan = np.full(times.size, np.nan)
    return ItdTrack(times, itds, nan, nan)


class ItdProcess(Stage):
    """An :class:`ItdWorker` (the options are its arguments) in a child process, called once a block; released once
    every block was answered."""

    loop, name = "app.itd_process:serve_itds", "ITD"

    def push(self, stamp_s: float, samples: np.ndarray) -> tuple[list[AudioMessage], bool]:
        self.child.send(("block", float(stamp_s), samples))
        _, messages, gap = self.child.receive()
        return messages, gap


def serve_itds(inbox: Inbox, outbox: Outbox, **options: Any) -> None:
    """The ITD process's loop (:func:`app.child_process.serve`): an :class:`ItdWorker` called once a block."""
    worker = ItdWorker(**options)
    while (message := inbox.recv())[0] == "block":
        outbox.send(("itds", *worker.push(message[1], message[2])))
