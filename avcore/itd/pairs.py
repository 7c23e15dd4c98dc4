"""ITDs on every pair of a microphone array, streamed: one :class:`PairStream` per pair, their windows joined into
vectors. A single microphone pair is an array of one pair (``MicArray.from_pair``).

Every pair's stream cuts the same windows (sample ``k * hop`` of the stream) and frames, so a window's ITDs on the
P pairs are one vector, the input of :func:`avcore.mixture.fit_pairs_em`. A pair whose energy gate rejected the
window leaves NaN in it. A frame's band peaks are not matched across pairs (a band may carry weight on one pair
and not on another), so each band row holds one pair's peak and NaN elsewhere. The cost is P streams: linear in
the number of pairs.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from avcore.geometry import MicArray

from ._extract import ItdTrack, PairStream, geometry_options

__all__ = ["FrameBins", "PairsItdStream", "join_pairs"]


@dataclass(frozen=True)
class FrameBins:
    """Frames' time-frequency bins on every pair of an array: ``times_s`` (m,) the frame centres, ``bins``
    (m, P, B) complex64 the weighted phase transforms (:meth:`PairStream.pop_frame_bins`), ``freqs_hz`` (B,)."""

    times_s: np.ndarray
    bins: np.ndarray
    freqs_hz: np.ndarray

    def __len__(self) -> int:
        return int(self.times_s.size)

    def within(self, stamp_s: float, span_s: float) -> FrameBins:
        """The frames centred within ``span_s`` of ``stamp_s``."""
        keep = np.abs(self.times_s - stamp_s) <= span_s
        return FrameBins(self.times_s[keep], self.bins[keep], self.freqs_hz)

    @staticmethod
    def concatenate(parts: list[FrameBins]) -> FrameBins:
        return FrameBins(np.concatenate([p.times_s for p in parts]), np.concatenate([p.bins for p in parts]),
                         parts[0].freqs_hz)


def join_pairs(tracks: list[ItdTrack]) -> tuple[np.ndarray, np.ndarray]:
    """The P pairs' tracks of the same windows as ``(times (K,), itds (K, P))``: one row per window centre that any
    pair has, NaN where a pair has none."""
    times = np.unique(np.concatenate([t.times_s for t in tracks])) if tracks else np.zeros(0)
    out = np.full((times.size, len(tracks)), np.nan)
    for p, t in enumerate(tracks):
        out[np.searchsorted(times, t.times_s), p] = t.itds_s
    return times, out


def _one_pair_rows(tracks: list[ItdTrack]) -> tuple[np.ndarray, np.ndarray]:
    """Each pair's values on rows of their own: ``(times (L,), itds (L, P))`` with one finite entry per row."""
    times = np.concatenate([t.times_s for t in tracks])  # an array has one pair at least
    out = np.full((times.size, len(tracks)), np.nan)
    row = 0
    for p, t in enumerate(tracks):
        out[row:row + len(t), p] = t.itds_s
        row += len(t)
    return times, out


class PairsItdStream:
    """:class:`PairStream` on every pair of ``array``: ``push(block)`` takes ``(n, C)`` samples of all channels
    (``array.channels`` name each microphone's) and returns the completed windows as ``(times (K,), itds (K, P))``;
    ``pop_frame_itds`` and ``pop_band_itds`` likewise for the single frames and their bands (with
    ``frame_itds=True``; the bands of the first pair only, unless ``all_bands``), ``pop_frame_bins`` the frames'
    bins on every pair (with ``frame_bins=True``). Options are :class:`PairStream`'s;
    each pair gets its own geometry (its distance for the robust methods' diffuse-field model, its ``max_itd_s``
    scaled by ``max_itd_scale``)."""

    def __init__(self, array: MicArray, samplerate: float, method: str = "correlogram", *,
                 max_itd_scale: float = 1.2, frame_itds: bool = False, frame_bins: bool = False,
                 all_bands: bool = False, **options: Any) -> None:
        self.all_bands = all_bands
        self.frame_bins = frame_bins
        self.columns = [(array.channels[i], array.channels[j]) for i, j in array.pairs]  # type: ignore[index]
        self._streams = []
        for p in range(array.n_pairs):
            pair = array.pair(p)
            extra = geometry_options(method, pair.distance_m, pair.speed_of_sound)
            self._streams.append(PairStream(samplerate, method=method, max_itd_s=max_itd_scale * pair.max_itd_s,
                                           frame_itds=frame_itds, frame_bins=frame_bins, **options, **extra))

    @property
    def n_pairs(self) -> int:
        return len(self._streams)

    def push(self, block: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """One block ``(n, C)`` of every channel; the windows it completed, as vectors."""
        samples = np.asarray(block, dtype=np.float64)
        need = max(max(c) for c in self.columns)
        if samples.ndim != 2 or samples.shape[1] <= need:
            raise ValueError(f"block must have shape (n, C) with C > {need} (the array's channels), got "
                             f"{samples.shape}")
        return join_pairs([s.push(samples[:, i], samples[:, j]) for s, (i, j) in zip(self._streams, self.columns)])

    def pop_frame_itds(self) -> tuple[np.ndarray, np.ndarray]:
        """The single frames analysed since the last call, one vector per frame centre."""
        return join_pairs([s.pop_frame_itds() for s in self._streams])

    @property
    def bin_freqs_hz(self) -> np.ndarray:
        """(B,) the bins' frequencies (every pair cuts the same frames with the same FFT)."""
        return self._streams[0].bin_freqs_hz

    def pop_frame_bins(self) -> FrameBins:
        """The frames analysed since the last call, every pair's bins at once (with ``frame_bins=True``;
        :meth:`PairStream.pop_frame_bins`). One frame's bins on every pair are one moment of sound, the input of
        :func:`avcore.speaking.bin_shares`."""
        popped = [s.pop_frame_bins() for s in self._streams]
        return FrameBins(popped[0][0], np.stack([b for _, b in popped], axis=1), self.bin_freqs_hz)

    def pop_band_itds(self) -> tuple[np.ndarray, np.ndarray]:
        """The frames' band peaks since the last call, one pair's peak per row: the first pair's only, unless
        ``all_bands``. A band's peak cannot be matched across pairs, so the other pairs' would count as evidence on
        one pair each, and the pairs with short baselines, which hardly tell the people apart, then add false
        alarms (docs/experiments.md, "Several microphone pairs")."""
        tracks = [s.pop_band_itds() for s in self._streams]
        if not self.all_bands:
            tracks = [t if p == 0 else ItdTrack.empty() for p, t in enumerate(tracks)]
        return _one_pair_rows(tracks)
