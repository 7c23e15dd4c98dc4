"""What every ITD method shares: the cross-spectrum of one window, the lag search and the sub-sample peak.

A method is a weighting of the cross-spectrum ``C(f) = X_L(f) conj(X_R(f))`` of a window: the generalised
cross-correlation ``r(tau) = IDFT(W(f) C(f))(tau)`` then peaks at ``tau = t_left - t_right`` (DESIGN.md sign: if the
left signal is the right one delayed by ``D`` samples, ``C = |S|^2 exp(-2 pi i f D)`` and ``r`` peaks at ``+D``).
Subclasses give ``W`` (and a normaliser that makes the peak height a confidence in ``[-1, 1]``).
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
import scipy.fft

__all__ = ["ItdMethod"]

_FINE_STEPS = 16  # evaluations per sample of the band-limited correlation around the integer peak


class ItdMethod(ABC):
    """One ITD estimator for windows of a fixed length (pyroomacoustics-doa style: one subclass per algorithm).

    Parameters
    ----------
    samplerate_hz : float
        Sampling rate of the windows, hertz.
    window_len : int
        Samples per window.
    max_itd_s : float
        Lags are searched in ``[-max_itd_s, +max_itd_s]``, seconds.
    """

    name: ClassVar[str] = ""
    frame_based: ClassVar[bool] = False  # True: stateful, frame by frame, run through ItdStream

    def __init__(self, samplerate_hz: float, window_len: int, max_itd_s: float) -> None:
        self.samplerate_hz = float(samplerate_hz)
        self.window_len = int(window_len)
        self.max_itd_s = float(max_itd_s)
        self.max_lag = int(np.ceil(self.max_itd_s * self.samplerate_hz))
        self.nfft = scipy.fft.next_fast_len(self._min_nfft(), real=True)
        n_bins = self.nfft // 2 + 1
        self.freqs_hz = np.arange(n_bins) * self.samplerate_hz / self.nfft
        # rfft bins stand for two conjugate bins except DC and Nyquist: weights that make sums over rfft bins equal
        # sums over the whole spectrum, divided by nfft (Parseval).
        fold = np.full(n_bins, 2.0)
        fold[0] = 1.0
        if self.nfft % 2 == 0:
            fold[-1] = 1.0
        self._fold = fold / self.nfft
        # Sub-sample refinement tables: the band-limited correlation r(p + d) for d in [-0.5, 0.5] (the integer
        # peak is within half a sample of the true one) is the real part of one matrix product.
        offsets = np.linspace(-0.5, 0.5, _FINE_STEPS + 1)
        self._fine_offsets = offsets
        angle = 2 * np.pi * np.outer(np.arange(n_bins), offsets) / self.nfft  # (K, F)
        self._fine_phasors = np.exp(1j * angle) * self._fold[:, None]
        lags = np.arange(-self.max_lag, self.max_lag + 1)
        self._lags = lags
        self._lag_phasors = np.exp(2j * np.pi * np.outer(lags, np.arange(n_bins)) / self.nfft)  # (2L+1, K)

    def _min_nfft(self) -> int:
        """Smallest FFT length: enough zero padding that lags up to max_lag do not wrap around."""
        return self.window_len + self.max_lag + 1

    def spectra(self, frames: np.ndarray) -> np.ndarray:
        """``rfft`` of ``(n, window_len)`` frames, zero-padded to ``nfft``: ``(n, nfft // 2 + 1)`` complex."""
        return scipy.fft.rfft(frames, n=self.nfft, axis=-1)

    @abstractmethod
    def weighted_cross_spectrum(self, spec_left: np.ndarray, spec_right: np.ndarray
                                ) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(W C, norm)``: the weighted cross-spectrum ``(n, K)`` and ``(n,)`` numbers such that
        ``r(tau) / norm`` is the method's confidence in ``[-1, 1]``."""

    def estimate(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """ITDs and confidences of ``(n, window_len)`` left and right frames.

        Returns ``itds_s (n,)`` seconds (NaN where the window gave no usable correlation, e.g. all zeros) and
        ``confidence (n,)`` in ``[-1, 1]`` (the normalised height of the peak).
        """
        spec_l = self.spectra(left)
        spec_r = self.spectra(right)
        weighted, norm = self.weighted_cross_spectrum(spec_l, spec_r)
        return self._peak(weighted, norm)

    def _peak(self, weighted: np.ndarray, norm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Integer-lag search of ``r = irfft(weighted)`` within +-max_lag, then band-limited sub-sample refinement."""
        n = weighted.shape[0]
        corr = scipy.fft.irfft(weighted, n=self.nfft, axis=-1)
        r = corr[:, self._lags]  # negative lags wrap to the end of the circular correlation
        best = np.argmax(r, axis=1)
        coarse = self._lags[best]
        # r(p + d) = sum_k fold_k Re(WC_k exp(2 pi i k (p + d) / nfft)), evaluated on a fine grid of d.
        shifted = weighted * self._lag_phasors[best]
        fine = (shifted @ self._fine_phasors).real  # (n, F)
        j = np.minimum(np.maximum(np.argmax(fine, axis=1), 1), fine.shape[1] - 2)
        rows = np.arange(n)
        y0, y1, y2 = fine[rows, j - 1], fine[rows, j], fine[rows, j + 1]
        # parabola through the three fine samples around the maximum (a maximum only if it curves down)
        denom = y0 - 2.0 * y1 + y2
        curved = denom < 0
        shift = np.zeros(n)
        shift[curved] = 0.5 * (y0[curved] - y2[curved]) / denom[curved]
        step = self._fine_offsets[1] - self._fine_offsets[0]
        lag = coarse + self._fine_offsets[j] + np.minimum(np.maximum(shift, -0.5), 0.5) * step
        peak = np.maximum(y1, np.max(fine, axis=1))
        itds = np.minimum(np.maximum(lag / self.samplerate_hz, -self.max_itd_s), self.max_itd_s)
        usable = norm > 0
        confidence = np.full(n, np.nan)
        confidence[usable] = peak[usable] / norm[usable]
        bad = ~np.isfinite(confidence)
        itds[bad] = np.nan
        return itds, np.minimum(np.maximum(confidence, -1.0), 1.0)
