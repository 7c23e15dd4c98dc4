"""Each person's voice as a stream (avcore.separation): the framing and resampling give the steered sound back, MVDR
learns the others from the person's silence, and the streams depend on the stamps, never on how the input came."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.geometry import SPEED_OF_SOUND
from avcore.separation import VoiceChunk, VoiceSeparator, frame_sizes

MICS = np.array([[-0.05, 0.0, 0.0], [0.05, 0.0, 0.0], [0.0, 0.0, 0.05], [0.0, 0.0, -0.05]])
TALKER = np.array([-0.6, 0.0, 1.5])
OTHER = np.array([0.9, 0.0, 1.2])


def _at_mics(signal: np.ndarray, fs: float, source: np.ndarray, mics: np.ndarray = MICS) -> np.ndarray:
    """(n, Q): ``signal`` as each microphone hears it from ``source`` in free field (fractional delays)."""
    n = signal.size
    delays = np.linalg.norm(mics - source, axis=1) / SPEED_OF_SOUND
    spec = np.fft.rfft(signal, 2 * n)
    f = np.fft.rfftfreq(2 * n, 1 / fs)
    return np.stack([np.fft.irfft(spec * np.exp(-2j * np.pi * f * d), 2 * n)[:n] for d in delays], axis=1)


def _speech_like(n: int, fs: float, seed: int) -> np.ndarray:
    """Noise shaped below 7 kHz (the voices' band), in bursts."""
    rng = np.random.default_rng(seed)
    spec = np.fft.rfft(rng.standard_normal(n))
    spec[np.fft.rfftfreq(n, 1 / fs) > 7000] = 0
    return np.fft.irfft(spec, n) * 0.1


def _run(separator: VoiceSeparator, audio: np.ndarray, fs: float, people: list, block: int) -> dict[int, np.ndarray]:
    """Push ``audio`` (n, Q) in blocks and ``people`` (stamp, ids, positions, speaking) as their stamps come; each
    person's stream on the output grid from 0 s."""
    chunks: list[VoiceChunk] = []
    pending = list(people)
    for start in range(0, audio.shape[0], block):
        while pending and pending[0][0] <= start / fs:
            separator.push_people(*pending.pop(0))
        separator.push_audio(start / fs, audio[start:start + block])
        chunks += separator.pop()
    for p in pending:
        separator.push_people(*p)
    chunks += separator.flush()
    return _streams(chunks, audio.shape[0] / fs)


def _streams(chunks: list[VoiceChunk], seconds: float) -> dict[int, np.ndarray]:
    out: dict[int, np.ndarray] = {}
    for c in chunks:
        s = out.setdefault(c.person_id, np.zeros(int(seconds * c.samplerate_hz) + c.samplerate_hz))
        i = int(round(c.stamp_s * c.samplerate_hz))
        assert i >= 0 and c.samples.dtype == np.float32
        s[i:i + c.samples.size] += c.samples
    return out


def _snr_db(reference: np.ndarray, estimate: np.ndarray) -> float:
    scale = np.dot(estimate, reference) / np.dot(reference, reference)
    return float(10 * np.log10(np.sum((scale * reference) ** 2) / np.sum((estimate - scale * reference) ** 2)))


@pytest.mark.parametrize("fs", [16000, 48000, 44100, 8000])
def test_frames_last_the_same_time_at_both_rates(fs: int) -> None:
    n_in, n_out = frame_sizes(fs)
    assert n_in % 2 == 0 and n_out % 2 == 0
    assert n_in / fs == pytest.approx(n_out / 16000) and 0.025 < n_in / fs < 0.05


@pytest.mark.parametrize("fs", [16000, 48000])
def test_one_talker_comes_back_at_16_khz(fs: int) -> None:
    """Delay-and-sum before anything is learned: the stream is the talker's sound resampled to 16 kHz (checked
    against the same sound made at 16 kHz, delayed to the first microphone)."""
    seconds = 2.0
    t16 = np.arange(int(seconds * 16000)) / 16000
    dry16 = np.sin(2 * np.pi * 440 * t16) * 0.3 + np.sin(2 * np.pi * 2500 * t16 + 1.0) * 0.2
    t = np.arange(int(seconds * fs)) / fs
    dry = np.sin(2 * np.pi * 440 * t) * 0.3 + np.sin(2 * np.pi * 2500 * t + 1.0) * 0.2
    separator = VoiceSeparator(MICS, fs, learn_delay_s=0.0)
    people = [(0.0, np.array([7]), TALKER[None], np.array([True]))]
    got = _run(separator, _at_mics(dry, fs, TALKER), fs, people, block=fs // 50)[7]
    ref = _at_mics(dry16, 16000, TALKER)[:, 0]
    inner = slice(1600, 16000)  # away from the ends (the first frame's fade-in)
    assert _snr_db(ref[inner], got[inner]) > 30
    assert np.std(got[inner]) == pytest.approx(np.std(ref[inner]), rel=0.02)


def test_mvdr_learns_the_other_talker_from_the_persons_silence() -> None:
    """A talker silent for the first 2 s while another talks all along: once learned, the other is left at least
    10 dB lower than delay-and-sum leaves it (what the speaking states are for). In free field there is no room to
    dereverberate, and the dereverberation's filter, 3 s old here, leaks into the nulls, so it is left out."""
    fs, seconds = 16000, 5.0
    n = int(fs * seconds)
    target = _speech_like(n, fs, 1) * (np.arange(n) >= 2 * fs)
    other = _speech_like(n, fs, 2)
    ids, where = np.array([1, 2]), np.stack([TALKER, OTHER])
    people = [(t, ids, where, np.array([t >= 2.0, True])) for t in np.arange(0, seconds, 1 / 30)]
    learned = _run(VoiceSeparator(MICS, fs, learn_delay_s=0.3), _at_mics(other, fs, OTHER), fs, people, 800)[1]
    # with nothing learned (never silent): delay-and-sum's weights
    never = [(t, ids, where, np.array([True, True])) for t, *_ in people]
    plain = _run(VoiceSeparator(MICS, fs, learn_delay_s=0.3), _at_mics(other, fs, OTHER), fs, never, 800)[1]
    late = slice(3 * fs, 5 * fs)
    assert 10 * np.log10(np.sum(plain[late] ** 2) / np.sum(learned[late] ** 2)) > 10
    mixture = _at_mics(target, fs, TALKER) + _at_mics(other, fs, OTHER)
    both = _run(VoiceSeparator(MICS, fs, learn_delay_s=0.3, dereverb=False), mixture, fs, people, 800)[1]
    ref = _at_mics(target, fs, TALKER)[:, 0]
    assert _snr_db(ref[late], both[late]) > _snr_db(ref[late], mixture[late, 0]) + 10


def test_a_beam_on_the_noise_alone_while_the_person_talks_alone() -> None:
    """Three noises all along, nobody for 1 s, another talker for 2 s, then the person alone: their silence taught
    the first beam the other talker, who is silent now; the beam on the frames where nobody spoke spends the four
    microphones on the noises, and the stream keeps it where it lets less through: more than 0.5 dB of SNR gained.
    Free field again: the dereverberation is left out (see the MVDR test)."""
    fs, seconds = 16000, 6.0
    n = int(fs * seconds)
    at = np.arange(n)
    target = _speech_like(n, fs, 1) * (at >= 3 * fs)
    other = _speech_like(n, fs, 2) * ((at >= fs) & (at < 3 * fs))
    noises = [np.array([1.5, 0.2, 1.0]), np.array([-1.5, -0.2, 0.5]), np.array([0.3, 0.5, -1.5])]
    mixture = _at_mics(target, fs, TALKER) + _at_mics(other, fs, OTHER) + sum(
        _at_mics(_speech_like(n, fs, 10 + i) * 0.3, fs, p) for i, p in enumerate(noises))
    ids, where = np.array([1, 2]), np.stack([TALKER, OTHER])
    people = [(t, ids, where, np.array([t >= 3.0, 1.0 <= t < 3.0])) for t in np.arange(0, seconds, 1 / 30)]
    ref = _at_mics(target, fs, TALKER)[:, 0]
    late = slice(4 * fs, 6 * fs)
    got = {beam: _run(VoiceSeparator(MICS, fs, quiet_beams=beam, dereverb=False), mixture, fs, people, 800)[1]
           for beam in (False, True)}
    snr = {beam: _snr_db(ref[late], stream[late]) for beam, stream in got.items()}
    assert snr[True] > snr[False] + 0.5 and snr[False] > _snr_db(ref[late], mixture[late, 0])


def test_the_streams_depend_on_the_stamps_not_on_how_the_input_came() -> None:
    """Blocks of other sizes, the people's updates early (a replay as fast as possible) or late (real time): the
    same samples."""
    fs = 16000
    n = 3 * fs
    mixture = _at_mics(_speech_like(n, fs, 3), fs, TALKER) + _at_mics(_speech_like(n, fs, 4), fs, OTHER)
    ids, where = np.array([1, 2]), np.stack([TALKER, OTHER])
    people = [(t, ids, where, np.array([(t % 1.0) < 0.5, True])) for t in np.arange(0, 3.0, 1 / 30)]
    a = _run(VoiceSeparator(MICS, fs), mixture, fs, people, 320)
    separator = VoiceSeparator(MICS, fs)
    for p in people:  # every update before any sound
        separator.push_people(*p)
    chunks = []
    for start in range(0, n, 1024):
        separator.push_audio(start / fs, mixture[start:start + 1024])
        chunks += separator.pop()
    b = _streams(chunks + separator.flush(), n / fs)
    assert set(a) == set(b) == {1, 2}
    for k in a:
        np.testing.assert_allclose(a[k], b[k], atol=1e-6)


def test_a_stream_goes_on_through_silence_and_starts_after_the_delay() -> None:
    fs = 16000
    separator = VoiceSeparator(MICS, fs, learn_delay_s=0.5)
    for t in np.arange(0, 3.0, 1 / 30):
        separator.push_people(t, np.array([4]), TALKER[None], np.array([False]))
    chunks = []
    for start in range(0, 3 * fs, 512):
        separator.push_audio(start / fs, np.zeros((512, 4)))
        chunks += separator.pop()
    chunks += separator.flush()
    assert chunks[0].stamp_s == pytest.approx(0.5, abs=0.04)
    assert all(abs(b.stamp_s - a.end_s) < 1e-9 for a, b in zip(chunks, chunks[1:]))
    assert chunks[-1].end_s == pytest.approx(3.0, abs=0.02)


def test_gaps_and_nans_in_the_audio() -> None:
    """Samples lost (a jump in the stamps) restart the framing: the chunks' stamps keep the capture times; NaNs are
    silence."""
    fs = 16000
    separator = VoiceSeparator(MICS, fs, learn_delay_s=0.0)
    separator.push_people(0.0, np.array([1]), TALKER[None], np.array([True]))
    block = _at_mics(_speech_like(fs, fs, 5), fs, TALKER)
    block[100:200] = np.nan
    separator.push_audio(0.0, block)
    separator.push_audio(5.0, block)  # 4 s lost
    chunks = separator.pop() + separator.flush()
    assert all(np.all(np.isfinite(c.samples)) for c in chunks)
    starts = sorted(c.stamp_s for c in chunks)
    assert starts[0] == pytest.approx(0.0) and any(s == pytest.approx(5.0) for s in starts)
    assert max(c.end_s for c in chunks) == pytest.approx(6.0, abs=0.02)


def test_each_chunk_carries_the_first_beam_alone_beside_the_choice() -> None:
    """With the choice between beams, each chunk's ``plain`` is the stream without it, sample for sample."""
    fs, seconds = 16000, 3.0
    n = int(fs * seconds)
    mixture = _at_mics(_speech_like(n, fs, 1), fs, TALKER) + _at_mics(_speech_like(n, fs, 2) * 0.5, fs, OTHER)
    ids, where = np.array([1, 2]), np.stack([TALKER, OTHER])
    people = [(t, ids, where, np.array([True, t < 1.5])) for t in np.arange(0, seconds, 1 / 30)]
    chunks = {}
    for beams in (True, False):
        separator, got = VoiceSeparator(MICS, fs, quiet_beams=beams), []
        for start in range(0, n, 640):
            while people and people[0][0] <= start / fs:
                separator.push_people(*people.pop(0))
            separator.push_audio(start / fs, mixture[start:start + 640])
            got += separator.pop()
        chunks[beams] = got + separator.flush()
        people = [(t, ids, where, np.array([True, t < 1.5])) for t in np.arange(0, seconds, 1 / 30)]
    assert all(c.plain is None for c in chunks[False]) and all(c.plain is not None for c in chunks[True])
    assert [(c.person_id, c.stamp_s) for c in chunks[True]] == [(c.person_id, c.stamp_s) for c in chunks[False]]
    for with_choice, without in zip(chunks[True], chunks[False]):
        np.testing.assert_array_equal(with_choice.plain, without.samples)
    assert not all(np.array_equal(a.samples, b.samples) for a, b in zip(chunks[True], chunks[False]))


def test_the_rooms_filter_comes_with_three_microphones_or_more() -> None:
    pair, four = VoiceSeparator(MICS[:2], 16000), VoiceSeparator(MICS, 16000)
    assert pair.dereverb is None and four.dereverb is not None
    assert VoiceSeparator(MICS[:2], 16000, dereverb=True).dereverb is not None
    assert VoiceSeparator(MICS, 16000, dereverb=False).dereverb is None


def test_bad_inputs_are_named() -> None:
    with pytest.raises(ValueError, match="at least 2 microphones"):
        VoiceSeparator(MICS[:1], 16000)
    separator = VoiceSeparator(MICS, 16000)
    with pytest.raises(ValueError, match=r"\(n, 4\)"):
        separator.push_audio(0.0, np.zeros((100, 3)))
    with pytest.raises(ValueError, match="disagree"):
        separator.push_people(0.0, np.array([1, 2]), TALKER[None], np.array([True]))


def test_a_rooms_late_reverberation_is_taken_out_before_the_beams() -> None:
    """A talker whose power changes every 50 ms (as speech's does) heard with a late tail (from 48 ms, RT60 0.5 s,
    twice the direct sound's energy, independent at each microphone): with the dereverberation the stream lies at
    least 6 dB nearer the direct sound than without it, once it is warm."""
    fs, seconds = 16000, 8.0
    n = int(fs * seconds)
    rng = np.random.default_rng(21)
    blocks = n // 800 + 1
    envelope = np.repeat(np.exp(rng.normal(0.0, 1.0, blocks)) * (rng.random(blocks) > 0.3), 800)[:n]
    target = _speech_like(n, fs, 11) * envelope
    direct = _at_mics(target, fs, TALKER)
    t = np.arange(int(0.6 * fs)) / fs
    tails = [rng.standard_normal(t.size) * np.exp(-6.9 * t / 0.5) * (t >= 0.048) for _ in range(MICS.shape[0])]
    mixture = direct + np.stack([np.convolve(target, h * np.sqrt(2.0 / np.sum(h ** 2)))[:n] for h in tails], axis=1)
    people = [(s, np.array([3]), TALKER[None], np.array([True])) for s in np.arange(0, seconds, 1 / 30)]
    late = slice(3 * fs, n - fs)
    got = {on: _run(VoiceSeparator(MICS, fs, dereverb=on), mixture, fs, people, 512)[3][:n] for on in (False, True)}
    assert _snr_db(direct[late, 0], got[True][late]) > _snr_db(direct[late, 0], got[False][late]) + 6.0


def test_the_voices_own_reverberation_is_taken_down_with_the_diffuse_term() -> None:
    """A room's late reverberation comes with the voice and from every direction: here a field of many far sources
    that sound only while the talker talks, so the talker's silences teach MVDR nothing of it. With the diffuse
    term (the talker's power spread over the sphere's coherence) the stream keeps more of the voice against it
    than without (the superdirective beam of ``quiet_beams``, which also answers a diffuse field, left out)."""
    fs, seconds = 16000, 4.0
    n = int(fs * seconds)
    rng = np.random.default_rng(7)
    on = (np.arange(n) % fs) < 0.6 * fs  # the talker talks 0.6 s of every second
    target = _speech_like(n, fs, 11) * on
    field = np.zeros((n, 4))
    for k in range(48):
        direction = rng.standard_normal(3)
        field += _at_mics(_speech_like(n, fs, 100 + k) * on, fs, 30.0 * direction / np.linalg.norm(direction))
    field *= 0.5 * np.std(target[on]) / np.std(field[on, 0])
    mixture = _at_mics(target, fs, TALKER) + field
    people = [(t, np.array([3]), TALKER[None], np.array([(t % 1.0) < 0.6])) for t in np.arange(0, seconds, 1 / 30)]
    ref = _at_mics(target, fs, TALKER)[:, 0]
    late = np.flatnonzero(on & (np.arange(n) >= 2 * fs))  # once learned, while the talker talks
    got = {d: _run(VoiceSeparator(MICS, fs, diffuse=d, quiet_beams=False), mixture, fs, people, 512)[3][:n]
           for d in (0.0, 1.0)}
    gain = _snr_db(ref[late], got[1.0][late]) - _snr_db(ref[late], got[0.0][late])
    assert gain > 0.8
