"""What every ITD method shares: the cross-spectrum of one window, the lag search and the sub-sample peak.

A method is a weighting of the cross-spectrum ``C(f) = X_L(f) conj(X_R(f))`` of a window: the generalised
cross-correlation ``r(tau) = IDFT(W(f) C(f))(tau)`` then peaks at ``tau = t_left - t_right`` (docs/architecture.md sign:
if the left signal is the right one delayed by ``D`` samples, ``C = |S|^2 exp(-2 pi i f D)`` and ``r`` peaks at ``+D``).
Subclasses give ``W`` (and a normaliser that makes the peak height a confidence in ``[-1, 1]``).

The peak: the integer lag maximising ``r`` within ``+-max_lag``, then the band-limited correlation itself evaluated
on a grid of 1/16 sample around it and a parabola through the three best points (the correlation of a zero-padded
window is a trigonometric polynomial, so this is exact interpolation, not a fit to sampled values). A method whose
weighting vanishes above some frequency (a band) computes and searches only the bins below it (``use_bins``); with
few bins and lags the integer lags come from one small matrix product instead of an inverse FFT of the padded
spectrum, which is what makes the streaming form cheap (one window per call).
"""
from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
import scipy.fft

__all__ = ["ItdMethod", "parabolic_peak"]

_FINE_STEPS = 16  # evaluations per sample of the band-limited correlation around the integer peak
_AROUND = np.array([-1, 0, 1])
_PRODUCT_PER_FFT = 16  # complex multiply-adds per FFT point at which a matrix product and an inverse FFT cost alike


def parabolic_peak(values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The maximum of each row of ``(n, G)`` samples on a uniform grid, refined by the parabola through the three
    samples around it (a maximum only where it curves down). Returns the index of the largest sample ``top``, the
    grid point ``j`` the parabola is centred on (``top`` kept one point off the ends) and the vertex's offset from
    ``j`` in grid steps, within ``[-0.5, 0.5]``."""
    rows = np.arange(values.shape[0])
    top = values.argmax(axis=1)
    j = np.minimum(np.maximum(top, 1), values.shape[1] - 2)
    y0, y1, y2 = values[rows[:, None], j[:, None] + _AROUND].T
    denom = y0 - 2.0 * y1 + y2
    curved = denom < 0
    shift = np.where(curved, 0.5 * (y0 - y2) / np.where(curved, denom, -1.0), 0.0)
    return top, j, np.minimum(np.maximum(shift, -0.5), 0.5)


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
    frame_based: ClassVar[bool] = False  # True: stateful, frame by frame, run through PairStream

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
        self._fine_offsets = np.linspace(-0.5, 0.5, _FINE_STEPS + 1)
        self._fine_step = self._fine_offsets[1] - self._fine_offsets[0]
        self._lags = np.arange(-self.max_lag, self.max_lag + 1)
        self.use_bins(n_bins)

    def use_bins(self, n_used: int) -> None:
        """Only the first ``n_used`` rfft bins carry weight (a band that stops below Nyquist): the weighted
        cross-spectrum is computed on those alone, and the tables below are built for them."""
        self.n_used = int(n_used)
        k = np.arange(self.n_used)
        # Sub-sample refinement tables: the band-limited correlation r(p + d) for d in [-0.5, 0.5] (the integer
        # peak is within half a sample of the true one) is the real part of one matrix product.
        angle = 2 * np.pi * np.outer(k, self._fine_offsets) / self.nfft  # (K, F)
        self._fine_phasors = np.exp(1j * angle) * self._fold[:self.n_used, None]
        self._lag_phasors = np.exp(2j * np.pi * np.outer(self._lags, k) / self.nfft)  # (2L+1, K)
        # The integer lags by one matrix product r = Re(WC @ table) when that is cheaper than an inverse FFT of
        # the whole padded spectrum (few bins and lags: GCC-PHAT's band, the robust methods' short frames).
        if self.n_used * self._lags.size <= _PRODUCT_PER_FFT * self.nfft:
            self._lag_table = np.ascontiguousarray((self._lag_phasors * self._fold[:self.n_used]).T)  # (K, 2L+1)
        else:
            self._lag_table = None

    def _min_nfft(self) -> int:
        """Smallest FFT length: enough zero padding that lags up to max_lag do not wrap around."""
        return self.window_len + self.max_lag + 1

    def spectra(self, frames: np.ndarray) -> np.ndarray:
        """``rfft`` of ``(..., window_len)`` frames, zero-padded to ``nfft``, bins the method uses:
        ``(..., n_used)`` complex."""
        return scipy.fft.rfft(frames, n=self.nfft, axis=-1)[..., :self.n_used]

    @abstractmethod
    def weighted_cross_spectrum(self, spec_left: np.ndarray, spec_right: np.ndarray
                                ) -> tuple[np.ndarray, np.ndarray]:
        """Return ``(W C, norm)``: the weighted cross-spectrum ``(n, K)`` and ``(n,)`` numbers such that
        ``r(tau) / norm`` is the method's confidence in ``[-1, 1]``. The spectra are ``(n, K)`` with
        ``K = n_used`` (see :meth:`use_bins`)."""

    def estimate(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """ITDs and confidences of ``(n, window_len)`` left and right frames.

        Returns ``itds_s (n,)`` seconds (NaN where the window gave no usable correlation, e.g. all zeros) and
        ``confidence (n,)`` in ``[-1, 1]`` (the normalised height of the peak).
        """
        spec_l = self.spectra(left)
        spec_r = self.spectra(right)
        weighted, norm = self.weighted_cross_spectrum(spec_l, spec_r)
        return self._peak(weighted, norm)

    def estimate_stereo(self, windows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`estimate` of ``(n, window_len, 2)`` (left, right) windows, as a ring buffer holds them: both
        channels in one FFT call (the streaming form, where ``n`` is often 1, pays the call overhead once)."""
        spec = self.spectra(np.moveaxis(windows, -1, 0))  # (2, n, K)
        weighted, norm = self.weighted_cross_spectrum(spec[0], spec[1])
        return self._peak(weighted, norm)

    def _peak(self, weighted: np.ndarray, norm: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Integer-lag search of ``r = irfft(weighted)`` within +-max_lag, then band-limited sub-sample refinement.

        Written with array methods and ufuncs rather than ``np.clip`` and friends: in the streaming form this runs
        on one window at a time, where numpy's per-call overhead, not arithmetic, is most of the cost.
        """
        n = weighted.shape[0]
        if self._lag_table is not None:
            best = (weighted @ self._lag_table).real.argmax(axis=1)
        else:
            corr = scipy.fft.irfft(weighted, n=self.nfft, axis=-1)  # bins past n_used: zero padding
            best = corr[:, self._lags].argmax(axis=1)  # negative lags wrap to the end of the circular correlation
        # r(p + d) = sum_k fold_k Re(WC_k exp(2 pi i k (p + d) / nfft)), evaluated on a fine grid of d.
        fine = ((weighted * self._lag_phasors[best]) @ self._fine_phasors).real  # (n, F)
        top, j, shift = parabolic_peak(fine)
        lag = self._lags[best] + self._fine_offsets[j] + shift * self._fine_step
        itds = np.minimum(np.maximum(lag / self.samplerate_hz, -self.max_itd_s), self.max_itd_s)
        confidence = fine[np.arange(n), top] / np.where(norm > 0, norm, np.nan)
        itds[~np.isfinite(confidence)] = np.nan
        return itds, np.minimum(np.maximum(confidence, -1.0), 1.0)
