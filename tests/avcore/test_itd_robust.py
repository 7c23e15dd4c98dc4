"""The frame methods' contract (avcore.itd.robust): their settings' bounds, band and defaults, as documented."""
from __future__ import annotations

import inspect
import re

import numpy as np
import pytest

from avcore.itd import RobustCorrelogram, RobustGccPhat, extract_itds
from avcore.itd.robust import FrameMethod, FrameState, _ratio


def make(**settings):
    """A gcc-phat-robust of 150 ms windows at 16 kHz, frames every 10 ms, as the stream builds it."""
    return RobustGccPhat(16000, 2400, 1e-3, **{"frame_hop_len": 160, **settings})


@pytest.mark.parametrize("settings", [
    {"frame_s": 16 / 16000}, {"frame_s": 1200 / 16000}, {"frame_hop_len": 1}, {"onset_floor": 0.0},
    {"onset_floor": 1.0}, {"coherence_power": 0.0, "diffuse_power": 0.0, "flatness_power": 0.0, "frame_snr_power": 0.0},
    {"speed_of_sound": 0.5}, {"low_hz": 0.0}, {"over_subtraction": 0.0}, {"dereverb_taps": 0, "dereverb_delay": 1},
    {"dereverb_step": 1.999}, {"noise_rise_db_per_s": 0.5},
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
                                   "> 0; got 1.0, 0.0, 0.03, 0.03"),
    ({"smoothing_s": 0.0}, "over_subtraction must be >= 0 and noise_rise_db_per_s, smoothing_s, coherence_s > 0; "
                           "got 1.0, 3.0, 0.0, 0.03"),
    ({"coherence_s": 0.0}, "over_subtraction must be >= 0 and noise_rise_db_per_s, smoothing_s, coherence_s > 0; "
                           "got 1.0, 3.0, 0.03, 0.0"),
    ({"dereverb_delay": 0}, "dereverb_taps must be an integer >= 0, dereverb_delay an integer >= 1 and dereverb_step "
                            "in (0, 2), got 3, 0 and 0.2"),
    ({"dereverb_step": 0.0}, "dereverb_taps must be an integer >= 0, dereverb_delay an integer >= 1 and "
                             "dereverb_step in (0, 2), got 3, 2 and 0.0"),
    ({"low_hz": 7990.0, "high_hz": 7995.0}, "no frequency bin lies in [7990.0, 7995.0] Hz at 16000.0 Hz"),
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
    with pytest.raises(NotImplementedError, match=r"^frame methods run through ItdStream; use frame_terms and "
                                                  r"finish_window$"):
        method.weighted_cross_spectrum(spectrum, spectrum)
    with pytest.raises(NotImplementedError, match=r"^frame methods run through ItdStream \(extract_itds does that "
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
        "dereverb_step": 0.2,
    }
    assert inspect.signature(RobustCorrelogram.__init__).parameters["n_channels"].default == 32
    own = inspect.signature(RobustGccPhat.__init__).parameters
    assert {name: own[name].default for name in ("flatness_power", "frame_snr_power", "frame_corr_power",
                                                  "dereverb_taps", "band_edges_hz")} == {
        "flatness_power": 8.0, "frame_snr_power": 8.0, "frame_corr_power": 2.0, "dereverb_taps": 3,
        "band_edges_hz": (800.0, 1600.0, 2600.0)}


def test_band_edges_must_be_finite_increasing_frequencies() -> None:
    assert make(band_edges_hz=(800.0, 800.5)).frame_corr_power == 2.0  # half a hertz apart is increasing
    for edges in [(800.0, 800.0), (1600.0, 800.0), (800.0, float("nan")), ((800.0, 1600.0),)]:
        with pytest.raises(ValueError, match=f"^band_edges_hz must be increasing frequencies in Hz, got "
                                             f"{re.escape(repr(edges))}$"):
            make(band_edges_hz=edges)


def test_a_delay_near_the_end_of_the_search_is_found() -> None:
    # max_itd_s of 3 samples: the frames' lag grid (quarter samples) must reach +-3 samples. (The parabola's vertex
    # stays within half a step of an inner grid point, so delays past 2.875 samples read as 2.875.)
    rng = np.random.default_rng(4)
    right = 0.1 * rng.standard_normal(16000)
    freqs = np.fft.rfftfreq(16000)
    for delay in (2.8, -2.8):
        left = np.fft.irfft(np.fft.rfft(right) * np.exp(-2j * np.pi * freqs * delay), 16000)
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
            "diffuse_subtract": False, "flatness_power": 0.0, "frame_snr_power": 0.0, "dereverb_taps": 0}
RISE = 10 ** (3.0 * 0.010 / 10)  # the noise floor's rise per 10 ms frame at the default 3 dB/s


def steady_then_louder(n_frames: int = 10, louder_from: int = 5) -> np.ndarray:
    """(n, 512) frames of a signal periodic over one frame hop (every frame has the same spectrum), twice as loud
    (four times the power) from frame ``louder_from`` on."""
    period = 0.1 * np.random.default_rng(0).standard_normal(160)
    signal = np.tile(period, n_frames + 4)
    frames = np.stack([signal[i * 160:i * 160 + 512] for i in range(n_frames)])
    gain = np.where(np.arange(n_frames) >= louder_from, 2.0, 1.0)
    return frames * gain[:, None]


def frame_weights(frames_left: np.ndarray, frames_right: np.ndarray | None = None, **cue) -> np.ndarray:
    """Each frame's total weight with one cue on, over its total weight with every cue off."""
    right = frames_left if frames_right is None else frames_right
    alone = make(**{**CUES_OFF, **cue}).frame_terms(frames_left, right, FrameState())["total"][:, 0]
    plain = make(**CUES_OFF).frame_terms(frames_left, right, FrameState())["total"][:, 0]
    return alone / plain


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

    def bin_weights(power: float) -> np.ndarray:  # frame_corr_power 0: the terms hold each bin's weight
        method = make(**{**CUES_OFF, "coherence_power": power, "frame_corr_power": 0.0})
        return method.frame_terms(left, other, FrameState())["weight"]

    np.testing.assert_allclose(bin_weights(0.5), bin_weights(2.0) ** 0.25, rtol=1e-9, atol=1e-12)
