"""Multichannel audio ring buffer.

The audio callback appends blocks of any size; the ITD worker (docs/architecture.md, "Data flow") reads the window that
ends at a given sample index, or the latest ``W`` seconds. Every sample has an absolute index (0 for the first sample
ever written), so a window's timestamp is ``stream_start_s + index / samplerate_hz``.

The buffer itself takes no lock: docs/architecture.md makes the ITD worker its owner, and the application hands it
blocks through a bounded queue filled by the audio callback. Wrap it in a lock if two threads must touch it.
"""
from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["RingBuffer"]


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
