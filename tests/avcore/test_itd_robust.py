"""The frame methods' contract (avcore.itd.robust): settings, band and defaults as documented; each weighting cue
on frames whose spectra are known; the correlogram's channels, the frames' heights and the dereverberation."""
from __future__ import annotations

import inspect
import re

import numpy as np
import pytest

from avcore.itd import RobustCorrelogram, RobustGccPhat, extract_itds
from avcore.itd._extract import PairStream
from avcore.itd.robust import FrameMethod, FrameState, _ratio


def make(**settings):
    """A gcc-phat-robust of 150 ms windows at 16 kHz, frames every 10 ms, as the stream builds it."""
    return RobustGccPhat(16000, 2400, 1e-3, **{"frame_hop_len": 160, **settings})


def delayed_noise(delay: float, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(left, right): n samples of white noise (rms 0.1), the left channel ``delay`` samples late (exact: a phase ramp
    on a periodic signal)."""
    right = 0.1 * rng.standard_normal(n)
    left = np.fft.irfft(np.fft.rfft(right) * np.exp(-2j * np.pi * np.fft.rfftfreq(n) * delay), n)
    return left, right


def frames_of(signal: np.ndarray, count: int) -> np.ndarray:
    """(count, 512) frames every 160 samples, as gcc-phat-robust cuts them at 16 kHz."""
    return np.stack([signal[i * 160:i * 160 + 512] for i in range(count)])


@pytest.mark.parametrize("settings", [
    {"frame_s": 16 / 16000}, {"frame_s": 1200 / 16000}, {"frame_hop_len": 1}, {"onset_floor": 0.0},
    {"onset_floor": 1.0}, {"coherence_power": 0.0, "diffuse_power": 0.0, "flatness_power": 0.0, "frame_snr_power": 0.0},
    {"speed_of_sound": 0.5}, {"low_hz": 0.0}, {"over_subtraction": 0.0}, {"dereverb_taps": 0, "dereverb_delay": 1},
    {"dereverb_step": 1.999}, {"noise_rise_db_per_s": 0.5}, {"noise_cross_s": 0.0}, {"noise_cross_gate": 1.0},
])
def test_each_setting_is_accepted_at_its_documented_edge(settings: dict) -> None:
    method = make(**settings)
    assert method.frame_hop == settings.get("frame_hop_len", 160)


@pytest.mark.parametrize("settings,message", [
    ({"frame_s": 15 / 16000}, "frame_s=0.0009375 s must give between 16 samples and half the window (1200 samples), "
                              "got 15"),
    ({"frame_s": 1201 / 16000}, "frame_s=0.0750625 s must give between 16 samples and half the window (1200 "
                                "samples), got 1201"),
    ({"frame_hop_len": 0}, "frame_hop_len must be a positive number of samples, got 0"),
    ({"frame_hop_len": 160.0}, "frame_hop_len must be a positive number of samples, got 160.0"),
    ({"onset_floor": -0.1}, "onset_floor must lie in [0, 1], got -0.1"),
    ({"onset_floor": 1.5}, "onset_floor must lie in [0, 1], got 1.5"),
    ({"diffuse_power": -1.0}, "coherence_power, diffuse_power, flatness_power and frame_snr_power must be >= 0, got "
                              "2.0, -1.0, 8.0 and 8.0"),
    ({"speed_of_sound": 0.0}, "mic_distance_m and speed_of_sound must be positive, got 0.12 and 0.0"),
    ({"low_hz": 4000.0}, "need 0 <= low_hz < high_hz, got low_hz=4000.0, high_hz=4000.0"),
    ({"over_subtraction": -1.0}, "over_subtraction must be >= 0 and noise_rise_db_per_s, smoothing_s, coherence_s "
                                 "> 0; got -1.0, 3.0, 0.03, 0.03"),
    ({"noise_rise_db_per_s": 0.0}, "over_subtraction must be >= 0 and noise_rise_db_per_s, smoothing_s, coherence_s "
                                   "> 0; got 3.0, 0.0, 0.03, 0.03"),
    ({"smoothing_s": 0.0}, "over_subtraction must be >= 0 and noise_rise_db_per_s, smoothing_s, coherence_s > 0; "
                           "got 3.0, 3.0, 0.0, 0.03"),
    ({"coherence_s": 0.0}, "over_subtraction must be >= 0 and noise_rise_db_per_s, smoothing_s, coherence_s > 0; "
                           "got 3.0, 3.0, 0.03, 0.0"),
    ({"dereverb_delay": 0}, "dereverb_taps must be an integer >= 0, dereverb_delay an integer >= 1 and dereverb_step "
                            "in (0, 2), got 3, 0 and 0.2"),
    ({"dereverb_step": 0.0}, "dereverb_taps must be an integer >= 0, dereverb_delay an integer >= 1 and "
                             "dereverb_step in (0, 2), got 3, 2 and 0.0"),
    ({"low_hz": 7990.0, "high_hz": 7995.0}, "no frequency bin lies in [7990.0, 7995.0] Hz at 16000.0 Hz"),
    ({"noise_cross_s": -1.0}, "noise_cross_s must be >= 0 seconds and noise_cross_gate in (0, 1], got -1.0 and 0.8"),
    ({"noise_cross_gate": 0.0}, "noise_cross_s must be >= 0 seconds and noise_cross_gate in (0, 1], got 1.0 and 0.0"),
    ({"noise_cross_gate": 1.5}, "noise_cross_s must be >= 0 seconds and noise_cross_gate in (0, 1], got 1.0 and 1.5"),
])
def test_each_setting_out_of_bounds_is_named_in_full(settings: dict, message: str) -> None:
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        make(**settings)


def test_the_band_holds_both_its_edges_and_nothing_above() -> None:
    # 1024-point frames at 16 kHz: bins every 15.625 Hz, so 125 Hz (bin 8) and 4 kHz (bin 256) are bins.
    method = make(low_hz=125.0)
    assert method.nfft == 1024 and method.n_used == 257
    assert method.freqs_hz[method.n_used - 1] == 4000.0
    assert np.flatnonzero(method.band).tolist() == list(range(8, 257))
    assert method.frames_per_window == 12  # 512-sample frames every 160 that fit in 2400: starts 0 ... 1760


def test_frame_methods_are_run_by_the_stream_only() -> None:
    method = make()
    spectrum = np.ones(method.n_used, dtype=complex)
    with pytest.raises(NotImplementedError, match=r"^frame methods run through PairStream; use frame_terms and "
                                                  r"finish_window$"):
        method.weighted_cross_spectrum(spectrum, spectrum)
    with pytest.raises(NotImplementedError, match=r"^frame methods run through PairStream \(extract_itds does that "
                                                  r"for you\)$"):
        method.estimate(np.zeros((1, 2400)), np.zeros((1, 2400)))


def test_a_silent_bin_has_an_infinite_ratio() -> None:
    ratio = _ratio(np.array([2.0, 0.0, 3.0]), np.array([4.0, 0.0, 0.0]))
    assert ratio.tolist() == [0.5, np.inf, np.inf]


def test_the_defaults_are_the_documented_ones() -> None:
    params = inspect.signature(FrameMethod.__init__).parameters
    defaults = {name: p.default for name, p in params.items() if p.default is not inspect.Parameter.empty}
    assert defaults == {
        "frame_s": 0.032, "onset_floor": 0.2, "over_subtraction": 1.0, "noise_rise_db_per_s": 3.0,
        "smoothing_s": 0.03, "coherence_power": 2.0, "coherence_s": 0.03, "diffuse_power": 2.0,
        "diffuse_subtract": True, "mic_distance_m": 0.12, "speed_of_sound": 343.0, "flatness_power": 0.0,
        "frame_snr_power": 0.0, "low_hz": 80.0, "high_hz": 4000.0, "dereverb_taps": 0, "dereverb_delay": 2,
        "dereverb_step": 0.2, "noise_cross_s": 0.0, "noise_cross_gate": 0.8,
    }
    assert inspect.signature(RobustCorrelogram.__init__).parameters["n_channels"].default == 32
    own = inspect.signature(RobustGccPhat.__init__).parameters
    assert {name: own[name].default for name in ("flatness_power", "frame_snr_power", "frame_corr_power",
                                                  "dereverb_taps", "over_subtraction", "band_edges_hz",
                                                  "noise_cross_s")} == {
        "flatness_power": 8.0, "frame_snr_power": 8.0, "frame_corr_power": 2.0, "dereverb_taps": 3,
        "over_subtraction": 3.0, "band_edges_hz": (800.0, 1600.0, 2600.0), "noise_cross_s": 1.0}


def test_band_edges_must_be_finite_increasing_frequencies() -> None:
    assert make(band_edges_hz=(800.0, 800.5)).frame_corr_power == 2.0  # half a hertz apart is increasing
    for edges in [(800.0, 800.0), (1600.0, 800.0), (800.0, float("nan")), ((800.0, 1600.0),)]:
        with pytest.raises(ValueError, match=f"^band_edges_hz must be increasing frequencies in Hz, got "
                                             f"{re.escape(repr(edges))}$"):
            make(band_edges_hz=edges)


def test_a_delay_near_the_end_of_the_search_is_found() -> None:
    # max_itd_s of 3 samples: the frames' lag grid (quarter samples) must reach +-3 samples. (The parabola's vertex
    # stays within half a step of an inner grid point, so delays past 2.875 samples read as 2.875.)
    for delay in (2.8, -2.8):
        left, right = delayed_noise(delay, 16000, np.random.default_rng(4))
        track = extract_itds(left, right, 16000, method="gcc-phat-robust", max_itd_s=3 / 16000)
        assert np.median(track.itds_s) * 16000 == pytest.approx(delay, abs=0.05)


def test_a_frame_method_keeps_no_band_peaks_or_bins_unless_asked() -> None:
    method = make()
    rng = np.random.default_rng(0)
    frames = 0.1 * rng.standard_normal((2, 3, method.frame_len))
    assert set(method.frame_terms(frames[0], frames[1], FrameState())) == {"corr", "total"}
    method.keep_band_peaks = method.keep_bins = True
    assert set(method.frame_terms(frames[0], frames[1], FrameState())) == {"corr", "total", "frame_band_itds",
                                                                          "frame_bins"}


# -- each cue alone, on frames whose spectra are known --------------------------------------------------------------
CUES_OFF = {"onset_floor": 1.0, "over_subtraction": 0.0, "coherence_power": 0.0, "diffuse_power": 0.0,
            "diffuse_subtract": False, "flatness_power": 0.0, "frame_snr_power": 0.0, "dereverb_taps": 0,
            "noise_cross_s": 0.0}
RISE = 10 ** (3.0 * 0.010 / 10)  # the noise floor's rise per 10 ms frame at the default 3 dB/s


def steady_then_louder(n_frames: int = 10, louder_from: int = 5) -> np.ndarray:
    """(n, 512) frames of a signal periodic over one frame hop (every frame has the same spectrum), twice as loud
    (four times the power) from frame ``louder_from`` on."""
    period = 0.1 * np.random.default_rng(0).standard_normal(160)
    frames = frames_of(np.tile(period, n_frames + 4), n_frames)
    gain = np.where(np.arange(n_frames) >= louder_from, 2.0, 1.0)
    return frames * gain[:, None]


def frame_weights(frames_left: np.ndarray, frames_right: np.ndarray | None = None, **cue) -> np.ndarray:
    """Each frame's total weight with one cue on, over its total weight with every cue off."""
    right = frames_left if frames_right is None else frames_right
    alone = make(**{**CUES_OFF, **cue}).frame_terms(frames_left, right, FrameState())["total"][:, 0]
    plain = make(**CUES_OFF).frame_terms(frames_left, right, FrameState())["total"][:, 0]
    return alone / plain


def bin_weights(frames_left: np.ndarray, frames_right: np.ndarray, **cues) -> np.ndarray:
    """(m, K) each bin's weight with the given cues (frame_corr_power 0: the terms hold the weights)."""
    method = make(**{**CUES_OFF, "frame_corr_power": 0.0, **cues})
    return method.frame_terms(frames_left, frames_right, FrameState())["weight"]


def test_with_every_cue_off_each_bin_of_the_band_weighs_one() -> None:
    method = make(**CUES_OFF)
    frames = steady_then_louder()
    total = method.frame_terms(frames, frames, FrameState())["total"][:, 0]
    np.testing.assert_allclose(total, method.band @ method._fold[:method.n_used], rtol=1e-12)


def test_the_onset_cue_weighs_a_steady_frame_at_its_floor_and_a_louder_one_by_its_new_share() -> None:
    # new energy share 1 - previous / current: 0 for a steady frame, 3/4 for one four times as powerful
    weights = frame_weights(steady_then_louder(), onset_floor=0.2)
    np.testing.assert_allclose(weights, [0.2] * 5 + [0.2 + 0.8 * 0.75] + [0.2] * 4, rtol=1e-9)


def test_the_noise_floor_weighs_steady_sound_out_and_rises_3_db_a_second() -> None:
    # A steady sound is its own noise floor (weight 1 - N / P = 0). Four times louder, the floor climbs from the old
    # level by the allowed rise each frame: weight 1 - RISE^(n+1) / 4 at the louder stretch's frame n.
    weights = frame_weights(steady_then_louder(), over_subtraction=1.0)
    np.testing.assert_allclose(weights[:5], 0.0, atol=1e-12)
    np.testing.assert_allclose(weights[5:], 1 - RISE ** np.arange(1, 6) / 4, rtol=1e-9)
    doubled = frame_weights(steady_then_louder(), over_subtraction=2.0)
    np.testing.assert_allclose(doubled[5:], 1 - 2 * RISE ** np.arange(1, 6) / 4, rtol=1e-9)


def test_the_frame_snr_cue_weighs_every_bin_by_the_frames_share_above_the_floor() -> None:
    weights = frame_weights(steady_then_louder(), frame_snr_power=0.5)
    np.testing.assert_allclose(weights[:5], 0.0, atol=1e-8)  # the square root of a share of 1e-17 (rounding)
    np.testing.assert_allclose(weights[5:], np.sqrt(1 - RISE ** np.arange(1, 6) / 4), rtol=1e-9)


def test_the_coherence_cue_keeps_one_sound_in_both_ears_and_weighs_two_unrelated_ones_down() -> None:
    rng = np.random.default_rng(1)
    left, other = 0.1 * rng.standard_normal((2, 40, 512))
    np.testing.assert_allclose(frame_weights(left, coherence_power=2.0), 1.0, rtol=1e-9)
    unrelated = frame_weights(left, other, coherence_power=2.0)
    assert unrelated[0] == pytest.approx(1.0)  # one frame alone is fully coherent with itself
    assert np.mean(unrelated[20:]) < 0.2  # averaged over ~30 ms, the unrelated noises' coherence falls
    # unrelated, then the same noise in both: the coherence comes back within a few 30 ms time constants
    both = np.concatenate([other[:20], left[20:]])
    recovering = frame_weights(left, both, coherence_power=2.0)
    assert recovering[19] < 0.5 and recovering[29] > 0.9


def test_the_flatness_cue_weighs_a_click_out_and_keeps_a_tone() -> None:
    # A click has a flat spectrum (flatness 1: weight 0); a tone's spectrum is one peak (flatness near 0: weight
    # near 1), each raised to the power.
    click = np.zeros((1, 512))
    click[0, 256] = 1.0
    tone = np.sin(2 * np.pi * 1000.0 * np.arange(512) / 16000)[None]
    assert frame_weights(click, flatness_power=0.5)[0] == pytest.approx(0.0, abs=1e-6)
    tone_weight = frame_weights(tone, flatness_power=0.5)[0]
    assert 0.9 < tone_weight < 1.0
    assert frame_weights(tone, flatness_power=2.0)[0] == pytest.approx(tone_weight ** 4, rel=1e-9)


def test_the_coherence_cue_raises_the_coherence_to_its_power() -> None:
    rng = np.random.default_rng(1)
    left, other = 0.1 * rng.standard_normal((2, 40, 512))
    np.testing.assert_allclose(bin_weights(left, other, coherence_power=0.5),
                               bin_weights(left, other, coherence_power=2.0) ** 0.25, rtol=1e-9, atol=1e-12)


def test_a_frames_height_is_its_normalised_correlation_whatever_the_power() -> None:
    # the frames' correlations are raised to frame_corr_power before the window sums them; a frame's own height
    # takes the power back off, so it reads the same for every power
    rng = np.random.default_rng(3)
    right = 0.1 * rng.standard_normal(16000)
    left = np.roll(right, 3) + 0.05 * rng.standard_normal(16000)
    heights = []
    for power in (1.0, 2.0, 4.0):
        stream = PairStream(16000, method="gcc-phat-robust", frame_itds=True, frame_corr_power=power)
        stream.push(left, right)
        heights.append(stream.pop_frame_itds().confidence)
    assert 0.5 < np.median(heights[0]) < 0.99
    np.testing.assert_allclose(heights[1], heights[0], rtol=1e-9)
    np.testing.assert_allclose(heights[2], heights[0], rtol=1e-9)
    with pytest.raises(ValueError, match=r"^frame ITDs need the per-frame correlations: frame_corr_power > 0$"):
        make(frame_corr_power=0.0).frame_itds({})


def test_the_robust_correlogram_on_a_pure_delay_with_every_cue_off_is_fully_confident() -> None:
    # every channel's weighted energy is then its raw energy (confidence 1 each), and its correlation at the delay
    # is 1: the confidence-weighted mean is 1
    left, right = delayed_noise(3.0, 16000, np.random.default_rng(3))
    track = extract_itds(left, right, 16000, method="correlogram-robust", **CUES_OFF)
    np.testing.assert_allclose(track.confidence, 1.0, atol=1e-3)
    assert np.median(track.itds_s) * 16000 == pytest.approx(3.0, abs=0.01)


def test_the_robust_correlograms_top_channel_stays_below_nyquist() -> None:
    assert RobustCorrelogram(8000, 1200, 1e-3, frame_hop_len=80).center_hz.max() == pytest.approx(0.45 * 8000)
    assert RobustCorrelogram(16000, 2400, 1e-3, frame_hop_len=160).center_hz.max() == pytest.approx(4000.0)


def echoing_spectra(n_bins: int, n_frames: int, n_echoing: int, rng: np.random.Generator) -> np.ndarray:
    """(2, n_frames, n_bins) left and right frame spectra with an echo of 0.7 two frames later (an AR process at lag
    2) for the first ``n_echoing`` frames, silent after."""
    spectra = np.zeros((2, n_frames, n_bins), dtype=complex)
    for t in range(n_echoing):
        new = rng.standard_normal((2, n_bins)) + 1j * rng.standard_normal((2, n_bins))
        spectra[:, t] = new + (0.7 * spectra[:, t - 2] if t >= 2 else 0.0)
    return spectra


def dereverberated(method: FrameMethod, spectra: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return method._dereverberate(spectra.copy(), (np.abs(spectra) ** 2).sum(axis=0), FrameState())


def test_the_dereverberation_removes_an_echo_two_frames_late() -> None:
    # Predicted from the frame two back (taps 1, delay 2), the prediction error tends to the new part alone, about
    # half the power.
    method = make(dereverb_taps=1, dereverb_delay=2)
    spectra = echoing_spectra(method.n_used, 400, 400, np.random.default_rng(3))
    left, right = dereverberated(method, spectra)
    before = np.mean(np.abs(spectra[:, 300:]) ** 2)
    after = np.mean(np.abs(np.stack([left, right])[:, 300:]) ** 2)
    assert after / before < 0.6  # the new part alone: 1 - 0.7^2 = 0.51 of the power


def test_half_the_power_coherent_reads_as_a_confidence_of_one_over_root_two() -> None:
    # left = right delayed + as much unrelated noise: each channel's normalised correlation at the delay is
    # S / sqrt(S (S + N)) = 1 / sqrt(2), and with every cue off each channel is fully confident
    rng = np.random.default_rng(3)
    left, right = delayed_noise(3.0, 32000, rng)
    left += 0.1 * rng.standard_normal(32000)
    track = extract_itds(left, right, 16000, method="correlogram-robust", **CUES_OFF)
    assert np.all((track.confidence > 0.6) & (track.confidence < 0.8))
    assert np.median(track.confidence) == pytest.approx(2 ** -0.5, abs=0.02)


def test_each_gammatone_channel_votes_by_its_normalised_correlation_not_its_energy() -> None:
    # A loud narrow band (300-500 Hz, a few channels) at +3 samples and a band 20 dB quieter over many channels
    # (1-4 kHz) at -3: the channels vote equally, so the many quiet ones win.
    rng = np.random.default_rng(3)
    freqs = np.fft.rfftfreq(32000, 1 / 16000)

    def band(low: float, high: float, delay: float, rms: float) -> tuple[np.ndarray, np.ndarray]:
        spectrum = np.fft.rfft(rng.standard_normal(32000)) * ((freqs >= low) & (freqs <= high))
        right = np.fft.irfft(spectrum, 32000)
        left = np.fft.irfft(spectrum * np.exp(-2j * np.pi * freqs * delay / 16000), 32000)
        return left * rms / right.std(), right * rms / right.std()

    (l_loud, r_loud), (l_quiet, r_quiet) = band(300, 500, 3.0, 0.1), band(1000, 4000, -3.0, 0.01)
    track = extract_itds(l_loud + l_quiet, r_loud + r_quiet, 16000, method="correlogram-robust", **CUES_OFF)
    assert np.median(track.itds_s) * 16000 == pytest.approx(-3.0, abs=0.5)


def test_a_frames_height_is_the_peak_of_its_own_correlation() -> None:
    rng = np.random.default_rng(3)
    frames = 0.1 * rng.standard_normal((2, 6, 512))
    frames[0] += np.roll(frames[1], 2, axis=1)
    for power in (1.0, 3.0):
        method = make(frame_corr_power=power)
        terms = method.frame_terms(frames[0], frames[1], FrameState())
        _, heights = method.frame_itds(terms)
        correlation = terms["corr"] / terms["total"]  # the normalised correlation raised to the power
        np.testing.assert_allclose(heights, correlation.max(axis=1) ** (1 / power), rtol=1e-9)


def sound_field(cosines: np.ndarray, rng: np.random.Generator, seconds: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Left and right signals at 16 kHz of independent noises arriving as plane waves on the default pair (12 cm,
    343 m/s), one per direction cosine; many directions drawn uniformly in cosine make a diffuse (isotropic) field,
    whose coherence is sinc(2 f d / c)."""
    n = int(16000 * seconds)
    freqs = np.fft.rfftfreq(n, 1 / 16000)
    left, right = np.zeros(freqs.size, complex), np.zeros(freqs.size, complex)
    for cosine in cosines:
        spectrum = np.fft.rfft(rng.standard_normal(n))
        half_delay = 0.5 * 0.12 * cosine / 343.0
        left += spectrum * np.exp(-2j * np.pi * freqs * half_delay)
        right += spectrum * np.exp(2j * np.pi * freqs * half_delay)
    return np.fft.irfft(left, n), np.fft.irfft(right, n)


def test_the_diffuse_cue_weighs_a_diffuse_field_down_and_keeps_a_direct_sound() -> None:
    rng = np.random.default_rng(5)
    diffuse, direct = sound_field(rng.uniform(-1, 1, 200), rng), sound_field(np.array([0.5]), rng)

    def mean_weight(left: np.ndarray, right: np.ndarray) -> float:  # over in-band bins, after 100 ms
        weights = bin_weights(frames_of(left, 90), frames_of(right, 90), diffuse_power=2.0)
        return float(weights[10:, make().band > 0].mean())

    assert mean_weight(*diffuse) < 0.3  # the coherent-to-diffuse ratio near 0: direct share near 0
    assert mean_weight(*direct) > 0.99  # fully coherent: direct share 1


def test_subtracting_the_diffuse_part_lowers_a_diffuse_fields_correlation() -> None:
    left, right = sound_field(np.random.default_rng(5).uniform(-1, 1, 200), np.random.default_rng(6))
    heights = [np.median(extract_itds(left, right, 16000, method="gcc-phat-robust", energy_threshold=0.0,
                                      **{**CUES_OFF, "diffuse_subtract": subtract}).confidence)
               for subtract in (False, True)]
    assert heights[1] < 0.75 * heights[0]


def test_the_cues_multiply() -> None:
    # each cue's weight depends on the frames alone, so together they weigh each bin by their product
    rng = np.random.default_rng(2)
    left, right = sound_field(np.array([0.3, -0.6]), rng)
    gains = 1 + np.arange(40)[:, None] % 7  # levels changing from frame to frame
    frames = [frames_of(x, 40) * gains for x in (left, right)]
    cues = [{"frame_snr_power": 0.5}, {"over_subtraction": 1.0}, {"onset_floor": 0.2}, {"coherence_power": 2.0},
            {"diffuse_power": 2.0}, {"flatness_power": 0.5}]
    together = bin_weights(*frames, **{k: v for cue in cues for k, v in cue.items()})
    product = np.prod([bin_weights(*frames, **cue) for cue in cues], axis=0)
    np.testing.assert_allclose(together, product, rtol=1e-9, atol=1e-15)
    assert 0 < together[5:].mean() < product[5:].max()
    np.testing.assert_allclose(bin_weights(*frames, diffuse_power=0.5),  # and each is raised to its power
                               bin_weights(*frames, diffuse_power=2.0) ** 0.25, rtol=1e-9, atol=1e-12)


def test_a_silent_frame_weighs_nothing_with_the_coherence_cue() -> None:
    frames = 0.1 * np.random.default_rng(0).standard_normal((8, 512))
    frames[:3] = 0.0
    weights = bin_weights(frames, frames, coherence_power=2.0)
    assert np.all(weights[:3] == 0.0) and np.all(weights[3:].sum(axis=1) > 0)


def test_the_flatness_is_measured_over_the_band_only() -> None:
    # a click (flat) plus a hum at 10 Hz, below the band: still flat within the band, so weighed out
    click = np.zeros((1, 512))
    click[0, 256] = 1.0
    hum = 0.3 * np.cos(2 * np.pi * 10.0 * np.arange(512) / 16000)[None]
    assert frame_weights(click + hum, flatness_power=0.5)[0] < 0.1


def test_one_band_edge_cuts_the_correlation_into_two_pieces_of_the_same_sum() -> None:
    rng = np.random.default_rng(3)
    frames = 0.1 * rng.standard_normal((2, 6, 512))
    frames[0] += np.roll(frames[1], 2, axis=1)
    uncut = make(band_edges_hz=()).frame_terms(frames[0], frames[1], FrameState())["corr"]
    cut = make(band_edges_hz=(1600.0,)).frame_terms(frames[0], frames[1], FrameState())["corr"]
    np.testing.assert_allclose(cut, uncut, rtol=1e-9, atol=1e-15)


def test_a_band_without_weight_gives_no_peak() -> None:
    # an edge at 60 Hz makes a band of bins 0-3, all below the 80 Hz band: it never has weight
    left, right = sound_field(np.array([0.5]), np.random.default_rng(1), seconds=0.5)
    cut = PairStream(16000, method="gcc-phat-robust", frame_itds=True, band_edges_hz=(60.0,))
    cut.push(left, right)
    frames, bands = cut.pop_frame_itds(), cut.pop_band_itds()
    assert len(frames) > 0 and bands.times_s.tolist() == frames.times_s.tolist()


def test_a_dereverberated_silent_frame_stays_silent_and_one_tap_is_used() -> None:
    # after an echoing stretch the predictor predicts sound; a silent frame's error would be that prediction: louder
    # than the frame, so the frame passes unchanged (zero)
    method = make(dereverb_taps=1, dereverb_delay=2)
    rng = np.random.default_rng(3)
    left, right = dereverberated(method, echoing_spectra(method.n_used, 60, 59, rng))
    assert np.all(left[59] == 0) and np.all(right[59] == 0)
    frames = 0.1 * rng.standard_normal((2, 8, 512))
    with_tap = make(**{**CUES_OFF, "dereverb_taps": 1}).frame_terms(frames[0], frames[1], FrameState())["corr"]
    without = make(**CUES_OFF).frame_terms(frames[0], frames[1], FrameState())["corr"]
    np.testing.assert_allclose(with_tap[:2], without[:2], rtol=1e-9)  # nothing to predict from yet
    assert np.abs(with_tap[4:] - without[4:]).max() > 0.01 * np.abs(without).max()  # predicted from t - 2 on


def talker_over_steady_noise(gain: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(left, right, talk): 8 s at 16 kHz of a steady point noise 4 samples to the left (white, rms 0.1) and, from
    2 s, a talker 4 samples to the right in 0.6 s bursts every 1.5 s (white noise at ``gain`` times the noise's rms,
    its envelope swinging between 0.5 and 1 four times a second); ``talk`` marks each burst's middle 0.4 s."""
    fs, n = 16000, 8 * 16000
    rng = np.random.default_rng(1)
    noise_l, noise_r = delayed_noise(-4.0, n, rng)
    talk_l, talk_r = delayed_noise(4.0, n, rng)
    t = np.arange(n) / fs
    envelope = (((t % 1.5) < 0.6) & (t > 2.0)) * (0.5 + 0.5 * np.sin(2 * np.pi * 4 * t) ** 2)
    talk = ((t % 1.5) > 0.1) & ((t % 1.5) < 0.5) & (t > 2.0)
    return noise_l + gain * envelope * talk_l, noise_r + gain * envelope * talk_r, talk


def test_a_steady_noises_cross_spectrum_subtracted_gives_a_talker_as_loud_as_it_the_windows() -> None:
    # The phase transform gives every bin one vote: at equal power the steady noise holds every window of the talk.
    # Its cross-spectrum learnt in the noise's own frames and subtracted, the talker takes most of them.
    left, right, talk = talker_over_steady_noise(1.0)
    share = {}
    for seconds in (0.0, 1.0):
        track = extract_itds(left, right, 16000, method="gcc-phat-robust", noise_cross_s=seconds)
        talking = np.interp(track.times_s, np.arange(talk.size) / 16000, talk) > 0.5
        assert talking.sum() == 76 and np.isfinite(track.itds_s[talking]).all()
        share[seconds] = np.mean(np.abs(track.itds_s[talking] * 16000 - 4.0) < 1.0)
    assert share[0.0] == 0.0 and share[1.0] > 0.8


def test_a_talkers_own_frames_do_not_teach_the_noises_cross_spectrum() -> None:
    # A frame whose share above the noise floor reaches the gate (0.8) teaches nothing; the noise's own frames do.
    method = make(noise_cross_s=1.0)
    noise_l, noise_r = delayed_noise(-4.0, 4000, np.random.default_rng(2))
    talk_l, talk_r = delayed_noise(4.0, 4000, np.random.default_rng(3))
    state = FrameState()
    method.frame_terms(frames_of(noise_l, 5), frames_of(noise_r, 5), state)
    learnt = state.noise_cross.copy()
    assert np.abs(learnt).max() > 0
    loud = 10 * np.stack((frames_of(talk_l[800:], 3), frames_of(talk_r[800:], 3)))  # 20 dB over the noise
    method.frame_terms(loud[0], loud[1], state)
    np.testing.assert_array_equal(state.noise_cross, learnt)
    method.frame_terms(frames_of(noise_l[1600:], 1), frames_of(noise_r[1600:], 1), state)
    assert not np.array_equal(state.noise_cross, learnt)


def test_the_learnt_cross_spectrum_is_taken_out_of_each_bin_before_the_phase_transform() -> None:
    method = make(**{**CUES_OFF, "noise_cross_s": 1.0, "frame_corr_power": 0.0})  # the terms: each bin's phasor
    left, right = delayed_noise(3.0, 2400, np.random.default_rng(3))
    other_l, other_r = delayed_noise(-2.0, 2400, np.random.default_rng(4))
    spec = method.spectra(np.stack((frames_of(left, 1), frames_of(right, 1))) * method.taper)
    other = method.spectra(np.stack((frames_of(other_l, 1), frames_of(other_r, 1))) * method.taper)
    learnt = (other[0] * np.conj(other[1]))[0]
    terms = method.frame_terms(frames_of(left, 1), frames_of(right, 1), FrameState(noise_cross=learnt.copy()))
    residual = (spec[0] * np.conj(spec[1]))[0] - learnt
    np.testing.assert_allclose(terms["cross"][0], method.band * residual / np.abs(residual), atol=1e-9)
