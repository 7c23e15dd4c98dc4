"""Reverberation- and noise-robust variants of the two ITD methods: time-frequency weighting of short frames.

The window is cut into short Hann-windowed frames (32 ms, on a grid of ``hop / 2``); each frame and frequency bin is
weighted by its signal-to-noise ratio (a running noise floor), its onset share (precedence), the short-time
coherence and the coherent-to-diffuse ratio; whole frames by their share above the noise floor and their spectral
flatness. ``gcc-phat-robust`` also dereverberates each bin by delayed linear prediction (WPE-like, NLMS filters),
subtracts a steady noise's learnt cross-spectrum and sums the frames' clipped, squared correlations;
``correlogram-robust`` sums the weighted cross-spectra through the gammatone correlogram. The band stops at 4 kHz.
Every cue, its formula, its source in the literature and the options that set it: docs/method.md ("ITD
extraction"); how each was chosen: docs/experiments.md ("The robust ITD extractors").

The noise floor, the previous frame, the coherence averages, the dereverberation's past frames and filters and the
noise's cross-spectrum are state carried from frame to frame: these methods run in streaming form (``PairStream``),
and ``extract_itds`` feeds the whole signal through a stream, so both forms agree by construction.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..gammatone import erb_space_hz, gammatone_power_response
from ._base import ItdMethod, parabolic_peak

__all__ = ["FrameMethod", "FrameState", "RobustCorrelogram", "RobustGccPhat"]


_TINY = np.finfo(np.float64).tiny
_PREDICT_LOADING = 1e-3  # share of the current frame's power added to the NLMS normaliser (dereverberation)
_GRID_STEPS = 4  # lags per sample of the per-frame correlations (RobustGccPhat.frame_corr_power)


def _unit(x: np.ndarray) -> np.ndarray:
    """``x`` clipped to ``[0, 1]`` (two ufunc calls: ``np.clip`` costs more than the arithmetic on K-vectors)."""
    return np.minimum(np.maximum(x, 0.0), 1.0)


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """``num / den`` for non-negative powers, infinite where ``den`` is 0 (a silent bin: digital silence after a
    loud stretch would otherwise overflow ``num / tiny``)."""
    return np.divide(num, den, out=np.full_like(den, np.inf), where=den > 0)


@dataclass
class FrameState:
    """What a frame method carries between frames: smoothed power, noise floor, previous power, coherence sums,
    and the dereverberation's past frames (spectra and powers) and prediction filters."""

    smoothed: np.ndarray | None = None
    noise: np.ndarray | None = None
    previous: np.ndarray | None = None
    cross_avg: np.ndarray | None = None
    left_avg: np.ndarray | None = None
    right_avg: np.ndarray | None = None
    past_spectra: np.ndarray | None = None
    past_power: np.ndarray | None = None
    predictor: np.ndarray | None = None
    noise_cross: np.ndarray | None = None


class FrameMethod(ItdMethod):
    """Base of the frame-based methods: per-frame weighted terms, summed per window, then a window weighting.

    Parameters (all keyword)
    ----------
    frame_s, frame_hop_len : float seconds, int samples
        Frame length (32 ms); samples between frames, dividing the window hop (the stream sets ``hop / 2``).
    onset_floor : float in [0, 1]
        Weight of a frame with no new energy (0.2; 1 disables the precedence weighting).
    over_subtraction : float
        Factor on the noise floor (1; 0 switches the signal-to-noise weighting off).
    noise_rise_db_per_s, smoothing_s : float, dB per second and seconds
        How fast the noise floor may rise (3); the power smoothing before its minimum tracking (30 ms).
    coherence_power : float
        Exponent on the coherence magnitude (2; 0 disables the coherence weighting).
    coherence_s : float, seconds
        Time constant of the recursive averages behind the coherence and the CDR (30 ms).
    diffuse_power : float
        Exponent on the direct share ``CDR / (1 + CDR)`` (2; 0 disables).
    diffuse_subtract : bool
        Remove the estimated diffuse part from each bin's cross-spectrum (True).
    mic_distance_m, speed_of_sound : float, metres and m/s
        For the diffuse-field coherence ``sinc(2 f d / c)`` (12 cm, 343 m/s: the project's head).
    flatness_power : float
        Exponent on one minus the frame's spectral flatness (0: off; ``gcc-phat-robust`` uses 8).
    frame_snr_power : float
        Exponent on the frame's in-band share above the noise floor (0: off; ``gcc-phat-robust`` uses 8).
    low_hz, high_hz : float, hertz
        Band used (80 Hz to 4 kHz).
    dereverb_taps : int
        Frames the linear-prediction dereverberation predicts from (0: off; ``gcc-phat-robust`` uses 3).
    dereverb_delay, dereverb_step : int, float in (0, 2)
        Frames between the predicted frame and the latest it is predicted from (2: 20 ms at the stream's hop);
        normalised step of the prediction filters' adaptation per frame (0.2).
    noise_cross_s, noise_cross_gate : float seconds, float in (0, 1]
        Time constant of a steady noise's cross-spectrum, learnt and subtracted from every frame's (0: off;
        ``gcc-phat-robust`` uses 1 s); only frames whose share above the floor is below the gate (0.8) teach it.
    """

    frame_based: ClassVar[bool] = True

    def __init__(self, samplerate_hz: float, window_len: int, max_itd_s: float, *, frame_hop_len: int,
                 frame_s: float = 0.032, onset_floor: float = 0.2,
                 over_subtraction: float = 1.0, noise_rise_db_per_s: float = 3.0, smoothing_s: float = 0.03,
                 coherence_power: float = 2.0, coherence_s: float = 0.03, diffuse_power: float = 2.0,
                 diffuse_subtract: bool = True, mic_distance_m: float = 0.12, speed_of_sound: float = 343.0,
                 flatness_power: float = 0.0, frame_snr_power: float = 0.0, low_hz: float = 80.0,
                 high_hz: float = 4000.0, dereverb_taps: int = 0, dereverb_delay: int = 2,
                 dereverb_step: float = 0.2, noise_cross_s: float = 0.0,
                 noise_cross_gate: float = 0.8) -> None:
        frame_len = round(frame_s * samplerate_hz)
        if not (16 <= frame_len <= window_len // 2):
            raise ValueError(f"frame_s={frame_s} s must give between 16 samples and half the window "
                             f"({window_len // 2} samples), got {frame_len}")
        self.frame_len = frame_len
        super().__init__(samplerate_hz, window_len, max_itd_s)
        if not isinstance(frame_hop_len, (int, np.integer)) or frame_hop_len < 1:
            raise ValueError(f"frame_hop_len must be a positive number of samples, got {frame_hop_len!r}")
        if not (0 <= onset_floor <= 1):
            raise ValueError(f"onset_floor must lie in [0, 1], got {onset_floor!r}")
        if min(coherence_power, diffuse_power, flatness_power, frame_snr_power) < 0:
            raise ValueError(f"coherence_power, diffuse_power, flatness_power and frame_snr_power must be >= 0, "
                             f"got {coherence_power!r}, {diffuse_power!r}, {flatness_power!r} and "
                             f"{frame_snr_power!r}")
        if not (mic_distance_m > 0 and speed_of_sound > 0):
            raise ValueError(f"mic_distance_m and speed_of_sound must be positive, got {mic_distance_m!r} and "
                             f"{speed_of_sound!r}")
        if not (0 <= low_hz < high_hz):
            raise ValueError(f"need 0 <= low_hz < high_hz, got low_hz={low_hz!r}, high_hz={high_hz!r}")
        if over_subtraction < 0 or noise_rise_db_per_s <= 0 or smoothing_s <= 0 or coherence_s <= 0:
            raise ValueError("over_subtraction must be >= 0 and noise_rise_db_per_s, smoothing_s, coherence_s > 0; "
                             f"got {over_subtraction!r}, {noise_rise_db_per_s!r}, {smoothing_s!r}, {coherence_s!r}")
        self.frame_hop = int(frame_hop_len)
        if not (int(dereverb_taps) == dereverb_taps >= 0 and int(dereverb_delay) == dereverb_delay >= 1
                and 0 < dereverb_step < 2):
            raise ValueError(f"dereverb_taps must be an integer >= 0, dereverb_delay an integer >= 1 and "
                             f"dereverb_step in (0, 2), got {dereverb_taps!r}, {dereverb_delay!r} and "
                             f"{dereverb_step!r}")
        self.dereverb_taps = int(dereverb_taps)
        self.dereverb_delay = int(dereverb_delay)
        self.dereverb_step = float(dereverb_step)
        self.frames_per_window = (window_len - frame_len) // self.frame_hop + 1
        self.onset_floor = float(onset_floor)
        self.over_subtraction = float(over_subtraction)
        self.flatness_power = float(flatness_power)
        self.frame_snr_power = float(frame_snr_power)
        frame_dt = self.frame_hop / self.samplerate_hz
        self._rise = 10 ** (noise_rise_db_per_s * frame_dt / 10)
        self._alpha = np.exp(-frame_dt / smoothing_s)
        self._beta = np.exp(-frame_dt / coherence_s)
        if not (noise_cross_s >= 0 and 0 < noise_cross_gate <= 1):
            raise ValueError(f"noise_cross_s must be >= 0 seconds and noise_cross_gate in (0, 1], got "
                             f"{noise_cross_s!r} and {noise_cross_gate!r}")
        self.noise_cross_gate = float(noise_cross_gate)
        self._noise_keep = float(np.exp(-frame_dt / noise_cross_s)) if noise_cross_s > 0 else None
        self.coherence_power = float(coherence_power)
        self.diffuse_power = float(diffuse_power)
        self.diffuse_subtract = bool(diffuse_subtract)
        self.low_hz, self.high_hz = float(low_hz), float(high_hz)
        self.taper = np.hanning(self.frame_len + 2)[1:-1]
        in_band = (self.freqs_hz >= low_hz) & (self.freqs_hz <= high_hz)
        if not np.any(in_band):
            raise ValueError(f"no frequency bin lies in [{low_hz}, {high_hz}] Hz at {self.samplerate_hz} Hz")
        self.use_bins(int(np.flatnonzero(in_band)[-1]) + 1)  # every term vanishes above the band: leave it out
        self.band = in_band[:self.n_used].astype(np.float64)
        # coherence of a diffuse field between two omnidirectional microphones: sinc(2 f d / c)
        self.diffuse_coherence = np.sinc(2 * self.freqs_hz[:self.n_used] * mic_distance_m / speed_of_sound)

    def _min_nfft(self) -> int:
        return 2 * self.frame_len

    def weighted_cross_spectrum(self, spec_left, spec_right):
        raise NotImplementedError("frame methods run through PairStream; use frame_terms and finish_window")

    def estimate(self, left, right):
        raise NotImplementedError("frame methods run through PairStream (extract_itds does that for you)")

    # -- per frame ---------------------------------------------------------------------------------------------
    def frame_terms(self, frames_left: np.ndarray, frames_right: np.ndarray, state: FrameState
                    ) -> dict[str, np.ndarray]:
        """Weighted terms of ``(m, frame_len)`` consecutive frames, updating ``state`` frame by frame.

        Returns a dict of ``(m, K)`` arrays, summed over the frames of a window by :meth:`finish_window`.
        """
        spec = self.spectra(np.stack((frames_left, frames_right)) * self.taper)  # one FFT call: (2, m, K)
        spec_l, spec_r = spec
        pow_l = np.abs(spec_l) ** 2
        pow_r = np.abs(spec_r) ** 2
        power = 0.5 * (pow_l + pow_r)  # the level cues (noise floor, SNR, onsets, flatness) use the microphones'
        if self.dereverb_taps > 0:
            # the prediction error replaces the spectra behind the cross-spectrum and the coherence
            spec_l, spec_r = self._dereverberate(spec, pow_l + pow_r, state)
            pow_l = np.abs(spec_l) ** 2
            pow_r = np.abs(spec_r) ** 2
        cross = spec_l * np.conj(spec_r)
        weights = np.empty_like(power)
        tiny = _TINY
        if self.flatness_power > 0:
            inband = power[:, self.band > 0] + tiny
            flatness = np.exp(np.log(inband).sum(axis=1) / inband.shape[1]) / (inband.sum(axis=1) / inband.shape[1])
            frame_weight = _unit(1.0 - flatness) ** self.flatness_power
        else:
            frame_weight = np.ones(power.shape[0])

        for j in range(power.shape[0]):  # the recursions: cheap (K-vectors), sequential by nature
            p = power[j]
            if state.smoothed is None:
                state.smoothed = p.copy()
                state.noise = p.copy()
                state.previous = p.copy()
                state.cross_avg = cross[j].copy()
                state.left_avg = pow_l[j].copy()
                state.right_avg = pow_r[j].copy()
            state.smoothed = self._alpha * state.smoothed + (1 - self._alpha) * p
            state.noise = np.minimum(state.smoothed, state.noise * self._rise)
            w = np.ones_like(p)
            if self.frame_snr_power > 0 or self._noise_keep is not None:
                share = (np.maximum(p - state.noise, 0.0) @ self.band) / max(float(p @ self.band), tiny)
            if self.frame_snr_power > 0:
                w *= share**self.frame_snr_power
            if self.over_subtraction > 0:
                w *= _unit(1.0 - self.over_subtraction * _ratio(state.noise, p))
            if self.onset_floor < 1:
                new = _unit(1.0 - _ratio(state.previous, p))
                w *= self.onset_floor + (1 - self.onset_floor) * new
            state.previous = p
            if self._noise_keep is not None:
                self._subtract_noise_cross(cross, j, p, share, state)
            if self.coherence_power > 0 or self.diffuse_power > 0 or self.diffuse_subtract:
                b = self._beta
                state.cross_avg = b * state.cross_avg + (1 - b) * cross[j]
                state.left_avg = b * state.left_avg + (1 - b) * pow_l[j]
                state.right_avg = b * state.right_avg + (1 - b) * pow_r[j]
                den = np.sqrt(state.left_avg * state.right_avg)
                gamma = np.where(den > tiny, state.cross_avg / np.maximum(den, tiny), 0.0)
                mag = np.abs(gamma)
                if self.coherence_power > 0:
                    w *= _unit(mag) ** self.coherence_power
                if self.diffuse_power > 0 or self.diffuse_subtract:
                    # coherent-to-diffuse ratio, DOA-independent estimator (Thiergart, Del Galdo, Habets 2012)
                    # Re{(G_n - G_x) / (G_x - exp(i arg G_x))}, written with |G_x| and cos(arg G_x) so that a
                    # fully coherent bin (|G_x| = 1) gives an infinite ratio, not 0 / 0.
                    cos_phase = np.where(mag > tiny, np.real(gamma) / np.maximum(mag, tiny), 1.0)
                    cdr = (mag - self.diffuse_coherence * cos_phase) / np.maximum(1.0 - mag, 1e-12)
                    cdr = np.minimum(np.maximum(cdr, 0.0), 1e12)
                    direct = cdr / (1.0 + cdr)
                    if self.diffuse_power > 0:
                        w *= direct ** self.diffuse_power
                    if self.diffuse_subtract:
                        cross[j] = cross[j] - self.diffuse_coherence * np.sqrt(pow_l[j] * pow_r[j]) * (1 - direct)
            weights[j] = w * self.band * frame_weight[j]
        return self._terms(weights, cross, pow_l, pow_r)

    def _subtract_noise_cross(self, cross: np.ndarray, j: int, p: np.ndarray, share: float,
                              state: FrameState) -> None:
        """Subtract the steady noise's learnt cross-spectrum from frame ``j``'s (in place), then learn from it.

        A point noise (a fan, a kitchen) is coherent: in every bin it holds a fixed phase, its direction's, and the
        phase transform gives each bin one vote, so it can take a lone talker's windows on every pair. Its
        cross-spectrum's mean, subtracted, leaves the talker's (the two are uncorrelated: Boll 1979's spectral
        subtraction, on the cross-spectrum rather than the power). It is learnt, with time constant ``noise_cross_s``,
        in the frames whose share above the noise floor is below ``noise_cross_gate`` (a talker's frames lie
        above it), and there in each bin by how close it lies to the floor: fully at or below ``over_subtraction``
        times the floor (at least once the floor), not at all where the floor is nothing to the bin.
        """
        if state.noise_cross is None:
            state.noise_cross = np.zeros_like(cross[j])
        heard = cross[j].copy()
        cross[j] = heard - state.noise_cross
        if share < self.noise_cross_gate:
            floor = 1.0 - _unit(1.0 - max(self.over_subtraction, 1.0) * _ratio(state.noise, p))
            state.noise_cross += ((1.0 - self._noise_keep) * floor) * (heard - state.noise_cross)

    def _dereverberate(self, spec: np.ndarray, power: np.ndarray, state: FrameState
                       ) -> tuple[np.ndarray, np.ndarray]:
        """Multichannel linear-prediction dereverberation of ``(2, m, K)`` (left, right) frame spectra, frame by
        frame, given their ``(m, K)`` powers ``|L|^2 + |R|^2``; returns the left and right ``(m, K)`` spectra.

        In each bin, both channels of frame ``t`` are predicted from both channels of the ``dereverb_taps`` frames
        ``t - dereverb_delay - dereverb_taps + 1 .. t - dereverb_delay``, and the prediction error is the output
        (the delayed linear prediction of WPE: Nakatani et al. 2010, Yoshioka and Nakatani 2012). The filter
        adapts by normalised least mean squares (a step of ``dereverb_step`` towards the error's minimum), not by
        the recursive least squares of online WPE (Caroselli et al. 2017): cheaper and, measured, more accurate
        here (module docstring). ``state`` carries the past frames and the filters.
        """
        taps, k_used = self.dereverb_taps, self.n_used
        n_past = self.dereverb_delay + taps - 1
        if state.past_spectra is None:
            # the last n_past frames, oldest first, both channels interleaved per frame: (K, 2 n_past), and their
            # powers |L|^2 + |R|^2: (K, n_past)
            state.past_spectra = np.zeros((k_used, 2 * n_past), dtype=complex)
            state.past_power = np.zeros((k_used, n_past))
            state.predictor = np.zeros((k_used, 2 * taps, 2), dtype=complex)  # conjugated prediction filters
        past, past_power, predictor, step = state.past_spectra, state.past_power, state.predictor, self.dereverb_step
        frames = spec.transpose(1, 2, 0)  # (m, K, 2) view
        out = np.empty(frames.shape, dtype=complex)
        for j in range(frames.shape[0]):
            y = frames[j]  # (K, 2)
            x = past[:, :2 * taps]  # (K, 2 taps): the frames the prediction uses
            error = y - (x[:, None, :] @ predictor)[:, 0, :]
            y_power = power[j]
            # Removing reverberation removes energy: where the error is louder than the frame, the filter has
            # injected past sound (another source: a filter learnt on a steady voice, applied to a past noise
            # burst), so that bin passes unchanged, both channels alike (their phase difference is the ITD).
            flat = error.view(np.float64)
            out[j] = np.where((np.einsum("ij,ij->i", flat, flat) > y_power)[:, None], y, error)
            # NLMS step, normalised by the regressor's power; the current frame's power in the denominator (a
            # thousandth) keeps the step small when the past is near-silent, and 0 / tiny is 0 in digital silence
            norm = past_power[:, :taps].sum(axis=1) + _PREDICT_LOADING * y_power
            gain = step / np.maximum(norm, _TINY)
            predictor += (gain[:, None] * x.conj())[:, :, None] * error[:, None, :]
            past[:, :-2] = past[:, 2:]
            past[:, -2:] = y
            past_power[:, :-1] = past_power[:, 1:]
            past_power[:, -1] = y_power
        return out[:, :, 0], out[:, :, 1]

    def _terms(self, weights, cross, pow_l, pow_r) -> dict[str, np.ndarray]:
        """The per-frame quantities a window sums: ``(m, K)`` arrays by name."""
        raise NotImplementedError

    def finish_window(self, sums: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """From ``(n, K)`` per-window sums of the frame terms to ``(weighted cross-spectrum, norm)``."""
        raise NotImplementedError

    def estimate_windows(self, sums: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        weighted, norm = self.finish_window(sums)
        return self._peak(weighted, norm)


class RobustGccPhat(FrameMethod):
    """GCC-PHAT over short frames, dereverberated by linear prediction and weighted by SNR, onsets, coherence and
    CDR, frames weighted by their SNR and spectral flatness, and the frames' own correlations combined with an
    exponent (see the module docstring).

    Defaults that differ from :class:`FrameMethod`'s (measured: module docstring): ``flatness_power`` and
    ``frame_snr_power`` 8, ``dereverb_taps`` 3, ``noise_cross_s`` 1 s, ``over_subtraction`` 3. The last because the
    phase transform gives every bin one vote and the running minimum lies well below a steady noise's mean power
    (Martin 2001): three times the floor (the over-subtraction of Berouti, Schwartz and Makhoul 1979) leaves little
    weight to the bins of a steady noise from one direction (a kitchen, a fan), which would otherwise take a lone
    talker's windows.

    Extra parameter ``frame_corr_power`` (2): each frame's weighted phase-transform correlation, normalised by the
    frame's total weight to ``[-1, 1]``, is clipped at 0 and raised to this power before the window sums the
    frames (weighted by their total weight), on a grid of 1/4 sample refined by a parabola. 0 sums the frames'
    weighted cross-spectra instead, then takes the band-limited peak (the method before; with power 1 the two
    agree up to the clipping).

    The confidence is the peak of the window's summed correlation over the frames' total weight: in ``[-1, 1]``
    (the weighted share of bins whose phase agrees with the chosen lag) with ``frame_corr_power`` 0, in
    ``[0, 1]`` otherwise (lower than before for the same window: the frames' correlations are raised to a power).

    Extra parameter ``band_edges_hz`` ((800, 1600, 2600)): with ``frame_corr_power`` > 0 each frame's correlation is
    the sum of the correlations of the bands these edges cut the spectrum into, and each band's own peak is also
    kept (``frame_band_itds``, on the lag grid) when ``keep_band_peaks`` is set (by ``PairStream(frame_itds=True)``):
    where two people talk at once, a band may belong to the quieter one (:class:`avcore.speaking.SpeakingTest`,
    ``band_itds``). The sum is the same product cut in pieces: no extra cost but the bands' peaks.

    ``keep_bins`` (set by ``PairStream(frame_bins=True)``): each frame's weighted phase transform itself, one phasor
    ``w(f) exp(i phi(f))`` per bin (``frame_bins``, complex64), for the speaking test's look at the bins of every
    pair at once (:func:`avcore.speaking.bin_shares`).
    """

    name = "gcc-phat-robust"

    frame_itds_capable: ClassVar[bool] = True  # its frames' correlations give per-frame and per-band ITDs

    def __init__(self, samplerate_hz: float, window_len: int, max_itd_s: float, *, flatness_power: float = 8.0,
                 frame_snr_power: float = 8.0, frame_corr_power: float = 2.0, dereverb_taps: int = 3,
                 over_subtraction: float = 3.0, band_edges_hz: tuple[float, ...] = (800.0, 1600.0, 2600.0),
                 noise_cross_s: float = 1.0, **options) -> None:
        # the frame-level cues are on by default here (measured: module docstring), off for the correlogram
        super().__init__(samplerate_hz, window_len, max_itd_s, flatness_power=flatness_power,
                         frame_snr_power=frame_snr_power, dereverb_taps=dereverb_taps,
                         over_subtraction=over_subtraction, noise_cross_s=noise_cross_s, **options)
        if frame_corr_power < 0:
            raise ValueError(f"frame_corr_power must be >= 0, got {frame_corr_power!r}")
        self.frame_corr_power = float(frame_corr_power)
        # lags of the per-frame correlations: 1/_GRID_STEPS sample steps within +-max_lag
        self._grid = np.arange(-_GRID_STEPS * self.max_lag, _GRID_STEPS * self.max_lag + 1) / _GRID_STEPS
        k = np.arange(self.n_used)
        table = np.exp(2j * np.pi * np.outer(k, self._grid) / self.nfft) * self._fold[:self.n_used, None]  # (K, G)
        # rows (re_k, -im_k) interleaved: (a + ib)(c + id) has real part a c - b d
        self._grid_table = np.ascontiguousarray(np.stack((table.real, -table.imag), axis=1).reshape(-1, table.shape[1]))
        edges = np.asarray(band_edges_hz, dtype=np.float64)
        if edges.ndim != 1 or not np.all(np.isfinite(edges)) or np.any(np.diff(edges) <= 0):
            raise ValueError(f"band_edges_hz must be increasing frequencies in Hz, got {band_edges_hz!r}")
        cuts = np.searchsorted(self.freqs_hz[:self.n_used], edges)
        cuts = np.unique(np.concatenate([[0], cuts[(cuts > 0) & (cuts < self.n_used)], [self.n_used]]))
        self._bands = list(zip(cuts[:-1].tolist(), cuts[1:].tolist()))  # bin ranges that tile the used bins
        self.keep_band_peaks = False  # the frames' terms carry each band's peak ("frame_band_itds")
        self.keep_bins = False  # the frames' terms carry their weighted phase transform ("frame_bins")

    def _terms(self, weights, cross, pow_l, pow_r):
        # the weighted phase transform, weights * cross / |cross|, in one complex product (0 where cross is 0)
        weighted = (weights / np.maximum(np.abs(cross), _TINY)) * cross
        if self.frame_corr_power == 0:
            return {"cross": weighted, "weight": weights}
        total = weights @ self._fold[:self.n_used]  # (m,) the frame's weight: its correlation at a perfect lag
        # Re(weighted @ table) as real products: the complex rows read as interleaved (re, im) pairs; one per band
        flat = weighted.view(np.float64)
        parts = [flat[:, 2 * a:2 * b] @ self._grid_table[2 * a:2 * b] for a, b in self._bands]  # (m, G) each
        corr = parts[0] if len(parts) == 1 else np.sum(parts, axis=0)
        corr = np.maximum(corr, 0.0) / np.where(total > 0, total, np.inf)[:, None]
        terms = {"corr": total[:, None] * corr**self.frame_corr_power, "total": total[:, None]}
        if self.keep_band_peaks:
            band_itds = np.stack([self._grid[np.argmax(p, axis=1)] for p in parts], axis=1) / self.samplerate_hz
            band_weight = np.stack([weights[:, a:b] @ self._fold[a:b] for a, b in self._bands], axis=1)
            band_itds[~(band_weight > 0)] = np.nan
            terms["frame_band_itds"] = band_itds
        if self.keep_bins:
            terms["frame_bins"] = weighted.astype(np.complex64)
        return terms

    def finish_window(self, sums):
        weighted = sums["cross"]
        norm = sums["weight"] @ self._fold[:self.n_used]
        return weighted, norm

    @property
    def gives_frame_itds(self) -> bool:
        return self.frame_corr_power > 0

    def frame_itds(self, terms: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """The ITD of each frame alone: the peak of the frame's own correlation (the ``corr`` term before the window
        sums it), and its height in ``[0, 1]``; nan for a frame with no weight. ``(m,)`` and ``(m,)``.

        A talker that a louder one masks in the window's sum still wins some of the 32 ms frames (the gaps between
        the louder talker's syllables); :class:`avcore.speaking.SpeakingTest` looks at these (``frame_rescue``).
        """
        if not self.gives_frame_itds:
            raise ValueError("frame ITDs need the per-frame correlations: frame_corr_power > 0")
        itds, peak = self._grid_peak(terms)
        return itds, np.minimum(peak ** (1.0 / self.frame_corr_power), 1.0)

    def estimate_windows(self, sums):
        if self.frame_corr_power == 0:
            return super().estimate_windows(sums)
        itds, confidence = self._grid_peak(sums)
        return itds, np.minimum(confidence, 1.0)

    def _grid_peak(self, terms: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
        """ITDs at the parabola-refined peaks of ``(n, G)`` correlations on the lag grid (a frame's, or a window's
        sum of frames), and the peak over the total weight; both nan where the total weight is 0."""
        corr, total = terms["corr"], terms["total"][:, 0]
        top, j, shift = parabolic_peak(corr)
        lag = self._grid[j] + shift / _GRID_STEPS
        itds = np.minimum(np.maximum(lag / self.samplerate_hz, -self.max_itd_s), self.max_itd_s)
        peak = corr[np.arange(corr.shape[0]), top] / np.where(total > 0, total, np.nan)
        itds[~np.isfinite(peak)] = np.nan
        return itds, peak


class RobustCorrelogram(FrameMethod):
    """Summary gammatone cross-correlogram over short frames weighted by SNR, onsets, coherence and CDR.

    Extra parameter ``n_channels`` (32). The confidence is the confidence-weighted mean of the channels'
    normalised correlations at the chosen lag.
    """

    name = "correlogram-robust"

    def __init__(self, samplerate_hz: float, window_len: int, max_itd_s: float, *, n_channels: int = 32,
                 **options) -> None:
        super().__init__(samplerate_hz, window_len, max_itd_s, **options)
        high = min(self.high_hz, 0.45 * self.samplerate_hz)
        self.center_hz = erb_space_hz(self.low_hz, high, n_channels)
        self.power_response = gammatone_power_response(self.center_hz, self.freqs_hz[:self.n_used])  # (C, K)
        self._folded_response = (self.power_response * self._fold[:self.n_used]).T  # (K, C)

    def _terms(self, weights, cross, pow_l, pow_r):
        return {"cross": weights * cross, "left": weights * pow_l, "right": weights * pow_r,
                "left_raw": pow_l * self.band, "right_raw": pow_r * self.band}

    def finish_window(self, sums):
        tiny = np.finfo(np.float64).tiny
        e_l = sums["left"] @ self._folded_response  # (n, C) weighted channel energies
        e_r = sums["right"] @ self._folded_response
        raw = np.sqrt((sums["left_raw"] @ self._folded_response) * (sums["right_raw"] @ self._folded_response))
        # Per-channel confidence: the share of the channel's energy that survived the weighting. A channel that
        # holds only noise (or only the fan) keeps its normalised correlation but loses its vote.
        confidence = np.where(raw > tiny, np.sqrt(e_l * e_r) / np.maximum(raw, tiny), 0.0)
        ch = np.where(raw > tiny, 1.0 / np.maximum(raw, tiny), 0.0)
        weighted = (ch @ self.power_response) * sums["cross"]
        norm = confidence.sum(axis=1)
        return weighted, norm
