"""The bin look of several microphone pairs (avcore.speaking.bin_shares, SpeakingTest's fourth look): its sign
against the geometry, and a phantom between two talkers that the pairs' peaks fall into but the bins do not."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from avcore.geometry import MicArray
from avcore.itd import FrameBins, PairsItdStream
from avcore.speaking import SpeakingTest, bin_shares

FS = 16000
NAO = MicArray.preset("nao")
LEFT, RIGHT, MIDDLE = np.array([-0.8, 0.0, 1.5]), np.array([0.8, 0.0, 1.5]), np.array([0.0, 0.0, 2.0])


def _noise(rng: np.random.Generator, n: int, lo_hz: float, hi_hz: float) -> np.ndarray:
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.fft.rfftfreq(n, 1 / FS)
    spec[(f < lo_hz) | (f > hi_hz)] = 0
    return np.fft.irfft(spec, n)


def _at_mics(signal: np.ndarray, source: np.ndarray) -> np.ndarray:
    """(n, Q): ``signal`` emitted at ``source`` and heard at every microphone of NAO, each delayed by its distance
    (exact fractional delays in the frequency domain; the delays are what eq. itd models)."""
    n = signal.size
    f = np.fft.rfftfreq(n, 1 / FS)
    spec = np.fft.rfft(signal)
    delays = np.linalg.norm(np.asarray(NAO.positions) - source, axis=1) / NAO.speed_of_sound
    return np.stack([np.fft.irfft(spec * np.exp(-2j * np.pi * f * d), n) for d in delays], axis=1)


def _bins(audio: np.ndarray) -> FrameBins:
    stream = PairsItdStream(NAO, FS, method="gcc-phat-robust", frame_itds=True, frame_bins=True)
    parts = []
    for i in range(0, audio.shape[0], 320):
        stream.push(audio[i:i + 320])
        parts.append(stream.pop_frame_bins())
    out = FrameBins.concatenate(parts)
    assert out.bins.shape[1:] == (NAO.n_pairs, out.freqs_hz.size) and out.bins.dtype == np.complex64
    return out


@pytest.mark.parametrize("talker", [0, 1])
def test_bins_vote_for_the_talker_on_the_side_it_is(talker: int) -> None:
    """A talker on the left, then on the right: the bins of every pair vote for that person (the extractor's phase
    and the mapping's ITD agree in sign), hardly ever for the person on the other side or the one in between."""
    rng = np.random.default_rng(talker)
    people = np.stack([LEFT, RIGHT, MIDDLE])
    audio = _at_mics(_noise(rng, FS, 300, 3800), people[talker]) + 1e-3 * rng.standard_normal((FS, 4))
    got = _bins(audio)
    share = bin_shares(got.bins, got.freqs_hz, NAO.itd(people))
    assert share[talker] > 0.5
    assert np.delete(share, talker).max() < 0.02
    # the same bins with the pairs' sign flipped (each pair's ITD negated) vote for the mirror image: nobody here
    assert bin_shares(got.bins, got.freqs_hz, -NAO.itd(people))[talker] < 0.02


def test_bins_spare_the_phantom_between_two_talkers_that_the_peaks_fall_on() -> None:
    """Two people talk at once, one on the left, one on the right, in different bands; a third sits between them.
    Judged on ITD peaks that fall between the two talkers (a phantom), the three looks call the one in the middle
    speaking; the bins of every pair give the middle person nothing and each talker a share, so with the fourth look
    the two talkers speak and the middle one does not."""
    rng = np.random.default_rng(5)
    n = FS
    audio = (_at_mics(_noise(rng, n, 300, 1700), LEFT) + _at_mics(_noise(rng, n, 2100, 3800), RIGHT)
             + 1e-3 * rng.standard_normal((n, 4)))
    people = np.stack([LEFT, RIGHT, MIDDLE])
    means = NAO.itd(people)
    got = _bins(audio)
    share = bin_shares(got.bins, got.freqs_hz, means)
    assert share[0] > 0.1 and share[1] > 0.1 and share[2] < 0.02

    phantom = means[2] + rng.normal(0.0, 5e-6, (20, NAO.n_pairs))  # every window's peaks at the one in between
    test = SpeakingTest(count_by="nearest")
    beta = np.zeros((20, 3))
    beta[:, 2] = 0.95
    supports = NAO.itd_intervals()
    var = np.full(means.shape, 1e-9)
    peaks_only, _, _ = test.decide(beta, phantom, means, var, supports)
    assert peaks_only.tolist() == [False, False, True]
    with_bins, prob, _ = test.decide(beta, phantom, means, var, supports, bin_share=share)
    assert with_bins.tolist() == [True, True, False]
    assert np.array_equal(prob > 0.5, with_bins)


def test_bin_shares_without_bins_or_people() -> None:
    empty = np.zeros((0, NAO.n_pairs, 10), dtype=np.complex64)
    assert bin_shares(empty, np.arange(10.0), NAO.itd(LEFT[None])).tolist() == [0.0]
    assert bin_shares(np.ones((3, NAO.n_pairs, 10), np.complex64), np.arange(10.0), np.zeros((0, 6))).size == 0


@pytest.mark.parametrize("bad", [{"bin_agreement": 1.5}, {"bin_confirm_share": 0.2, "bin_claim_share": 0.1},
                                 {"bin_confirm_share": -0.1}])
def test_bad_bin_settings_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError, match="bin_"):
        SpeakingTest(**bad)


def test_bin_shares_of_single_silent_faint_and_exactly_agreeing_bins() -> None:
    # one bin of one pair, its phase that of a person 100 us to the left at 1 kHz: the whole share is theirs
    tau = np.array([[100e-6], [-200e-6]])
    one = np.exp(-2j * np.pi * 1000.0 * tau[0, 0]).astype(np.complex64).reshape(1, 1, 1)
    assert bin_shares(one, np.array([1000.0]), tau) == pytest.approx([1.0, 0.0], abs=1e-6)
    # faint bins (their weights sum to far less than 1) count as much as loud ones: a share is relative
    assert bin_shares(1e-3 * one, np.array([1000.0]), tau) == pytest.approx([1.0, 0.0], abs=1e-6)
    # silent bins (no weight at all): no share, one per person, not a division by zero
    silent = bin_shares(np.zeros((4, 1, 3), np.complex64), np.array([500.0, 1000.0, 1500.0]), tau)
    assert silent.shape == (2,) and silent.tolist() == [0.0, 0.0]
    # a bin at 0 Hz agrees exactly (a = 1) with everyone, and an agreement of exactly 1 takes it (a >= agreement)
    dc = np.ones((1, 1, 1), np.complex64)
    assert bin_shares(dc, np.array([0.0]), tau, agreement=1.0).tolist() == [1.0, 0.0]  # the first of equals


def test_the_bins_look_keeps_drops_and_claims_with_its_probability() -> None:
    test = SpeakingTest()  # confirms above 0.03 of the bins, claims above 0.1
    speaking = np.array([True, True, False, False, True, False])
    prob = np.array([0.9, 0.8, 0.3, 0.2, 0.7, 0.4])
    share = np.array([0.2, 0.01, 0.25, 0.05, 0.03, 0.1])  # the last two exactly at the thresholds
    out, p = test._bins(speaking, prob, share)
    assert out.tolist() == [True, False, True, False, False, False]
    # unchanged states keep the probability that decided them; a changed one gets its share against the threshold
    # that decided it (a dropped talker against the confirmation, a claimed person against the claim)
    assert p == pytest.approx([0.9, 0.01 / 0.04, 0.25 / 0.35, 0.2, 0.5, 0.4])
    # with a confirmation of 0, a talker with no bins at all is dropped with probability 0: no 0/0, no warning
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out, p = SpeakingTest(bin_confirm_share=0.0)._bins(np.array([True]), np.array([0.9]), np.array([0.0]))
    assert out.tolist() == [False] and p.tolist() == [0.0]


def test_decide_passes_its_probabilities_through_the_bins_look() -> None:
    itds = np.repeat([[-100e-6], [100e-6]], 8, axis=0)
    means, variances, supports = np.array([[-100e-6], [100e-6]]), np.full((2, 1), 1e-10), np.array([[-3.5e-4, 3.5e-4]])
    beta = np.zeros((16, 2))
    beta[:8, 0] = 1.0
    test = SpeakingTest()
    speaking, prob, _ = test.decide(beta, itds, means, variances, supports)
    assert speaking.tolist() == [True, False]
    # the bins confirm the talker and do not claim the other: both states and probabilities stay as they were
    kept, kept_prob, _ = test.decide(beta, itds, means, variances, supports, bin_share=np.array([0.5, 0.05]))
    assert kept.tolist() == [True, False] and kept_prob.dtype == float and kept_prob.tolist() == prob.tolist()


def test_one_pairs_bins_claim_only_a_larger_share() -> None:
    """With one pair a bin agrees with every ITD whose phase lies within the agreement at its frequency, and no other
    pair narrows it: the bins claim a person only above ``bin_claim_share_one_pair`` (0.25), above
    ``bin_claim_share`` (0.1) with several pairs."""
    beta = np.zeros((16, 2))
    beta[:8, 0] = 1.0
    test = SpeakingTest()
    for pairs, claimed_at in ((1, 0.25), (3, 0.1)):
        itds = np.repeat([[-100e-6] * pairs, [100e-6] * pairs], 8, axis=0)
        means = np.array([[-100e-6] * pairs, [100e-6] * pairs])
        variances, supports = np.full((2, pairs), 1e-10), np.tile([-3.5e-4, 3.5e-4], (pairs, 1))
        for share, claims in ((claimed_at - 0.01, False), (claimed_at + 0.01, True)):
            speaking, prob, _ = test.decide(beta, itds, means, variances, supports,
                                            bin_share=np.array([0.5, share]))
            assert speaking.tolist() == [True, claims], (pairs, share)
            assert (prob[1] > 0.5) == claims
        dropped, _, _ = test.decide(beta, itds, means, variances, supports, bin_share=np.array([0.02, 0.0]))
        # a share under 0.03 drops the talker with several pairs; one pair's bins confirm nothing (a phantom owns
        # bins there too)
        assert dropped.tolist() == [pairs == 1, False]
    with pytest.raises(ValueError, match="bin_claim_share_one_pair"):
        SpeakingTest(bin_claim_share_one_pair=0.02)


def test_one_pairs_bins_never_outvote_the_talker_the_other_looks_hear() -> None:
    """With one pair a bin's phase cannot tell a second voice from one voice mixed with a steady sound (both put it
    between them), so while the other looks hear a talker the pair's bins claim only a person whose share is at most
    the talker's: the quieter voice of an overlap. Several pairs rule such phases out and claim as before; with
    nobody heard, the pair's bins claim too (a talker masked in every window and frame)."""
    beta = np.zeros((16, 2))
    beta[:8, 0] = 1.0  # the windows hear person 0
    test = SpeakingTest()
    for pairs in (1, 3):
        itds = np.repeat([[-100e-6] * pairs, [100e-6] * pairs], 8, axis=0)
        means = np.array([[-100e-6] * pairs, [100e-6] * pairs])
        variances, supports = np.full((2, pairs), 1e-10), np.tile([-3.5e-4, 3.5e-4], (pairs, 1))
        for talker, other, claims in ((0.4, 0.3, True), (0.4, 0.4, True), (0.3, 0.4, pairs > 1)):
            speaking, prob, _ = test.decide(beta, itds, means, variances, supports,
                                            bin_share=np.array([talker, other]))
            assert speaking.tolist() == [True, claims], (pairs, talker, other)
            assert (prob[1] > 0.5) == claims
        quiet = np.zeros((16, 2))
        speaking, _, _ = test.decide(quiet, itds, means, variances, supports, bin_share=np.array([0.0, 0.6]))
        assert speaking.tolist() == [False, True], pairs


def _three_on_two_pairs(middle: list[float], heard: list[int]) -> tuple:
    """Three people on two pairs (left, ``middle``, right, microseconds) and 8 windows' ITDs at each heard one."""
    means = np.array([[-100e-6, -80e-6], np.asarray(middle) * 1e-6, [100e-6, 80e-6]])
    itds = np.repeat(means[heard], 8, axis=0)
    beta = np.zeros((itds.shape[0], 3))
    for k, who in enumerate(heard):
        beta[8 * k:8 * (k + 1), who] = 1.0
    return beta, itds, means, np.full((3, 2), 1e-10), np.tile([-3.5e-4, 3.5e-4], (2, 1))


def test_a_person_between_two_talkers_needs_the_bins_claim() -> None:
    """Two voices at once put a pair's peak between them, on every pair: the windows hear the person whose ITD
    vector lies near the chord between the two talkers'. Such a call stands only where the bins would claim the
    person on their own (a share above ``bin_claim_share``), not merely confirm it (above ``bin_confirm_share``);
    a person off the chord keeps the confirmation's rule."""
    test = SpeakingTest()  # between_chord 0.3: off the chord by at most 0.3 of its length
    on_chord = _three_on_two_pairs([0.0, 5.0], [0, 1, 2])
    for middle_share, called in ((0.07, False), (0.12, True)):
        speaking, prob, _ = test.decide(*on_chord, bin_share=np.array([0.3, middle_share, 0.3]))
        assert speaking.tolist() == [True, called, True], middle_share
        assert (prob[1] > 0.5) == called
    off_chord = _three_on_two_pairs([0.0, 120.0], [0, 1, 2])  # 94 us off the 256 us chord: 0.37 of it
    assert test.decide(*off_chord, bin_share=np.array([0.3, 0.07, 0.3]))[0].tolist() == [True, True, True]
    # beyond either end of the chord is not between
    beyond = _three_on_two_pairs([150.0, 120.0], [0, 1, 2])
    assert test.decide(*beyond, bin_share=np.array([0.3, 0.07, 0.3]))[0].tolist() == [True, True, True]
    # one pair keeps its own rule (its bins confirm nothing): the windows' call of the person between stands
    beta, itds, means, variances, supports = on_chord
    one = test.decide(beta, itds[:, :1], means[:, :1], variances[:, :1], supports[:1],
                      bin_share=np.array([0.3, 0.07, 0.3]))
    assert one[0].tolist() == [True, True, True]
    # 0 switches the rule off
    off = SpeakingTest(between_chord=0.0)
    assert off.decide(*on_chord, bin_share=np.array([0.3, 0.07, 0.3]))[0].tolist() == [True, True, True]
    with pytest.raises(ValueError, match="between_chord"):
        SpeakingTest(between_chord=-0.1)


def test_a_talker_masked_by_the_phantom_still_makes_its_neighbour_between() -> None:
    """Where the phantom between two talkers takes the windows of one of them, that talker is not heard; its bins'
    share at least the middle person's still marks the middle person as between (a quieter share does not)."""
    test = SpeakingTest()
    masked = _three_on_two_pairs([0.0, 5.0], [1, 2])  # the windows hear the middle and the right, not the left
    assert test.decide(*masked, bin_share=np.array([0.08, 0.07, 0.4]))[0].tolist() == [False, False, True]
    assert test.decide(*masked, bin_share=np.array([0.05, 0.07, 0.4]))[0].tolist() == [False, True, True]
