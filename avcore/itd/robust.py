"""Reverberation- and noise-robust variants of the two methods: time-frequency weighting of short frames.

In a room the microphones hear the direct sound, which carries the ITD of eq. (itd), its reflections, which pull
the correlation peak towards zero lag (a diffuse field is coherent at low frequencies for a 12 cm pair) or towards
strong reflections, background noise and the robot's own fan, which is a few centimetres from the microphones and
so perfectly coherent. The plain methods give every frequency of the window a vote (the phase transform, or the
per-channel normalisation of the correlogram), including bands where there is no speech at all. Here the window is
cut into short Hann-windowed frames (32 ms, on a grid of ``hop / 2``) and each frame and frequency bin is weighted by

- **signal-to-noise**: ``clip(1 - over_subtraction * N(f) / P(t, f), 0, 1)`` with ``N(f)`` a running noise floor
  (minimum tracking of the smoothed power, rising at most ``noise_rise_db_per_s``; Doblinger 1995, Martin 2001).
  Bins that hold only the fan or the background noise no longer vote;
- **precedence (onsets)**: the share of the frame's power that is new, ``clip(1 - P(t-1, f) / P(t, f), 0, 1)``,
  with a floor: at a rise of energy the direct sound arrives before its reflections (Wilson and Darrell, 2006,
  "Learning a precedence effect-like weighting function for the generalized cross-correlation framework");
- **coherence**: the magnitude of the short-time coherence (recursive averages over about 30 ms) raised to
  ``coherence_power``: where one plane wave dominates a bin the left and right spectra stay coherent
  (a direct-path-dominance test, Nadiri and Rafaely, 2014);
- **coherent-to-diffuse ratio**: a diffuse field (late reverberation, room noise) is itself coherent at low
  frequencies for a 12 cm pair, with the known coherence ``sinc(2 f d / c)``, and pulls the peak to zero lag. The
  DOA-independent estimator of Thiergart, Del Galdo and Habets (2012) gives each bin's coherent-to-diffuse ratio
  CDR; the bin is weighted by ``(CDR / (1 + CDR))^diffuse_power`` and, with ``diffuse_subtract``, the diffuse part
  ``sinc(2 f d / c) sqrt(P_L P_R) / (1 + CDR)`` is removed from its cross-spectrum.

Two frame-level cues then weight whole frames: within a "speech" window the talker pauses between words and
the background noise (clattering dishes in the benchmark) takes over some frames, whose bins the per-bin weights
above only partly silence. They are on by default for ``gcc-phat-robust`` and off for ``correlogram-robust``
(where they helped the spoken digits but cost 1.7 points with ARCTIC sentences, seed 1):

- **frame signal-to-noise**: ``share^frame_snr_power`` with ``share = sum_f max(P(t, f) - N(f), 0) / sum_f P(t, f)``
  over the band, the part of the frame's power above the noise floor (an a-posteriori SNR, as in statistical voice
  activity detection, Sohn, Kim and Sung 1999; Valin, Michaud and Rouat 2007 weight their cross-spectra by a
  speech-presence probability built the same way);
- **spectral flatness**: ``(1 - flatness)^flatness_power``, flatness being the ratio of the geometric to the
  arithmetic mean of the frame's power over the band (Gray and Markel 1974; a voice-activity feature, Moattar and
  Homayounpour 2009). Voiced speech is peaky (flatness about 0.02), clattering dishes or water are flat (about
  0.25).

Measured in the benchmark rooms at SNR 10 dB, RT60 0.4 and 0.6 s, as the share of speech windows within 40 us (mean
of the two rooms; ``python benchmarks/itd_accuracy.py --rt60 0.4 0.6 --snr 10 --seed N [--speech arctic]``),
without -> with both frame cues, power 8 each: spoken digits, seeds 1 / 2 / 3: 73.6 -> 76.7, 68.0 -> 72.9,
65.0 -> 70.4; ARCTIC sentences, seeds 1 / 2: 74.0 -> 74.5, 77.3 -> 78.1; at 0 and 20 dB (digits, seeds 1 and 2)
47.4 -> 52.0 and 76.3 -> 79.3. Flatness alone with power 16 (the earlier option) gave +4.4 on the digits but -0.2
on ARCTIC; the frame SNR alone +2.7 and +0.8.

Tried without a gain (same measure, digits seed 1, 73.6 before the frame cues): the weighted phase transform
``|C|^-beta`` with beta 0.9 / 0.7 / 0.5 (73.7 / 72.4 / 68.5), the phase transform applied to the window's summed
cross-spectrum instead of per frame (66.3), frames of 16 or 64 ms (73.3, 70.5), frames every quarter hop (73.2; with
16 ms frames 74.9, but 66.8 and 64.9 on seeds 2 and 3 against 68.0 and 65.0), other exponents on the coherence and
CDR weights, a higher low band edge (71.5 at 400 Hz), and a harmonic-comb weighting at the frame's pitch (no change;
weighting frames by their harmonicity: +2.9 on the digits over the three seeds, +0.1 on ARCTIC, less than the two
cues above). The sub-sample peak is already the exact band-limited correlation (``_base``), so a finer interpolation
has nothing to add. What remains is mostly a bias towards zero lag for lateral talkers: the room's own reflections
arriving 5 to 30 ms after the direct sound (a phase transform of the whole impulse-response pair is biased by up to
47 us for some positions, of its first 5 ms by under 3 us).

The weighted frame cross-spectra of a window are summed, then the window is finished as in the plain method: phase
transform per bin (``gcc-phat-robust``) or per-channel normalised gammatone cross-correlation summed over channels
(``correlogram-robust``; each channel's correlation is normalised by its energy and weighted by the share of that
energy the weighting kept: a per-channel confidence).

The band stops at 4 kHz by default (5 kHz for the plain methods): speech carries little energy above it, and the
spoken digits of the benchmark (recorded at 8 kHz) none at all, so above it the bins hold only fan and noise.
The defaults were chosen on the simulated rooms of ``benchmarks/itd_accuracy.py`` (which also measures each cue
switched off); they are not fitted to real recordings.

The noise floor and the previous frame are state carried from frame to frame: these methods run in streaming form
(``ItdStream``), and ``extract_itds`` feeds the whole signal through a stream, so both forms agree by construction.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..gammatone import erb_space_hz, gammatone_power_response
from ._base import ItdMethod

__all__ = ["FrameMethod", "FrameState", "RobustCorrelogram", "RobustGccPhat"]


_TINY = np.finfo(np.float64).tiny


def _unit(x: np.ndarray) -> np.ndarray:
    """``x`` clipped to ``[0, 1]`` (two ufunc calls: ``np.clip`` costs more than the arithmetic on K-vectors)."""
    return np.minimum(np.maximum(x, 0.0), 1.0)


def _ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """``num / den`` for non-negative powers, infinite where ``den`` is 0 (a silent bin: digital silence after a
    loud stretch would otherwise overflow ``num / tiny``)."""
    return np.divide(num, den, out=np.full_like(den, np.inf), where=den > 0)


@dataclass
class FrameState:
    """What a frame method carries between frames: smoothed power, noise floor, previous power, coherence sums."""

    smoothed: np.ndarray | None = None
    noise: np.ndarray | None = None
    previous: np.ndarray | None = None
    cross_avg: np.ndarray | None = None
    left_avg: np.ndarray | None = None
    right_avg: np.ndarray | None = None


class FrameMethod(ItdMethod):
    """Base of the frame-based methods: per-frame weighted terms, summed per window, then a window weighting.

    Parameters (all keyword)
    ----------
    frame_s : float, seconds
        Frame length (32 ms).
    frame_hop_len : int
        Samples between frames; must divide the window hop (the stream sets it to ``hop / 2``).
    onset_floor : float in [0, 1]
        Weight of a frame with no new energy (0.2; 1 disables the precedence weighting).
    over_subtraction : float
        Factor on the noise floor (1; 0 switches the signal-to-noise weighting off).
    noise_rise_db_per_s : float
        How fast the noise floor may rise, dB per second.
    smoothing_s : float, seconds
        Time constant of the power smoothing before minimum tracking.
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
        Exponent on the share of the frame's in-band power above the noise floor (0: off; ``gcc-phat-robust``
        uses 8).
    low_hz, high_hz : float, hertz
        Band used (80 Hz to 4 kHz).
    """

    frame_based: ClassVar[bool] = True

    def __init__(self, samplerate_hz: float, window_len: int, max_itd_s: float, *, frame_hop_len: int,
                 frame_s: float = 0.032, onset_floor: float = 0.2,
                 over_subtraction: float = 1.0, noise_rise_db_per_s: float = 3.0, smoothing_s: float = 0.03,
                 coherence_power: float = 2.0, coherence_s: float = 0.03, diffuse_power: float = 2.0,
                 diffuse_subtract: bool = True, mic_distance_m: float = 0.12, speed_of_sound: float = 343.0,
                 flatness_power: float = 0.0, frame_snr_power: float = 0.0, low_hz: float = 80.0,
                 high_hz: float = 4000.0) -> None:
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
        self.frames_per_window = (window_len - frame_len) // self.frame_hop + 1
        self.onset_floor = float(onset_floor)
        self.over_subtraction = float(over_subtraction)
        self.flatness_power = float(flatness_power)
        self.frame_snr_power = float(frame_snr_power)
        frame_dt = self.frame_hop / self.samplerate_hz
        self._rise = 10 ** (noise_rise_db_per_s * frame_dt / 10)
        self._alpha = np.exp(-frame_dt / smoothing_s)
        self._beta = np.exp(-frame_dt / coherence_s)
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
        raise NotImplementedError("frame methods run through ItdStream; use frame_terms and finish_window")

    def estimate(self, left, right):
        raise NotImplementedError("frame methods run through ItdStream (extract_itds does that for you)")

    # -- per frame ---------------------------------------------------------------------------------------------
    def frame_terms(self, frames_left: np.ndarray, frames_right: np.ndarray, state: FrameState
                    ) -> dict[str, np.ndarray]:
        """Weighted terms of ``(m, frame_len)`` consecutive frames, updating ``state`` frame by frame.

        Returns a dict of ``(m, K)`` arrays, summed over the frames of a window by :meth:`finish_window`.
        """
        spec_l, spec_r = self.spectra(np.stack((frames_left, frames_right)) * self.taper)  # one FFT call
        pow_l = np.abs(spec_l) ** 2
        pow_r = np.abs(spec_r) ** 2
        power = 0.5 * (pow_l + pow_r)
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
            if self.frame_snr_power > 0:
                share = (np.maximum(p - state.noise, 0.0) @ self.band) / max(float(p @ self.band), tiny)
                w *= share**self.frame_snr_power
            if self.over_subtraction > 0:
                w *= _unit(1.0 - self.over_subtraction * _ratio(state.noise, p))
            if self.onset_floor < 1:
                new = _unit(1.0 - _ratio(state.previous, p))
                w *= self.onset_floor + (1 - self.onset_floor) * new
            state.previous = p
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
    """GCC-PHAT over short frames weighted by SNR, onsets, coherence and CDR, and frames weighted by their SNR and
    spectral flatness (``frame_snr_power`` and ``flatness_power``, 8 by default; see the module docstring).

    The confidence is the weighted share of bins whose phase agrees with the chosen lag, in [-1, 1].
    """

    name = "gcc-phat-robust"

    def __init__(self, samplerate_hz: float, window_len: int, max_itd_s: float, *, flatness_power: float = 8.0,
                 frame_snr_power: float = 8.0, **options) -> None:
        # the frame-level cues are on by default here (measured: module docstring), off for the correlogram
        super().__init__(samplerate_hz, window_len, max_itd_s, flatness_power=flatness_power,
                         frame_snr_power=frame_snr_power, **options)

    def _terms(self, weights, cross, pow_l, pow_r):
        mag = np.abs(cross)
        tiny = np.finfo(np.float64).tiny
        phat = np.where(mag > tiny, cross / np.maximum(mag, tiny), 0.0)
        return {"cross": weights * phat, "weight": weights}

    def finish_window(self, sums):
        weighted = sums["cross"]
        norm = sums["weight"] @ self._fold[:self.n_used]
        return weighted, norm


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
