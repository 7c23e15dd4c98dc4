"""avcore.lips: each face's lip activity followed from frame to frame, no opinion until it has seen enough, and the
veto that only ever removes a speaker whose lips are still."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.lips import HiddenLips, LipTracks, choose_by_lips, same_direction_groups, veto_still_lips


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
    """Marks are kept only while a face is heard alone; hidden needs a second from the first mark to the last and a
    median activity under twice the veto's threshold; a face not heard for the window is forgotten."""
    hidden = HiddenLips(window_s=3.0, heard_s=1.0, moving_factor=2.0)
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
    hidden = HiddenLips(window_s=3.0, heard_s=1.0, moving_factor=2.0)
    ids = np.array([1, 2])  # the talker (lips moving), the listener (still)
    for t in np.arange(0.0, 3.0, 0.05):
        out = hidden.update(float(t), ids, np.array([True, True]), np.array([0.08, 0.008]), 0.012)
        assert not out.any()
    # heard alone for a second with the same still lips: now they are hidden (a hand, a mask)
    for t in np.arange(3.0, 4.12, 0.05):
        out = hidden.update(float(t), ids, np.array([False, True]), np.array([0.08, 0.008]), 0.012)
    assert out.tolist() == [False, True]


def test_each_followed_face_keeps_its_track_number() -> None:
    tracks = LipTracks()
    tracks.update(0.0, np.array([[100, 100, 40, 40], [300, 100, 40, 40]]), np.array([0.1, 0.1]))
    first = tracks.ids.copy()
    assert len(set(first.tolist())) == 2
    # the two faces listed the other way round, moved a little, and a newcomer far from both
    tracks.update(0.033, np.array([[305, 100, 40, 40], [600, 100, 40, 40], [102, 100, 40, 40]]),
                  np.array([0.1, 0.1, 0.1]))
    assert tracks.ids[0] == first[1] and tracks.ids[2] == first[0] and tracks.ids[1] not in first
