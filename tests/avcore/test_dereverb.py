"""Streaming multichannel WPE (avcore.dereverb): it takes a room's late reverberation out of what the microphones
hear, leaves the first frames alone, and names bad frames."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.dereverb import Dereverberator, SignalDereverberator

FS, FRAME, HOP = 16000, 512, 256
WINDOW = np.sqrt(np.hanning(FRAME + 1)[:-1])


def _frames(signal: np.ndarray) -> np.ndarray:
    """(T, F, Q) or (T, F): sqrt-Hann spectra of (n, Q) or (n,) samples, half overlapping."""
    w = WINDOW[:, None] if signal.ndim == 2 else WINDOW
    return np.array([np.fft.rfft(signal[i:i + FRAME] * w, axis=0)
                     for i in range(0, signal.shape[0] - FRAME + 1, HOP)])


def _room(seconds: float, channels: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(mixture (n, Q), the direct sound at microphone 0 (n,)): a source whose power changes every 50 ms (as
    speech's does; WPE's model) heard through responses with a direct path and a late tail from 48 ms on, of RT60
    0.5 s and twice the direct path's energy."""
    rng = np.random.default_rng(seed)
    n, step = int(seconds * FS), 800
    blocks = n // step + 1
    envelope = np.repeat(np.exp(rng.normal(0.0, 1.0, blocks)) * (rng.random(blocks) > 0.3), step)[:n]
    source = rng.standard_normal(n) * envelope
    t = np.arange(int(0.6 * FS)) / FS
    heard, direct = [], None
    for q in range(channels):
        path = np.zeros(t.size)
        path[3 + q] = 1.0
        tail = rng.standard_normal(t.size) * np.exp(-6.9 * t / 0.5) * (t >= 0.048)
        heard.append(np.convolve(source, path + tail * np.sqrt(2.0 / np.sum(tail ** 2)))[:n])
        if q == 0:
            direct = np.convolve(source, path)[:n]
    return np.stack(heard, axis=1), direct


def _sdr_db(reference: np.ndarray, estimate: np.ndarray) -> float:
    return float(10 * np.log10(np.sum(np.abs(reference) ** 2) / np.sum(np.abs(estimate - reference) ** 2)))


def test_the_late_reverberation_is_taken_out_once_warm() -> None:
    """Four microphones in a room whose tail holds twice the direct sound's energy: after the first 2 s, the first
    microphone's dereverberated frames lie at least 8 dB nearer its direct sound than the frames heard."""
    mixture, direct = _room(10.0, 4, seed=3)
    heard, wanted = _frames(mixture), _frames(direct)
    wpe = Dereverberator(heard.shape[1], 4, FS / HOP, every=16)
    out = np.array([wpe(frame) for frame in heard])
    later = slice(250, None)
    before, after = _sdr_db(wanted[later], heard[later, :, 0]), _sdr_db(wanted[later], out[later, :, 0])
    assert before < 0.0
    assert after > before + 8.0


def test_the_frames_pass_unchanged_until_warm_and_after_a_gap_the_past_is_forgotten() -> None:
    mixture, _ = _room(3.0, 2, seed=5)
    heard = _frames(mixture)
    wpe = Dereverberator(heard.shape[1], 2, FS / HOP, warm_s=1.6, every=16)
    out = np.array([wpe(frame) for frame in heard[:100]])
    np.testing.assert_array_equal(out, heard[:100])
    for frame in heard[100:150]:
        wpe(frame)
    assert not np.allclose(wpe(heard[150]), heard[150])  # warm: the filter is in use
    wpe.gap()
    # the first frame after a gap has no past to predict from, so it passes as it came
    np.testing.assert_allclose(wpe(heard[151]), heard[151])


def test_bad_frames_and_settings_are_named() -> None:
    wpe = Dereverberator(257, 4)
    with pytest.raises(ValueError, match=r"\(257, 4\)"):
        wpe(np.zeros((257, 2), dtype=complex))
    with pytest.raises(ValueError, match="taps"):
        Dereverberator(257, 4, taps=0)


def test_a_stream_of_samples_comes_back_in_place_and_dereverberated() -> None:
    """Blocks of any size: before the filter is warm the samples come back exactly, ``lag`` behind; once warm the
    first microphone lies at least 6 dB nearer its direct sound; the bins above ``max_hz`` pass as they came."""
    mixture, direct = _room(10.0, 4, seed=3)
    cold = SignalDereverberator(FS, 4, warm_s=100.0)
    out = np.concatenate([cold.push(mixture[i:i + 333]) for i in range(0, mixture.shape[0], 333)])
    assert cold.lag == 256 and mixture.shape[0] - 2 * cold.lag < out.shape[0] <= mixture.shape[0] - cold.lag
    np.testing.assert_allclose(out, mixture[: out.shape[0]], atol=1e-12)
    warm = SignalDereverberator(FS, 4)
    out = np.concatenate([warm.push(mixture[i:i + 1000]) for i in range(0, mixture.shape[0], 1000)])
    later = slice(3 * FS, out.shape[0])
    assert _sdr_db(direct[later], out[later, 0]) > _sdr_db(direct[later], mixture[later, 0]) + 6.0
    low = SignalDereverberator(FS, 4, max_hz=1000.0)
    out = np.concatenate([low.push(mixture[i:i + 1000]) for i in range(0, mixture.shape[0], 1000)])
    change = np.fft.rfft(out[later, 0] - mixture[later, 0])
    heard = np.fft.rfft(mixture[later, 0])
    freqs = np.fft.rfftfreq(out[later].shape[0], 1 / FS)

    def changed(band: np.ndarray) -> float:  # the share of the band's energy the dereverberation changed
        return float(np.sum(np.abs(change[band]) ** 2) / np.sum(np.abs(heard[band]) ** 2))

    assert changed(freqs > 1500) < 1e-3 and changed((freqs > 200) & (freqs < 800)) > 0.1
