from __future__ import annotations

import inspect
import re

import numpy as np
import pytest
import scipy.fft
from hypothesis import given, settings
from hypothesis import strategies as st

from avcore.gammatone import erb_space_hz, gammatone_power_response
from avcore.geometry import MicPair
from avcore.itd import METHODS, ItdTrack, extract_itds, make_method
from avcore.itd._extract import PairStream

ALL_METHODS = ["correlogram", "gcc-phat", "correlogram-robust", "gcc-phat-robust"]


def delayed_pair(delay_samples: float, fs: int, seconds: float = 1.0, seed: int = 0, level: float = 0.1):
    """Left = right delayed by ``delay_samples`` (fractional, exact: a phase ramp on a periodic noise signal).

    Left lagging means the sound reached the right microphone first: ITD = t_left - t_right = +delay.
    """
    rng = np.random.default_rng(seed)
    n = int(seconds * fs)
    right = level * rng.standard_normal(n)
    freqs = np.fft.rfftfreq(n)
    left = np.fft.irfft(np.fft.rfft(right) * np.exp(-2j * np.pi * freqs * delay_samples), n)
    return left, right


def test_registry_holds_the_two_methods_and_their_improved_forms():
    assert set(ALL_METHODS) <= set(METHODS)


def test_public_signature_and_paper_defaults():
    sig = inspect.signature(extract_itds)
    assert list(sig.parameters)[:8] == ["left", "right", "samplerate", "method", "window_s", "hop_s",
                                        "energy_threshold", "max_itd_s"]
    assert sig.parameters["window_s"].default == 0.15  # paper, Implementation Details: W = 150 ms
    assert sig.parameters["hop_s"].default == 0.02  # f = 20 ms
    assert sig.parameters["energy_threshold"].default == 1e-3  # E_A = 0.001
    assert sig.parameters["method"].default == "correlogram"


def test_every_form_has_the_same_defaults() -> None:
    whole = inspect.signature(extract_itds).parameters
    shared = ["method", "window_s", "hop_s", "energy_threshold", "max_itd_s", "min_confidence"]
    for form in (make_method, PairStream.__init__):
        params = inspect.signature(form).parameters
        assert [params[name].default for name in shared] == [whole[name].default for name in shared], form


@pytest.mark.parametrize("args,error,message", [
    ((16000, "gcc-phat", "0.15"), TypeError, "window_s must be a number of seconds, got str"),
    (("16000",), TypeError, "samplerate must be a number of hertz, got str"),
    ((True,), TypeError, "samplerate must be a number of hertz, got bool"),
    ((-16000,), ValueError, "samplerate must be a positive number of hertz, got -16000"),
    ((16000, "gcc-phat", 0.0), ValueError, "window_s must be a positive number of seconds, got 0.0"),
    ((16000, "gcc-phat", 0.15, float("nan")), ValueError, "hop_s must be a positive number of seconds, got nan"),
    ((16000, "gcc-phat", 0.15, 0.02, 1e-3, -1e-3), ValueError, "max_itd_s must be a positive number of seconds, "
                                                                "got -0.001"),
])
def test_each_wrong_length_or_rate_is_named_with_its_unit(args: tuple, error: type, message: str) -> None:
    with pytest.raises(error, match=f"^{re.escape(message)}$"):
        make_method(*args)


def test_each_shared_setting_is_accepted_at_its_edge_and_named_in_full_past_it() -> None:
    # accepted: a window of 16 samples with lags up to 7 (2 x 7 < 16), a hop of one sample, confidence bounds 1 and -1
    impl, framing = make_method(16000, "gcc-phat", 16 / 16000, 1 / 16000, 0.0, 6.9 / 16000, 1.0)
    assert (framing.window_len, framing.hop_len, impl.max_lag, framing.min_confidence) == (16, 1, 7, 1.0)
    assert make_method(16000, "gcc-phat", 0.15, 0.02, 1e-3, 1e-3, -1.0)[1].min_confidence == -1.0
    # frames every half hop when the hop is even, every hop when it is odd (the windows start on the frames' grid)
    assert make_method(16000, "gcc-phat-robust", 0.15, 320 / 16000, 1e-3, 1e-3, -1.0)[0].frame_hop == 160
    assert make_method(16000, "gcc-phat-robust", 0.15, 321 / 16000, 1e-3, 1e-3, -1.0)[0].frame_hop == 321
    wrong = [
        ((0.15, 0.02, True, 1e-3, -1.0), "energy_threshold must be a non-negative mean power, got True"),
        ((0.15, 0.02, float("nan"), 1e-3, -1.0), "energy_threshold must be a non-negative mean power, got nan"),
        ((0.15, 0.02, 1e-3, 1e-3, -1.5), "min_confidence must lie in [-1, 1], got -1.5"),
        ((0.15, 0.02, 1e-3, 1e-3, 1.5), "min_confidence must lie in [-1, 1], got 1.5"),
        ((15 / 16000, 0.02, 1e-3, 1e-4, -1.0), "window_s=0.0009375 s is only 15 samples at 16000.0 Hz; use a longer "
                                               "window"),
        ((0.15, 0.4 / 16000, 1e-3, 1e-3, -1.0), "hop_s=2.5e-05 s is shorter than one sample at 16000.0 Hz"),
        ((16 / 16000, 0.02, 1e-3, 7.9 / 16000, -1.0), "max_itd_s=0.00049375 s (8 samples) needs a window longer than "
                                                      "16 samples, got window_s=0.001 s (16 samples)"),
    ]
    for args, message in wrong:
        with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
            make_method(16000, "gcc-phat", *args)


@pytest.mark.parametrize("method", ALL_METHODS)
@pytest.mark.parametrize("fs,delay", [(16000, 3.0), (16000, -2.37), (16000, 0.0), (48000, 7.61), (48000, -11.0)])
def test_pure_delays_recovered_within_a_tenth_of_a_sample(method, fs, delay):
    left, right = delayed_pair(delay, fs, seconds=0.6)
    track = extract_itds(left, right, fs, method=method)
    assert len(track) == 1 + (len(left) - int(0.15 * fs)) // int(0.02 * fs)
    np.testing.assert_allclose(track.itds_s * fs, delay, atol=0.1)


@pytest.mark.parametrize("method", ALL_METHODS)
def test_sign_agrees_with_micpair_in_both_channel_orders(method):
    fs = 16000
    mics = MicPair(left=(-0.06, 0, 0), right=(0.06, 0, 0))
    source_on_right = np.array([1.0, 0.0, 1.5])
    itd = float(mics.itd(source_on_right))
    assert itd > 0
    left, right = delayed_pair(itd * fs, fs, seconds=0.5)
    forward = extract_itds(left, right, fs, method=method)
    swapped = extract_itds(right, left, fs, method=method)
    assert np.all(forward.itds_s > 0)
    np.testing.assert_allclose(forward.itds_s, itd, atol=0.1 / fs)
    np.testing.assert_allclose(swapped.itds_s, -itd, atol=0.1 / fs)


@settings(max_examples=15, deadline=None)
@given(delay=st.floats(-12.0, 12.0), seed=st.integers(0, 1000), method=st.sampled_from(["correlogram", "gcc-phat"]))
def test_swapping_channels_negates_the_itd(delay, seed, method):
    fs = 16000
    left, right = delayed_pair(delay, fs, seconds=0.3, seed=seed)
    a = extract_itds(left, right, fs, method=method)
    b = extract_itds(right, left, fs, method=method)
    np.testing.assert_allclose(a.itds_s, -b.itds_s, atol=0.02 / fs)


@pytest.mark.parametrize("method", ALL_METHODS)
def test_silence_and_sub_threshold_windows_yield_nothing(method):
    fs = 16000
    silence = np.zeros(fs)
    assert len(extract_itds(silence, silence, fs, method=method)) == 0
    quiet_l, quiet_r = delayed_pair(2.0, fs, level=0.01)  # mean power 1e-4 < E_A = 1e-3
    assert len(extract_itds(quiet_l, quiet_r, fs, method=method)) == 0
    # loud second half: only windows lying wholly in it... or mostly in it pass the gate
    loud_l, loud_r = delayed_pair(2.0, fs, level=0.1)
    left = np.concatenate([quiet_l, loud_l])
    right = np.concatenate([quiet_r, loud_r])
    track = extract_itds(left, right, fs, method=method)
    assert len(track) > 0
    assert np.all(track.times_s > 0.9)
    assert np.all(track.energy >= 1e-3)


def test_times_are_window_centres_on_the_hop_grid():
    fs = 16000
    left, right = delayed_pair(1.0, fs, seconds=1.0)
    track = extract_itds(left, right, fs, method="gcc-phat", window_s=0.1, hop_s=0.025)
    np.testing.assert_allclose(track.times_s, 0.05 + 0.025 * np.arange(len(track)))


def test_min_confidence_drops_windows_and_confidence_is_bounded():
    fs = 16000
    rng = np.random.default_rng(3)
    left, right = rng.standard_normal((2, fs)) * 0.1  # independent channels: no coherent peak
    all_windows = extract_itds(left, right, fs, method="correlogram")
    assert np.all(np.abs(all_windows.confidence) <= 1)
    kept = extract_itds(left, right, fs, method="correlogram", min_confidence=0.5)
    assert len(kept) < len(all_windows)


@pytest.mark.parametrize("method", ALL_METHODS)
def test_streaming_equals_batch(method):
    fs = 16000
    left, right = delayed_pair(-4.2, fs, seconds=1.5, seed=5)
    left[: fs // 3] *= 0.05  # a quiet stretch: the energy gate skips windows in both forms
    batch = extract_itds(left, right, fs, method=method)
    stream = PairStream(fs, method=method)
    rng = np.random.default_rng(1)
    parts, i = [], 0
    while i < len(left):
        n = int(rng.choice([1, 7, 160, 333, 2400, 5000]))
        parts.append(stream.push(left[i:i + n], right[i:i + n]))
        i += n
    streamed = ItdTrack.concatenate(parts)
    assert stream.samples_seen == len(left)
    np.testing.assert_array_equal(streamed.times_s, batch.times_s)
    np.testing.assert_allclose(streamed.itds_s, batch.itds_s, rtol=0, atol=1e-12)
    np.testing.assert_allclose(streamed.confidence, batch.confidence, rtol=0, atol=1e-9)


def test_stream_push_stereo_block():
    fs = 16000
    left, right = delayed_pair(2.0, fs, seconds=0.5)
    stream = PairStream(fs, method="gcc-phat")
    track = stream.push_stereo(np.stack([left, right], axis=1))
    np.testing.assert_allclose(track.itds_s * fs, 2.0, atol=0.1)
    with pytest.raises(ValueError, match=r"shape \(n, 2\)"):
        stream.push_stereo(np.zeros((10, 3)))


@pytest.mark.parametrize("bad,match", [(np.nan, "NaN or infinite"), (np.inf, "NaN or infinite")])
def test_nan_and_inf_are_errors(bad, match):
    left, right = delayed_pair(1.0, 16000, seconds=0.3)
    left[100] = bad
    with pytest.raises(ValueError, match=match):
        extract_itds(left, right, 16000)
    with pytest.raises(ValueError, match=match):
        PairStream(16000).push(left, right)


def test_bad_inputs_are_clear_errors():
    fs = 16000
    left, right = delayed_pair(1.0, fs, seconds=0.3)
    with pytest.raises(ValueError, match="same length"):
        extract_itds(left, right[:-1], fs)
    with pytest.raises(ValueError, match="1-D array"):
        extract_itds(np.stack([left, right]), right, fs)
    with pytest.raises(ValueError, match="shorter than one window"):
        extract_itds(left[:1000], right[:1000], fs)
    with pytest.raises(ValueError, match="method must be one of"):
        extract_itds(left, right, fs, method="music")
    with pytest.raises(ValueError, match="window_s must be a positive"):
        extract_itds(left, right, fs, window_s=-0.1)
    with pytest.raises(ValueError, match="max_itd_s"):
        extract_itds(left, right, fs, window_s=0.01, max_itd_s=0.01)
    with pytest.raises(ValueError, match="energy_threshold"):
        extract_itds(left, right, fs, energy_threshold=-1.0)
    with pytest.raises(TypeError, match="samplerate"):
        extract_itds(left, right, "16000")
    with pytest.raises(TypeError, match="does not take these options"):
        extract_itds(left, right, fs, method="gcc-phat", n_channels=16)


@pytest.mark.parametrize("method", ["gcc-phat", "gcc-phat-robust"])
def test_a_signal_of_exactly_one_window_gives_its_itd_at_once(method: str) -> None:
    # 0.15 s at 16 kHz is 2400 samples: exactly one window, in the whole-signal form and in the push that brings it.
    left, right = delayed_pair(3.0, 16000, seconds=0.15)
    whole = extract_itds(left, right, 16000, method=method)
    pushed = PairStream(16000, method=method).push(left, right)
    for track in (whole, pushed):
        assert track.times_s.tolist() == [0.075]
        assert track.itds_s[0] == pytest.approx(3.0 / 16000, abs=0.2 / 16000)


def test_unequal_channels_are_named_in_full() -> None:
    left, right = delayed_pair(1.0, 16000, seconds=0.3)
    with pytest.raises(ValueError, match=r"^left and right must have the same length, got 4800 and 4799 samples$"):
        extract_itds(left, right[:-1], 16000)
    with pytest.raises(ValueError, match=r"^left and right blocks must have the same length, got 10 and 9 samples$"):
        PairStream(16000).push(left[:10], right[:9])


def test_samples_of_any_real_dtype_are_read_as_float_and_others_are_named_in_full() -> None:
    left, right = delayed_pair(2.0, 16000, seconds=0.3)
    as_int = (np.round(left * 30000).astype(np.int16), np.round(right * 30000).astype(np.int16))
    from_int = extract_itds(*as_int, 16000, method="gcc-phat", energy_threshold=0.0)
    from_float = extract_itds(*(a.astype(np.float64) for a in as_int), 16000, method="gcc-phat",
                              energy_threshold=0.0)
    for field in ("times_s", "itds_s", "confidence", "energy"):  # int16 squares would overflow unconverted
        np.testing.assert_array_equal(getattr(from_int, field), getattr(from_float, field))
    with pytest.raises(TypeError, match=r"^left must hold real samples, got dtype complex128$"):
        extract_itds(left + 0j, right, 16000)
    with pytest.raises(TypeError, match=r"^right must hold real samples, got dtype <U1$"):
        extract_itds(left, np.array(["a"] * right.size), 16000)
    with pytest.raises(ValueError, match=r"^left must be a 1-D array of samples, got shape \(1, 4800\)$"):
        PairStream(16000).push(left[None], right)
    left[[5, 9]] = [np.nan, -np.inf]
    with pytest.raises(ValueError, match=r"^left holds 2 NaN or infinite sample\(s\); clean the audio before "):
        extract_itds(left, right, 16000)


def test_the_energy_gate_keeps_a_window_at_exactly_e_a_and_only_silence_at_zero() -> None:
    # Samples of +-0.5: every window's mean power is exactly 0.25.
    right = 0.5 * np.sign(np.random.default_rng(0).standard_normal(8000))
    left = np.roll(right, 3)
    n_windows = 1 + (8000 - 2400) // 320
    assert len(extract_itds(left, right, 16000, method="gcc-phat", energy_threshold=0.25)) == n_windows
    assert len(extract_itds(left, right, 16000, method="gcc-phat", energy_threshold=0.2500001)) == 0
    # E_A = 0 keeps every window that is not silent, however faint
    left[:4000], right[:4000] = 0.0, 0.0
    left[4000:] *= 1e-3
    right[4000:] *= 1e-3
    faint = extract_itds(left, right, 16000, method="gcc-phat", energy_threshold=0.0)
    assert faint.times_s.tolist() == [(s + 1200) / 16000 for s in range(0, 8000 - 2399, 320) if s + 2400 > 4000]


def test_a_window_at_exactly_the_least_confidence_is_kept() -> None:
    left, right = delayed_pair(2.0, 16000, seconds=0.5)
    everything = extract_itds(left, right, 16000, method="gcc-phat")
    least = int(np.argmin(everything.confidence))
    kept = extract_itds(left, right, 16000, method="gcc-phat", min_confidence=float(everything.confidence[least]))
    assert kept.times_s.tolist() == everything.times_s.tolist()


@pytest.mark.parametrize("asked", ["frame_itds", "frame_bins"])
def test_frame_results_of_a_method_without_frames_are_named_in_full(asked: str) -> None:
    with pytest.raises(ValueError, match=rf"^{asked} needs the per-frame correlations of 'gcc-phat-robust' "
                                         rf"\(frame_corr_power > 0\); method 'gcc-phat' has none: pass {asked}=False$"):
        PairStream(16000, method="gcc-phat", **{asked: True})


def test_lag_search_is_limited_to_max_itd():
    fs = 16000
    left, right = delayed_pair(12.0, fs, seconds=0.5)  # 750 us, outside +-300 us
    track = extract_itds(left, right, fs, method="gcc-phat", max_itd_s=3e-4)
    assert np.all(np.abs(track.itds_s) <= 3e-4 + 1e-12)


def test_erb_spacing_and_gammatone_response():
    centres = erb_space_hz(80.0, 5000.0, 32)
    assert centres.shape == (32,)
    np.testing.assert_allclose([centres[0], centres[-1]], [80.0, 5000.0])
    assert np.all(np.diff(centres) > 0)
    freqs = np.linspace(0, 8000, 4001)
    response = gammatone_power_response(centres, freqs)
    np.testing.assert_allclose(response.max(axis=1), 1.0)
    peaks = freqs[np.argmax(response, axis=1)]
    np.testing.assert_allclose(peaks, centres, atol=8.0)
    # one ERB away from the centre a 4th-order gammatone is down by (1 + (1/1.019)^2)^-4, about -11.7 dB
    i = np.argmin(np.abs(freqs - (1000 + 24.7 * (4.37 + 1))))
    one_erb = gammatone_power_response(np.array([1000.0]), freqs)[0, i]
    assert 10 * np.log10(one_erb) == pytest.approx(-11.7, abs=0.6)


@pytest.mark.parametrize("options,match", [
    ({"frame_s": 0.1}, "frame_s"),
    ({"onset_floor": 2.0}, "onset_floor"),
    ({"coherence_power": -1.0}, "coherence_power"),
    ({"flatness_power": -1.0}, "flatness_power"),
    ({"frame_snr_power": -1.0}, "frame_snr_power"),
    ({"mic_distance_m": 0.0}, "mic_distance_m"),
    ({"low_hz": 5000.0, "high_hz": 100.0}, "low_hz"),
    ({"frame_corr_power": -1.0}, "frame_corr_power"),
    ({"dereverb_taps": -1}, "dereverb_taps"),
    ({"dereverb_taps": 1.5}, "dereverb_taps"),
    ({"dereverb_delay": 0}, "dereverb_delay"),
    ({"dereverb_step": 2.0}, "dereverb_step"),
])
def test_robust_options_are_validated(options, match):
    left, right = delayed_pair(1.0, 16000, seconds=0.3)
    with pytest.raises(ValueError, match=match):
        extract_itds(left, right, 16000, method="gcc-phat-robust", **options)


def test_robust_stream_with_odd_hop_uses_frames_on_the_hop_grid():
    fs = 16000
    left, right = delayed_pair(2.5, fs, seconds=0.8)
    track = extract_itds(left, right, fs, method="correlogram-robust", hop_s=0.0150625)  # 241 samples: odd
    np.testing.assert_allclose(track.itds_s * fs, 2.5, atol=0.1)
    np.testing.assert_allclose(np.diff(track.times_s), 241 / fs)


@pytest.mark.parametrize("method", ["gcc-phat", "gcc-phat-robust", "correlogram"])
def test_lag_search_by_matrix_product_equals_the_inverse_fft(method):
    """Where few bins and lags are used, the integer lags come from one matrix product instead of an inverse FFT
    of the padded spectrum; both must pick the same peak."""
    fs = 16000
    rng = np.random.default_rng(7)
    left, right = rng.standard_normal((2, fs)) * 0.1  # independent channels: a peak anywhere, ties unlikely
    left += np.roll(right, 3)
    fast = PairStream(fs, method=method)
    slow = PairStream(fs, method=method)
    slow._impl._lag_table = None  # force the inverse-FFT search
    a, b = fast.push(left, right), slow.push(left, right)
    assert len(a) == len(b) > 0
    np.testing.assert_allclose(a.itds_s, b.itds_s, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.confidence, b.confidence, rtol=0, atol=1e-9)
    # not only the same peak: the product is the inverse FFT's correlation at every lag (DC and Nyquist folded once)
    impl = fast._impl
    if impl._lag_table is None:  # the correlogram's full band: the inverse FFT is the cheaper search there
        assert method == "correlogram"
        return
    weighted = rng.standard_normal((3, impl.n_used)) + 1j * rng.standard_normal((3, impl.n_used))
    weighted[:, 0] = weighted[:, 0].real
    if impl.n_used == impl.nfft // 2 + 1 and impl.nfft % 2 == 0:
        weighted[:, -1] = weighted[:, -1].real
    corr = scipy.fft.irfft(weighted, n=impl.nfft, axis=-1)[:, impl._lags]
    np.testing.assert_allclose((weighted @ impl._lag_table).real, corr, rtol=0, atol=1e-12)


def test_parabolic_peak_finds_a_parabolas_vertex_and_not_a_slopes() -> None:
    from avcore.itd._base import parabolic_peak

    x = np.arange(8.0)
    top, j, shift = parabolic_peak(np.vstack([-(x - 3.3) ** 2, x, [0.0, 2.0, 3.0, 3.5, 0, 0, 0, -5]]))
    assert top.tolist() == [3, 7, 3] and j.tolist() == [3, 6, 3]  # the slope's top kept one point off the end
    assert shift[0] == pytest.approx(0.3, abs=1e-12)  # three samples of a parabola: its vertex exactly
    assert shift[1] == 0.0  # a straight line does not curve down: no vertex
    assert shift[2] == -0.375  # 0.5 * (3 - 0) / (3 - 2 * 3.5 + 0): a vertex inside, not held
    top, j, shift = parabolic_peak(np.array([[2.0, 3.0, 3.5]]))
    assert (top[0], j[0], shift[0]) == (2, 1, 0.5)  # vertex 1.5 steps from j: held at half a step


@pytest.mark.parametrize("window_len", [960, 2400])
@pytest.mark.parametrize("delay", [0.3, -0.41, 2.17])
def test_sub_sample_delays_to_a_two_hundredth_of_a_sample(window_len: int, delay: float) -> None:
    """The band-limited correlation on its 1/16-sample grid and the parabola through its top: within 0.006 samples
    of an exact fractional delay (the grid alone is within 1/32; a parabola bent the wrong way, or stepped twice,
    misses by 0.0125 or more)."""
    from avcore.itd.gcc_phat import GccPhat

    fs = 16000
    left, right = delayed_pair(delay, fs, seconds=4.0, seed=3)
    g = GccPhat(fs, window_len, 5e-4)
    itd, confidence = g.estimate(left[None, 5000:5000 + window_len], right[None, 5000:5000 + window_len])
    assert abs(itd[0] * fs - delay) < 0.006 and 0.5 < confidence[0] <= 1.0


def test_the_lag_search_reaches_max_itd_and_the_padding_never_wraps() -> None:
    from avcore.itd.gcc_phat import GccPhat

    fs = 16000
    left, right = delayed_pair(8.0, fs, seconds=1.0)  # 500 us: the edge of a search of +-500 us (8 samples)
    g = GccPhat(fs, 960, 5e-4)
    itd, _ = g.estimate(left[None, 2000:2960], right[None, 2000:2960])
    assert g.max_lag == 8 and itd[0] == pytest.approx(5e-4, abs=0.05 / fs)
    for window_len in range(200, 1200):  # the zero padding holds every searched lag without wrapping around
        g = GccPhat(fs, window_len, 5e-4)
        assert g.nfft >= window_len + g.max_lag + 1


@pytest.mark.parametrize("window_len", [1015, 1206])  # nfft 1024 (even: a Nyquist bin) and 1215 (odd: none)
def test_the_rfft_fold_keeps_parseval(window_len: int) -> None:
    """Summed with the fold, an rfft's bins give the frame's energy: DC (and Nyquist, when nfft is even) once, every
    other bin twice, over nfft."""
    from avcore.itd.gcc_phat import GccPhat

    g = GccPhat(16000, window_len, 5e-4)
    assert g.nfft == {1015: 1024, 1206: 1215}[window_len]
    frame = np.random.default_rng(1).standard_normal(window_len)
    spectrum = scipy.fft.rfft(frame, n=g.nfft)
    assert np.sum(g._fold * np.abs(spectrum) ** 2) == pytest.approx(np.sum(frame ** 2), rel=1e-12)


def test_band_up_to_nyquist_and_empty_band():
    fs = 16000
    left, right = delayed_pair(2.0, fs, seconds=0.5)
    track = extract_itds(left, right, fs, method="gcc-phat", high_hz=fs / 2)
    np.testing.assert_allclose(track.itds_s * fs, 2.0, atol=0.1)
    with pytest.raises(ValueError, match="no frequency bin"):
        extract_itds(left, right, fs, method="gcc-phat", low_hz=9000.0, high_hz=9500.0)


def test_frame_cues_favour_the_peaky_talker_over_flat_noise_bursts():
    """A voiced talker (harmonic complex, ITD +3 samples) pauses every other 40 ms; in the pauses, loud bursts of
    white noise come from the other side (-5 samples). The frame cues let the talker's frames dominate the windows
    (here the spectral flatness: the bursts are too brief for the noise floor); without them the bursts win."""
    fs = 16000
    n = 2 * fs
    rng = np.random.default_rng(11)
    t = np.arange(n) / fs
    f0 = 140 + 10 * np.sin(2 * np.pi * 0.5 * t)
    phase = 2 * np.pi * np.cumsum(f0) / fs
    voiced = sum(np.sin(h * phase) / h for h in range(1, 25))
    on = (np.floor(t / 0.04) % 2 == 0).astype(float)
    talker = 0.1 * voiced * on
    bursts = 0.2 * rng.standard_normal(n) * (1 - on)
    left = np.roll(talker, 3) + np.roll(bursts, -5)
    right = talker + bursts
    left += 0.003 * rng.standard_normal(n)
    right += 0.003 * rng.standard_normal(n)
    with_cues = extract_itds(left, right, fs, method="gcc-phat-robust")
    without = extract_itds(left, right, fs, method="gcc-phat-robust", flatness_power=0, frame_snr_power=0)
    near_with = np.mean(np.abs(with_cues.itds_s * fs - 3) < 0.5)
    near_without = np.mean(np.abs(without.itds_s * fs - 3) < 0.5)
    assert near_with > 0.8
    assert near_with > near_without + 0.3


def test_a_steady_noise_from_one_side_does_not_take_a_talkers_windows():
    """A voiced talker (ITD +3 samples) speaks in syllables (0.3 s in every 0.5 s) over a steady white noise from the
    other side (-5 samples) 10 dB under the talker's power. The phase transform gives every bin one vote and the
    running minimum lies below the noise's mean, so at a subtraction of 1 the noise wins most of the talker's
    windows; at the default 3 the talker does, and so it does at 1 once the noise's cross-spectrum is subtracted."""
    fs = 16000
    n = 6 * fs
    rng = np.random.default_rng(5)
    t = np.arange(n) / fs
    phase = 2 * np.pi * np.cumsum(130 + 20 * np.sin(2 * np.pi * 0.7 * t)) / fs
    talker = sum(np.sin(h * phase) / h for h in range(1, 25)) * ((t % 0.5) < 0.3)
    noise = rng.standard_normal(n)
    noise *= np.sqrt(np.mean(talker[(t % 0.5) < 0.3] ** 2) / np.mean(noise**2) / 10)
    left, right = np.roll(talker, 3) + np.roll(noise, -5), talker + noise

    def near(track, delay):  # windows wholly inside a syllable, after the noise floor has settled
        inside = ((track.times_s % 0.5) > 0.1) & ((track.times_s % 0.5) < 0.2) & (track.times_s > 1.0)
        return np.mean(np.abs(track.itds_s[inside] * fs - delay) < 0.5)

    # the floor alone (the noise's learnt cross-spectrum off): once against three times
    thrice = extract_itds(left, right, fs, method="gcc-phat-robust", noise_cross_s=0.0)
    once = extract_itds(left, right, fs, method="gcc-phat-robust", over_subtraction=1.0, noise_cross_s=0.0)
    assert near(once, -5) > near(once, 3)
    assert near(thrice, 3) > 0.5 > 0.2 > near(thrice, -5)
    assert near(thrice, 3) > near(once, 3) + 0.25
    # the noise's cross-spectrum subtracted gives the talker its windows at a subtraction of 1 as well
    crossed = extract_itds(left, right, fs, method="gcc-phat-robust", over_subtraction=1.0)
    assert near(crossed, 3) > 0.5 > 0.2 > near(crossed, -5)


def test_robust_gcc_phat_earlier_forms_are_options():
    """Summing the frames' cross-spectra (frame_corr_power=0) and no dereverberation: the method before them."""
    fs = 16000
    left, right = delayed_pair(-2.6, fs, seconds=0.6, seed=4)
    for options in ({"frame_corr_power": 0, "dereverb_taps": 0},
                    {"frame_corr_power": 1}, {"dereverb_taps": 1, "dereverb_delay": 4}):
        track = extract_itds(left, right, fs, method="gcc-phat-robust", **options)
        np.testing.assert_allclose(track.itds_s * fs, -2.6, atol=0.1)
        assert np.all((track.confidence > 0.5) & (track.confidence <= 1))


def test_dereverberation_survives_digital_silence_and_near_silence():
    """The prediction filter adapts by normalised steps: zeros and a 1e-9 level stretch must not blow it up, and
    the ITD after them is exact; streaming equals batch through them."""
    fs = 16000
    a_l, a_r = delayed_pair(3.0, fs, seconds=0.5, seed=1)
    b_l, b_r = delayed_pair(-1.5, fs, seconds=0.8, seed=2)
    tiny_l, tiny_r = delayed_pair(-1.5, fs, seconds=0.5, seed=3, level=1e-9)
    zeros = np.zeros(fs)
    left = np.concatenate([a_l, zeros, tiny_l, b_l])
    right = np.concatenate([a_r, zeros, tiny_r, b_r])
    batch = extract_itds(left, right, fs, method="gcc-phat-robust")
    assert np.all(np.isfinite(batch.itds_s)) and np.all(np.isfinite(batch.confidence))
    last = batch.times_s > (len(left) - len(b_l) + 0.15 * fs) / fs  # windows wholly in the last stretch
    assert np.count_nonzero(last) >= 20
    np.testing.assert_allclose(batch.itds_s[last] * fs, -1.5, atol=0.1)
    stream = PairStream(fs, method="gcc-phat-robust")
    streamed = ItdTrack.concatenate([stream.push(left[i:i + 160], right[i:i + 160])
                                     for i in range(0, len(left), 160)])
    np.testing.assert_allclose(streamed.itds_s, batch.itds_s, rtol=0, atol=1e-12)


def test_dereverberation_weakens_a_late_echo_from_the_other_side():
    """Noise bursts (ITD +3 samples) and an equally loud echo 40 ms later from the other side (-5 samples): the
    linear prediction removes much of the echo, which is predictable from the past, so more windows find the
    direct sound."""
    fs = 16000
    rng = np.random.default_rng(2)
    n = 4 * fs
    t = np.arange(n) / fs
    source = 0.1 * rng.standard_normal(n) * (np.floor(t / 0.1) % 2 == 0)
    echo = np.concatenate([np.zeros(640), source[:-640]])
    left = np.roll(source, 3) + np.roll(echo, -5) + 0.001 * rng.standard_normal(n)
    right = source + echo + 0.001 * rng.standard_normal(n)
    near = {}
    for taps in (0, 3):
        track = extract_itds(left, right, fs, method="gcc-phat-robust", dereverb_taps=taps)
        near[taps] = np.mean(np.abs(track.itds_s * fs - 3) < 0.5)
    assert near[3] > near[0] + 0.03


def test_frame_itds_of_the_robust_stream():
    """Each 32 ms frame's own ITD, every 10 ms, for the frames that pass the energy gate; the same whatever the
    blocks; only gcc-phat-robust has them, and only when asked."""
    fs = 16000
    left, right = delayed_pair(3.0, fs, seconds=1.0, seed=2)
    left[: fs // 4] = 0.0
    right[: fs // 4] = 0.0  # a silent start: no frame ITD there
    whole = PairStream(fs, method="gcc-phat-robust", frame_itds=True)
    whole.push(left, right)
    frames = whole.pop_frame_itds()
    assert len(whole.pop_frame_itds()) == 0  # popped once
    assert frames.times_s[0] > 0.25 - 0.016 and frames.times_s[-1] <= 1.0 - 0.016 + 1e-9
    np.testing.assert_allclose(np.diff(frames.times_s), 0.01)
    assert len(frames) > 60
    assert np.median(np.abs(frames.itds_s - 3.0 / fs)) < 10e-6
    assert np.all((frames.confidence > 0) & (frames.confidence <= 1))
    pieces = PairStream(fs, method="gcc-phat-robust", frame_itds=True)
    parts = []
    for i in range(0, len(left), 333):
        pieces.push(left[i:i + 333], right[i:i + 333])
        parts.append(pieces.pop_frame_itds())
    streamed = ItdTrack.concatenate(parts)
    np.testing.assert_array_equal(streamed.times_s, frames.times_s)
    np.testing.assert_allclose(streamed.itds_s, frames.itds_s, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="frame_itds"):
        PairStream(fs, method="gcc-phat", frame_itds=True)
    with pytest.raises(ValueError, match="frame_itds"):
        PairStream(fs, method="gcc-phat-robust", frame_itds=True, frame_corr_power=0)
    with pytest.raises(RuntimeError, match="frame_itds=True"):
        PairStream(fs, method="gcc-phat-robust").pop_frame_itds()


def test_band_itds_of_the_robust_stream():
    """Each frame's bands (cut at 800, 1600 and 2600 Hz) give their own peak: up to four per frame that passes the
    gate, at the frame's time, at the source's ITD for broadband noise; the windows' ITDs are unchanged by the cut
    (the same product in pieces)."""
    fs = 16000
    left, right = delayed_pair(3.0, fs, seconds=1.0, seed=2)
    left[: fs // 4] = 0.0
    right[: fs // 4] = 0.0
    stream = PairStream(fs, method="gcc-phat-robust", frame_itds=True)
    windows = stream.push(left, right)
    frames, bands = stream.pop_frame_itds(), stream.pop_band_itds()
    assert len(stream.pop_band_itds()) == 0  # popped once
    assert len(frames) < len(bands) <= 4 * len(frames)
    assert set(np.round(bands.times_s, 6)) <= set(np.round(frames.times_s, 6))
    assert np.median(np.abs(bands.itds_s - 3.0 / fs)) < 16e-6  # within a step of the 1/4-sample grid
    one_band = PairStream(fs, method="gcc-phat-robust", frame_itds=True, band_edges_hz=())
    uncut = one_band.push(left, right)
    np.testing.assert_allclose(uncut.itds_s, windows.itds_s, rtol=0, atol=1e-9)
    assert len(one_band.pop_band_itds()) == len(one_band.pop_frame_itds())  # one band: one peak per frame
    with pytest.raises(ValueError, match="band_edges_hz"):
        PairStream(fs, method="gcc-phat-robust", band_edges_hz=(1600.0, 800.0))
    with pytest.raises(RuntimeError, match="frame_itds=True"):
        PairStream(fs, method="gcc-phat-robust").pop_band_itds()


def test_band_peaks_carry_no_height() -> None:
    left, right = delayed_pair(3.0, 16000, seconds=0.5, seed=2)
    stream = PairStream(16000, method="gcc-phat-robust", frame_itds=True)
    stream.push(left, right)
    bands = stream.pop_band_itds()
    assert len(bands) > 0 and bands.confidence.dtype == np.float64 and np.isnan(bands.confidence).all()


def test_a_robust_stream_analyses_each_frame_in_the_push_that_completes_it() -> None:
    # gcc-phat-robust at 16 kHz: 512-sample frames every 160 samples; a push of exactly one frame analyses it. (The
    # signal-to-noise cue off: steady white noise is its own noise floor, and three times the floor weighs it out.)
    left, right = delayed_pair(3.0, 16000, seconds=0.5, seed=2)
    stream = PairStream(16000, method="gcc-phat-robust", frame_itds=True, frame_bins=True, over_subtraction=0.0)
    assert len(stream.push(left[:512], right[:512])) == 0  # no window yet
    assert stream.pop_frame_itds().times_s.tolist() == [0.016]
    assert stream.pop_frame_bins()[0].tolist() == [0.016]
    stream.push(left[512:672], right[512:672])  # one frame hop more: the second frame
    assert stream.pop_frame_bins()[0].tolist() == [0.026]


def test_a_robust_stream_finishes_no_window_before_its_last_sample() -> None:
    # Windows of 2400 samples every 320: a push one sample short of the second window gives the first only, and
    # the next sample gives the second; both as the whole-signal extraction gives them.
    left, right = delayed_pair(3.0, 16000, seconds=0.5, seed=2)
    whole = extract_itds(left, right, 16000, method="gcc-phat-robust")
    stream = PairStream(16000, method="gcc-phat-robust")
    first = stream.push(left[:2719], right[:2719])
    second = stream.push(left[2719:2720], right[2719:2720])
    assert first.times_s.tolist() == [0.075] and second.times_s.tolist() == [0.095]
    np.testing.assert_array_equal(np.concatenate([first.itds_s, second.itds_s]), whole.itds_s[:2])


def test_pairs_stream_gives_every_pairs_itd_of_one_window_as_one_vector() -> None:
    """Four microphones hearing one noise source: each pair's ITDs equal those of its own PairStream, joined by
    window into (K, P) vectors, and they match the array's geometry."""
    from avcore.geometry import MicArray
    from avcore.itd import PairsItdStream

    fs = 16000
    array = MicArray(((-0.06, 0.0, 0.0), (0.06, 0.0, 0.0), (0.0, 0.0, 0.05), (0.0, 0.0, -0.05)),
                     pairs=((0, 1), (3, 2), (0, 2)))
    source = np.array([1.0, 0.0, 1.5])
    delays = np.linalg.norm(np.array(array.positions) - source, axis=1) / array.speed_of_sound
    rng = np.random.default_rng(2)
    dry = rng.standard_normal(fs + 400)
    spectrum = np.fft.rfft(dry)
    freqs = np.fft.rfftfreq(dry.size, 1 / fs)
    channels = np.stack([np.fft.irfft(spectrum * np.exp(-2j * np.pi * freqs * d), dry.size) for d in delays], axis=1)
    channels = 0.1 * channels[200:-200] / channels.std()
    stream = PairsItdStream(array, fs, method="gcc-phat")
    parts = [stream.push(channels[i:i + 512]) for i in range(0, channels.shape[0], 512)]
    times = np.concatenate([p[0] for p in parts])
    vectors = np.concatenate([p[1] for p in parts])
    assert vectors.shape == (times.size, 3) and times.size > 30
    for k, (i, j) in enumerate(array.pairs):
        single = PairStream(fs, method="gcc-phat", max_itd_s=1.2 * array.pair(k).max_itd_s)
        track = [single.push(channels[a:a + 512, i], channels[a:a + 512, j]) for a in range(0, channels.shape[0], 512)]
        np.testing.assert_array_equal(vectors[:, k], np.concatenate([t.itds_s for t in track]))
    np.testing.assert_allclose(np.median(vectors, axis=0), array.itd(source), atol=1.5 / fs)
    with pytest.raises(ValueError, match="channels"):
        stream.push(np.zeros((10, 3)))


def test_pairs_stream_passes_frames_of_every_pair_and_the_first_pairs_bands() -> None:
    from avcore.geometry import MicArray
    from avcore.itd import PairsItdStream

    array = MicArray.preset("respeaker4")
    rng = np.random.default_rng(3)
    noise = 0.1 * rng.standard_normal((16000, 4))
    stream = PairsItdStream(array, 16000, method="gcc-phat-robust", frame_itds=True)
    for i in range(0, noise.shape[0], 512):
        stream.push(noise[i:i + 512])
    frame_times, frames = stream.pop_frame_itds()
    band_times, bands = stream.pop_band_itds()
    assert frames.shape == (frame_times.size, array.n_pairs) and frame_times.size > 10
    assert bands.shape[1] == array.n_pairs and band_times.size == bands.shape[0] > 0
    assert np.isfinite(bands[:, 0]).all() and np.isnan(bands[:, 1:]).all()
    every = PairsItdStream(array, 16000, method="gcc-phat-robust", frame_itds=True, all_bands=True)
    for i in range(0, noise.shape[0], 512):
        every.push(noise[i:i + 512])
    _, all_bands = every.pop_band_itds()
    assert (np.isfinite(all_bands).sum(axis=1) == 1).all() and np.isfinite(all_bands[:, 1:]).any()


def test_gcc_phats_band_is_80_hz_to_5_khz_inclusive_and_its_bins_unit_phasors():
    """GCC-PHAT keeps the bins from 80 Hz to 5 kHz, both ends included (the correlogram's band by default), and
    nothing above; each kept bin of the whitened cross-spectrum has unit magnitude, and the confidence's norm counts
    each once with its rfft fold (2 / nfft, a pair of conjugate bins). With 1,600 points at 16 kHz the bins fall every
    10 Hz, on both ends of the band (written out here, not taken from the class)."""
    from avcore.itd.correlogram import Correlogram
    from avcore.itd.gcc_phat import GccPhat

    for cls in (GccPhat, Correlogram):
        defaults = inspect.signature(cls.__init__).parameters
        assert (defaults["low_hz"].default, defaults["high_hz"].default) == (80.0, 5000.0)
    g = GccPhat(16000, 1550, 0.0007)
    assert g.nfft == 1600 and g.n_used == 501  # bin 500 is 5 kHz, the last one used
    k = np.arange(501)
    band = ((k >= 8) & (k <= 500)).astype(float)
    np.testing.assert_array_equal(g.band, band)
    np.testing.assert_allclose(g._band_fold, band * 2.0 / 1600)
    rng = np.random.default_rng(0)
    left = rng.standard_normal(501) + 1j * rng.standard_normal(501)
    right = rng.standard_normal(501) + 1j * rng.standard_normal(501)
    weighted, norm = g.weighted_cross_spectrum(left, right)
    np.testing.assert_allclose(np.abs(weighted), band, atol=1e-12)
    assert norm == pytest.approx(band.sum() * 2.0 / 1600)
    full = GccPhat(16000, 1550, 0.0007, low_hz=0.0)  # DC may be in the band
    assert full.band[0] == 1.0 and full._band_fold[0] == pytest.approx(1.0 / 1600)
    with pytest.raises(ValueError, match=r"need 0 <= low_hz < high_hz, got low_hz=500.0, high_hz=500.0"):
        GccPhat(16000, 1550, 0.0007, low_hz=500.0, high_hz=500.0)


def test_the_correlogram_normalises_each_channel_and_keeps_below_nyquist():
    """The correlogram's confidence is the mean normalised correlation over its channels: 1 for a signal and itself,
    and for it at half the level (each channel divided by sqrt(E_L E_R), Parseval over the folded rfft bins); a
    silent channel weighs nothing; its top channel sits at 0.45 of the sampling rate when 5 kHz is above that (8 kHz:
    3.6 kHz); the frequency-domain filtering pads to twice the window so that the filters' ringing does not wrap."""
    import scipy.fft

    from avcore.itd.correlogram import Correlogram

    rng = np.random.default_rng(0)
    x = 0.1 * rng.standard_normal(16000)
    for right in (x, 0.5 * x):
        track = extract_itds(x, right, 16000, method="correlogram")
        assert track.confidence.size > 0
        np.testing.assert_allclose(track.confidence, 1.0, atol=1e-9)
        np.testing.assert_allclose(track.itds_s, 0.0, atol=1e-9)
    assert inspect.signature(Correlogram.__init__).parameters["n_channels"].default == 32  # as its docstring says
    c = Correlogram(8000, 1200, 0.0007)
    assert c.center_hz.size == 32 and c.center_hz[-1] == pytest.approx(3600.0) and c.center_hz[0] == pytest.approx(80.0)
    assert c.nfft == scipy.fft.next_fast_len(2 * 1200, real=True)
    silent = np.zeros((1, c.n_used))
    np.testing.assert_array_equal(c.channel_weights(silent, silent), 0.0)
    # the weights against Parseval written out: E_c = sum over the whole spectrum of |G_c|^2 |X|^2 / nfft, each rfft
    # bin but DC and Nyquist standing for two
    spec_l = rng.standard_normal((2, c.n_used)) + 1j * rng.standard_normal((2, c.n_used))
    spec_r = rng.standard_normal((2, c.n_used)) + 1j * rng.standard_normal((2, c.n_used))
    fold = np.full(c.n_used, 2.0)
    fold[0] = fold[-1] = 1.0  # nfft is even here
    assert c.nfft % 2 == 0 and c.n_used == c.nfft // 2 + 1
    e_l = (np.abs(spec_l) ** 2 * fold) @ c.power_response.T / c.nfft
    e_r = (np.abs(spec_r) ** 2 * fold) @ c.power_response.T / c.nfft
    np.testing.assert_allclose(c.channel_weights(spec_l, spec_r), 1.0 / np.sqrt(e_l * e_r), rtol=1e-12)



def test_pairs_stream_gives_each_pair_its_own_search_and_every_option():
    """Each pair's stream searches 1.2 times its own largest ITD, gets the options given (a window of 0.1 s here),
    runs the correlogram unless told otherwise, and with a robust method models its own pair's diffuse field
    (sinc(2 f d / c) with its own distance d); no pairs joined is no window."""
    from avcore.geometry import MicArray
    from avcore.itd.pairs import FrameBins, PairsItdStream, join_pairs

    array = MicArray.preset("respeaker4")
    plain = PairsItdStream(array, 16000, window_s=0.1)
    robust = PairsItdStream(array, 16000, method="gcc-phat-robust")
    for p in range(array.n_pairs):
        pair = array.pair(p)
        impl = plain._streams[p]._impl
        assert impl.name == "correlogram" and impl.window_len == 1600
        assert impl.max_itd_s == pytest.approx(1.2 * pair.max_itd_s)
        r = robust._streams[p]._impl
        np.testing.assert_allclose(r.diffuse_coherence, np.sinc(2 * r.freqs_hz[:r.n_used] * pair.distance_m / 343.0))
    times, itds = join_pairs([])
    assert times.shape == (0,) and itds.shape == (0, 0)
    frames = FrameBins(np.array([0.0, 0.25, 0.5, 0.75]), np.zeros((4, 1, 2), np.complex64), np.array([100.0, 200.0]))
    np.testing.assert_array_equal(frames.within(0.25, 0.25).times_s, [0.0, 0.25, 0.5])  # both ends inside


@pytest.mark.parametrize("method", ["gcc-phat", "correlogram"])
def test_a_stream_with_silent_gaps_gives_the_batch_extractions_itds(method: str) -> None:
    """Speech comes with pauses: blocks where some windows pass the energy gate and others do not. The stream gives
    exactly the windows, times and ITDs the whole-signal extraction gives, in any block sizes."""
    fs = 16000
    rng = np.random.default_rng(40)
    noise = rng.normal(0.0, 0.3, fs * 2)
    noise[int(0.5 * fs):int(1.1 * fs)] = 0.0  # a pause longer than a window
    left, right = noise[3:], noise[:-3]  # the left channel 3 samples early
    whole = extract_itds(left, right, fs, method=method)
    assert 0 < len(whole) < 1 + (left.size - int(0.15 * fs)) // int(0.02 * fs)  # some windows gated out
    assert np.median(whole.itds_s) == pytest.approx(-3 / fs, abs=0.5 / fs)
    for block in (2500, left.size):  # blocks of a few windows each, and all at once
        stream = PairStream(fs, method=method)
        streamed = ItdTrack.concatenate([stream.push(left[i:i + block], right[i:i + block])
                                         for i in range(0, left.size, block)])
        np.testing.assert_allclose(streamed.times_s, whole.times_s, rtol=0, atol=1e-12)
        np.testing.assert_allclose(streamed.itds_s, whole.itds_s, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(streamed.confidence, whole.confidence, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(streamed.energy, whole.energy, rtol=1e-9)


def test_an_empty_track_is_four_empty_read_only_arrays() -> None:
    empty = ItdTrack.empty()
    for name in ("times_s", "itds_s", "confidence", "energy"):
        arr = getattr(empty, name)
        assert arr.shape == (0,) and arr.dtype == np.float64 and not arr.flags.writeable
    assert len(empty) == 0


def test_a_windows_energy_is_its_mean_power_over_both_channels() -> None:
    fs = 16000
    rng = np.random.default_rng(41)
    left, right = rng.normal(0.0, 0.3, fs), rng.normal(0.0, 0.1, fs)
    track = extract_itds(left, right, fs, method="gcc-phat")
    w, hop = int(0.15 * fs), int(0.02 * fs)
    want = [np.mean((left[k * hop:k * hop + w] ** 2 + right[k * hop:k * hop + w] ** 2) / 2) for k in range(len(track))]
    np.testing.assert_allclose(track.energy, want, rtol=1e-9)


def test_the_robust_methods_apply_the_confidence_floor_too() -> None:
    fs = 16000
    rng = np.random.default_rng(42)
    noise = rng.normal(0.0, 0.3, fs)
    left, right = noise[3:] + rng.normal(0.0, 0.3, fs - 3), noise[:-3]
    every = extract_itds(left, right, fs, method="gcc-phat-robust")
    sure = extract_itds(left, right, fs, method="gcc-phat-robust", min_confidence=float(np.median(every.confidence)))
    assert 0 < len(sure) < len(every) and np.all(sure.confidence >= np.median(every.confidence))


def test_what_a_stream_does_not_keep_is_named_and_an_empty_bins_pop_has_their_width() -> None:
    from avcore.itd._extract import geometry_options, gives_frame_itds

    plain = PairStream(16000, method="gcc-phat")
    for pop in (plain.pop_frame_itds, plain.pop_band_itds):
        with pytest.raises(RuntimeError, match="^this PairStream keeps no frame ITDs: create it with frame_itds=True$"):
            pop()
    with pytest.raises(RuntimeError, match="^this PairStream keeps no frame bins: create it with frame_bins=True$"):
        plain.pop_frame_bins()
    robust = PairStream(16000, method="gcc-phat-robust", frame_bins=True)
    times, bins = robust.pop_frame_bins()
    assert times.shape == (0,) and bins.shape == (0, robust.bin_freqs_hz.size) and bins.dtype == np.complex64
    assert gives_frame_itds("gcc-phat-robust") and not gives_frame_itds("nope")
    with pytest.raises(ValueError, match=r"^method must be one of \['correlogram', "):
        geometry_options("nope", 0.12, 343.0)
