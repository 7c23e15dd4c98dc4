"""avcore.lips: each face's lip activity followed from frame to frame, no opinion until it has seen enough, and the
veto that only ever removes a speaker whose lips are still."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.lips import LipTracks, veto_still_lips


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
