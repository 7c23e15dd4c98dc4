"""Each talker's learned spill onto a neighbour's bins (avcore.bin_spill) and the bins' claim above it
(SpeakingTest ``bin_spill``): the learner's bookkeeping, and on real bins of NAO's four microphones a reflection
that the fixed claim calls a neighbour speaking, which the learned spill does not, while the neighbour's own voice
still is."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.bin_spill import BinSpill
from avcore.speaking import SpeakingTest, bin_shares
from tests.avcore.test_bins import FS, NAO, _at_mics, _bins, _noise

MEANS = np.array([[-100e-6, 50e-6], [40e-6, 0.0], [150e-6, -80e-6]])


def test_the_median_ratio_is_learned_where_one_talker_is_heard_alone() -> None:
    spill = BinSpill(min_samples=3, memory=5)
    assert np.isnan(spill.ratios(MEANS)).all()
    alone0 = np.array([True, False, False])
    for k, s1 in enumerate([0.1, 0.3, 0.2]):
        assert np.isnan(spill.ratios(MEANS)).all(), k  # nothing before min_samples
        spill.update(MEANS, np.array([0.5, s1, 0.05]), alone0)
    r = spill.ratios(MEANS)
    assert r[0, 1] == pytest.approx(0.4) and r[0, 2] == pytest.approx(0.1)  # medians of 0.2, 0.6, 0.4 and 0.1s
    assert np.isnan(r[1]).all() and np.isnan(r[2]).all() and np.isnan(np.diag(r)).all()
    # within the tolerance on every pair it is the same person; a person who moved is someone else
    assert spill.ratios(MEANS + 8e-6)[0, 1] == pytest.approx(0.4)
    moved = MEANS.copy()
    moved[1, 1] += 15e-6
    assert np.isnan(spill.ratios(moved)[0, 1]) and spill.ratios(moved)[0, 2] == pytest.approx(0.1)
    # the memory keeps the last five: three ratios of 2.0 move the median there
    for _ in range(3):
        spill.update(MEANS, np.array([0.1, 0.2, 0.0]), alone0)
    assert spill.ratios(MEANS)[0, 1] == pytest.approx(2.0)


@pytest.mark.parametrize("alone, share", [([True, True, False], [0.5, 0.3, 0.1]),  # two heard: not alone
                                          ([False, False, False], [0.5, 0.3, 0.1]),  # nobody heard
                                          ([True, False, False], [0.0, 0.3, 0.1]),  # the talker has no bins
                                          ([True, False, False], None)])  # the bins were not looked at
def test_nothing_is_learned_unless_one_talker_with_bins_is_heard_alone(alone: list, share: list | None) -> None:
    spill = BinSpill(min_samples=1)
    spill.update(MEANS, None if share is None else np.array(share), np.array(alone))
    assert len(spill) == 0 and np.isnan(spill.ratios(MEANS)).all()


def test_people_who_keep_moving_are_forgotten_oldest_first() -> None:
    spill = BinSpill(min_samples=1, max_pairs=4)
    for k in range(5):
        spill.update(MEANS[:2] + k * 30e-6, np.array([0.5, 0.1]), np.array([True, False]))
    assert len(spill) == 4
    assert np.isnan(spill.ratios(MEANS[:2])[0, 1])  # the first place, forgotten
    assert spill.ratios(MEANS[:2] + 120e-6)[0, 1] == pytest.approx(0.2)


@pytest.mark.parametrize("bad", [{"min_samples": 0}, {"min_samples": 10, "memory": 5}, {"tolerance_s": 0.0}])
def test_bad_spill_settings_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError):
        BinSpill(**bad)
    with pytest.raises(ValueError, match="bin_spill_factor"):
        SpeakingTest(bin_spill_factor=-1.0)


def test_the_hearing_refuses_a_spill_that_is_not_one_per_pair_of_faces() -> None:
    from avcore.inference import FaceGuidedHearing

    faces = np.array([[-0.5, 0.0, 2.0], [0.5, 0.0, 2.0]])
    itds = np.tile(NAO.itd(faces[:1]).reshape(1, -1), (10, 1))
    hearing = FaceGuidedHearing(NAO)
    assert hearing.step(faces, itds, bin_spill=np.full((2, 2), np.nan)).speaking.shape == (2,)
    with pytest.raises(ValueError, match="bin_spill must be"):
        hearing.step(faces, itds, bin_spill=np.zeros((3, 3)))


def test_a_reflection_on_a_neighbour_is_claimed_half_as_often_once_learned_and_its_own_voice_always() -> None:
    """A talker on the left, and a reflection of the talker's voice from the direction of a silent neighbour (0.8 of
    its amplitude): the neighbour gets more than the fixed claim's 0.1 of the bins in nearly every quarter second,
    so the fixed claim calls them speaking nearly every time. Learned over quarter seconds in which the talker is
    heard alone, the spill (the median ratio) explains that share about half the time: the claim comes in about
    half of the quarter seconds (and the pipeline's vote over 9 results removes such scattered calls). When the
    neighbour then talks too, softer than the talker, their share rises far above the spill, and the bins claim them
    every time."""
    rng = np.random.default_rng(3)
    left, near = np.array([-0.8, 0.0, 1.5]), np.array([-0.2, 0.0, 1.6])
    means = NAO.itd(np.stack([left, near]))
    n = FS // 4
    test = SpeakingTest()
    spill = BinSpill()

    def shares(neighbour_talks: bool) -> np.ndarray:
        voice = _noise(rng, n + 400, 300, 3800)
        audio = _at_mics(voice[400:], left) + 0.8 * _at_mics(voice[:n], near)  # the reflection comes 25 ms late
        if neighbour_talks:
            audio += 0.7 * _at_mics(_noise(rng, n, 300, 3800), near)
        got = _bins(audio + 1e-3 * rng.standard_normal((n, 4)))
        return bin_shares(got.bins, got.freqs_hz, means)

    heard, prob = np.array([True, False]), np.array([0.9, 0.3])
    for _ in range(spill.min_samples):
        spill.update(means, shares(False), heard)
    ratios = spill.ratios(means)
    assert 0.1 < ratios[0, 1] < 1.0
    lone = [shares(False) for _ in range(20)]
    claims = [test._bins(heard, prob, s, spill=ratios)[0][1] for s in lone]
    fixed = [test._bins(heard, prob, s)[0][1] for s in lone]
    assert sum(fixed) >= 18  # the fixed claim calls the silent neighbour nearly every time (19 of 20 here)
    assert sum(claims) <= 12  # about half (9 of 20 here), give or take the median's scatter over 20
    for _ in range(4):
        claimed, p = test._bins(heard, prob, shares(True), spill=ratios)
        assert claimed.tolist() == [True, True] and p[1] > 0.5
    # the spill is the heard talkers': with nobody heard the claim is the fixed threshold's
    assert test._bins(np.array([False, False]), np.array([0.3, 0.3]), lone[0], spill=ratios)[0][1]
