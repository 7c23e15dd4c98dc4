"""Each person's own ITD (avcore.own_itd): learned where the windows hear one person alone, and what it changes."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.geometry import MicPair
from avcore.inference import FaceGuidedHearing
from avcore.own_itd import OwnItds


def _pulled(rng: np.random.Generator, centre_s: float, k: int = 20) -> np.ndarray:
    return (centre_s + rng.normal(0.0, 10e-6, k))[:, None]


def test_a_lone_talkers_offset_is_learned_and_clipped() -> None:
    rng = np.random.default_rng(0)
    own = OwnItds()
    mapped = np.array([[-150e-6], [-80e-6]])
    for _ in range(200):
        own.update(mapped, _pulled(rng, -128e-6), np.array([True, False]))
    offsets = own.offsets(mapped)
    assert offsets[0, 0] == pytest.approx(22e-6, abs=2e-6)
    assert offsets[1, 0] == 0.0  # never heard alone: the mapping stays
    far = OwnItds(max_offset_s=10e-6)
    for _ in range(200):
        far.update(mapped, _pulled(rng, -128e-6), np.array([True, False]))
    assert far.offsets(mapped)[0, 0] == pytest.approx(10e-6)


def test_nothing_is_learned_while_two_are_heard_or_from_too_few_itds() -> None:
    rng = np.random.default_rng(1)
    own = OwnItds()
    mapped = np.array([[-150e-6], [80e-6]])
    own.update(mapped, _pulled(rng, -128e-6), np.array([True, True]))
    own.update(mapped, _pulled(rng, -128e-6), np.array([False, False]))
    own.update(mapped, _pulled(rng, -128e-6, k=4), np.array([True, False]))  # min_itds 5
    own.update(mapped, _pulled(rng, 100e-6), np.array([True, False]))  # another's voice: none within 60 us
    assert len(own) == 0 and not own.offsets(mapped).any()


def test_each_pair_learns_its_own_and_a_moved_person_starts_afresh() -> None:
    rng = np.random.default_rng(2)
    own = OwnItds()
    mapped = np.array([[-150e-6, 40e-6]])
    for _ in range(200):
        itds = np.hstack([_pulled(rng, -130e-6), _pulled(rng, 45e-6)])
        own.update(mapped, itds, np.array([True]))
    assert own.offsets(mapped)[0] == pytest.approx([20e-6, 5e-6], abs=2e-6)
    assert not own.offsets(mapped + 30e-6).any()


def test_offsets_move_the_persons_means_and_must_fit_the_faces() -> None:
    hearing = FaceGuidedHearing(MicPair())
    faces = np.array([[-0.8, 0.0, 2.0], [0.6, 0.0, 2.0]])
    itds = np.full(10, 1e-4)
    base = hearing.step(faces, itds)
    shifted = hearing.step(faces, itds, None, None, None, None, np.array([[15e-6], [-5e-6]]))
    assert shifted.itd_means - base.itd_means == pytest.approx([15e-6, -5e-6])
    with pytest.raises(ValueError, match="mean_offsets_s"):
        hearing.step(faces, itds, None, None, None, None, np.zeros((3, 1)))


def test_a_neighbour_nearer_the_front_is_no_longer_called_once_the_talkers_pull_is_learned() -> None:
    """One pair, a talker at -25 degrees and a silent neighbour at -13 (nearer the front); the room pulls the
    talker's window ITDs to 0.8 of their free-field value, towards the neighbour, who collects a share of them:
    heard at the mapping the neighbour is called in most results; after a few seconds of the talker alone, heard
    where the talker's voice is, never."""
    pair = MicPair()
    hearing = FaceGuidedHearing(pair)
    faces = np.array([[2.0 * np.sin(np.radians(a)), 0.0, 2.0 * np.cos(np.radians(a))] for a in (-25.0, -13.0)])
    mapped = pair.itd(faces).reshape(2, 1)
    rng = np.random.default_rng(3)
    own = OwnItds()
    calls, at_the_mapping = [], []
    for _ in range(150):  # five seconds at 30 results a second
        itds = 0.8 * mapped[0, 0] + rng.laplace(0.0, 8e-6, 20)
        out = hearing.step(faces, itds, None, None, None, None, own.offsets(mapped))
        own.update(mapped, itds[:, None], out.speaking & ~out.rescued)
        calls.append(out.speaking.copy())
        at_the_mapping.append(hearing.step(faces, itds).speaking.copy())
    calls, at_the_mapping = np.array(calls), np.array(at_the_mapping)
    assert calls[:, 0].all() and at_the_mapping[:, 0].all()
    assert at_the_mapping[-60:, 1].mean() > 0.5
    assert calls[:10, 1].any() and not calls[-60:, 1].any()
    assert own.offsets(mapped)[0, 0] == pytest.approx(-0.2 * mapped[0, 0], abs=3e-6)
