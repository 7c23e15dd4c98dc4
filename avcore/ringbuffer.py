"""Multichannel audio ring buffer and microphone channel selection.

The audio callback appends blocks of any size; the ITD worker (DESIGN.md, "Data flow") reads the window that ends at
a given sample index, or the latest ``W`` seconds. Every sample has an absolute index (0 for the first sample ever
written), so a window's timestamp is ``stream_start_s + index / samplerate_hz``.

The buffer itself takes no lock: DESIGN.md makes the ITD worker its owner, and the application hands it blocks
through a bounded queue filled by the audio callback. Wrap it in a lock if two threads must touch it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
import numpy.typing as npt

__all__ = ["ChannelSelection", "RingBuffer", "select_channels"]


class RingBuffer:
    """Fixed-capacity ring buffer of multichannel samples with absolute sample indices.

    Parameters
    ----------
    n_channels : int
        Number of channels of every block.
    capacity : int
        Number of samples (frames) kept; older samples are overwritten.
    dtype : numpy dtype
        Storage type (float64 by default). Appended blocks are cast into it without a temporary copy.

    The storage is allocated once; ``append`` copies a block into it with at most two slice assignments and
    allocates nothing. ``read_*`` return a new ``(n, n_channels)`` array unless ``out`` is given.
    """

    def __init__(self, n_channels: int, capacity: int, dtype: npt.DTypeLike = np.float64) -> None:
        if not isinstance(n_channels, (int, np.integer)) or isinstance(n_channels, bool) or n_channels < 1:
            raise ValueError(f"n_channels must be a positive integer, got {n_channels!r}")
        if not isinstance(capacity, (int, np.integer)) or isinstance(capacity, bool) or capacity < 1:
            raise ValueError(f"capacity must be a positive number of samples, got {capacity!r}")
        self._data = np.zeros((int(capacity), int(n_channels)), dtype=dtype)
        self._written = 0  # absolute index of the next sample to be written

    @classmethod
    def for_duration(cls, n_channels: int, duration_s: float, samplerate_hz: float,
                     dtype: npt.DTypeLike = np.float64) -> RingBuffer:
        """A buffer holding at least ``duration_s`` seconds at ``samplerate_hz``."""
        if not (np.isfinite(duration_s) and duration_s > 0):
            raise ValueError(f"duration_s must be a positive number of seconds, got {duration_s!r}")
        if not (np.isfinite(samplerate_hz) and samplerate_hz > 0):
            raise ValueError(f"samplerate_hz must be a positive number of hertz, got {samplerate_hz!r}")
        return cls(n_channels, int(np.ceil(duration_s * samplerate_hz)), dtype)

    @property
    def capacity(self) -> int:
        """Number of samples the buffer keeps."""
        return self._data.shape[0]

    @property
    def n_channels(self) -> int:
        return self._data.shape[1]

    @property
    def total_written(self) -> int:
        """Absolute index one past the newest sample (the number of samples ever appended)."""
        return self._written

    @property
    def oldest_index(self) -> int:
        """Absolute index of the oldest sample still held."""
        return max(0, self._written - self.capacity)

    def __len__(self) -> int:
        """Number of samples currently held."""
        return min(self._written, self.capacity)

    def append(self, block: np.ndarray) -> int:
        """Append a ``(n, n_channels)`` block (or ``(n,)`` for a one-channel buffer).

        Returns the absolute index of the block's first sample. A block longer than the capacity keeps only its
        tail, as if it had been appended in pieces.
        """
        arr = np.asarray(block)
        if arr.ndim == 1 and self.n_channels == 1:
            arr = arr[:, None]
        if arr.ndim != 2 or arr.shape[1] != self.n_channels:
            raise ValueError(
                f"block must have shape (n, {self.n_channels}) (samples, channels), got shape {arr.shape}")
        first = self._written
        n = arr.shape[0]
        if n == 0:
            return first
        cap = self.capacity
        if n > cap:
            arr = arr[n - cap:]
            skipped = n - cap
        else:
            skipped = 0
        start = (first + skipped) % cap
        m = arr.shape[0]
        head = min(m, cap - start)
        self._data[start:start + head] = arr[:head]
        if head < m:
            self._data[:m - head] = arr[head:]
        self._written = first + n
        return first

    def read_ending_at(self, end_index: int, n: int, out: np.ndarray | None = None) -> np.ndarray:
        """The ``n`` samples with absolute indices ``end_index - n .. end_index - 1``.

        Returns ``(n, n_channels)``. Raises ``ValueError`` when part of that window is not written yet or has
        already been overwritten.
        """
        if n < 0 or n > self.capacity:
            raise ValueError(f"n must be between 0 and the capacity {self.capacity}, got {n}")
        start = end_index - n
        if end_index > self._written:
            raise ValueError(
                f"end_index {end_index} is in the future: only {self._written} samples were written")
        if start < self.oldest_index:
            raise ValueError(
                f"the window [{start}, {end_index}) starts before the oldest sample held ({self.oldest_index}); "
                "make the buffer longer or read sooner")
        if out is None:
            out = np.empty((n, self.n_channels), dtype=self._data.dtype)
        elif out.shape != (n, self.n_channels):
            raise ValueError(f"out must have shape ({n}, {self.n_channels}), got {out.shape}")
        cap = self.capacity
        s = start % cap
        head = min(n, cap - s)
        out[:head] = self._data[s:s + head]
        if head < n:
            out[head:] = self._data[:n - head]
        return out

    def read_latest(self, n: int, out: np.ndarray | None = None) -> np.ndarray:
        """The newest ``n`` samples, ``(n, n_channels)``."""
        return self.read_ending_at(self._written, n, out)

    def read_latest_seconds(self, duration_s: float, samplerate_hz: float) -> np.ndarray:
        """The newest ``round(duration_s * samplerate_hz)`` samples."""
        return self.read_latest(round(duration_s * samplerate_hz))


Layout = Literal["frames", "planar", "interleaved"]


@dataclass(frozen=True)
class ChannelSelection:
    """Which two channels of a multichannel stream are the left and right microphones.

    Parameters
    ----------
    left, right : int
        Zero-based channel numbers (the robot's head had four microphones; the user names two).
    n_channels : int
        Channels in the stream.
    layout : {"frames", "planar", "interleaved"}
        How a block is laid out: ``"frames"`` is ``(n, n_channels)`` (sounddevice, soundfile), ``"planar"`` is
        ``(n_channels, n)`` (pyroomacoustics, librosa), ``"interleaved"`` is a flat ``(n * n_channels,)`` array of
        frames one after the other (raw PCM).
    """

    left: int
    right: int
    n_channels: int = 2
    layout: Layout = "frames"

    def __post_init__(self) -> None:
        if not isinstance(self.n_channels, (int, np.integer)) or self.n_channels < 2:
            raise ValueError(f"n_channels must be an integer >= 2, got {self.n_channels!r}")
        for name in ("left", "right"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or isinstance(value, bool) or not (
                    0 <= value < self.n_channels):
                raise ValueError(
                    f"{name} must be a channel number in [0, {self.n_channels - 1}], got {value!r}")
        if self.left == self.right:
            raise ValueError(f"left and right name the same channel {self.left}; name two different channels")
        if self.layout not in ("frames", "planar", "interleaved"):
            raise ValueError(f"layout must be 'frames', 'planar' or 'interleaved', got {self.layout!r}")

    def split(self, block: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Return the left and right channels of ``block`` as two ``(n,)`` views (no copy)."""
        arr = np.asarray(block)
        c = self.n_channels
        if self.layout == "frames":
            if arr.ndim != 2 or arr.shape[1] != c:
                raise ValueError(f"block must have shape (n, {c}) for layout 'frames', got shape {arr.shape}")
            return arr[:, self.left], arr[:, self.right]
        if self.layout == "planar":
            if arr.ndim != 2 or arr.shape[0] != c:
                raise ValueError(f"block must have shape ({c}, n) for layout 'planar', got shape {arr.shape}")
            return arr[self.left], arr[self.right]
        if arr.ndim != 1 or arr.shape[0] % c:
            raise ValueError(
                f"block must be a 1-D array whose length is a multiple of {c} for layout 'interleaved', "
                f"got shape {arr.shape}")
        return arr[self.left::c], arr[self.right::c]

    def stereo(self, block: np.ndarray) -> np.ndarray:
        """Return a new ``(n, 2)`` array of (left, right) samples, ready for :meth:`RingBuffer.append`."""
        left, right = self.split(block)
        return np.stack([left, right], axis=1)


def select_channels(block: np.ndarray, left: int, right: int, layout: Layout = "frames") -> np.ndarray:
    """Shortcut: ``(n, 2)`` left/right samples of ``block`` (see :class:`ChannelSelection`).

    The number of channels is read from the block's shape (for ``"interleaved"`` it must be given through
    :class:`ChannelSelection` instead).
    """
    arr = np.asarray(block)
    if layout == "interleaved":
        raise ValueError("an interleaved block does not say how many channels it has; use "
                         "ChannelSelection(left, right, n_channels, layout='interleaved')")
    if arr.ndim != 2:
        raise ValueError(f"block must be a 2-D array, got shape {arr.shape}")
    n_channels = arr.shape[1] if layout == "frames" else arr.shape[0]
    return ChannelSelection(left, right, n_channels, layout).stereo(arr)
