"""Tests of sim.scenario: the section 7.3 presets, their timelines and the ground truth of every instant."""
from __future__ import annotations

import numpy as np
import pytest

from sim.scenario import (
    CALIBRATION_BURST_S,
    PRESETS,
    SOURCE_OFFSETS_M,
    Actor,
    Path3D,
    Scenario,
    SoundEvent,
    make_scenario,
    synthetic_clip_bank,
    trim_quiet_ends,
)

DURATIONS = synthetic_clip_bank(16000, n_voices=3, seed=0).durations_s


def _scenario(name: str, seed: int = 0, duration_s: float = 20.0) -> Scenario:
    return make_scenario(name, clip_durations_s=DURATIONS, duration_s=duration_s, seed=seed)


@pytest.mark.parametrize("name", PRESETS)
def test_every_preset_is_deterministic_for_a_seed(name):
    a, b, c = _scenario(name, 3), _scenario(name, 3), _scenario(name, 4)
    assert a.events == b.events and [x.path for x in a.actors] == [x.path for x in b.actors]
    assert a.events != c.events or [x.path for x in a.actors] != [x.path for x in c.actors]
    for t in (0.0, 3.3, 7.9):
        ta, tb = a.truth(t), b.truth(t)
        np.testing.assert_array_equal(ta.positions_m, tb.positions_m)
        np.testing.assert_array_equal(ta.speaking, tb.speaking)
    assert all(0 <= e.start_s < e.end_s <= a.duration_s for e in a.events)


def test_s1_is_one_person_in_front_counting():
    s = _scenario("S1")
    assert len(s.actors) == 1 and all(e.kind == "speech" for e in s.events)
    assert [e.label for e in s.events[:5]] == ["1", "2", "3", "4", "5"]
    truth = s.truth(1.0)
    assert truth.visible.all() and abs(truth.positions_m[0, 0]) < 0.2


def test_s2_people_count_in_turns_without_overlap():
    s = _scenario("S2")
    assert len(s.actors) == 3
    speech = [e for e in s.events if e.kind == "speech"]
    assert [e.actor for e in speech[:6]] == [0, 1, 2, 0, 1, 2]
    assert all(e1.start_s >= e0.end_s for e0, e1 in zip(speech, speech[1:]))
    times = np.linspace(0, s.duration_s, 400, endpoint=False)
    assert s.speaking_at(times).sum(axis=1).max() == 1
    for t in times[::40]:
        np.testing.assert_array_equal(s.speaking(t), s.speaking_at([t])[0])
        assert s.truth(t).visible.all()
    # held longer at both ends: speaking just before a number starts and just after it ends
    first = speech[0]
    edges = [first.start_s - 0.02, first.end_s + 0.02]
    assert not s.speaking_at(edges)[:, first.actor].any()
    assert s.speaking_at(edges, hold_s=0.025)[:, first.actor].all()
    with pytest.raises(ValueError, match="hold_s"):
        s.speaking_at(times, hold_s=-0.1)


def test_s3_has_one_standing_person_higher_than_in_s2():
    s2, s3 = _scenario("S2"), _scenario("S3")
    y2, y3 = s2.positions(1.0)[:, 1], s3.positions(1.0)[:, 1]
    assert np.sum(y3 < y2 - 0.3) == 1  # y points down: standing is higher
    assert [a.posture for a in s3.actors].count("standing") == 1 and s3.truth(1.0).visible.all()


def test_s4_has_a_talker_outside_the_field_of_view():
    s = _scenario("S4")
    hidden = [i for i in range(3) if not any(s.visible(t)[i] for t in np.linspace(0, 20, 21))]
    assert len(hidden) == 1
    assert any(e.actor == hidden[0] and e.kind == "speech" for e in s.events)  # it talks all the same
    assert np.isnan(s.face_boxes_left(0.0)).sum() == 0  # in front of the rig, outside the image


def test_s5_has_independent_speakers_a_walker_and_claps():
    s = _scenario("S5", duration_s=25.0)
    kinds = {e.kind for e in s.events}
    assert kinds == {"speech", "clap"}
    moving = [i for i, a in enumerate(s.actors) if not a.path.is_still]
    assert len(moving) == 1
    xs = np.array([s.positions(t)[moving[0], 0] for t in np.linspace(0, 25, 50)])
    assert xs.max() - xs.min() > 1.0
    times = np.linspace(0, 25, 2500, endpoint=False)
    assert s.speaking_at(times).sum(axis=1).max() >= 2  # independent talkers overlap sometimes
    # claps are sounds, not speech
    clap = next(e for e in s.events if e.kind == "clap")
    t = (clap.start_s + clap.end_s) / 2
    assert s.truth(t).sounding[clap.actor]



def test_s6_puts_two_visible_people_in_one_direction_who_talk_in_turns_then_at_once():
    s = _scenario("S6", duration_s=25.0)
    truth = s.truth(1.0)
    assert truth.visible.tolist() == [True, True]
    near, far = truth.positions_m
    assert far[2] - near[2] > 1.0 and far[1] < near[1]  # deeper, and higher: the far face shows above the near head
    # the mouths' ITDs for microphones 12 cm apart on x, from distances written out (343 m/s)
    mouths = truth.positions_m + np.array(SOURCE_OFFSETS_M["speech"])
    left, right = np.array([-0.06, 0.0, 0.0]), np.array([0.06, 0.0, 0.0])
    itds = (np.linalg.norm(mouths - left, axis=1) - np.linalg.norm(mouths - right, axis=1)) / 343.0
    assert abs(itds[0] - itds[1]) < 1e-6 and itds[0] > 50e-6  # one direction, to the right
    times = np.arange(0.0, 25.0, 0.01)
    both = s.speaking_at(times).all(axis=1)
    assert not both[times < 12.5].any()  # in turns first
    assert both[times >= 12.5].sum() > 20  # then at times at once (over 0.2 s)
    assert {e.actor for e in s.events if e.start_s < 12.5} == {0, 1}

def test_calibration_sweeps_the_whole_field_of_view_with_white_noise():
    s = _scenario("calibration", duration_s=40.0)
    assert len(s.actors) == 1 and {e.kind for e in s.events} == {"noise"}
    # bursts of CALIBRATION_BURST_S (on, off) over the whole sequence
    on, off = CALIBRATION_BURST_S
    starts = np.array([e.start_s for e in s.events])
    assert np.allclose([e.end_s - e.start_s for e in s.events], on)
    assert np.allclose(np.diff(starts), on + off) and starts[0] < 1.0 and s.events[-1].end_s > 39.0
    times = np.linspace(0.5, 39.5, 300)
    truths = [s.truth(t) for t in times]
    assert all(tr.visible[0] and not tr.speaking[0] for tr in truths)
    sounding = np.array([tr.sounding[0] for tr in truths])
    assert abs(sounding.mean() - on / (on + off)) < 0.05
    u = np.array([tr.boxes_left[0, 0] + tr.boxes_left[0, 2] / 2 for tr in truths])
    z = np.array([tr.positions_m[0, 2] for tr in truths])
    assert u.min() < 0.15 * 640 and u.max() > 0.85 * 640  # edge to edge
    assert z.max() - z.min() > 1.0                        # and in depth
    assert np.sum(np.diff(np.sign(np.diff(u))) != 0) >= 8  # zig-zag: the direction changes many times
    # the truth ITD is the loudspeaker's, held below the face
    itd = np.array([tr.itds_s[0] for tr in truths])
    assert np.corrcoef(itd, u)[0, 1] > 0.9  # right of the image = positive ITD (docs/architecture.md sign)


def test_boxes_are_the_projected_faces_and_itds_follow_the_mapping():
    s = _scenario("S2")
    tr = s.truth(2.0)
    centres = tr.boxes_left[:, :2] + tr.boxes_left[:, 2:] / 2 - 0.5
    uv_l, _ = s.rig.project(tr.positions_m)
    np.testing.assert_allclose(centres, uv_l, atol=1e-9)
    # the sound leaves from the mouth (SOURCE_OFFSETS_M), and reaches the microphones after its distance to each at
    # 343 m/s; the delay is written out here from the microphones' positions, not taken from MicPair.itd
    mouths = tr.positions_m + np.array(SOURCE_OFFSETS_M["speech"])
    assert 0.02 < np.linalg.norm(SOURCE_OFFSETS_M["speech"]) < 0.1 and SOURCE_OFFSETS_M["speech"][1] > 0  # below
    left, right = np.asarray(s.mics.left), np.asarray(s.mics.right)
    delays = (np.linalg.norm(mouths - left, axis=1) - np.linalg.norm(mouths - right, axis=1)) / 343.0
    np.testing.assert_allclose(tr.itds_s, delays, rtol=1e-9)
    assert tr.itds_s[0] < 0 < tr.itds_s[2]  # left person: negative, right person: positive


def test_a_person_behind_another_is_not_visible():
    front = Actor("front", Path3D.still((0.0, -0.1, 1.5)), 0, 0)
    back = Actor("back", Path3D.still((0.0, -0.1, 3.0)), 1, 1)
    s = Scenario("occlusion", "", 5.0, 0, (front, back), ())
    np.testing.assert_array_equal(s.visible(1.0), [True, False])


def test_paths_interpolate_and_clamp():
    p = Path3D((0.0, 2.0), ((0.0, 0.0, 1.0), (2.0, 0.0, 1.0)))
    np.testing.assert_allclose(p.at(1.0), [1.0, 0.0, 1.0])
    np.testing.assert_allclose(p.at([-1.0, 5.0]), [[0.0, 0.0, 1.0], [2.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match="strictly increasing"):
        Path3D((1.0, 1.0), ((0, 0, 1), (0, 0, 1)))


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="unknown scenario 'S9'"):
        make_scenario("S9", clip_durations_s=DURATIONS)
    with pytest.raises(ValueError, match="clip_durations_s"):
        make_scenario("S1", clip_durations_s=[])
    with pytest.raises(ValueError, match="duration_s"):
        make_scenario("S1", clip_durations_s=DURATIONS, duration_s=0.1)
    with pytest.raises(ValueError, match="names actor 3"):
        Scenario("x", "", 5.0, 0, (Actor("a", Path3D.still((0, 0, 1)), 0, 0),), (SoundEvent(3, "speech", 0, 1),))


def test_trim_quiet_ends_cuts_only_what_is_30_db_under_the_loudest_frame() -> None:
    fs = 16000
    rng = np.random.default_rng(0)
    word = np.sin(2 * np.pi * 200 * np.arange(4000) / fs)  # 0.25 s, power 0.5
    faint = 10 ** (-40 / 20) * rng.standard_normal(3200)  # 0.2 s at -37 dB re the word (a fricative left at 8 kHz)
    weak = 10 ** (-20 / 20) * rng.standard_normal(1600)  # 0.1 s at -17 dB: kept
    out = trim_quiet_ends(np.concatenate([faint, word, faint]), fs)
    assert out.size == word.size and np.array_equal(out, word)
    kept = np.concatenate([faint, weak, word, faint[:800]])
    out = trim_quiet_ends(kept, fs)
    assert out.size == weak.size + word.size and np.array_equal(out[:10], weak[:10])
    assert np.array_equal(trim_quiet_ends(word, fs), word)  # nothing quiet: unchanged
    assert trim_quiet_ends(np.zeros(100), fs).size == 100  # digital silence or shorter than a frame: unchanged
    assert trim_quiet_ends(np.ones(50), fs).size == 50


def test_the_voices_change_with_the_seed_and_stay_for_a_seed() -> None:
    six = synthetic_clip_bank(16000, n_voices=6, seed=0).durations_s
    casts = {tuple(a.voice for a in make_scenario("S2", clip_durations_s=six, seed=s).actors) for s in range(8)}
    assert len(casts) > 3 and all(len(set(c)) == 3 and max(c) < 6 for c in casts)  # three different people each
    again = make_scenario("S5", clip_durations_s=six, seed=4)
    same = make_scenario("S5", clip_durations_s=six, seed=4)
    assert [a.voice for a in again.actors] == [a.voice for a in same.actors]
    # each speech event is as long as its speaker's clip
    for e in again.events:
        if e.kind == "speech":
            assert e.end_s - e.start_s == pytest.approx(six[again.actors[e.actor].voice][e.clip])
    one = synthetic_clip_bank(16000, n_voices=1, seed=0).durations_s  # fewer voices than people: they share
    assert {a.voice for a in make_scenario("S2", clip_durations_s=one, seed=1).actors} == {0}
