"""The gammatone auditory filterbank used by the cross-correlogram ITD method.

Centre frequencies are spaced uniformly on the ERB-rate scale of Glasberg and Moore (1990); each channel is a
fourth-order gammatone filter of bandwidth ``b = 1.019 * ERB(fc)`` (Patterson et al., 1992; Holdsworth et al., 1988),
the front-end of Christensen, Ma, Wrigley and Barker (2007) that the paper uses for its ITDs (section 5.1).

The ITD extractor only needs each channel's *power* response ``|G_c(f)|^2``: the cross-correlation of two signals
passed through the same linear filter is their cross-correlation with ``|G_c|^2`` applied to the cross-spectrum,
whatever the filter's phase. So the filterbank is given here in the frequency domain, in closed form, which is
also numerically safe at low centre frequencies and high sampling rates (where direct IIR designs lose precision).
"""
from __future__ import annotations

import numpy as np

__all__ = ["erb_hz", "erb_space_hz", "gammatone_power_response"]

_EAR_Q = 9.26449  # Glasberg and Moore (1990): ERB(f) = f / EAR_Q + MIN_BW
_MIN_BW_HZ = 24.7
_BANDWIDTH_FACTOR = 1.019  # fourth-order gammatone: b = 1.019 ERB (Patterson et al., 1992)
_ORDER = 4


def erb_hz(freq_hz: np.ndarray | float) -> np.ndarray:
    """Equivalent rectangular bandwidth, hertz: ``24.7 * (4.37 f / 1000 + 1)`` (Glasberg and Moore, 1990)."""
    return _MIN_BW_HZ * (4.37 * np.asarray(freq_hz, dtype=np.float64) / 1000.0 + 1.0)


def _erb_rate(freq_hz: np.ndarray | float) -> np.ndarray:
    return 21.4 * np.log10(4.37 * np.asarray(freq_hz, dtype=np.float64) / 1000.0 + 1.0)


def _inverse_erb_rate(rate: np.ndarray) -> np.ndarray:
    return (10.0 ** (rate / 21.4) - 1.0) * 1000.0 / 4.37


def erb_space_hz(low_hz: float, high_hz: float, n_channels: int) -> np.ndarray:
    """``n_channels`` centre frequencies from ``low_hz`` to ``high_hz`` equally spaced in ERB rate, hertz, ascending."""
    if not isinstance(n_channels, (int, np.integer)) or n_channels < 1:
        raise ValueError(f"n_channels must be a positive integer, got {n_channels!r}")
    if not (np.isfinite(low_hz) and np.isfinite(high_hz) and 0 < low_hz <= high_hz):
        raise ValueError(f"need 0 < low_hz <= high_hz, got low_hz={low_hz!r}, high_hz={high_hz!r}")
    if n_channels == 1:
        return np.array([float(low_hz)])
    rates = np.linspace(_erb_rate(low_hz), _erb_rate(high_hz), n_channels)
    return _inverse_erb_rate(rates)


def gammatone_power_response(center_hz: np.ndarray, freqs_hz: np.ndarray) -> np.ndarray:
    """Power response ``|G_c(f)|^2`` of fourth-order gammatone filters, peak-normalised to 1.

    Parameters
    ----------
    center_hz : (C,) float, hertz
        Centre frequencies.
    freqs_hz : (K,) float, hertz
        Frequencies at which to evaluate (for example the bins of an ``rfft``).

    Returns
    -------
    (C, K) float, dimensionless
        The classical closed form of the gammatone's amplitude response,
        ``(1 + ((f - fc) / b)^2)^(-n/2)`` with ``n = 4``, plus the mirror term at ``-fc`` so that the response of
        a real filter is even in ``f``, squared.
    """
    fc = np.asarray(center_hz, dtype=np.float64)[:, None]
    f = np.asarray(freqs_hz, dtype=np.float64)[None, :]
    b = _BANDWIDTH_FACTOR * erb_hz(fc)
    upper = (1.0 + ((f - fc) / b) ** 2) ** (-_ORDER / 2)
    mirror = (1.0 + ((f + fc) / b) ** 2) ** (-_ORDER / 2)
    amplitude = upper + mirror
    return amplitude**2 / np.max(amplitude**2, axis=1, keepdims=True)
