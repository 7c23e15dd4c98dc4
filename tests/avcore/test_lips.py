"""avcore.lips: each face's lip activity followed from frame to frame, no opinion until it has seen enough, the veto
that removes a speaker whose lips are still, and the lips that move with the sound while another face talks."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.lips import (
    HiddenLips,
    LipTracks,
    SoundEnvelope,
    choose_by_lips,
    frame_powers,
    lip_synchrony,
    lips_with_the_words,
    same_direction_groups,
    veto_still_lips,
    voice_without_lips,
)


def test_activity_is_the_spread_of_each_faces_opening_over_the_window() -> None:
    tracks = LipTracks(window_s=0.4, min_samples=6)
    t = np.arange(0, 1.0, 1 / 30)
    talker = 0.25 + 0.15 * np.sin(2 * np.pi * 5 * t)  # syllables at 5 Hz
    listener = np.full(t.size, 0.08)
    boxes = np.array([[100.0, 100.0, 50.0, 50.0], [300.0, 110.0, 40.0, 40.0]])
    out = []
    for k, tk in enumerate(t):
        moved = boxes + [[0.5 * k, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]  # the talker drifts 15 px a second
        order = [1, 0] if k % 2 else [0, 1]  # the faces come in any order
        act = tracks.update(tk, moved[order], np.array([talker[k], listener[k]])[order])
        out.append(act[np.argsort(order)])
    out = np.array(out)
    assert np.isnan(out[:5]).all()  # fewer than six openings: no opinion
    window = t > t[-1] - 0.4  # the last 0.4 s, its start excluded
    assert out[-1, 0] == pytest.approx(np.std(talker[window]))
    assert out[-1, 1] == pytest.approx(0.0)


def test_a_new_face_far_from_every_track_starts_its_own() -> None:
    tracks = LipTracks(min_samples=2)
    tracks.update(0.0, np.array([[100.0, 100.0, 40.0, 40.0]]), np.array([0.1]))
    tracks.update(0.033, np.array([[100.0, 100.0, 40.0, 40.0]]), np.array([0.3]))
    # the face jumps by more than half its width: a new person, whose history starts now
    act = tracks.update(0.066, np.array([[140.0, 100.0, 40.0, 40.0]]), np.array([0.3]))
    assert np.isnan(act[0])
    # and a face unseen for longer than the window is forgotten
    tracks.update(1.0, np.array([[100.0, 100.0, 40.0, 40.0]]), np.array([0.1]))
    assert np.isnan(tracks.update(1.033, np.array([[500.0, 100.0, 40.0, 40.0]]), np.array([0.1]))[0])
    with pytest.raises(ValueError, match="one value per box"):
        tracks.update(2.0, np.zeros((2, 4)), np.zeros(1))


def test_the_mesh_losing_a_face_is_no_opinion_not_still() -> None:
    tracks = LipTracks(min_samples=6)
    box = np.array([[100.0, 100.0, 40.0, 40.0]])
    for k in range(12):
        act = tracks.update(k / 30, box, np.array([np.nan if k > 3 else 0.1]))
    assert np.isnan(act[0])  # 4 openings in the window: no opinion
    speaking, probability = veto_still_lips(np.array([True]), np.array([0.9]), act, 0.012)
    assert speaking.tolist() == [True] and probability.tolist() == [0.9]


def test_the_veto_removes_still_lipped_speakers_only() -> None:
    speaking = np.array([True, True, False, True])
    probability = np.array([0.9, 0.8, 0.2, 0.7])
    activity = np.array([0.004, 0.05, 0.004, np.nan])  # still, moving, still and silent, no opinion
    s, p = veto_still_lips(speaking, probability, activity, 0.012)
    assert s.tolist() == [False, True, False, True]
    assert p.tolist() == [0.5, 0.8, 0.2, 0.7]  # at most 0.5 where vetoed: above 0.5 exactly when speaking
    # just either side of the threshold
    assert veto_still_lips(np.array([True]), np.array([0.9]), np.array([0.0119]), 0.012)[0].tolist() == [False]
    assert veto_still_lips(np.array([True]), np.array([0.9]), np.array([0.012]), 0.012)[0].tolist() == [True]


def test_relative_activity_is_placed_between_the_tracks_own_still_and_moving_levels() -> None:
    tracks = LipTracks(window_s=0.4, min_samples=6, floor_window_s=10.0, min_floor=15)
    rng = np.random.default_rng(3)
    t = np.arange(0, 6.0, 1 / 30)
    # a near face whose mesh barely jitters and a far one whose mesh jitters four times more; each talks in turn
    talks = [(t % 2.0) < 1.0, (t % 2.0) >= 1.0]
    near = 0.1 + 0.005 * rng.standard_normal(t.size) + np.where(talks[0], 0.2 * np.sin(2 * np.pi * 5 * t), 0.0)
    far = 0.1 + 0.02 * rng.standard_normal(t.size) + np.where(talks[1], 0.2 * np.sin(2 * np.pi * 5 * t), 0.0)
    boxes = np.array([[100.0, 100.0, 80.0, 80.0], [300.0, 60.0, 30.0, 30.0]])
    rel = []
    for k, tk in enumerate(t):
        tracks.update(tk, boxes, np.array([near[k], far[k]]))
        rel.append(tracks.relative.copy())
    rel = np.array(rel)
    assert np.isnan(rel[:15]).all()  # too few activities for a floor yet
    late = t > 3.0
    mid_talk = [late & ((t % 2.0) > 0.5) & ((t % 2.0) < 1.0), late & ((t % 2.0) > 1.5)]
    for i in (0, 1):  # each face: high while its own lips move, near its floor while they are still
        assert np.all(rel[mid_talk[i], i] > 0.5)
        assert np.all(rel[mid_talk[1 - i], i] < 0.3)


def test_faces_direction_cannot_tell_apart_are_grouped_on_every_pair() -> None:
    itds = np.array([[80e-6, 10e-6], [95e-6, 20e-6], [300e-6, 10e-6], [85e-6, 70e-6], [np.nan, np.nan]])
    groups = same_direction_groups(itds, 40e-6)
    assert [g.tolist() for g in groups] == [[0, 1], [2], [3], [4]]  # 3: near 0 on the first pair, not the second
    chained = same_direction_groups(np.array([[0.0], [30e-6], [60e-6]]), 40e-6)
    assert [g.tolist() for g in chained] == [[0, 1, 2]]  # 0 and 2 are 60 us apart, linked through 1
    apart = same_direction_groups(np.array([[0.0], [10e-6], [20e-6]]), 40e-6, np.array([True, False, True]))
    assert [g.tolist() for g in apart] == [[0, 2], [1]]  # 1 may not be grouped: alone, and no link through it


def test_a_groups_words_go_to_the_face_whose_lips_move() -> None:
    groups = [np.array([0, 1]), np.array([2])]
    speaking = np.array([True, True, True])
    probability = np.array([0.8, 0.8, 0.7])
    s, p = choose_by_lips(speaking, probability, np.array([0.1, 0.9, 0.0]), groups, both_above=0.5)
    assert s.tolist() == [False, True, True] and p.tolist() == [0.5, 0.8, 0.7]  # a face alone is left as it is
    s, _ = choose_by_lips(speaking, probability, np.array([0.7, 0.9, 0.0]), groups, both_above=0.5)
    assert s.tolist() == [True, True, True]  # both lips move: two talking at once
    s, _ = choose_by_lips(speaking, probability, np.array([np.nan, 0.9, 0.0]), groups, both_above=0.5)
    assert s.tolist() == [True, True, True]  # one opinion only: the lips cannot choose
    s, _ = choose_by_lips(np.array([False, False, True]), probability, np.array([0.1, 0.9, 0.0]), groups, 0.5)
    assert s.tolist() == [False, False, True]  # a silent group stays silent: the lips add no speaker


def test_hidden_lips_are_still_through_a_second_of_their_own_voice() -> None:
    """Without earning trust (before wave 4): marks are kept only while a face is heard alone; hidden needs a second
    from the first mark to the last and a median activity under twice the veto's threshold; a face not heard for
    the window is forgotten."""
    hidden = HiddenLips(window_s=3.0, heard_s=1.0, moving_factor=2.0, earn_trust=False)
    ids = np.array([4, 5])
    turns = [np.array([True, False]), np.array([False, True])]  # heard alone in turn, every 50 ms
    for k, t in enumerate(np.arange(0.0, 0.99, 0.05)):  # face 4 from 0.0 to 0.9 s, face 5 from 0.05 to 0.95 s
        out = hidden.update(float(t), ids, turns[k % 2], np.array([0.02, 0.02]), 0.012)
        assert not out.any()
    assert hidden.update(1.0, ids, turns[0], np.array([0.02, 0.02]), 0.012).tolist() == [True, False]
    out = hidden.update(1.05, ids, turns[1], np.array([0.02, 0.02]), 0.012)
    assert out.tolist() == [True, True]  # a second each; medians 0.02 < 0.024
    for t in np.arange(1.1, 1.74, 0.05):  # face 5's lips move now: 13 marks at 0.06 against 11, its median too
        out = hidden.update(t, ids, turns[1], np.array([0.02, 0.06]), 0.012)
    assert out.tolist() == [True, False]
    # silent moments add no marks: the same verdict later, from the marks still in the window
    assert hidden.update(2.5, ids, np.array([False, False]), np.array([0.5, 0.5]), 0.012).tolist() == [True, False]
    # a NaN (no opinion) is no mark either; after the window the marks are gone
    assert hidden.update(4.5, ids, turns[0], np.array([np.nan, np.nan]), 0.012).tolist() == [False, False]
    assert 4 not in hidden._marks or hidden._marks[4] == []


def test_a_listener_heard_beside_the_talker_is_never_hidden() -> None:
    """A neighbour's spill calls the listener speaking with the talker, for seconds on end: those moments are not
    the listener's own voice, so their still lips keep their opinion (the veto still takes them)."""
    hidden = HiddenLips(window_s=3.0, heard_s=1.0, moving_factor=2.0, earn_trust=False)
    ids = np.array([1, 2])  # the talker (lips moving), the listener (still)
    for t in np.arange(0.0, 3.0, 0.05):
        out = hidden.update(float(t), ids, np.array([True, True]), np.array([0.08, 0.008]), 0.012)
        assert not out.any()
    # heard alone for a second with the same still lips: now they are hidden (a hand, a mask)
    for t in np.arange(3.0, 4.12, 0.05):
        out = hidden.update(float(t), ids, np.array([False, True]), np.array([0.08, 0.008]), 0.012)
    assert out.tolist() == [False, True]


def test_lips_earn_the_right_to_veto_with_their_own_voice() -> None:
    """Earning trust (the default): no face's lips say anything until judged by a second of its own voice heard
    alone. The talker's lips move with it (trusted: from then on its still lips may veto, even after the window has
    passed while it listens); a photograph's stay still (hidden), and so does a face only ever heard beside
    another. A second of still lips with its own voice takes a trusted face's opinion away again."""
    hidden = HiddenLips(window_s=3.0, heard_s=1.0, moving_factor=2.0)
    ids = np.array([1, 2, 3])  # the talker (lips move), a photograph (still), a listener heard only beside 1
    for t in np.arange(0.0, 1.12, 0.05):
        out = hidden.update(float(t), ids, np.array([True, False, False]), np.array([0.08, 0.008, 0.008]), 0.012)
    assert out.tolist() == [False, True, True]  # 1 trusted after a second; 2 and 3 unjudged: no opinion
    for t in np.arange(1.2, 2.32, 0.05):
        out = hidden.update(float(t), ids, np.array([False, True, False]), np.array([0.008, 0.008, 0.008]), 0.012)
    assert out.tolist() == [False, True, True]  # the photograph's voice with still lips: hidden, now judged so
    for t in np.arange(2.4, 8.0, 0.05):  # 1 and 3 heard together (a spill on 3); 1 listens with its lips still
        out = hidden.update(float(t), ids, np.array([True, False, True]), np.array([0.008, 0.008, 0.008]), 0.012)
    assert out.tolist() == [False, True, True]  # 1 keeps its trust beyond the window; 3 never earned any
    for t in np.arange(8.0, 9.12, 0.05):  # 1's own voice, heard alone, with still lips (a hand): trust lost
        out = hidden.update(float(t), ids, np.array([True, False, False]), np.array([0.008, 0.008, 0.008]), 0.012)
    assert out.tolist() == [True, True, True]
    hidden.update(20.0, np.array([2]), np.array([False]), np.array([0.008]), 0.012)
    assert set(hidden._trusted) == {2}  # the tracks gone from view without a moment in the window are forgotten


def test_lips_moving_with_the_sound_earn_trust_beside_another_voice() -> None:
    """With ``synced_s``: a face heard only beside another, whose lips move with the sound for that long, is trusted
    (its still lips may veto later); a moment is not enough, nor are lips that never move with the sound; without
    ``synced_s`` the same face stays unjudged. Its own voice heard alone with still lips takes the trust back."""
    still, loud = np.array([0.008, 0.008]), np.array([True, True])
    for synced_s, trusted in ((0.3, True), (None, False)):
        hidden = HiddenLips(window_s=3.0, heard_s=1.0, synced_s=synced_s)
        ids = np.array([1, 2])  # two talking at once: 1's lips move with the sound, 2's never do
        out = hidden.update(0.0, ids, loud, np.array([0.08, 0.008]), 0.012, np.array([True, False]))
        assert out.tolist() == [True, True]  # one moment: no opinion yet
        for t in np.arange(0.05, 0.4, 0.05):
            out = hidden.update(float(t), ids, loud, np.array([0.08, 0.008]), 0.012, np.array([True, False]))
        assert out.tolist() == [not trusted, True]
        for t in np.arange(0.4, 5.0, 0.05):  # both listen; the window passes
            out = hidden.update(float(t), ids, np.array([False, False]), still, 0.012, np.array([False, False]))
        assert out.tolist() == [not trusted, True]
        for t in np.arange(5.0, 6.12, 0.05):  # 1 heard alone, lips still (a hand): trust taken back
            out = hidden.update(float(t), ids, np.array([True, False]), still, 0.012, np.array([False, False]))
        assert out.tolist() == [True, True]


def test_lips_that_jitter_out_of_step_with_their_own_voice_earn_no_trust() -> None:
    """A photograph's mesh jitters (activity 0.03, over twice the veto's threshold) while its owner's voice is heard
    alone for a second, but never in step with that voice: given the synchrony, the face stays hidden, and so it does
    when chance puts it a little in step (0.3, as S5's photographs reach); lips that move as much in step with it (0.7)
    are trusted; with no synchrony given (motion-guided) the activity alone judges."""
    ids, alone, jitter = np.array([1, 2]), np.array([True, False]), np.array([0.03, 0.008])
    verdicts = {}
    for name, sync in (("out of step", np.array([0.0, np.nan])), ("by chance", np.array([0.3, np.nan])),
                       ("in step", np.array([0.7, np.nan])), ("unknown", None)):
        hidden = HiddenLips(window_s=3.0, heard_s=1.0)
        for t in np.arange(0.0, 1.12, 0.05):
            out = hidden.update(float(t), ids, alone, jitter, 0.012, None, sync)
        verdicts[name] = bool(out[0])
    assert verdicts == {"out of step": True, "by chance": True, "in step": False, "unknown": False}


def test_each_followed_face_keeps_its_track_number() -> None:
    tracks = LipTracks()
    tracks.update(0.0, np.array([[100, 100, 40, 40], [300, 100, 40, 40]]), np.array([0.1, 0.1]))
    first = tracks.ids.copy()
    assert len(set(first.tolist())) == 2
    # the two faces listed the other way round, moved a little, and a newcomer far from both
    tracks.update(0.033, np.array([[305, 100, 40, 40], [600, 100, 40, 40], [102, 100, 40, 40]]),
                  np.array([0.1, 0.1, 0.1]))
    assert tracks.ids[0] == first[1] and tracks.ids[2] == first[0] and tracks.ids[1] not in first


def test_frame_powers_are_the_mean_square_of_the_channels_mean_in_frames_of_about_10_ms() -> None:
    fs = 16000.0
    x = np.zeros((480, 2))
    x[:160] = [0.5, 0.3]  # first frame: the mean 0.4, power 0.16
    x[160:320, 0] = 1.0  # second: the mean 0.5
    x[320:, :] = -0.2  # third: 0.04
    times, powers = frame_powers(x, fs)
    np.testing.assert_allclose(powers, [0.16, 0.25, 0.04])
    np.testing.assert_allclose(times, [0.005, 0.015, 0.025])  # each frame's centre
    times, powers = frame_powers(np.ones(512), fs)  # a block of 32 ms: three frames of 10.7 ms, none left short
    np.testing.assert_allclose(np.diff(times), 171 / fs, atol=1 / fs)
    np.testing.assert_allclose(powers, 1.0)
    assert len(times) == 3 and frame_powers(np.ones(40), fs)[0].tolist() == [20 / fs]  # a short block: one frame
    assert frame_powers(np.zeros((0, 2)), fs)[0].size == 0


def test_the_envelope_gives_the_log_energy_around_each_time_and_forgets_the_old() -> None:
    env = SoundEnvelope(keep_s=1.0, smooth_s=0.03)
    t = np.arange(0.005, 2.0, 0.01)
    env.push(t[:100], np.full(100, 1e-2))
    env.push(t[100:], np.full(t.size - 100, 1e-4))
    np.testing.assert_allclose(env.log_energy([1.5, 1.95]), [-4.0, -4.0], rtol=1e-5)
    # the first second is gone but its last frame (keep_s before the newest); a time never heard: NaN
    assert np.isnan(env.log_energy([0.5, 0.97, 3.0])).all()
    np.testing.assert_allclose(env.log_energy([1.003]), [np.log10((1e-2 + 2e-4) / 3)], rtol=1e-5)


def test_loud_share_is_the_share_of_a_span_above_the_rooms_quiet_by_15_db() -> None:
    env = SoundEnvelope(keep_s=3.0, smooth_s=0.005)  # one 10 ms frame a time: no smoothing across them
    t = np.arange(0.005, 3.0, 0.01)
    power = np.full(t.size, 1e-6)  # the room's quiet
    power[(t > 2.0) & (t < 2.2)] = 40e-6  # 16 dB over it
    power[(t > 2.4) & (t < 2.6)] = 25e-6  # 14 dB: not loud
    env.push(t, power)
    assert env.loud_share(1.9, 2.3) == pytest.approx(0.5)  # 20 of the 40 frames
    assert env.loud_share(2.3, 2.7) == 0.0
    assert env.loud_share(2.0, 2.2) == 1.0
    assert env.loud_share(2.0, 2.2, above_db=17.0) == 0.0
    assert np.isnan(env.loud_share(3.5, 3.9)) and np.isnan(SoundEnvelope().loud_share(0.0, 1.0))


def test_a_voice_that_no_lips_in_view_make_hides_the_lips_of_the_one_face_heard() -> None:
    """The one face heard, a loud frame, no other lips moving: its still lips say nothing. Each condition alone
    undone leaves every face's opinion (a face without one may be the talker)."""
    heard = np.array([False, True, False])
    still = np.array([0.004, 0.009, 0.011])
    assert voice_without_lips(heard, still, 0.012, 0.35).tolist() == [False, True, False]
    assert voice_without_lips(heard, still, 0.012, 1.0, share_above=0.9).tolist() == [False, True, False]
    assert not voice_without_lips(heard, still, 0.012, 0.34).any()  # a clap: under a third of the frame
    assert not voice_without_lips(heard, still, 0.012, float("nan")).any()  # nothing heard in the frame
    assert not voice_without_lips(np.array([True, True, False]), still, 0.012, 1.0).any()  # two heard
    assert not voice_without_lips(np.zeros(3, dtype=bool), still, 0.012, 1.0).any()
    assert not voice_without_lips(heard, np.array([0.012, 0.009, 0.004]), 0.012, 1.0).any()  # lips that move
    assert not voice_without_lips(heard, np.array([np.nan, 0.009, 0.004]), 0.012, 1.0).any()  # no opinion
    # the heard face's own lips do not matter (moving ones are never vetoed); nor does a lone face's neighbourhood
    assert voice_without_lips(heard, np.array([0.004, np.nan, 0.004]), 0.012, 0.5).tolist() == [False, True, False]
    assert voice_without_lips(np.array([True]), np.array([0.009]), 0.012, 0.5).tolist() == [True]


def test_synchrony_follows_the_sound_a_mouth_shapes_75_ms_later() -> None:
    fs_frames = np.arange(0.005, 3.0, 0.01)
    syllables = 0.5 + 0.5 * np.sin(2 * np.pi * 4.0 * fs_frames)  # the talker's sound, 4 syllables a second
    env = SoundEnvelope()
    env.push(fs_frames, 1e-3 * (0.05 + syllables) ** 2)
    video = np.arange(2.0, 2.6, 1 / 30)
    talker = np.stack([video, 0.3 * (0.5 + 0.5 * np.sin(2 * np.pi * 4.0 * (video + 0.075)))], axis=1)
    mouthing = np.stack([video, 0.3 * (0.5 + 0.5 * np.sin(2 * np.pi * 2.7 * video + 1.0))], axis=1)
    still = np.stack([video, np.full(video.size, 0.1)], axis=1)
    few = talker[:5]
    sync = lip_synchrony([talker, mouthing, still, few], env)
    assert sync[0] > 0.9 and abs(sync[1]) < 0.5
    assert np.isnan(sync[2:]).all()  # a flat mouth, and five openings, give no opinion
    late = lip_synchrony([talker], env, lead_s=0.0)  # read without the lead the mouth's syllables miss the sound's
    assert late[0] < sync[0] - 0.1


def test_series_keeps_the_synchronys_window_while_activity_keeps_its_own() -> None:
    tracks = LipTracks(window_s=0.4, min_samples=6, sync_window_s=0.6)
    for k, t in enumerate(np.arange(0.0, 1.0, 1 / 30)):
        act = tracks.update(float(t), np.array([[100, 100, 40, 40]]), np.array([0.1 * (k >= 15)]))
    rows = tracks.series()[0]
    assert rows.shape[1] == 2 and rows[0, 0] > 1.0 - 1 / 30 - 0.6 and rows[-1, 0] == pytest.approx(29 / 30)
    assert len(rows) == 18 and act[0] == pytest.approx(0.0)  # 0.6 s of openings; the last 0.4 s all 0.1
    tracks.update(1.0, np.zeros((0, 4)), np.zeros(0))
    assert tracks.series() == []


def test_lips_within_their_own_still_level_are_still_beside_a_talker_unless_they_plainly_move() -> None:
    speaking, probability = np.ones(5, bool), np.full(5, 0.8)
    activity = np.array([0.02, 0.04, 0.02, 0.02, 0.005])
    relative = np.array([0.05, 0.05, 0.5, np.nan, np.nan])
    s, p = veto_still_lips(speaking, probability, activity, 0.012, relative)
    # a far face's jitter at its own floor: still; above the cap: moving; above its floor: moving; no floor yet:
    # only the absolute threshold
    assert s.tolist() == [False, True, True, True, False] and p.tolist() == [0.5, 0.8, 0.8, 0.8, 0.5]
    assert veto_still_lips(speaking, probability, activity, 0.012)[0].tolist() == [True, True, True, True, False]
    edge = veto_still_lips(speaking[:2], probability[:2], np.array([0.0299, 0.03]), 0.012, np.array([0.0999, 0.05]))
    assert edge[0].tolist() == [False, True]
    at_edge = veto_still_lips(speaking[:2], probability[:2], np.array([0.02, 0.05]), 0.012, np.array([0.1, 0.9]))
    assert at_edge[0].tolist() == [True, True]
    # heard alone (a hand over a lone talker's mouth jitters at its floor too): only the absolute threshold
    alone = veto_still_lips(np.array([True, False]), probability[:2], np.array([0.02, 0.02]), 0.012,
                            np.array([0.05, 0.05]))
    assert alone[0].tolist() == [True, False] and alone[1].tolist() == [0.8, 0.8]


def test_a_second_talker_whose_lips_move_with_the_sound_speaks_too() -> None:
    heard = np.array([True, False])
    prob = np.array([0.8, 0.3])
    act, rel, sync = np.array([0.08, 0.08]), np.array([0.9, 0.8]), np.array([0.6, 0.5])
    s, p = lips_with_the_words(heard, prob, act, rel, sync)
    assert s.tolist() == [True, True] and p[0] == 0.8 and 0.5 < p[1] < 0.5001
    # each condition alone keeps the second face silent: nobody else heard, too little ITD support, lips barely
    # moving, moving less than their own range, out of step with the sound, no opinion
    assert lips_with_the_words(np.array([False, False]), prob, act, rel, sync)[0].tolist() == [False, False]
    for changed in ({"prob": 0.19}, {"act": 0.05}, {"rel": 0.59}, {"sync": 0.29}, {"sync": np.nan}, {"rel": np.nan}):
        a = {"prob": prob.copy(), "act": act.copy(), "rel": rel.copy(), "sync": sync.copy()}
        for k, v in changed.items():
            a[k][1] = v
        out = lips_with_the_words(heard, a["prob"], a["act"], a["rel"], a["sync"])
        assert out[0].tolist() == [True, False] and out[1][1] == a["prob"][1], changed
    edge = lips_with_the_words(heard, np.array([0.8, 0.2]), act, np.array([0.9, 0.6]), np.array([0.6, 0.3]))
    assert edge[0].tolist() == [True, True]  # each threshold is inclusive but the activity's
    assert lips_with_the_words(np.zeros(0, bool), np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0))[0].size == 0
