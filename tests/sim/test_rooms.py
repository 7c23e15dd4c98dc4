"""The rooms drawn from a seed (sim.rooms): every draw inside the issue's ranges, deterministic, and its audio."""
from __future__ import annotations

import math

import numpy as np
import pytest

from sim.rooms import HELD_OUT_SEEDS, MAX_DISTANCE_M, MIN_APART_DEG, MIN_APART_M, draw_room, make_room, overlap_share
from sim.scenario import SoundEvent

SENTENCES = ((3.5, 3.6, 3.3), (3.0,), (2.5, 1.3, 3.2))  # the ARCTIC excerpts' durations, seconds


def _azimuth(p) -> float:
    return math.degrees(math.atan2(p[0], p[2]))


@pytest.mark.parametrize("seed", list(range(0, 40)) + list(HELD_OUT_SEEDS[:5]))
def test_every_draw_is_inside_the_ranges(seed: int) -> None:
    d = draw_room(seed)
    w, depth, h = d.dims_m
    assert 4.0 <= w <= 9.0 and 4.0 <= depth <= 9.0 and 2.5 <= h <= 3.2
    assert 0.2 <= d.rt60_s <= 0.7 and 10.0 <= d.noise_snr_db <= 30.0 and 0.15 <= d.overlap_target <= 0.40
    assert 2 <= len(d.faces_m) <= 4 and len(d.postures) == len(d.faces_m)
    for i, p in enumerate(d.faces_m):
        assert 1.0 <= math.hypot(p[0], p[2]) <= MAX_DISTANCE_M
        for q in d.faces_m[i + 1:]:
            assert math.dist(p, q) >= MIN_APART_M
            assert abs(_azimuth(p) - _azimuth(q)) >= MIN_APART_DEG
    assert math.dist(d.noise_position_m, (0, 0, 0)) >= 0.5


def test_the_family_spans_its_ranges() -> None:
    """Over 40 seeds: two, three and four people; seated and standing; small and large rooms; people down to
    10-15 degrees apart."""
    draws = [draw_room(s) for s in range(40)]
    assert {len(d.faces_m) for d in draws} == {2, 3, 4}
    assert {p for d in draws for p in d.postures} == {"seated", "standing"}
    assert min(d.dims_m[0] for d in draws) < 5.0 and max(d.dims_m[0] for d in draws) > 8.0
    closest = min(abs(_azimuth(p) - _azimuth(q)) for d in draws for i, p in enumerate(d.faces_m)
                  for q in d.faces_m[i + 1:])
    assert closest < 15.0


@pytest.mark.parametrize("seed", [0, 3, 7, 101])
def test_a_room_is_its_seed(seed: int) -> None:
    a, da = make_room(seed, clip_durations_s=SENTENCES)
    b, db = make_room(seed, clip_durations_s=SENTENCES)
    assert da == db and a.events == b.events
    other, _ = make_room(seed + 1, clip_durations_s=SENTENCES)
    assert other.events != a.events
    assert a.visible(0.0).all()  # everyone in view
    assert abs(overlap_share(a.events) - da.overlap_target) < 0.06
    for i in range(len(a.actors)):  # nobody overlaps their own previous sentence
        own = sorted((e.start_s, e.end_s) for e in a.events if e.actor == i)
        assert all(s2 >= e1 for (_, e1), (s2, _) in zip(own, own[1:]))


def test_overlap_share_counts_two_voices_at_once() -> None:
    events = [SoundEvent(0, "speech", 0.0, 2.0), SoundEvent(1, "speech", 1.5, 3.0), SoundEvent(0, "clap", 2.0, 2.1)]
    assert overlap_share(events) == pytest.approx(0.5 / 3.0, abs=0.01)
    assert overlap_share([SoundEvent(0, "speech", 0.0, 1.0)]) == 0.0


def test_an_array_preset_places_its_microphones() -> None:
    pair, _ = make_room(2, clip_durations_s=SENTENCES)
    nao, _ = make_room(2, clip_durations_s=SENTENCES, mics="nao")
    assert len(pair.array.positions) == 2 and len(nao.array.positions) == 4
    assert nao.events == pair.events


def test_background_noise_lies_at_its_snr_under_the_speech() -> None:
    from sim.audio import Background, render_audio
    from sim.scenario import synthetic_clip_bank

    bank = synthetic_clip_bank(16000, n_voices=2)
    scenario, _ = make_room(5, clip_durations_s=bank.durations_s, duration_s=6.0)
    quiet = render_audio(scenario, bank, fan_snr_db=80.0, sensor_noise_rms=0.0)
    noise = np.random.default_rng(0).standard_normal(16000)
    loud = render_audio(scenario, bank, fan_snr_db=80.0, sensor_noise_rms=0.0,
                        background=Background(noise, (1.0, 0.0, -0.3), 12.0))
    talking = np.zeros(quiet.samples.shape[0], dtype=bool)
    for e in scenario.events:
        talking[round(e.start_s * 16000):round(e.end_s * 16000)] = True
    speech = quiet.samples[talking, 0].astype(float)
    added = loud.samples[:, 0].astype(float) - quiet.samples[:, 0].astype(float)
    snr = 20 * np.log10(np.sqrt(np.mean(speech**2)) / np.sqrt(np.mean(added**2)))
    assert snr == pytest.approx(12.0, abs=0.5)


def test_each_talkers_own_signals_add_up_to_what_the_microphones_hear() -> None:
    """``render_audio(images=True)``: each actor alone on every microphone; without the fan and the converter's
    noise their sum is the recording (to its 16-bit rounding), and each talker's image is silent outside their
    own speech, beyond the room's reverberation."""
    from sim.audio import render_audio
    from sim.scenario import synthetic_clip_bank

    bank = synthetic_clip_bank(16000, n_voices=2)
    scenario, _ = make_room(5, clip_durations_s=bank.durations_s, duration_s=5.0, mics="respeaker4")
    audio = render_audio(scenario, bank, fan_snr_db=200.0, sensor_noise_rms=0.0, images=True)
    assert audio.images is not None and audio.images.shape == (len(scenario.actors), 4, audio.samples.shape[0])
    np.testing.assert_allclose(audio.images.sum(axis=0).T, audio.samples / 32768.0, atol=1.5 / 32768.0)
    first = min(e.start_s for e in scenario.events if e.actor == 0)
    assert not audio.images[0, :, : int(first * 16000)].any()
