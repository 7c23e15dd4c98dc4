"""Generalised cross-correlation with the phase transform (Knapp and Carter, 1976)."""
from __future__ import annotations

import numpy as np

from ._base import ItdMethod

__all__ = ["GccPhat"]

_TINY = np.finfo(np.float64).tiny


class GccPhat(ItdMethod):
    """GCC-PHAT: the cross-spectrum whitened to unit magnitude, ``W(f) = 1 / |X_L(f) X_R(f)^*|``.

    Only the phase is kept, so every frequency votes equally for the delay; the peak height divided by its
    largest possible value (every bin in phase) measures how well the bins agree on the chosen lag, a confidence
    in ``[-1, 1]``.
    Frequencies outside ``[low_hz, high_hz]`` are left out (the same band as the correlogram by default).

    Parameters
    ----------
    low_hz, high_hz : float, hertz
        Band used (``high_hz`` is capped at Nyquist).
    """

    name = "gcc-phat"

    def __init__(self, samplerate_hz: float, window_len: int, max_itd_s: float, *,
                 low_hz: float = 80.0, high_hz: float = 5000.0) -> None:
        super().__init__(samplerate_hz, window_len, max_itd_s)
        if not (0 <= low_hz < high_hz):
            raise ValueError(f"need 0 <= low_hz < high_hz, got low_hz={low_hz!r}, high_hz={high_hz!r}")
        in_band = (self.freqs_hz >= low_hz) & (self.freqs_hz <= high_hz)
        if not np.any(in_band):
            raise ValueError(f"no frequency bin lies in [{low_hz}, {high_hz}] Hz at {self.samplerate_hz} Hz")
        self.use_bins(int(np.flatnonzero(in_band)[-1]) + 1)  # the bins above the band are left out altogether
        self.band = in_band[:self.n_used].astype(np.float64)
        self._band_fold = self.band * self._fold[:self.n_used]

    def weighted_cross_spectrum(self, spec_left, spec_right):
        cross = spec_left * spec_right.conj()
        mag = np.abs(cross)
        in_phase = mag > _TINY
        weighted = cross / np.where(in_phase, mag, np.inf) * self.band  # unit magnitude, 0 where silent
        norm = in_phase @ self._band_fold  # sum of |weighted| * fold: each used bin has unit magnitude
        return weighted, norm
