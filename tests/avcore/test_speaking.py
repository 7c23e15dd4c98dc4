from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from avcore.mixture import Mixture1D
from avcore.speaking import (RescueContinuity, SpeakingTest, SpeakingVote, _poisson_quantile, speaking_threshold,
                             vote_speaking)

SUPPORT = (-350e-6, 350e-6)
MODEL = Mixture1D(np.array([0.3, 0.3, 0.4]), np.array([-100e-6, 100e-6]), np.array([4e-10, 4e-10]), SUPPORT)


@given(st.floats(0.0, 80.0), st.sampled_from([0.5, 0.9, 0.95, 0.99]))
def test_poisson_quantile_matches_scipy(lam: float, q: float) -> None:
    assert _poisson_quantile(q, np.array([lam]))[0] == stats.poisson.ppf(q, lam) or lam == 0


def _beta(itds: np.ndarray) -> np.ndarray:
    return MODEL.responsibilities(itds)[:, :-1]


def _decide(test: SpeakingTest, beta: np.ndarray, itds: np.ndarray, model: Mixture1D,
            present: np.ndarray | None = None, frame_itds: np.ndarray | None = None, band_itds: np.ndarray | None = None
            ) -> tuple[np.ndarray, np.ndarray, float]:
    """The test on one pair: values become (K, 1) vectors, the model's Gaussians (N, 1)."""
    def column(v: np.ndarray | None) -> np.ndarray | None:
        return None if v is None else np.asarray(v, dtype=np.float64).reshape(-1, 1)

    return test.decide(beta, column(itds), model.means[:, None], model.variances[:, None], np.array([model.support]),
                       present, column(frame_itds), column(band_itds))


def test_paper_rule_is_tau_a() -> None:
    itds = np.array([-100e-6, -95e-6, -105e-6, 100e-6, 250e-6])
    paper = SpeakingTest(outlier_aware=False)
    speaking, prob, tau = _decide(paper, _beta(itds), itds, MODEL)
    assert tau == pytest.approx(speaking_threshold(5, 2)) == pytest.approx(5 / 4)
    assert speaking.tolist() == [True, False]
    np.testing.assert_array_equal(prob > 0.5, speaking)


def test_paper_rule_at_tau_a_exactly_and_its_probability() -> None:
    """Eq. (audio_act): a person speaks when beta_bar_n exceeds tau_A; the probability is beta_bar_n / (beta_bar_n +
    tau_A), 0 with no ITD at all. Responsibilities are given here, not fitted, so the counts are exact."""
    paper = SpeakingTest(outlier_aware=False)
    means, var, supports = np.array([[-1e-4], [1e-4]]), np.full((2, 1), 1e-10), np.array([[-3.5e-4, 3.5e-4]])
    beta = np.array([[1.0, 0.0], [0.5, 0.5], [0.5, 0.0], [0.0, 0.0]])  # (K = 4, N = 2), the rest the outliers
    speaking, prob, tau = paper.decide(beta, np.zeros(4), means, var, supports)
    assert tau == 1.0 and beta.sum(axis=0)[0] == 2.0 and beta.sum(axis=0)[1] == 0.5
    assert speaking.tolist() == [True, False]
    np.testing.assert_allclose(prob, [2.0 / 3.0, 0.5 / 1.5])
    tie = np.array([[1.0, 0.0], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]])  # beta_bar_0 = tau_A = 1
    exactly, prob, _ = paper.decide(tie, np.zeros(4), means, var, supports)
    assert not exactly.any() and prob.tolist() == [0.5, 0.0]
    one = np.array([[0.25, 0.0]])  # a single ITD, a quarter of it to person 0: tau_A = 1/4, a tie is silent
    speaking, prob, tau = paper.decide(one, np.zeros(1), means, var, supports)
    assert tau == 0.25 and speaking.tolist() == [False, False] and prob.tolist() == [0.5, 0.0]


def test_outlier_aware_ignores_a_few_stray_itds() -> None:
    # three stray ITDs, one of them by chance on a person: the paper's tau_A = 3/4 fires, ours does not
    itds = np.array([-98e-6, 20e-6, 300e-6])
    paper, _, _ = _decide(SpeakingTest(outlier_aware=False), _beta(itds), itds, MODEL)
    ours, prob, _ = _decide(SpeakingTest(), _beta(itds), itds, MODEL)
    assert paper[0] and not ours.any()
    assert np.all(prob <= 0.5)


def test_outlier_aware_keeps_a_talker_among_unseen_ones() -> None:
    # 8 ITDs of the visible talker, 14 of talkers the model does not know: tau_A = 22/4 = 5.5 is met
    # by few, ours counts the talker's ITDs against chance
    rng = np.random.default_rng(0)
    itds = np.concatenate([rng.normal(-100e-6, 10e-6, 6), rng.normal(280e-6, 10e-6, 16)])
    paper, _, _ = _decide(SpeakingTest(outlier_aware=False), _beta(itds), itds, MODEL)
    ours, prob, _ = _decide(SpeakingTest(), _beta(itds), itds, MODEL)
    assert not paper[0] and ours[0] and not ours[1]
    np.testing.assert_array_equal(prob > 0.5, ours)


def test_no_itds_nobody_speaks() -> None:
    speaking, prob, tau = _decide(SpeakingTest(), np.zeros((0, 2)), np.empty(0), MODEL)
    assert not speaking.any() and np.all(prob == 0) and tau == 0


def test_frame_rescue_finds_a_talker_masked_in_every_window() -> None:
    """The window ITDs are all the louder talker's (at -100 us); the other one (at +100 us) wins 10 of 45 frames.
    Chance: a fifth of the 45 frames spread over 700 us put 0.64 within +-25 us on average (at most 3 in 99 %), and
    the louder talker's frames 200 us away spill almost none over."""
    itds = np.full(20, -100e-6) + np.linspace(-5e-6, 5e-6, 20)
    rng = np.random.default_rng(0)
    frame_itds = np.concatenate([np.full(30, -100e-6), np.full(10, 104e-6), rng.uniform(-350e-6, 350e-6, 5)])
    windows_only, _, _ = _decide(SpeakingTest(), _beta(itds), itds, MODEL)
    assert windows_only.tolist() == [True, False]
    speaking, prob, _ = _decide(SpeakingTest(), _beta(itds), itds, MODEL, frame_itds=frame_itds)
    assert speaking.tolist() == [True, True]
    np.testing.assert_array_equal(prob > 0.5, speaking)
    off, _, _ = _decide(SpeakingTest(frame_rescue=False), _beta(itds), itds, MODEL, frame_itds=frame_itds)
    assert off.tolist() == [True, False]
    # what chance allows is not enough
    chance = np.concatenate([np.full(30, -100e-6), np.full(3, 104e-6), np.linspace(-340e-6, 340e-6, 12)[::3]])
    speaking, prob, _ = _decide(SpeakingTest(), _beta(itds), itds, MODEL, frame_itds=chance)
    assert speaking.tolist() == [True, False] and prob[1] < 0.5


def test_decide_all_says_which_calls_only_the_later_looks_made() -> None:
    """The masked talker of the test above is called by the frames alone: ``rescued`` says so, and not of the
    talker the windows hear; the paper's test has no later look, so it rescues nobody."""
    itds = np.full(20, -100e-6) + np.linspace(-5e-6, 5e-6, 20)
    rng = np.random.default_rng(0)
    frame_itds = np.concatenate([np.full(30, -100e-6), np.full(10, 104e-6), rng.uniform(-350e-6, 350e-6, 5)])
    d = SpeakingTest().decide_all(_beta(itds), itds[:, None], MODEL.means[:, None], MODEL.variances[:, None],
                                  np.array([MODEL.support]), frame_itds=frame_itds[:, None])
    assert d.speaking.tolist() == [True, True] and d.rescued.tolist() == [False, True]
    speaking, prob, tau = _decide(SpeakingTest(), _beta(itds), itds, MODEL, frame_itds=frame_itds)
    np.testing.assert_array_equal(d.speaking, speaking)
    np.testing.assert_array_equal(d.probability, prob)
    assert d.tau_a == tau
    paper = SpeakingTest(outlier_aware=False).decide_all(_beta(itds), itds[:, None], MODEL.means[:, None],
                                                         MODEL.variances[:, None], np.array([MODEL.support]))
    assert paper.rescued.tolist() == [False, False] and paper.speaking.tolist() == [True, False]


def test_rescue_continuity_carries_speech_on_and_never_starts_it() -> None:
    """Person 7 is heard by the windows at 0.0 s; rescued calls carry them on in steps of 0.1 s (each within the
    gap of the last call that stood) until a 0.2 s hole breaks the chain; person 9, rescued from the start and
    never heard by the windows, is never called. A call dropped keeps a probability of at most 0.5; a call of the
    windows always stands."""
    c = RescueContinuity(gap_s=0.1)
    ids = np.array([7, 9])
    states = []
    for stamp, windows_7, rescued in [(0.0, True, (False, True)), (0.1, False, (True, True)),
                                      (0.2, False, (True, True)), (0.4, False, (True, True)),
                                      (0.5, True, (False, True))]:
        speaking = np.array([True, True])
        probability = np.array([0.9 if windows_7 else 0.7, 0.8])
        out, prob = c.update(stamp, ids, speaking, probability, np.array(rescued))
        np.testing.assert_array_equal(prob > 0.5, out)
        states.append(out.tolist())
    assert states == [[True, False], [True, False], [True, False], [False, False], [True, False]]
    # silent people and people the windows hear are passed through as they are
    out, prob = c.update(0.6, ids, np.array([False, True]), np.array([0.2, 0.9]), np.array([False, False]))
    assert out.tolist() == [False, True] and prob.tolist() == [0.2, 0.9]


def test_rescue_continuity_ends_a_chain_a_while_after_the_windows_last_heard_the_person() -> None:
    """Person 3 is heard by the windows at 0.0 s, then only rescued, every 0.1 s: the chain stands until 1.0 s
    after that call (``chain_s``) and no longer, though no gap breaks it; a new call of the windows at 1.5 s
    starts a chain again. With ``chain_s`` of 10 s the whole chain stands."""
    for chain_s, last_standing in ((1.0, 1.0), (10.0, 1.4)):
        c = RescueContinuity(gap_s=0.1, chain_s=chain_s)
        standing = []
        for k in range(20):
            stamp = round(0.1 * k, 1)
            windows = k in (0, 15)
            out, prob = c.update(stamp, np.array([3]), np.array([True]), np.array([0.8]), np.array([not windows]))
            assert (prob[0] > 0.5) == out[0]
            if out[0]:
                standing.append(stamp)
        before = [t for t in standing if t < 1.5]
        assert before == [round(0.1 * k, 1) for k in range(int(round(last_standing * 10)) + 1)], chain_s
        assert standing[len(before):] == [1.5, 1.6, 1.7, 1.8, 1.9]
    with pytest.raises(ValueError, match="chain_s"):
        RescueContinuity(chain_s=-1.0)


def test_rescue_continuity_forgets_and_checks_its_input() -> None:
    """An id unseen for ``memory_s`` is forgotten; mismatched lengths are refused."""
    c = RescueContinuity(gap_s=1.0, memory_s=2.0)
    c.update(0.0, np.array([1]), np.array([True]), np.array([0.9]), np.array([False]))
    assert c.update(0.5, np.array([1]), np.array([True]), np.array([0.6]), np.array([True]))[0].tolist() == [True]
    c.update(3.0, np.array([2]), np.array([False]), np.array([0.1]), np.array([False]))
    assert 1 not in c._last
    with pytest.raises(ValueError, match="one entry per person"):
        c.update(3.1, np.array([1, 2]), np.array([True]), np.array([0.9]), np.array([False]))


def test_frame_rescue_expects_a_talkers_frames_to_spill_over_to_a_neighbour() -> None:
    """A talker 40 us from a silent person: single frames scatter (Laplace, scale 20 us), and about one in six lands
    nearer the silent person. That is the talker's spill, not a second talker."""
    model = Mixture1D(np.array([0.4, 0.2, 0.4]), np.array([0.0, 40e-6]), np.array([1e-9, 1e-9]), SUPPORT)
    itds = np.zeros(1)
    beta = model.responsibilities(itds)[:, :-1]
    u = (np.arange(30) + 0.5) / 30  # the talker's 30 frames: Laplace quantiles
    frames = -20e-6 * np.sign(u - 0.5) * np.log(1 - 2 * np.abs(u - 0.5))
    d = np.abs(frames[:, None] - model.means[None, :])
    assert np.sum((d[:, 1] <= 25e-6) & (d[:, 1] < d[:, 0])) >= 4  # frames nearer the silent person
    speaking, _, _ = _decide(SpeakingTest(), beta, itds, model, frame_itds=frames)
    assert speaking.tolist() == [True, False]  # the talker by its frames (one window ITD is too few), not the other
    naive, _, _ = _decide(SpeakingTest(frame_spread_s=1e-12), beta, itds, model, frame_itds=frames)
    assert naive.tolist() == [True, True]  # without the spill, the silent neighbour would speak too


def test_frame_rescue_counts_a_frame_for_the_nearest_person_only() -> None:
    """Two people 40 us apart: frames at the talker's ITD are within 25 us of the talker alone (nearest person),
    frames in between count for the nearer one."""
    model = Mixture1D(np.array([0.3, 0.3, 0.4]), np.array([0.0, 40e-6]), np.array([4e-10, 4e-10]), SUPPORT)
    itds = np.array([0.0, 2e-6])
    beta = model.responsibilities(itds)[:, :-1]
    frames = np.full(12, 15e-6)  # within 25 us of both, nearer to the first
    speaking, _, _ = _decide(SpeakingTest(min_itds=5), beta, itds, model, frame_itds=frames)
    assert speaking.tolist() == [True, False]


def test_band_itds_find_a_talker_and_spare_a_phantom_between_two() -> None:
    """The bands' peaks are a third look, with a wider spread (30 us): 12 of them at a quiet talker make it speak.
    Two people talking at once put their shared bands at a phantom between them: a person lying between two
    speaking people is not called speaking on the bands."""
    model = Mixture1D(np.array([0.25, 0.25, 0.25, 0.25]), np.array([-150e-6, 0.0, 150e-6]),
                      np.array([4e-10, 4e-10, 4e-10]), SUPPORT)
    itds = np.full(20, -150e-6) + np.linspace(-5e-6, 5e-6, 20)
    beta = model.responsibilities(itds)[:, :-1]
    bands = np.concatenate([np.full(60, -150e-6), np.full(12, 148e-6)])
    speaking, prob, _ = _decide(SpeakingTest(), beta, itds, model, band_itds=bands)
    assert speaking.tolist() == [True, False, True]
    np.testing.assert_array_equal(prob > 0.5, speaking)
    assert _decide(SpeakingTest(frame_rescue=False), beta, itds, model, band_itds=bands)[0].tolist() == [
        True, False, False]
    # both outer people speak (the windows): bands at the middle person are a phantom of the two
    both = np.concatenate([itds, np.full(20, 150e-6)])
    beta = model.responsibilities(both)[:, :-1]
    phantom = np.concatenate([np.full(40, -150e-6), np.full(40, 150e-6), np.full(30, 2e-6)])
    speaking, _, _ = _decide(SpeakingTest(), beta, both, model, band_itds=phantom)
    assert speaking.tolist() == [True, False, True]
    # the same ITDs as single frames (narrower, no phantom there) do call the middle person
    speaking, _, _ = _decide(SpeakingTest(), beta, both, model, frame_itds=phantom)
    assert speaking.tolist() == [True, True, True]


def test_vote_takes_each_persons_majority_over_the_window() -> None:
    """Person 7 speaks in 2 of the 4 results that hold it: not more than half, silent; person 3 in 4 of 5 (a
    one-result gap): speaking; person 9 in 1 of 2: silent. Probabilities follow the votes they change."""
    window = [(np.array([3, 7]), np.array([True, True])),
              (np.array([3, 7, 9]), np.array([False, True, True])),
              (np.array([7, 3, 9]), np.array([False, True, False])),
              (np.array([3, 7]), np.array([True, False])),
              (np.array([3]), np.array([True]))]
    ids, spk = window[1]
    voted, prob = vote_speaking(ids, spk, np.array([0.3, 0.8, 0.9]), window)
    assert voted.tolist() == [True, False, False]
    np.testing.assert_allclose(prob, [0.8, 0.5, 0.5])
    np.testing.assert_array_equal(prob > 0.5, voted)
    alone, kept = vote_speaking(ids, spk, np.array([0.3, 0.8, 0.9]), [window[1]])  # a window of one: unchanged
    assert alone.tolist() == spk.tolist() and kept.tolist() == [0.3, 0.8, 0.9]  # states the vote keeps keep theirs
    with pytest.raises(ValueError, match="one entry per person"):
        vote_speaking(np.array([1, 2]), np.array([True]), np.array([0.9]), window)


@pytest.mark.parametrize("bad", [{"count_by": "loudest"}, {"frame_within_s": 0.0}, {"frame_spread_s": -1e-6},
                                 {"frame_quantile": 1.0}, {"frame_quantile": 0.0}, {"band_spread_s": 0.0},
                                 {"bin_agreement": -1.5}, {"bin_claim_share": 1.5}])
def test_bad_settings_are_refused(bad: dict) -> None:
    with pytest.raises(ValueError, match=next(iter(bad))):
        SpeakingTest(**bad)


def test_settings_at_their_bounds_are_taken_and_a_bad_count_names_the_choices() -> None:
    for good in ({"bin_agreement": -1.0}, {"bin_agreement": 1.0}, {"bin_confirm_share": 0.1, "bin_claim_share": 0.1},
                 {"bin_claim_share": 1.0}):
        SpeakingTest(**good)
    with pytest.raises(ValueError, match="one of posterior, nearest, window"):
        SpeakingTest(count_by="loudest")


def test_speaking_vote_streams_the_majority_with_its_lag() -> None:
    vote = SpeakingVote(3)
    ids = np.array([7])
    states = [False, True, False, True, True, False, True]  # one-result gaps and blips
    out = []
    for k, s in enumerate(states):
        released = vote.push(k, ids, np.array([s]), np.array([0.9 if s else 0.1]))
        assert len(released) == (1 if k >= 1 else 0)  # each result waits for the one after it
        out += released
    out += vote.flush()
    assert [item for item, _, _ in out] == list(range(len(states)))
    voted = [bool(s[0]) for _, s, _ in out]
    # majority over (k-1, k, k+1), over what there is at the ends
    expected = [False, False, True, True, True, True, False]
    assert voted == expected
    assert all((p[0] > 0.5) == s[0] for _, s, p in out)


def test_speaking_vote_of_one_passes_through() -> None:
    vote = SpeakingVote(1)
    got = vote.push("r", np.array([1, 2]), np.array([True, False]), np.array([0.8, 0.2]))
    assert got[0][0] == "r" and got[0][1].tolist() == [True, False] and vote.flush() == []
    # states and probabilities leave as bool and float whatever they came as (0 / 1 from a caller's counts)
    ((_, states, prob),) = vote.push("s", [1, 2], [1, 0], [1, 0])
    assert states.dtype == bool and prob.dtype == float and prob.tolist() == [1.0, 0.0]
    with pytest.raises(ValueError, match="odd"):
        SpeakingVote(4)


@pytest.mark.parametrize("n_itds", [50, 400])
def test_the_outlier_aware_threshold_either_side(n_itds: int) -> None:
    """One person at 0 with sigma 20 us: the window is +-40 us, 8 % of the +-500 us support. If a fifth of the K
    ITDs strayed uniformly, the window would hold Poisson(lam = 0.2 K 0.08) of them; the person speaks when the
    count exceeds that Poisson's 90 % quantile (scipy's, an independent reference) and is at least 2. Counts just
    at and just below the threshold decide both ways (a threshold scaled by 1.5 flips the first)."""
    test = SpeakingTest(frame_rescue=False)
    model = Mixture1D(np.array([0.5, 0.5]), np.array([0.0]), np.array([(20e-6) ** 2]), (-500e-6, 500e-6))
    lam = 0.2 * n_itds * (80e-6 / 1000e-6)
    threshold = max(int(stats.poisson.ppf(0.9, lam)) + 1, 2)
    assert threshold == (3 if n_itds == 50 else 11)  # the two regimes: min_itds-bound and quantile-bound
    for count, speaks in ((threshold, True), (threshold - 1, False)):
        inside = np.linspace(-30e-6, 30e-6, count)
        outside = np.full(n_itds - count, 400e-6)  # nobody's: far from the person
        itds = np.concatenate([inside, outside])
        beta = (np.abs(itds) < 100e-6).astype(float)[:, None]  # the person's posterior: 1 inside, 0 outside
        speaking, probability, _ = _decide(test, beta, itds, model)
        assert bool(speaking[0]) is speaks, (count, threshold)
        assert bool(probability[0] > 0.5) is speaks


def test_a_trailing_vote_releases_each_result_at_once_over_the_past() -> None:
    """trailing: each result leaves when pushed, voted over itself and the frames - 1 before it."""
    vote = SpeakingVote(3, trailing=True)
    ids = np.array([4])
    states = [True, False, True, True, False, False]
    out = [vote.push(k, ids, np.array([s]), np.array([0.9 if s else 0.1])) for k, s in enumerate(states)]
    assert [len(o) for o in out] == [1] * 6 and [o[0][0] for o in out] == list(range(6))
    # majority of the results pushed so far, at most three: T | T,F | T,F,T | F,T,T | T,T,F | T,F,F
    assert [bool(o[0][1][0]) for o in out] == [True, False, True, True, True, False]
    # a state the vote keeps keeps its probability; one it changes gets the share of speaking votes
    assert [float(o[0][2][0]) for o in out] == [0.9, 0.1, 0.9, 0.9, 2 / 3, 0.1]
    assert vote.waiting == 0 and vote.flush() == []
    # five results: over the four before each one too (a window of 2 * 2 + 1)
    five = SpeakingVote(5, trailing=True)
    got = [five.push(k, ids, np.array([s]), np.array([0.5])) for k, s in enumerate([True, True, True, False, False])]
    assert bool(got[-1][0][1][0])  # T, T, T, F, F: three of five speak


def test_frame_rescue_chance_is_the_poisson_mean_its_docstring_writes(monkeypatch: pytest.MonkeyPatch) -> None:
    """The frames' look, its chance count written out from SpeakingTest._rescue's docstring with loops: frames that
    stray uniformly (a share of them, the tightest pair's box) plus those another person's frames spill over
    (Laplacian errors of scale b), summed over groups of frames that have different pairs; a frame exactly at
    frame_within_s counts; a person speaks at max(quantile + 1, frame_min) frames or more."""
    lams: list[np.ndarray] = []

    def quantile(q: float, lam: np.ndarray) -> np.ndarray:
        lams.append(np.asarray(lam, dtype=np.float64).copy())
        return np.full(np.shape(lam), 3.0)

    monkeypatch.setattr("avcore.speaking._poisson_quantile", quantile)
    delta, b, share = 25e-6, 20e-6, 0.2
    test = SpeakingTest(frame_within_s=delta, frame_min=2, outlier_share=share)
    means = np.array([[0.0, 0.0], [40e-6, 100e-6]])  # two people, two pairs
    u = np.array([1 / 30e-6, 1 / 0.8e-3])  # the pairs' uniform densities (pair 0's box is wider than its interval)
    nan = np.nan
    both = [[0.0, 0.0], [10e-6, -5e-6], [25e-6, 0.0], [40e-6, 100e-6]]  # 3 for person 0 (one at delta), 1 for 1
    first = [[-10e-6, nan], [30e-6, nan], [45e-6, nan], [50e-6, nan]]  # pair 0 only: 1 for person 0, 3 for 1
    obs = np.array(both + first)
    speaking, prob = test._rescue(np.array([False, False]), np.array([0.1, 0.1]), obs, means, u, b)
    expected = np.zeros(2)
    for counts, pairs in (([3, 1], [0, 1]), ([1, 3], [0])):
        stray = share * 4 * min(min(2 * delta * u[p], 1.0) for p in pairs)
        for n in range(2):
            spilt = 0.0
            for s in range(2):
                if s != n:
                    per_pair = []
                    for p in pairs:
                        g = abs(means[s, p] - means[n, p])
                        lo, hi = max(g / 2, g - delta), g + delta
                        per_pair.append(0.5 * (math.exp(-lo / b) - math.exp(-hi / b)))
                    spilt += counts[s] / (1 - math.exp(-delta / b)) * min(per_pair)
            expected[n] += stray + spilt
    (lam,) = lams
    np.testing.assert_allclose(lam, expected, rtol=1e-12)
    # four frames each against a threshold of max(3 + 1, 2) = 4: both speak, at a probability of 4 / (4 + 4)
    assert speaking.tolist() == [True, True]
    np.testing.assert_allclose(prob, [0.5, 0.5], rtol=1e-6)


@pytest.mark.parametrize("count_by", ["posterior", "window"])
def test_the_window_look_counts_and_chance_as_its_docstring_writes(monkeypatch: pytest.MonkeyPatch,
                                                                   count_by: str) -> None:
    """The outlier-aware window test's count and Poisson mean, written out: each person's window is +-window_sd
    sigma (at least min_sd_s) on every pair a vector has, an ITD exactly at its edge inside; chance is a share of the
    vectors times the window's share of the ITD interval, the tightest pair's, at most 1; rows with different
    pairs count apart and add up."""
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    original = SpeakingTest._count_test

    def record(self: SpeakingTest, counts: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        seen.append((counts.copy(), lam.copy()))
        return original(self, counts, lam)

    monkeypatch.setattr(SpeakingTest, "_count_test", record)
    test = SpeakingTest(count_by=count_by, frame_rescue=False)  # windows of 2 sd, 20 us at least, share 0.2
    means = np.array([[0.0, 0.0], [200e-6, 100e-6]])
    variances = np.array([[1e-12, 1e-12], [(50e-6) ** 2, 1e-12]])  # half windows 40 us; 100 us and 40 us
    supports = np.array([[-50e-6, 50e-6], [-1e-3, 1e-3]])  # pair 0's interval narrower than a window
    nan = np.nan
    itds = np.array([[40e-6, 0.0], [10e-6, 30e-6], [250e-6, 100e-6], [41e-6, 0.0],  # both pairs
                     [-40e-6, nan], [150e-6, nan]])  # pair 0 only
    beta = np.array([[0.5, 0.0], [1.0, 0.0], [0.0, 0.8], [0.9, 0.0], [0.7, 0.0], [0.0, 0.6]])
    test.decide(beta, itds, means, variances, supports)
    ((counts, lam),) = seen
    half = 2.0 * np.maximum(np.sqrt(variances), 20e-6)
    u = 1.0 / (supports[:, 1] - supports[:, 0])
    weight = beta if count_by == "posterior" else np.ones_like(beta)
    expected_counts, expected_lam = np.zeros(2), np.zeros(2)
    for rows, pairs in (([0, 1, 2, 3], [0, 1]), ([4, 5], [0])):
        for n in range(2):
            for r in rows:
                if all(abs(itds[r, p] - means[n, p]) <= half[n, p] for p in pairs):
                    expected_counts[n] += weight[r, n]
            expected_lam[n] += 0.2 * len(rows) * min(min(2.0 * half[n, p] * u[p], 1.0) for p in pairs)
    # row 0 lies exactly at person 0's edge on pair 0 and counts; row 3, 1 us beyond it, does not
    assert expected_counts[0] == (2.2 if count_by == "posterior" else 3.0)
    np.testing.assert_allclose(counts, expected_counts, rtol=1e-12)
    np.testing.assert_allclose(lam, expected_lam, rtol=1e-12)


@pytest.mark.parametrize("third", [(-100e-6, 0.0), (100e-6, 0.0)])
def test_bands_find_a_person_level_with_a_talker_on_one_pair_as_not_between(third: tuple[float, float]) -> None:
    """The bands' phantom rule spares only a person strictly between two talkers on every pair: one level with a
    talker on a pair is not between them, and the bands' ITDs on them find them speaking."""
    means = np.array([[-100e-6, -100e-6], [100e-6, 100e-6], list(third)])
    variances, supports = np.full((3, 2), (10e-6) ** 2), np.array([[-350e-6, 350e-6]] * 2)
    itds = np.repeat(means[:2], 8, axis=0)  # the two talkers' windows
    beta = np.zeros((16, 3))
    beta[:8, 0] = beta[8:, 1] = 1.0
    bands = np.repeat(means[2:], 12, axis=0)  # the third's bands
    speaking, _, _ = SpeakingTest().decide(beta, itds, means, variances, supports, band_itds=bands)
    assert speaking.tolist() == [True, True, True]
    between = np.array([[-100e-6, -100e-6], [100e-6, 100e-6], [0.0, 0.0]])  # strictly between: spared
    spared, prob, _ = SpeakingTest().decide(beta, itds, between, variances, supports,
                                            band_itds=np.repeat(between[2:], 12, axis=0))
    assert spared.tolist() == [True, True, False]
    _, without_bands, _ = SpeakingTest().decide(beta, itds, between, variances, supports)
    assert prob[2] == without_bands[2]  # the bands leave the spared person's probability as the windows gave it


def test_poisson_quantile_at_its_edges() -> None:
    """Exactly 1 (an integer mean), 300 (the sum reaches its 400 terms), and no mean at all."""
    lam = np.array([1.0, 300.0, 0.0])
    np.testing.assert_array_equal(_poisson_quantile(0.99, lam), [stats.poisson.ppf(0.99, 1.0),
                                                                 stats.poisson.ppf(0.99, 300.0), 0.0])
    assert _poisson_quantile(0.99, np.zeros(0)).shape == (0,)


def test_naos_head_claims_the_quieter_talker_that_the_defaults_leave() -> None:
    from avcore.geometry import MicArray
    nao_array = MicArray.preset("nao", rotation=np.diag([-1.0, 1.0, -1.0]))  # placed on a robot facing back
    means = nao_array.itd(np.array([[-1.0, 0.0, 2.0], [1.0, 0.0, 2.0], [0.0, 0.0, 2.0]]))
    heard = np.array([True, False, False])  # the windows hear the first talker only
    share = np.array([0.25, 0.08, 0.03])  # the second's bins: a quieter voice; the third's: spill
    default = SpeakingTest(count_by="nearest")
    nao = default.for_array(nao_array)
    assert default.for_array(MicArray.preset("respeaker4")) == default
    assert default.for_array(MicArray.preset("pair")) == default
    assert default.for_array(MicArray(((0.0, 0.0, 0.0), (0.1, 0.0, 0.0), (0.0, 0.0, 0.1)))) == default
    assert nao.bin_claim_share < default.bin_claim_share
    called, prob = default._bins(heard, np.array([0.9, 0.1, 0.1]), share, means=means)
    assert called.tolist() == [True, False, False]
    called, prob = nao._bins(heard, np.array([0.9, 0.1, 0.1]), share, means=means)
    assert called.tolist() == [True, True, False] and prob[1] > 0.5 > prob[2]
