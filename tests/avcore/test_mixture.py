from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avcore.mixture import (
    BinnedSamples,
    ConvergenceWarning,
    EMSettings,
    Mixture1D,
    bic_score,
    davies_bouldin,
    fit_em,
    fit_fusion_em,
    initial_models,
    ridgeline_merge,
    split_at_mean,
)

SUPPORT = (-350e-6, 350e-6)


def _sample(rng: np.random.Generator, means_us, sds_us, counts, n_out: int) -> np.ndarray:
    parts = [rng.normal(m * 1e-6, s * 1e-6, c) for m, s, c in zip(means_us, sds_us, counts)]
    parts.append(rng.uniform(*SUPPORT, n_out))
    return np.concatenate(parts)


def _model(weights, means_us, sds_us) -> Mixture1D:
    return Mixture1D(np.asarray(weights), np.asarray(means_us) * 1e-6, (np.asarray(sds_us) * 1e-6) ** 2, SUPPORT)


def test_density_integrates_to_one_over_support() -> None:
    m = _model([0.4, 0.3, 0.3], [-100, 80], [20, 15])
    x = np.linspace(*SUPPORT, 20001)
    assert np.trapezoid(m.density(x), x) == pytest.approx(1.0, abs=2e-3)
    r = m.responsibilities(x)
    np.testing.assert_allclose(r.sum(axis=1), 1.0)


@pytest.mark.parametrize("bin_width_s", [None, 1e-6])
def test_em_recovers_known_parameters(bin_width_s: float | None) -> None:
    rng = np.random.default_rng(3)
    x = _sample(rng, [-120, 60], [20, 12], [3000, 4000], 1000)
    init = _model([0.45, 0.45, 0.1], [-60, 20], [60, 60])
    fit = fit_em(x, init, bin_width_s=bin_width_s)
    m = fit.model_.ordered_by_weight()
    assert fit.converged_
    np.testing.assert_allclose(m.means * 1e6, [60, -120], atol=2.0)
    np.testing.assert_allclose(np.sqrt(m.variances) * 1e6, [12, 20], rtol=0.08)
    np.testing.assert_allclose(m.weights, [0.5, 0.375, 0.125], atol=0.02)


@pytest.mark.filterwarnings("ignore:EM did not converge")
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 10_000), n=st.integers(1, 4), binned=st.booleans())
def test_em_never_lowers_the_likelihood(seed: int, n: int, binned: bool) -> None:
    rng = np.random.default_rng(seed)
    x = _sample(rng, rng.uniform(-250, 250, 3), rng.uniform(5, 40, 3), rng.integers(5, 200, 3), int(rng.integers(0, 50)))
    init = initial_models(None, n, SUPPORT, BinnedSamples.from_samples(x))[n]
    fit = fit_em(x, init, settings=EMSettings(max_iter=60, tol=1e-12), bin_width_s=1e-6 if binned else None)
    steps = np.diff(fit.lower_bounds_)
    assert np.all(steps >= -1e-7 * np.abs(fit.lower_bounds_[:-1]).max())


def test_binned_engine_matches_exact_em() -> None:
    rng = np.random.default_rng(5)
    x = _sample(rng, [-150, 0, 140], [25, 18, 22], [600, 500, 700], 200)
    init = initial_models(None, 3, SUPPORT, BinnedSamples.from_samples(x))[3]
    exact = fit_em(x, init).model_.ordered_by_weight()
    binned = fit_em(x, init, bin_width_s=1e-6).model_.ordered_by_weight()
    np.testing.assert_allclose(binned.means, exact.means, atol=0.5e-6)
    np.testing.assert_allclose(np.sqrt(binned.variances), np.sqrt(exact.variances), atol=0.5e-6)


def test_fusion_keeps_alpha_and_never_lowers_its_objective() -> None:
    rng = np.random.default_rng(7)
    v = _sample(rng, [-100, 90], [20, 20], [800, 800], 150)
    a = _sample(rng, [-95], [25], [15], 4)
    vis = fit_em(v, initial_models(None, 2, SUPPORT, BinnedSamples.from_samples(v))[2]).model_
    alpha = vis.responsibilities(v)
    alpha_before = alpha.copy()
    fused = fit_fusion_em(v, alpha, a, vis, settings=EMSettings(tol=1e-12, max_iter=50))
    np.testing.assert_array_equal(alpha, alpha_before)  # vision-guided: alpha is an input, never updated
    assert np.all(np.diff(fused.objective_) >= -1e-7 * np.abs(fused.objective_).max())
    # the ITDs go to the left cluster, not the right one
    left = int(np.argmin(fused.model_.means))
    assert fused.beta_[:, left].sum() > 12
    assert fused.beta_.shape == (a.size, 3)
    np.testing.assert_allclose(fused.beta_.sum(axis=1), 1.0)
    # pi = gamma / (M + K)
    gamma = alpha.sum(axis=0) + fused.beta_.sum(axis=0)
    assert fused.model_.weights == pytest.approx(gamma / (v.size + a.size), abs=0.01)


def test_bic_picks_the_true_number_on_separated_mixtures() -> None:
    rng = np.random.default_rng(11)
    for true_n, means in [(1, [0]), (2, [-150, 100]), (3, [-200, -20, 180])]:
        x = _sample(rng, means, [15] * true_n, [700] * true_n, 150)
        inits = initial_models(None, 6, SUPPORT, BinnedSamples.from_samples(x))
        scores = []
        for n, init in enumerate(inits):
            fit = fit_em(x, init, bin_width_s=1e-6)
            scores.append(bic_score(fit.log_likelihood_, n, x.size))
        assert int(np.argmax(scores)) == true_n


def test_bic_formula() -> None:
    assert bic_score(-100.0, 2, 1000) == pytest.approx(-100.0 - 6 * np.log(1000) / 2)
    assert bic_score(-5.0, 0, 0) == -5.0
    # every candidate N at once, as Algorithm 1 scores them
    np.testing.assert_allclose(bic_score(np.array([-10.0, -8.0, -7.0]), np.arange(3), 100),
                               [-10.0, -8.0 - 1.5 * np.log(100), -7.0 - 3.0 * np.log(100)])


@pytest.mark.filterwarnings("ignore:EM did not converge")
def test_outliers_only_data_prefers_n0() -> None:
    rng = np.random.default_rng(2)
    x = rng.uniform(*SUPPORT, 400)
    inits = initial_models(None, 3, SUPPORT, BinnedSamples.from_samples(x))
    scores = [bic_score(fit_em(x, m).log_likelihood_, n, x.size) for n, m in enumerate(inits)]
    assert int(np.argmax(scores)) == 0


def test_initialisation_from_previous_interval() -> None:
    prev = _model([0.1, 0.5, 0.3, 0.1], [-200, 0, 150], [20, 30, 10])
    models = initial_models(prev, 5, SUPPORT)
    assert [m.n_components for m in models] == [0, 1, 2, 3, 4, 5]
    # N <= N_prev: the heaviest clusters
    np.testing.assert_allclose(models[1].means, [0.0])
    np.testing.assert_allclose(sorted(models[2].means * 1e6), [0, 150])
    # N > N_prev: one more component each time, by a split at a mean
    assert set(np.round(models[3].means * 1e6, 6)) <= set(np.round(models[4].means * 1e6, 6)) | {0.0, -200.0, 150.0}
    for m in models:
        assert m.weights.sum() == pytest.approx(1.0)


def test_a_component_shared_by_its_members_leaves_the_density_as_it_was() -> None:
    model = Mixture1D(np.array([0.5, 0.3, 0.2]), np.array([-1e-4, 2e-4]), np.array([1e-9, 4e-9]), (-8e-4, 8e-4))
    shared = model.shared(np.array([0, 0, 1, 0]))  # three faces in one direction, one apart
    np.testing.assert_allclose(shared.means, [-1e-4, -1e-4, 2e-4, -1e-4])
    np.testing.assert_allclose(shared.variances, [1e-9, 1e-9, 4e-9, 1e-9])
    np.testing.assert_allclose(shared.weights, [0.5 / 3, 0.5 / 3, 0.3, 0.5 / 3, 0.2])
    x = np.linspace(-8e-4, 8e-4, 101)
    np.testing.assert_allclose(shared.density(x), model.density(x))
    assert model.shared(np.array([1, 0])).means.tolist() == [2e-4, -1e-4]  # any order
    for bad in ([0, 0], [0, 2], [-1, 1]):  # a component with no member, one that does not exist
        with pytest.raises(ValueError, match="owner must name each of the 2 components"):
            model.shared(np.array(bad))


def test_split_at_mean_preserves_moments() -> None:
    m = _model([0.6, 0.4], [10], [30])
    s = split_at_mean(m, 0)
    w = s.weights[:-1]
    mean = (w * s.means).sum() / w.sum()
    second = (w * (s.variances + s.means**2)).sum() / w.sum()
    assert mean == pytest.approx(10e-6)
    assert second - mean**2 == pytest.approx((30e-6) ** 2, rel=1e-9)
    assert w.sum() == pytest.approx(0.6)


def test_davies_bouldin_index() -> None:
    db = davies_bouldin(np.array([0.0, 10.0, 100.0]), np.array([2.0, 3.0, 5.0]))
    np.testing.assert_allclose(db, [0.5, 0.5, 8 / 90])
    assert np.isinf(davies_bouldin(np.array([1.0]), np.array([1.0]))[0])


def test_ridgeline_merges_overlapping_and_keeps_separated() -> None:
    close = _model([0.4, 0.4, 0.2], [0, 20], [20, 20])  # 1 sd apart: unimodal
    merged, groups = ridgeline_merge(close)
    assert merged.n_components == 1 and sorted(groups[0]) == [0, 1]
    assert merged.means[0] == pytest.approx(10e-6)
    far = _model([0.4, 0.4, 0.2], [-100, 100], [20, 20])
    kept, groups = ridgeline_merge(far)
    assert kept.n_components == 2 and groups == [[0], [1]]
    # a heavy and a light component close by: unimodal although 2.2 sd apart
    lopsided = _model([0.85, 0.05, 0.1], [0, 44], [20, 20])
    assert ridgeline_merge(lopsided)[0].n_components == 1


def test_degenerate_inputs() -> None:
    init = _model([0.5, 0.5], [0], [30])
    empty = fit_em(np.empty(0), init)
    assert empty.model_ is init
    dup = fit_em(np.full(50, 12e-6), init)  # all identical: variance floor, no NaN
    assert np.all(np.isfinite(dup.model_.variances)) and dup.model_.variances[0] >= EMSettings().var_floor_s2
    n0 = Mixture1D.outliers_only(SUPPORT)
    assert fit_em(np.zeros(5), n0).log_likelihood_ == pytest.approx(5 * np.log(1 / 700e-6))
    # an empty component keeps its place and gets no weight
    far_init = _model([0.45, 0.45, 0.1], [-100, 340], [5, 5])
    fit = fit_em(np.random.default_rng(0).normal(-100e-6, 5e-6, 300), far_init, settings=EMSettings(tol=1e-9))
    assert np.all(np.isfinite(fit.model_.means)) and fit.model_.weights[1] < 1e-3
    # fusion with no ITDs and with no visual data
    v = np.random.default_rng(1).normal(0, 20e-6, 100)
    res = fit_fusion_em(v, init.responsibilities(v), np.empty(0), init)
    assert res.beta_.shape == (0, 2)
    res = fit_fusion_em(np.empty(0), np.empty((0, 2)), np.array([1e-5, 2e-5]), init)
    assert res.beta_.shape == (2, 2)


def test_bad_inputs_raise_clear_errors() -> None:
    init = _model([0.5, 0.5], [0], [30])
    with pytest.raises(ValueError, match="NaN"):
        fit_em(np.array([0.0, np.nan]), init)
    with pytest.raises(ValueError, match="1-D"):
        fit_em(np.zeros((3, 2)), init)
    with pytest.raises(ValueError, match="alpha must have shape"):
        fit_fusion_em(np.zeros(4), np.zeros((3, 2)), np.zeros(2), init)
    with pytest.raises(ValueError, match="sum to 1"):
        Mixture1D(np.array([0.5, 0.6]), [0.0], [1e-9], SUPPORT)
    with pytest.raises(ValueError, match="N \\+ 1 weights"):
        Mixture1D(np.array([1.0]), [0.0], [1e-9], SUPPORT)
    with pytest.raises(ValueError, match="support"):
        Mixture1D(np.array([0.5, 0.5]), [0.0], [1e-9], (1.0, 0.0))
    with pytest.raises(ValueError, match="max_iter"):
        EMSettings(max_iter=0)


def test_non_convergence_is_a_warning() -> None:
    rng = np.random.default_rng(4)
    x = _sample(rng, [-100, 100], [20, 20], [300, 300], 50)
    init = initial_models(None, 4, SUPPORT, BinnedSamples.from_samples(x))[4]
    with pytest.warns(UserWarning, match="did not converge"):
        fit_em(x, init, settings=EMSettings(max_iter=1, tol=1e-12))


def test_em_with_anchored_means_and_bounded_variances() -> None:
    """The restricted M-step Algorithm 2 uses: means stay put, each variance is the second moment about its fixed
    mean, clipped to [floor, ceiling]; the log-likelihood still never decreases."""
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.normal(-100e-6, 30e-6, 300), rng.normal(150e-6, 10e-6, 200)])
    init = Mixture1D(np.array([0.4, 0.4, 0.2]), np.array([-90e-6, 150e-6]), np.array([1e-9, 1e-9]), (-6e-4, 6e-4))
    ceiling = 4e-10  # (20 us)^2: the wide component must hit it
    fit = fit_em(x, init, update_means=False, max_variance_s2=ceiling)
    assert np.array_equal(fit.model_.means, init.means)
    assert fit.model_.variances[0] == pytest.approx(ceiling)
    assert fit.model_.variances[1] == pytest.approx(np.mean((x[300:] - 150e-6) ** 2), rel=0.05)
    assert np.all(np.diff(fit.lower_bounds_) >= -1e-9)
    frozen = fit_em(x, init, update_means=False, update_variances=False)
    assert np.array_equal(frozen.model_.variances, init.variances)
    assert frozen.model_.weights[0] == pytest.approx(0.6, abs=0.05)
    with pytest.raises(ValueError, match="max_variance_s2"):
        fit_em(x, init, max_variance_s2=1e-20)


@pytest.mark.parametrize(("means", "variances"), [(False, False), (True, True), (False, True)])
def test_pairs_em_with_one_pair_is_the_standard_em(means: bool, variances: bool) -> None:
    from avcore.mixture import fit_pairs_em

    rng = np.random.default_rng(1)
    x = np.concatenate([rng.normal(-1e-4, 3e-5, 40), rng.uniform(-4e-4, 4e-4, 20)])
    init = Mixture1D(np.array([0.4, 0.4, 0.2]), np.array([-9e-5, 1e-4]), np.array([1e-9, 1e-9]), (-4e-4, 4e-4))
    settings = EMSettings(max_iter=50)
    one = fit_em(x, init, settings=settings, update_means=means, update_variances=variances, max_variance_s2=4e-9)
    pairs = fit_pairs_em(x[:, None], init.weights, init.means[:, None], init.variances[:, None],
                         np.array([init.support]), settings=settings, update_means=means, update_variances=variances,
                         max_variance_s2=4e-9)
    assert pairs.weights == pytest.approx(one.model_.weights, abs=1e-12)
    assert pairs.means[:, 0] == pytest.approx(one.model_.means, abs=1e-15)
    assert pairs.variances[:, 0] == pytest.approx(one.model_.variances, rel=1e-9)
    assert pairs.n_iter == one.n_iter_ and pairs.log_likelihood == pytest.approx(one.log_likelihood_)


def _reference_pairs_em(x: np.ndarray, w: np.ndarray, mu: np.ndarray, var: np.ndarray, sup: np.ndarray,
                        n_iter: int, min_wo: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The model of fit_pairs_em written out plainly, in seconds and logs: a vector's density is the product over
    the pairs it has; M-step per pair over the vectors that have it; a fixed number of iterations."""
    seen = np.isfinite(x)
    for _ in range(n_iter + 1):
        d = np.where(seen[:, None, :], x[:, None, :] - mu[None], 0.0)
        log_g = (-0.5 * (d * d / var[None] + np.log(2 * np.pi * var)[None]) * seen[:, None, :]).sum(axis=2)
        log_o = (seen * -np.log(sup[:, 1] - sup[:, 0])).sum(axis=1)
        log_d = np.concatenate([log_g + np.log(w[:-1]), (log_o + np.log(w[-1]))[:, None]], axis=1)
        beta = np.exp(log_d - log_d.max(axis=1, keepdims=True))
        beta /= beta.sum(axis=1, keepdims=True)
        if _ == n_iter:
            return w, mu, var, beta
        w = beta.sum(axis=0) / len(x)
        if w[-1] < min_wo:
            w[:-1] *= (1 - min_wo) / w[:-1].sum()
            w[-1] = min_wo
        r = beta[:, :-1, None] * seen[:, None, :]
        xs = np.where(seen, x, 0.0)[:, None, :]
        mu = (r * xs).sum(axis=0) / r.sum(axis=0)
        var = (r * (xs - mu[None]) ** 2 * seen[:, None, :]).sum(axis=0) / r.sum(axis=0)
    raise AssertionError("unreachable")


def test_pairs_em_with_missing_pairs_is_the_model_written_out() -> None:
    """Three pairs, a third of the vectors missing one pair, two people and stray vectors: the engine's fit (means and
    variances free, until the log-likelihood stops changing) equals the model written out plainly in logs, run for
    as many iterations."""
    from avcore.mixture import fit_pairs_em

    rng = np.random.default_rng(3)
    mu0 = np.array([[-1e-4, 5e-5, 2e-4], [1.2e-4, -6e-5, 0.0]])
    x = np.concatenate([mu0[0] + rng.normal(0, 2e-5, (40, 3)), mu0[1] + rng.normal(0, 2e-5, (30, 3)),
                        rng.uniform(-3e-4, 3e-4, (15, 3))])
    x[rng.random(len(x)) < 0.33, rng.integers(0, 3)] = np.nan
    sup = np.array([[-4e-4, 4e-4], [-3e-4, 3e-4], [-5e-4, 5e-4]])
    w0, var0 = np.array([0.4, 0.4, 0.2]), np.full((2, 3), 1e-9)
    settings = EMSettings(max_iter=12, tol=1e-300, var_floor_s2=1e-14)
    fit = fit_pairs_em(x, w0, mu0 + 1e-5, var0, sup, settings=settings)
    w, mu, var, beta = _reference_pairs_em(x, w0, mu0 + 1e-5, var0, sup, fit.n_iter, settings.min_outlier_weight)
    assert fit.n_iter >= 5  # it stops when the log-likelihood no longer changes at all
    np.testing.assert_allclose(fit.weights, w, rtol=1e-9)
    np.testing.assert_allclose(fit.means, mu, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(fit.variances, var, rtol=1e-7)
    np.testing.assert_allclose(fit.beta, beta, atol=1e-9)


def test_each_class_holds_its_weight_of_the_density() -> None:
    """pi_n P(x | n) integrates to pi_n over the support for each Gaussian (well inside it here) and for the
    outlier class, and the classes add up to the density."""
    model = _model([0.5, 0.3, 0.2], [-120.0, 80.0], [25.0, 15.0])
    x = np.linspace(*SUPPORT, 20001)
    per_class = model.component_densities(x)
    np.testing.assert_allclose(np.trapezoid(per_class, x, axis=0), model.weights, atol=1e-4)
    np.testing.assert_allclose(per_class.sum(axis=1), model.density(x), rtol=1e-12)
    with pytest.raises(ValueError, match="^x must be a 1-D array"):
        model.density(np.zeros((2, 2)))
    with pytest.raises(ValueError, match="^x must be a 1-D array"):
        model.component_densities(np.zeros((2, 2)))


def test_bic_of_one_candidate_is_a_number_and_of_several_an_array() -> None:
    one = bic_score(-100.0, 2, 50)
    assert type(one) is float and one == pytest.approx(-100.0 - 3.0 * np.log(50))
    several = bic_score(np.array([-100.0, -90.0]), np.array([1, 2]), 50)
    assert isinstance(several, np.ndarray)
    np.testing.assert_allclose(several, [-100.0 - 1.5 * np.log(50), -90.0 - 3.0 * np.log(50)])


def test_davies_bouldin_of_two_components() -> None:
    """Two components: each one's index is (sigma_1 + sigma_2) / |mu_1 - mu_2| (section 4.4); one: +inf."""
    np.testing.assert_allclose(davies_bouldin(np.array([0.0, 100.0]), np.array([10.0, 30.0])), [0.4, 0.4])
    assert davies_bouldin(np.array([5.0]), np.array([1.0])).tolist() == [np.inf]


def test_em_reports_the_likelihood_of_its_model_in_one_over_seconds() -> None:
    """log_likelihood_ and the last lower bound are sum log p(x) of the returned model, densities in 1/s."""
    rng = np.random.default_rng(12)
    x = _sample(rng, [-120, 60], [20, 12], [300, 400], 100)
    init = _model([0.45, 0.45, 0.1], [-60, 20], [60, 60])
    fit = fit_em(x, init, settings=EMSettings(tol=1e-10))
    want = float(np.sum(np.log(fit.model_.density(x))))
    assert fit.log_likelihood_ == pytest.approx(want, rel=1e-10)
    assert fit.lower_bounds_[-1] == pytest.approx(want, rel=1e-10) and fit.lower_bounds_.size == fit.n_iter_ + 1
    assert fit.lower_bounds_[0] == pytest.approx(init.log_likelihood(x), rel=1e-10)
    assert fit.model_.support == SUPPORT and fit.model_.weights.sum() == pytest.approx(1.0, abs=1e-12)
    n0 = fit_em(x, Mixture1D.outliers_only(SUPPORT))
    assert n0.log_likelihood_ == pytest.approx(x.size * np.log(1 / 700e-6)) and n0.n_iter_ == 0 and n0.converged_
    assert n0.lower_bounds_.tolist() == [n0.log_likelihood_]


def test_em_keeps_what_it_is_told_to_keep_and_caps_the_variance() -> None:
    rng = np.random.default_rng(13)
    x = _sample(rng, [-120, 60], [40, 12], [300, 400], 0)
    init = _model([0.45, 0.45, 0.1], [-60, 20], [60, 60])
    anchored = fit_em(x, init, update_means=False)
    assert np.allclose(anchored.model_.means, init.means, rtol=1e-12, atol=0)
    assert not np.allclose(anchored.model_.variances, init.variances, rtol=0.01, atol=0)
    fixed = fit_em(x, init, update_variances=False)
    assert np.allclose(fixed.model_.variances, init.variances, rtol=1e-12, atol=0)
    assert not np.allclose(fixed.model_.means, init.means, rtol=0.01, atol=0)
    capped = fit_em(x, init, max_variance_s2=(30e-6) ** 2).model_.ordered_by_weight()
    assert capped.variances[1] == pytest.approx((30e-6) ** 2, rel=1e-9)  # the 40 us talker, held at 30 us
    assert capped.variances[0] < (20e-6) ** 2
    floor = EMSettings().var_floor_s2
    assert fit_em(x, init, max_variance_s2=floor).model_.variances == pytest.approx([floor, floor])
    with pytest.raises(ValueError, match="max_variance_s2 must be >= the variance floor"):
        fit_em(x, init, max_variance_s2=floor / 2)


def test_em_and_fusion_say_when_they_ran_out_of_iterations() -> None:
    rng = np.random.default_rng(14)
    x = _sample(rng, [-120, 60], [20, 12], [300, 400], 100)
    init = _model([0.45, 0.45, 0.1], [-300, 300], [10, 10])
    with pytest.warns(ConvergenceWarning, match="^EM did not converge in 2 iterations; try a larger max_iter"):
        fit = fit_em(x, init, settings=EMSettings(max_iter=2))
    assert not fit.converged_ and fit.n_iter_ == 2
    alpha = init.responsibilities(x)
    with pytest.warns(ConvergenceWarning, match="^vision-guided EM fusion did not converge in 1 iterations"):
        fused = fit_fusion_em(x, alpha, x[:10], init, settings=EMSettings(max_iter=1, tol=1e-15))
    assert not fused.converged_ and fused.n_iter_ == 1 and fused.objective_.size == 2


def test_the_fusion_reports_its_objective_and_the_itds_posteriors_in_seconds() -> None:
    """objective_: sum_m sum_n alpha_mn log(pi_n P(v_m | n)) + sum_k log p(a_k), 1/s densities (section 4.1)."""
    rng = np.random.default_rng(15)
    v = _sample(rng, [-100, 90], [20, 20], [300, 300], 60)
    a = _sample(rng, [-95], [25], [12], 3)
    vis = fit_em(v, _model([0.45, 0.45, 0.1], [-80, 80], [40, 40])).model_
    alpha = vis.responsibilities(v)
    fused = fit_fusion_em(v, alpha, a, vis, settings=EMSettings(tol=1e-12, max_iter=200))
    m = fused.model_
    log_classes = np.log(m.component_densities(v))
    want = float(np.sum(alpha * log_classes) + np.sum(np.log(m.density(a))))
    assert fused.converged_ and fused.objective_[-1] == pytest.approx(want, rel=1e-9)
    assert fused.log_likelihood_ == pytest.approx(m.log_likelihood(v) + m.log_likelihood(a), rel=1e-12)
    assert np.allclose(fused.beta_, m.responsibilities(a), rtol=1e-12)
    assert fused.n_iter_ == fused.objective_.size - 1
    nobody = Mixture1D.outliers_only(SUPPORT)
    alone = fit_fusion_em(v, np.ones((v.size, 1)), a, nobody)
    assert alone.model_ is nobody and alone.beta_.shape == (a.size, 1) and np.all(alone.beta_ == 1.0)
    ll = nobody.log_likelihood(v) + nobody.log_likelihood(a)
    assert alone.log_likelihood_ == ll and alone.objective_.tolist() == [ll] and alone.converged_
    for bad in (-alpha, np.where(alpha > 0.5, np.nan, alpha)):
        with pytest.raises(ValueError, match="alpha must hold finite non-negative posteriors"):
            fit_fusion_em(v, bad, a, vis)


def test_without_a_previous_interval_the_first_cluster_sits_on_the_datas_moments() -> None:
    from avcore.mixture import _seed_model

    x = np.array([-30e-6, 10e-6, 20e-6, 40e-6])
    seed = _seed_model(BinnedSamples.from_samples(x, None), SUPPORT, 0.2)
    assert seed.weights.tolist() == [0.8, 0.2]
    assert seed.means[0] == pytest.approx(x.mean(), rel=1e-9) and seed.variances[0] == pytest.approx(x.var(), rel=1e-9)
    one = _seed_model(BinnedSamples.from_samples(np.full(3, 5e-6), None), SUPPORT, 0.1)
    assert one.variances[0] == pytest.approx(1e-12, rel=1e-9, abs=0)  # at least 1 us^2: identical values no spread
    lone = _seed_model(BinnedSamples.from_samples(np.array([5e-6]), None), SUPPORT, 0.1)
    assert lone.means[0] == pytest.approx(5e-6, rel=1e-9) and lone.variances[0] == pytest.approx(1e-12, rel=1e-9,
                                                                                                 abs=0)
    empty = _seed_model(BinnedSamples.from_samples(np.empty(0)), (-100e-6, 300e-6), 0.1)
    assert empty.means[0] == pytest.approx(100e-6) and empty.variances[0] == pytest.approx((100e-6) ** 2)


def test_a_component_is_added_where_the_data_most_exceed_the_model() -> None:
    """The residual: the data's histogram smoothed by the new component's shape minus the model's expected counts;
    the new component at its peak, its weight the excess's share (in [0.02, 0.5]), the others scaled to make room."""
    from avcore.mixture import _ResidualGrid

    rng = np.random.default_rng(16)
    x = np.concatenate([rng.normal(-150e-6, 15e-6, 400), rng.normal(200e-6, 2e-6, 100)])
    data = BinnedSamples.from_samples(x)
    grid = _ResidualGrid(data, SUPPORT, 15e-6)
    assert grid.grid[0] == SUPPORT[0] and np.allclose(np.diff(grid.grid), 2e-6)
    assert grid.smooth.sum() == pytest.approx(500.0, rel=1e-9)  # counts per step, none lost at the middle
    known = _model([0.75, 0.25], [-150], [15])
    added = grid.add_component(known)
    assert added is not None and added.n_components == 2
    assert added.means[1] == pytest.approx(200e-6, abs=2e-6) and added.variances[1] == pytest.approx((15e-6) ** 2)
    w = added.weights[1]
    assert w == pytest.approx(0.2, abs=0.02)  # 100 of 500 unexplained (less what the outlier class expects there)
    assert added.weights[[0, 2]] == pytest.approx([0.75 * (1 - w), 0.25 * (1 - w)], rel=1e-12)
    dens = known._density(grid.grid)
    assert grid.add_component(known, dens).means[1] == added.means[1]  # the caller's density on the grid
    stray = _ResidualGrid(BinnedSamples.from_samples(np.append(np.full(400, 100e-6), -300e-6)), SUPPORT, 15e-6)
    least = stray.add_component(_model([0.999, 0.001], [100], [15]))  # one stray value unexplained
    assert least.means[1] == pytest.approx(-300e-6, abs=1e-9) and least.weights[1] == 0.02  # the least it adds
    nothing = _ResidualGrid(BinnedSamples.from_samples(np.empty(0)), SUPPORT, 15e-6)
    assert nothing.add_component(known) is None
    lone = _ResidualGrid(BinnedSamples.from_samples(np.full(400, 100e-6)), SUPPORT, 15e-6)
    assert lone.add_component(_model([0.5, 0.5], [-200], [15])).weights[1] == 0.5  # at most half


def test_the_previous_intervals_clusters_start_the_next_heaviest_first() -> None:
    prev = _model([0.2, 0.5, 0.29, 0.01], [-200, 0, 150], [20, 30, 10])
    models = initial_models(prev, 3, SUPPORT, outlier_weight=0.2)
    # the outlier prior is raised to outlier_weight / 10 = 0.02, the clusters scaled to the rest
    assert models[3].weights[-1] == pytest.approx(0.02)
    assert models[3].weights[:-1] == pytest.approx(np.array([0.5, 0.29, 0.2]) * 0.98 / 0.99, rel=1e-12)
    assert models[3].means == pytest.approx([0.0, 150e-6, -200e-6])
    assert models[1].weights == pytest.approx([0.98, 0.02]) and models[1].variances == pytest.approx([(30e-6) ** 2])
    kept = initial_models(_model([0.2, 0.5, 0.05, 0.25], [-200, 0, 150], [20, 30, 10]), 2, SUPPORT)
    assert kept[2].weights.tolist() == pytest.approx([0.5 * 0.75 / 0.7, 0.2 * 0.75 / 0.7, 0.25])
    zero = initial_models(_model([0.0, 0.0, 1.0], [-200, 0], [20, 30]), 2, SUPPORT)  # clusters with no weight left
    assert zero[1].weights.tolist() == [0.0, 1.0] and zero[2].weights.tolist() == [0.0, 0.0, 1.0]
    with pytest.raises(ValueError, match="n_max must be >= 0"):
        initial_models(prev, -1, SUPPORT)


def test_a_newcomer_far_from_everybody_is_found_only_at_the_residual() -> None:
    rng = np.random.default_rng(17)
    x = np.concatenate([rng.normal(-150e-6, 15e-6, 400), rng.normal(250e-6, 12e-6, 150)])
    data = BinnedSamples.from_samples(x)
    prev = _model([0.9, 0.1], [-150], [15])
    grown = initial_models(prev, 2, SUPPORT, data)[2]
    split = initial_models(prev, 2, SUPPORT, data, grow_at_residual=False)[2]
    assert np.abs(grown.means - 250e-6).min() < 8e-6  # a component where the newcomer is
    assert np.abs(split.means - 250e-6).min() > 100e-6  # the paper's split stays by the known cluster
    assert sorted(split.means * 1e6) == pytest.approx([-150 - 15 * np.sqrt(2 / np.pi), -150 + 15 * np.sqrt(2 / np.pi)])
    # with the data at the split's halves, the split explains them better than any residual
    near = np.concatenate([rng.normal(-170e-6, 8e-6, 300), rng.normal(-130e-6, 8e-6, 300)])
    halves = initial_models(_model([0.9, 0.1], [-150], [22]), 2, SUPPORT, BinnedSamples.from_samples(near))[2]
    assert sorted(halves.means * 1e6) == pytest.approx([-150 - 22 * np.sqrt(2 / np.pi), -150 + 22 * np.sqrt(2 / np.pi)])


def test_the_split_goes_to_the_component_with_the_highest_davies_bouldin_index() -> None:
    """DW_i: the two overlapping components (-50 and 0 us, 20 us wide) have it highest; the wider of the two is
    split, and the far one (200 us) never."""
    prev = _model([0.3, 0.3, 0.3, 0.1], [-50, 0, 200], [15, 20, 10])
    grown = initial_models(prev, 4, SUPPORT, grow_at_residual=False)[4]
    shift = 20 * np.sqrt(2 / np.pi)
    assert sorted(grown.means * 1e6) == pytest.approx(sorted([-50, 200, -shift, shift]))
    assert grown.weights[:-1].sum() == pytest.approx(0.9)


@pytest.mark.parametrize("gap_sd, unimodal", [(1.9, True), (2.1, False)])
def test_two_equal_gaussians_are_one_mode_up_to_two_standard_deviations_apart(gap_sd: float, unimodal: bool) -> None:
    """Equal weights and variances: the mixture is unimodal iff the means are at most 2 sd apart."""
    from avcore.mixture import _is_unimodal_on_ridgeline

    assert bool(_is_unimodal_on_ridgeline(0.5, 0.0, 100.0, 0.5, gap_sd * 10.0, 100.0)) is unimodal
    assert bool(_is_unimodal_on_ridgeline(0.5, gap_sd * 10.0, 100.0, 0.5, 0.0, 100.0)) is unimodal
    assert _is_unimodal_on_ridgeline(0.5, 3.0, 100.0, 0.5, 3.0, 100.0)  # one and the same: flat ridgeline


def test_merged_components_keep_the_pairs_moments_and_zero_weights_stay_apart() -> None:
    model = _model([0.3, 0.1, 0.4, 0.2], [40, 240, 55], [20, 10, 25])
    merged, groups = ridgeline_merge(model)
    assert groups == [[0, 2], [1]]
    w, mu, var = np.array([0.3, 0.4]), np.array([40e-6, 55e-6]), np.array([20e-6, 25e-6]) ** 2
    mean = (w @ mu) / w.sum()
    assert merged.weights.tolist() == pytest.approx([0.7, 0.1, 0.2])
    assert merged.means[0] == pytest.approx(mean) and merged.variances[0] == pytest.approx((w @ (var + mu**2)) / 0.7
                                                                                          - mean**2)
    ghost = _model([0.5, 0.0, 0.5], [0, 5], [20, 20])  # a component with no weight is not merged into another
    assert ridgeline_merge(ghost)[1] == [[0], [1]]
    assert ridgeline_merge(_model([0.0, 0.5, 0.5], [0, 5], [20, 20]))[1] == [[0], [1]]  # nor another into it
    single = _model([0.9, 0.1], [3], [20])
    assert ridgeline_merge(single) == (single, [[0]])


def test_pairs_em_reports_the_likelihood_of_what_it_returns_and_handles_nobody() -> None:
    """log_likelihood: sum_k log p(a_k) of the returned parameters, each vector's density the product over the
    pairs it has, in 1/s; no vectors or no people: the start as it was, with the posteriors' shapes."""
    from avcore.mixture import fit_pairs_em

    rng = np.random.default_rng(18)
    mu0 = np.array([[-1e-4, 5e-5], [1.2e-4, -6e-5]])
    x = np.concatenate([mu0[0] + rng.normal(0, 2e-5, (30, 2)), mu0[1] + rng.normal(0, 2e-5, (20, 2)),
                        rng.uniform(-3e-4, 3e-4, (8, 2))])
    x[::5, 1] = np.nan
    sup = np.array([[-4e-4, 4e-4], [-3e-4, 3e-4]])
    fit = fit_pairs_em(x, np.array([0.4, 0.4, 0.2]), mu0, np.full((2, 2), 4e-10), sup,
                       settings=EMSettings(tol=1e-10))
    seen = np.isfinite(x)
    d = np.where(seen[:, None, :], x[:, None, :] - fit.means[None], 0.0)
    gauss = np.exp((-0.5 * (d * d / fit.variances[None] + np.log(2 * np.pi * fit.variances)[None])
                    * seen[:, None, :]).sum(axis=2))
    out = np.exp((seen * -np.log(sup[:, 1] - sup[:, 0])).sum(axis=1))
    p_x = gauss @ fit.weights[:-1] + fit.weights[-1] * out
    assert fit.converged and fit.log_likelihood == pytest.approx(np.log(p_x).sum(), rel=1e-9)
    np.testing.assert_allclose(fit.beta[:, -1], fit.weights[-1] * out / p_x, rtol=1e-9)
    w = np.array([0.5, 0.5])
    none = fit_pairs_em(x[:0], w, mu0[:1], np.full((1, 2), 1e-9), sup)
    assert none.beta.shape == (0, 2) and none.weights is not None and np.array_equal(none.means, mu0[:1])
    assert (none.log_likelihood, none.n_iter, none.converged) == (0.0, 0, True)
    nobody = fit_pairs_em(x, np.ones(1), np.empty((0, 2)), np.empty((0, 2)), sup)
    assert nobody.beta.shape == (x.shape[0], 1) and np.all(nobody.beta == 1.0)
    with pytest.raises(ValueError, match=r"need itds \(K, P\), means and variances \(N, P\), supports \(P, 2\)"):
        fit_pairs_em(x, w, mu0[:1], np.full((1, 3), 1e-9), sup)
    three = np.array([[-4e-4, 4e-4]] * 3)
    for bad in [(x, np.zeros((1, 3)), np.full((1, 3), 1e-9), three),  # three pairs' people, two pairs' ITDs
                (x[:, 0], mu0[:1], np.full((1, 2), 1e-9), sup)]:  # ITDs not as vectors
        with pytest.raises(ValueError, match=r"^need itds \(K, P\)"):
            fit_pairs_em(bad[0], w, bad[1], bad[2], bad[3])
    with pytest.raises(ValueError, match=r"weights must have N \+ 1 = 2 entries, got \(3,\)"):
        fit_pairs_em(x, np.ones(3) / 3, mu0[:1], np.full((1, 2), 1e-9), sup)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"max_iter": 0}, "max_iter must be >= 1, got 0"),
    ({"tol": 0.0}, "tol must be > 0, got 0.0"),
    ({"var_floor_s2": -1e-12}, r"var_floor_s2 must be > 0 s\^2, got -1e-12"),
    ({"var_floor_s2": 0.0}, r"var_floor_s2 must be > 0 s\^2, got 0.0"),
    ({"min_outlier_weight": 1.0}, r"min_outlier_weight must be in \(0, 1\), got 1.0"),
    ({"min_outlier_weight": 0.0}, r"min_outlier_weight must be in \(0, 1\), got 0.0"),
])
def test_em_settings_name_what_is_wrong(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=f"^{message}$"):
        EMSettings(**kwargs)


def test_em_settings_at_their_limits_are_accepted() -> None:
    s = EMSettings(max_iter=1, tol=1e-300, var_floor_s2=1e-300, min_outlier_weight=1e-12)
    assert (s.max_iter, s.min_outlier_weight) == (1, 1e-12)
    assert EMSettings() == EMSettings(max_iter=100, tol=1e-4, var_floor_s2=2.5e-11, min_outlier_weight=1e-3)


@pytest.mark.parametrize(("args", "message"), [
    (([0.5, 0.6], [0.0], [1e-9]), r"weights must be non-negative and sum to 1, got \[0.5 0.6\]"),
    (([1.2, -0.2], [0.0], [1e-9]), r"weights must be non-negative and sum to 1, got \[ 1.2 -0.2\]"),
    (([1.0], [0.0], [1e-9]), "a mixture of N Gaussians needs N \\+ 1 weights, N means and N variances; got 1, 1, 1"),
    (([0.5, 0.5], [0.0], [1e-9, 1e-9]), "a mixture of N Gaussians needs N \\+ 1 weights, N means and N variances; "
                                         "got 2, 1, 2"),
    (([0.5, 0.5], [np.nan], [1e-9]), "mixture parameters must be finite"),
    (([0.5, 0.5], [0.0], [np.inf]), "mixture parameters must be finite"),
    (([np.nan, 0.5], [0.0], [1e-9]), "mixture parameters must be finite"),
    (([0.5, 0.5], [0.0], [0.0]), r"variances must be positive, got \[0.\]"),
])
def test_a_mixture_names_what_is_wrong(args: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=f"^{message}$"):
        Mixture1D(np.asarray(args[0]), args[1], args[2], SUPPORT)


@pytest.mark.parametrize("support", [(1e-4, 1e-4), (2e-4, -2e-4), (-np.inf, 1e-4), (0.0, np.nan)])
def test_a_mixtures_support_must_be_an_interval(support: tuple[float, float]) -> None:
    with pytest.raises(ValueError, match=r"^support must be an interval \(lo, hi\) of seconds with lo < hi, got "):
        Mixture1D(np.ones(1), [], [], support)


def test_a_mixture_stores_flat_float_arrays_and_weights_within_a_millionth_of_one() -> None:
    m = Mixture1D([[0.5], [0.5 + 9e-7]], [[1]], [[2]], (-1, 1))
    assert m.weights.shape == (2,) and m.means.dtype == np.float64 and m.variances.tolist() == [2.0]
    assert m.weights.dtype == np.float64 and m.variances.dtype == np.float64
    assert m.support == (-1.0, 1.0) and type(m.support[0]) is float
    with pytest.raises(ValueError, match="sum to 1"):
        Mixture1D([0.5, 0.5 + 2e-6], [1.0], [2.0], (-1, 1))
    zero = Mixture1D([0, 1], [1.0], [2.0], (-1, 1))  # a component with no weight is allowed (integers: floats)
    assert zero.weights[0] == 0.0 and zero.weights.dtype == np.float64


def test_binned_samples_keep_each_bins_exact_count_sum_and_square() -> None:
    x = np.array([3.9, 0.0, 1.2, 0.4, 1.99]) * 1e-6
    b = BinnedSamples.from_samples(x, 1e-6)  # bins of 1 us from the smallest value: [0, 1), [1, 2), [3, 4)
    np.testing.assert_allclose(b.stats[:, 0], [2, 2, 1])
    np.testing.assert_allclose(b.stats[:, 1], [0.4, 3.19, 3.9], rtol=1e-12)
    np.testing.assert_allclose(b.stats[:, 2], [0.16, 1.2**2 + 1.99**2, 3.9**2], rtol=1e-12)
    np.testing.assert_allclose(b.x_us, [0.2, 1.595, 3.9], rtol=1e-12)  # each bin's mean, where it is evaluated
    assert b.total == 5.0
    exact = BinnedSamples.from_samples(x, None)
    np.testing.assert_allclose(exact.x_us, x * 1e6, rtol=1e-12)
    np.testing.assert_allclose(exact.stats[:, 0], 1)
    np.testing.assert_allclose(exact.stats[:, 2], (x * 1e6) ** 2, rtol=1e-12)
    empty = BinnedSamples.from_samples(np.empty(0))
    assert empty.x_us.shape == (0,) and empty.stats.shape == (0, 3) and empty.total == 0.0


def test_models_pack_into_the_engines_microseconds_and_back() -> None:
    from avcore.mixture import pack, unpack

    a, b = _model([0.5, 0.3, 0.2], [-100, 50], [20, 10]), _model([0.9, 0.1], [30], [15])
    p = pack([a, b])
    assert p.sizes.tolist() == [2, 1] and p.wo.tolist() == [0.2, 0.1]
    np.testing.assert_allclose(p.mu, [-100, 50, 30], rtol=1e-12)
    np.testing.assert_allclose(p.var, [400, 100, 225], rtol=1e-12)
    back = unpack(p, 1, SUPPORT)
    assert back.weights.tolist() == pytest.approx([0.9, 0.1]) and back.means == pytest.approx([30e-6])
    assert back.variances == pytest.approx([(15e-6) ** 2]) and back.support == SUPPORT
    p.wg[2], p.wo[1] = 0.45, 0.05  # weights that no longer sum to one come back normalised
    assert unpack(p, 1, SUPPORT).weights.tolist() == pytest.approx([0.9, 0.1])
    with pytest.raises(ValueError, match="^only models with at least one Gaussian component can be packed$"):
        pack([a, Mixture1D.outliers_only(SUPPORT)])


def test_a_components_density_far_out_is_tiny_but_not_zero() -> None:
    m = _model([0.6, 0.4], [0], [1])  # 1 us wide
    far = m.component_densities(np.array([300e-6]))[0, 0]
    assert far == pytest.approx(0.6 * np.exp(-700) / np.sqrt(2 * np.pi * 1e-12), rel=1e-9)
    near = m.component_densities(np.array([30e-6]))[0, 0]
    assert near == pytest.approx(0.6 * np.exp(-450) / np.sqrt(2 * np.pi * 1e-12), rel=1e-9)
    np.testing.assert_allclose(m.density(np.array([300e-6, 30e-6])),
                               [far + 0.4 / 700e-6, near + 0.4 / 700e-6], rtol=1e-12)


def test_components_ordered_by_weight_keep_ties_in_place_and_the_outlier_last() -> None:
    m = _model([0.2, 0.3, 0.2, 0.3], [-100, 0, 100], [10, 20, 30])
    o = m.ordered_by_weight()
    assert o.weights.tolist() == [0.3, 0.2, 0.2, 0.3] and o.means.tolist() == pytest.approx([0, -100e-6, 100e-6])
    assert o.variances.tolist() == pytest.approx([(20e-6) ** 2, (10e-6) ** 2, (30e-6) ** 2])
    nobody = Mixture1D.outliers_only(SUPPORT)
    assert nobody.weights.tolist() == [1.0] and nobody.n_components == 0 and nobody.support == SUPPORT
    assert nobody.outlier_density == pytest.approx(1 / 700e-6)


def test_the_public_fits_name_their_arguments() -> None:
    init = _model([0.5, 0.5], [0], [30])
    with pytest.raises(ValueError, match="^x_s holds 1 NaN"):
        fit_em(np.array([0.0, np.nan]), init)
    for kwargs, name in [({"visual_s": np.array([np.nan])}, "visual_s"), ({"itds_s": np.array([np.nan])}, "itds_s")]:
        args = {"visual_s": np.zeros(1), "alpha": np.full((1, 2), 0.5), "itds_s": np.zeros(1), **kwargs}
        with pytest.raises(ValueError, match=f"^{name} holds 1 NaN"):
            fit_fusion_em(args["visual_s"], args["alpha"], args["itds_s"], init)
    with pytest.raises(ValueError, match=r"^alpha must have shape \(M, N \+ 1\) = \(4, 2\), got \(3, 2\)$"):
        fit_fusion_em(np.zeros(4), np.zeros((3, 2)), np.zeros(2), init)
    with pytest.raises(ValueError, match="^alpha must hold finite non-negative posteriors$"):
        fit_fusion_em(np.zeros(2), np.array([[0.5, 0.5], [-0.1, 1.1]]), np.zeros(2), init)
    exact = np.array([[1.0, 0.0], [0.0, 1.0]])  # posteriors of exactly 0 and 1 are posteriors
    assert fit_fusion_em(np.array([0.0, 1e-4]), exact, np.zeros(2), init).model_.n_components == 1
    nobody = fit_fusion_em(np.zeros(3), np.ones((3, 1)), np.zeros(2), Mixture1D.outliers_only(SUPPORT))
    assert nobody.n_iter_ == 0 and type(nobody.n_iter_) is int


def test_the_bin_width_is_the_callers() -> None:
    """Bins keep exact sums, so only where the posteriors are evaluated changes: 20 us bins move the means by
    hundredths of a microsecond from the exact EM's, 1 us bins by less."""
    rng = np.random.default_rng(20)
    x = _sample(rng, [-120, 60], [20, 12], [300, 400], 100)
    init = _model([0.45, 0.45, 0.1], [-60, 20], [60, 60])
    exact = fit_em(x, init).model_.means
    coarse = np.abs(fit_em(x, init, bin_width_s=20e-6).model_.means - exact).max()
    fine = np.abs(fit_em(x, init, bin_width_s=1e-6).model_.means - exact).max()
    assert 1e-8 < coarse < 0.5e-6 and fine < coarse / 3


def test_the_fusion_holds_a_variance_at_its_floor() -> None:
    init = _model([0.5, 0.5], [10], [30])
    v = np.full(50, 10e-6)
    fused = fit_fusion_em(v, init.responsibilities(v), np.full(5, 10e-6), init).model_
    assert fused.variances[0] == pytest.approx(EMSettings().var_floor_s2, rel=1e-9)


def test_the_residual_grid_smooths_with_a_kernel_four_sds_wide_and_keeps_values_beyond_its_ends() -> None:
    """The smoothing kernel: a Gaussian of sd_s on the 2 us grid, cut at 4 sd, summing to one; values beyond the
    support count at its first and last steps."""
    from avcore.mixture import _ResidualGrid

    grid = _ResidualGrid(BinnedSamples.from_samples(np.array([0.0]), None), SUPPORT, 9.7e-6)  # 4 sd: 19.4 steps
    i0 = int(np.argmin(np.abs(grid.grid)))
    d = np.arange(-20, 21)
    k = np.exp(-0.5 * (d * 2e-6 / 9.7e-6) ** 2)
    np.testing.assert_allclose(grid.smooth[i0 - 20:i0 + 21], k / k.sum(), rtol=1e-9)
    assert grid.smooth[i0 - 21] == 0.0 and grid.smooth[i0 + 21] == 0.0 and grid.smooth.sum() == pytest.approx(1.0)
    edges = _ResidualGrid(BinnedSamples.from_samples(np.array([-400e-6, -349e-6, 349e-6, 400e-6]), None), SUPPORT,
                          0.1e-6)  # a kernel narrower than a step: the counts themselves
    assert edges.smooth[0] == pytest.approx(2.0) and edges.smooth[-1] == pytest.approx(2.0)
    assert edges.smooth[1:-1].sum() == pytest.approx(0.0, abs=1e-12)


def test_one_value_is_data_enough_for_a_new_component_and_no_data_gives_the_supports_centre() -> None:
    from avcore.mixture import _ResidualGrid

    one = _ResidualGrid(BinnedSamples.from_samples(np.array([100e-6]), None), SUPPORT, 15e-6)
    added = one.add_component(_model([0.9, 0.1], [-200], [15]))
    assert added is not None and added.means[1] == pytest.approx(100e-6, abs=1e-6)
    fresh = initial_models(None, 2, (-100e-6, 300e-6))
    assert fresh[1].means[0] == pytest.approx(100e-6) and fresh[1].variances[0] == pytest.approx((100e-6) ** 2,
                                                                                                 rel=1e-9, abs=0)


def test_a_previous_outlier_prior_just_under_a_tenth_of_the_default_is_raised() -> None:
    prev = _model([0.6, 0.3905, 0.0095], [-200, 100], [20, 20])
    assert initial_models(prev, 2, SUPPORT, outlier_weight=0.1)[2].weights[-1] == pytest.approx(0.01)


def test_growing_two_components_at_once_is_growing_one_twice() -> None:
    """The model's density on the data and on the residual grid is updated step by step: the third component found
    after the second is the one a fresh start from the two-component model finds; one value is data enough."""
    rng = np.random.default_rng(21)
    x = np.concatenate([rng.normal(-200e-6, 12e-6, 300), rng.normal(0.0, 10e-6, 150), rng.normal(200e-6, 10e-6, 150)])
    data = BinnedSamples.from_samples(x)
    prev = _model([0.9, 0.1], [-200], [12])
    grown = initial_models(prev, 3, SUPPORT, data)
    again = initial_models(grown[2], 3, SUPPORT, data)
    np.testing.assert_allclose(np.sort(grown[3].means), np.sort(again[3].means), atol=1e-9)
    assert np.abs(np.sort(grown[3].means) - [-200e-6, 0.0, 200e-6]).max() < 4e-6
    one = initial_models(prev, 2, SUPPORT, BinnedSamples.from_samples(np.array([150e-6]), None))
    assert np.sort(one[2].means)[1] == pytest.approx(150e-6, abs=1e-6)
    # a split first (the data at the halves of a wide cluster), then a component at the residual
    h = 22e-6 * np.sqrt(2 / np.pi)
    x = np.concatenate([rng.normal(-150e-6 - h, 8e-6, 300), rng.normal(-150e-6 + h, 8e-6, 300),
                        rng.normal(200e-6, 10e-6, 40)])
    data = BinnedSamples.from_samples(x)
    grown = initial_models(_model([0.9, 0.1], [-150], [22]), 3, SUPPORT, data)
    np.testing.assert_allclose(np.sort(grown[2].means), [-150e-6 - h, -150e-6 + h], rtol=1e-9)
    again = initial_models(grown[2], 3, SUPPORT, data)
    np.testing.assert_allclose(np.sort(grown[3].means), np.sort(again[3].means), atol=1e-9)


def test_the_growths_gaussian_is_the_normal_density() -> None:
    from avcore.mixture import _gauss

    x = np.array([-30e-6, 0.0, 45e-6])
    np.testing.assert_allclose(_gauss(x, 10e-6, 4e-10), np.exp(-0.5 * (x - 10e-6) ** 2 / 4e-10)
                               / np.sqrt(2 * np.pi * 4e-10), rtol=1e-12)
