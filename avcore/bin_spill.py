"""Each talker's spill onto a neighbour's bins, learned where the talker is heard alone (beyond the paper).

The bins' look (:func:`avcore.speaking.bin_shares`) gives each person the share of the time-frequency bins that
agree best with them on every pair. A talker's reverberation and the array's limited aperture give some of the
talker's bins to a silent neighbour; how many depends on the room and on where both sit, not on the angle alone
(measured: docs/experiments.md, wave 4, fifteenth session). A fixed claim threshold cannot tell that spill from a
talker a louder one masks: raising it costs the masked talkers' recall as much as it saves precision.

So each ordered pair of persons (talker i, neighbour j) learns the ratio ``s_j / s_i`` of their bins' shares from
the results in which the windows' test hears i alone: what i's voice alone gives j in this room. The median of the
last ``memory`` ratios is robust to the results in which j in fact talks too, masked by i (some of the learning
results). :meth:`ratios` gives those medians for a result's persons, and the speaking test claims j by the bins
only where j's share exceeds what the heard talkers' spill explains
(:class:`avcore.speaking.SpeakingTest` ``bin_spill_factor``).

Persons are matched by their ITD vectors (within ``tolerance_s`` on every pair): a person who stays put keeps
what was learned, one who moves starts again. Nothing is learned until ``min_samples`` ratios are in: until then
the claim is the fixed threshold's.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

__all__ = ["BinSpill"]


@dataclass
class BinSpill:
    """The learned spill ratios (module docstring): :meth:`ratios` for a result's persons, then :meth:`update`
    with what that result heard."""

    min_samples: int = 20
    memory: int = 300
    tolerance_s: float = 10e-6
    max_pairs: int = 100
    _talkers: np.ndarray | None = field(default=None, init=False, repr=False)  # (K, P) each key's talker
    _neighbours: np.ndarray | None = field(default=None, init=False, repr=False)  # (K, P) its neighbour
    _ratios: list = field(default_factory=list, init=False, repr=False)  # K deques of s_j / s_i
    _medians: list = field(default_factory=list, init=False, repr=False)  # K medians (NaN under min_samples)

    def __post_init__(self) -> None:
        if self.min_samples < 1 or self.memory < self.min_samples:
            raise ValueError(f"need 1 <= min_samples <= memory, got {self.min_samples!r} and {self.memory!r}")
        if not self.tolerance_s > 0:
            raise ValueError(f"tolerance_s must be > 0 seconds, got {self.tolerance_s!r}")

    def __len__(self) -> int:
        return len(self._ratios)

    def _find(self, mi: np.ndarray, mj: np.ndarray) -> int | None:
        if self._talkers is None or self._talkers.shape[1] != mi.size:
            return None
        near = ((np.abs(self._talkers - mi).max(axis=1) <= self.tolerance_s)
                & (np.abs(self._neighbours - mj).max(axis=1) <= self.tolerance_s))
        return int(np.argmax(near)) if near.any() else None

    def _add(self, mi: np.ndarray, mj: np.ndarray) -> int:
        if self._talkers is None or self._talkers.shape[1] != mi.size:  # a first key, or another array
            self._talkers, self._neighbours, self._ratios, self._medians = mi[None].copy(), mj[None].copy(), [], []
        else:
            keep = slice(1, None) if len(self._ratios) >= self.max_pairs else slice(None)  # forget the oldest
            self._talkers = np.vstack([self._talkers[keep], mi[None]])
            self._neighbours = np.vstack([self._neighbours[keep], mj[None]])
            self._ratios, self._medians = self._ratios[keep], self._medians[keep]
        self._ratios.append(deque(maxlen=self.memory))
        self._medians.append(np.nan)
        return len(self._ratios) - 1

    def ratios(self, means_s: np.ndarray) -> np.ndarray:
        """(N, N): entry [i, j] the median share of neighbour j per unit share of talker i where i talked alone;
        NaN where fewer than ``min_samples`` were learned, and on the diagonal. means_s : (N, P) the persons' ITDs."""
        means = np.asarray(means_s, dtype=np.float64)
        n = means.shape[0]
        out = np.full((n, n), np.nan)
        if not self._ratios:
            return out
        for i in range(n):
            for j in range(n):
                if i != j:
                    k = self._find(means[i], means[j])
                    if k is not None:
                        out[i, j] = self._medians[k]
        return out

    def update(self, means_s: np.ndarray, share: np.ndarray | None, alone: np.ndarray) -> None:
        """One result: the persons' ITDs (N, P), their bins' shares (N,) (None: the bins were not looked at) and
        the windows' own calls (N,) bool; learns only when those call exactly one person, whose share is > 0."""
        called = np.flatnonzero(np.asarray(alone, dtype=bool))
        if share is None or called.size != 1:
            return
        s = np.asarray(share, dtype=np.float64)
        i = int(called[0])
        if not s[i] > 0:
            return
        means = np.asarray(means_s, dtype=np.float64)
        for j in range(len(s)):
            if j == i or not np.isfinite(s[j]):
                continue
            k = self._find(means[i], means[j])
            if k is None:
                k = self._add(means[i], means[j])
            self._ratios[k].append(float(s[j] / s[i]))
            if len(self._ratios[k]) >= self.min_samples:
                self._medians[k] = float(np.median(self._ratios[k]))
