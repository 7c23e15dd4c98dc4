"""Each person's own ITD: where a person's voice is heard, learned while they talk alone (beyond the paper).

Eq. (itd_up) maps a face to the ITD its voice would have in free field, and Algorithm 2 anchors each person's
Gaussian there. A room moves the peaks: its reflections pull a talker's ITDs towards the front (docs/method.md), so
a lone talker's ITDs fall nearer a neighbour between them and the front, and the neighbour is called speaking.
Section 5.3's calibration removes the pull for one rig in one room; a robot nobody calibrated still has it.

Where the windows' test (not a later look) calls exactly one person speaking, the window ITDs within ``window_s``
of that person's mean (their own voice, if they are alone) say where the person is heard: their median minus the
mapped ITD is one observation of the person's offset, which an exponential average (weight ``rate`` a result)
follows, clipped to +-``max_offset_s``. The offset belongs to the mapped ITD on each pair (quantised by
``quantum_s``): a person who stays put keeps it, one who moves meets their new place's. Each pair of an array
learns its own. The persons' means (EM's anchors and every look of the speaking test) are then the mapped ITDs plus
the offsets: a talker is heard where their voice is, and the neighbour no longer sits between that voice and its
anchor.

Not a line (section 5.3, :mod:`avcore.selfcal`): no scale range to choose (a pair on a head pulls the other way,
c1 > 1) and nothing learned for a person who never talks alone, who keeps the free-field mapping.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["OwnItds"]


@dataclass
class OwnItds:
    """The learned offsets (module docstring): :meth:`offsets` for the mapped ITDs of a result's faces, then
    :meth:`update` with what that result heard."""

    rate: float = 0.05
    window_s: float = 60e-6
    max_offset_s: float = 40e-6
    min_itds: int = 5
    quantum_s: float = 4e-6
    _offsets: dict = field(default_factory=dict, init=False, repr=False)  # (pair, quantised mapped ITD) -> s

    def __post_init__(self) -> None:
        if not 0 < self.rate <= 1:
            raise ValueError(f"rate must be in (0, 1], got {self.rate!r}")
        for name in ("window_s", "max_offset_s", "quantum_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 seconds, got {getattr(self, name)!r}")
        if self.min_itds < 1:
            raise ValueError(f"min_itds must be >= 1, got {self.min_itds!r}")

    def __len__(self) -> int:
        return len(self._offsets)

    def _key(self, pair: int, mapped_s: float) -> tuple[int, int]:
        return pair, int(round(mapped_s / self.quantum_s))

    def offsets(self, mapped_s: np.ndarray) -> np.ndarray:
        """(N, P) seconds to add to the mapped ITDs ``mapped_s`` (N, P) of a result's faces (0 where nothing is
        learned)."""
        mapped = np.asarray(mapped_s, dtype=np.float64)
        out = np.zeros(mapped.shape)
        for (j, p), m in np.ndenumerate(mapped):
            if np.isfinite(m):
                out[j, p] = self._offsets.get(self._key(p, m), 0.0)
        return out

    def update(self, mapped_s: np.ndarray, itds_s: np.ndarray, by_windows: np.ndarray) -> None:
        """One result: the faces' mapped ITDs (N, P), the window ITDs (K, P) (NaN where a pair has none) and the
        windows' own calls (N,) bool (the speaking states less the later looks' rescues)."""
        mapped = np.asarray(mapped_s, dtype=np.float64)
        called = np.flatnonzero(np.asarray(by_windows, dtype=bool))
        if called.size != 1:
            return
        j = int(called[0])
        x = np.asarray(itds_s, dtype=np.float64).reshape(-1, mapped.shape[1])
        for p in range(mapped.shape[1]):
            if not np.isfinite(mapped[j, p]):
                continue
            key = self._key(p, mapped[j, p])
            old = self._offsets.get(key, 0.0)
            xp = x[:, p]
            near = xp[np.isfinite(xp) & (np.abs(xp - (mapped[j, p] + old)) <= self.window_s)]
            if near.size < self.min_itds:
                continue
            new = (1.0 - self.rate) * old + self.rate * (float(np.median(near)) - mapped[j, p])
            self._offsets[key] = float(np.clip(new, -self.max_offset_s, self.max_offset_s))
