"""The packed EM engine against the paper's formulas written out one model, one point and one pair at a time.

Each reference below is a plain loop over the equations of section 4.1 (E-step eq. alpha_m / beta_kn, M-step for
pi, mu, sigma^2; the fusion's eqs. update_mu and update_sigma), not a call into avcore: a mistake in the engine's
packing, masks, floors or convergence shows as a difference.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from avcore._packed_em import (
    ALL,
    Packed,
    Updates,
    class_sums,
    e_step,
    fixed_q,
    log_likelihoods,
    m_step,
    run_em,
    run_fusion,
    _Live,
)

U = 1.0 / 1200.0  # a uniform outlier density over +-600 us


def _normal(x: float, mu: float, var: float) -> float:
    return math.exp(-0.5 * (x - mu) ** 2 / var) / math.sqrt(2.0 * math.pi * var)


def _models() -> Packed:
    """Three packed models of 1, 2 and 3 components (six slots), weights of each summing to one with its outlier."""
    return Packed(np.array([1, 2, 3]),
                  np.array([0.8, 0.5, 0.3, 0.2, 0.3, 0.4]),
                  np.array([-100.0, -200.0, 150.0, -300.0, 0.0, 250.0]),
                  np.array([400.0, 900.0, 250.0, 100.0, 1600.0, 625.0]),
                  np.array([0.2, 0.2, 0.1]))


def _slots(p: Packed, c: int) -> range:
    start = int(sum(p.sizes[:c]))
    return range(start, start + int(p.sizes[c]))


def test_packed_models_give_back_their_own_slots() -> None:
    p = _models()
    assert p.starts.tolist() == [0, 1, 3]
    wg, mu, var, wo = p.model(2)
    assert wg.tolist() == [0.2, 0.3, 0.4] and mu.tolist() == [-300.0, 0.0, 250.0] and wo == 0.1
    q = p.copy()
    q.mu[0] = 7.0
    q.wo[0] = 0.5
    assert p.mu[0] == -100.0 and p.wo[0] == 0.2  # a copy, not a view


def test_the_e_step_of_values_is_each_class_prior_times_its_density() -> None:
    p = _models()
    x = np.array([-250.0, -90.0, 0.0, 140.0, 500.0])
    dens, dens_o, total = e_step(x, p.sizes, p.wg, p.mu, p.var, p.wo, U)
    assert dens.shape == (5, 6) and total.shape == (5, 3)
    for b, xb in enumerate(x):
        for s in range(6):
            assert dens[b, s] == pytest.approx(p.wg[s] * _normal(xb, p.mu[s], p.var[s]), rel=1e-12)
        for c in range(3):
            want = sum(p.wg[s] * _normal(xb, p.mu[s], p.var[s]) for s in _slots(p, c)) + p.wo[c] * U
            assert total[b, c] == pytest.approx(want, rel=1e-12)
    assert np.allclose(dens_o, p.wo * U, rtol=1e-14)


def test_a_value_far_from_a_gaussian_keeps_a_tiny_density_not_zero() -> None:
    """The kernel's exponent is held at -700 (exp(-700) ~ 1e-304): a log of the total never meets log 0."""
    p = Packed(np.array([1]), np.array([1.0]), np.array([0.0]), np.array([1.0]), np.array([0.0]))
    dens, _, total = e_step(np.array([1e4, 30.0]), p.sizes, p.wg, p.mu, p.var, p.wo, U)
    assert dens[0, 0] == pytest.approx(math.exp(-700.0) / math.sqrt(2.0 * math.pi), rel=1e-9)
    assert dens[1, 0] == pytest.approx(math.exp(-450.0) / math.sqrt(2.0 * math.pi), rel=1e-9)  # not clipped
    assert np.all(total > 0)


def _vector_models() -> Packed:
    """Two models of 1 and 2 components over two microphone pairs (means and variances per pair)."""
    return Packed(np.array([1, 2]), np.array([0.9, 0.5, 0.3]),
                  np.array([[-100.0, 50.0], [200.0, -80.0], [-250.0, 300.0]]),
                  np.array([[400.0, 900.0], [250.0, 100.0], [1600.0, 625.0]]),
                  np.array([0.1, 0.2]))


@pytest.mark.parametrize("missing", [False, True])
def test_the_e_step_of_vectors_multiplies_over_the_pairs_a_vector_has(missing: bool) -> None:
    p = _vector_models()
    u = np.array([U, 1.0 / 800.0])
    x = np.array([[-90.0, 40.0], [210.0, -70.0], [0.0, 0.0]])
    if missing:
        x[1, 0] = np.nan  # the first pair had no value there
        x[2, 1] = np.nan
    dens, dens_o, total = e_step(x, p.sizes, p.wg, p.mu, p.var, p.wo, u)
    assert dens_o.shape == ((3, 2) if missing else (2,))  # one outlier density per model unless pairs are missing
    for b in range(3):
        seen = [k for k in range(2) if np.isfinite(x[b, k])]
        for s in range(3):
            want = p.wg[s] * math.prod(_normal(x[b, k], p.mu[s, k], p.var[s, k]) for k in seen)
            assert dens[b, s] == pytest.approx(want, rel=1e-12)
        for c, slots in enumerate((range(0, 1), range(1, 3))):
            out = p.wo[c] * math.prod(u[k] for k in seen)
            assert (dens_o[b, c] if missing else dens_o[c]) == pytest.approx(out, rel=1e-12)
            assert total[b, c] == pytest.approx(sum(dens[b, s] for s in slots) + out, rel=1e-12)


def test_an_empty_e_step_has_no_rows() -> None:
    p = _models()
    dens, _, total = e_step(np.empty(0), p.sizes, p.wg, p.mu, p.var, p.wo, U)
    assert dens.shape == (0, 6) and total.shape == (0, 3)


def _sums(x: np.ndarray, r: np.ndarray) -> np.ndarray:
    return np.stack([r.sum(), r @ x, r @ (x * x)])


def test_the_m_step_gives_the_weighted_moments_and_the_shares() -> None:
    x = np.array([-10.0, 0.0, 10.0, 100.0, 110.0])
    r = np.array([[1.0, 0.9, 0.5, 0.0, 0.1], [0.0, 0.1, 0.5, 1.0, 0.8]])
    o = np.array([0.0, 0.0, 0.0, 0.0, 0.1])
    g = np.stack([_sums(x, ri) for ri in r])
    wg, mu, var, wo = m_step(g, np.array([o.sum()]), 5.0, np.array([2]), np.zeros(2), np.ones(2), 1.0, 0.0)
    for n in range(2):
        mean = (r[n] @ x) / r[n].sum()
        assert mu[n] == pytest.approx(mean, rel=1e-12)
        assert var[n] == pytest.approx((r[n] @ (x - mean) ** 2) / r[n].sum(), rel=1e-10)
        assert wg[n] == pytest.approx(r[n].sum() / 5.0, rel=1e-12)
    assert wo[0] == pytest.approx(0.1 / 5.0)


def test_the_m_step_holds_the_outlier_prior_at_its_floor_with_the_rest_in_proportion() -> None:
    """The maximiser of sum gamma_n log pi_n with pi_o >= min_wo: pi_o = min_wo, the others keep their ratios."""
    g = np.array([[3.0, 0.0, 30.0], [1.0, 5.0, 40.0], [6.0, 60.0, 700.0]])
    sizes = np.array([2, 1])
    o = np.array([0.0, 4.0])  # model 0: no outlier mass (under the floor); model 1: 0.4 (above it)
    wg, _, _, wo = m_step(g, o, 10.0, sizes, np.zeros(3), np.ones(3), 1.0, 0.05)
    assert wo.tolist() == [0.05, pytest.approx(0.4)]
    assert wg[:2] == pytest.approx(np.array([0.75, 0.25]) * 0.95, rel=1e-12)
    assert wg[2] == pytest.approx(0.6, rel=1e-12)  # untouched: its model's outlier prior is above the floor
    assert wg[:2].sum() + wo[0] == pytest.approx(1.0) and wg[2] + wo[1] == pytest.approx(1.0)
    _, _, _, wo_exact = m_step(g, np.array([0.5, 4.0]), 10.0, sizes, np.zeros(3), np.ones(3), 1.0, 0.05)
    assert wo_exact[0] == 0.05  # exactly at the floor: kept as it is


def test_the_m_step_clips_the_variance_to_its_floor_and_ceiling() -> None:
    g = np.array([[2.0, 0.0, 2.0], [2.0, 0.0, 2e4]])  # variances 1 and 1e4
    args = (np.array([0.0, 0.0]), 1.0, np.array([2]), np.zeros(2), np.ones(2))
    _, _, var, _ = m_step(g, *args, 25.0, 0.0)
    assert var.tolist() == [25.0, 1e4]
    _, _, var, _ = m_step(g, *args, 25.0, 0.0, updates=Updates(var_ceiling=900.0))
    assert var.tolist() == [25.0, 900.0]
    _, _, var, _ = m_step(g, *args, 0.5, 0.0, updates=Updates(var_ceiling=900.0))
    assert var.tolist() == [1.0, 900.0]


def test_a_fixed_mean_gets_the_second_moment_about_itself() -> None:
    x = np.array([1.0, 2.0, 6.0])
    g = _sums(x, np.ones(3))[None, :]
    mu_old = np.array([4.0])
    _, mu, var, _ = m_step(g, np.zeros(1), 3.0, np.array([1]), mu_old, np.array([9.0]), 1e-6, 0.0,
                           updates=Updates(means=False))
    assert mu.tolist() == [4.0] and var[0] == pytest.approx(np.mean((x - 4.0) ** 2), rel=1e-12)
    _, mu, var, _ = m_step(g, np.zeros(1), 3.0, np.array([1]), mu_old, np.array([9.0]), 1e-6, 0.0,
                           updates=Updates(variances=False))
    assert mu[0] == pytest.approx(3.0) and var.tolist() == [9.0]
    wg, mu, var, _ = m_step(g, np.zeros(1), 3.0, np.array([1]), mu_old, np.array([9.0]), 1e-6, 0.0,
                            updates=Updates(means=False, variances=False))
    assert wg.tolist() == [1.0] and mu.tolist() == [4.0] and var.tolist() == [9.0]


def test_an_empty_component_keeps_its_mean_and_variance() -> None:
    g = np.array([[0.0, 0.0, 0.0], [1e-11, 1e-9, 1e-7], [2.0, 4.0, 10.0]])
    wg, mu, var, _ = m_step(g, np.zeros(1), 2.0, np.array([3]), np.array([-5.0, 7.0, 0.0]),
                            np.array([30.0, 40.0, 9.0]), 0.1, 0.0)
    assert mu.tolist() == [-5.0, 7.0, 2.0] and var.tolist() == [30.0, 40.0, 1.0]
    assert wg.tolist() == [0.0, 5e-12, 1.0]
    # 1e-10 of a point is still empty: a mean from it would be noise
    _, mu, _, _ = m_step(np.array([[1e-10, 5e-10, 3e-9], [2.0, 4.0, 10.0]]), np.zeros(1), 2.0, np.array([2]),
                         np.array([-5.0, 0.0]), np.array([30.0, 1.0]), 0.1, 0.0)
    assert mu.tolist() == [-5.0, 2.0]


def _reference_em(x: np.ndarray, n: np.ndarray, wg: np.ndarray, mu: np.ndarray, var: np.ndarray, wo: float,
                  max_iter: int, tol: float, var_floor: float, min_wo: float) -> tuple:
    """One model's EM on counted values, written out: log-likelihood, E-step, M-step, stop when it moves < tol."""
    wg, mu, var = wg.copy(), mu.copy(), var.copy()
    total_n = n.sum()
    previous, history = -np.inf, []
    for it in range(max_iter + 1):
        dens = np.array([[w * _normal(xb, m, v) for w, m, v in zip(wg, mu, var)] for xb in x])
        p_x = dens.sum(axis=1) + wo * U
        ll = float(n @ np.log(p_x))
        history.append(ll)
        if abs(ll - previous) < tol * total_n or it == max_iter:
            return wg, mu, var, wo, ll, it, abs(ll - previous) < tol * total_n, history
        previous = ll
        r = dens / p_x[:, None] * n[:, None]
        ro = (wo * U / p_x) @ n
        gamma = r.sum(axis=0)
        wg, wo = gamma / total_n, ro / total_n
        if wo < min_wo:
            wg, wo = wg * (1.0 - min_wo) / wg.sum(), min_wo
        mu = (r.T @ x) / gamma
        var = np.maximum((r.T @ x ** 2) / gamma - mu ** 2, var_floor)
    raise AssertionError("unreachable")


def _data(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Binned values (bin centres and counts) from two talkers and the outliers."""
    raw = np.concatenate([rng.normal(-180.0, 25.0, 300), rng.normal(120.0, 15.0, 200), rng.uniform(-600, 600, 60)])
    edges = np.arange(-600.0, 602.0, 2.0)
    counts, _ = np.histogram(raw, edges)
    centres = 0.5 * (edges[1:] + edges[:-1])
    keep = counts > 0
    return centres[keep], counts[keep].astype(float)


def test_packed_models_fit_as_each_would_alone() -> None:
    x, n = _data(np.random.default_rng(3))
    stats = np.stack([n, n * x, n * x * x], axis=1)
    p = Packed(np.array([1, 2, 3]), np.array([0.9, 0.45, 0.45, 0.3, 0.3, 0.3]),
               np.array([-50.0, -100.0, 100.0, -300.0, 0.0, 300.0]), np.full(6, 2500.0), np.array([0.1, 0.1, 0.1]))
    kw = dict(max_iter=200, tol=1e-9, var_floor=4.0, min_wo=0.02)
    history: list[np.ndarray] = []
    fit, ll, n_iter, converged = run_em(x, stats, p, U, history=history, **kw)
    for c in range(3):
        s = _slots(p, c)
        wg, mu, var, wo, ll_c, it_c, conv_c, hist_c = _reference_em(x, n, p.wg[s], p.mu[s], p.var[s], p.wo[c], **kw)
        assert np.allclose(fit.wg[s], wg, rtol=1e-8) and np.allclose(fit.mu[s], mu, rtol=1e-8, atol=1e-8)
        assert np.allclose(fit.var[s], var, rtol=1e-8) and fit.wo[c] == pytest.approx(wo, rel=1e-8)
        assert ll[c] == pytest.approx(ll_c, rel=1e-10) and n_iter[c] == it_c and converged[c] == conv_c
        rows = np.array(history)[:, c]
        assert np.allclose(rows[:len(hist_c)], hist_c, rtol=1e-10) and np.all(np.isnan(rows[len(hist_c):]))
    assert len(set(n_iter.tolist())) > 1  # the models left the batch at different iterations
    assert n_iter.dtype == np.int64 and converged.dtype == bool
    assert p.mu[0] == -50.0  # the start is not changed in place


def test_em_stops_at_its_iteration_budget_unconverged() -> None:
    x, n = _data(np.random.default_rng(4))
    stats = np.stack([n, n * x, n * x * x], axis=1)
    p = Packed(np.array([2]), np.array([0.45, 0.45]), np.array([-500.0, 500.0]), np.full(2, 100.0), np.array([0.1]))
    _, ll, n_iter, converged = run_em(x, stats, p, U, max_iter=3, tol=1e-12, var_floor=4.0, min_wo=0.0)
    *_, ll_ref, it_ref, conv_ref, _ = _reference_em(x, n, p.wg, p.mu, p.var, 0.1, 3, 1e-12, 4.0, 0.0)
    assert n_iter.tolist() == [3] and not converged[0] and it_ref == 3 and not conv_ref
    assert ll[0] == pytest.approx(ll_ref, rel=1e-12)


def test_em_on_nothing_returns_its_start_as_converged() -> None:
    p = _models()
    fit, ll, n_iter, converged = run_em(np.empty(0), np.empty((0, 3)), p, U, max_iter=5, tol=1e-6, var_floor=1.0,
                                        min_wo=0.0)
    assert np.array_equal(fit.mu, p.mu) and fit is not p
    assert ll.tolist() == [0.0] * 3 and n_iter.tolist() == [0] * 3 and converged.all()
    assert n_iter.dtype == np.int64 and converged.dtype == bool


def test_a_fusion_on_nothing_returns_its_start_as_converged() -> None:
    p = _models()
    fused, n_iter, converged = run_fusion(np.zeros((6, 3)), np.zeros(3), 0.0, np.empty(0), p, U, max_iter=5, tol=1e-6,
                                          var_floor=1.0, min_wo=0.0)
    assert np.array_equal(fused.mu, p.mu) and fused is not p
    assert n_iter.dtype == np.int64 and converged.dtype == bool and n_iter.tolist() == [0] * 3 and converged.all()


def test_the_last_e_step_is_handed_back() -> None:
    x, n = _data(np.random.default_rng(5))
    stats = np.stack([n, n * x, n * x * x], axis=1)
    p = Packed(np.array([2]), np.array([0.45, 0.45]), np.array([-150.0, 150.0]), np.full(2, 900.0), np.array([0.1]))
    last: list[np.ndarray] = []
    fit, ll, _, _ = run_em(x, stats, p, U, max_iter=100, tol=1e-10, var_floor=4.0, min_wo=0.0, last=last)
    dens, dens_o, total = last
    # the final E-step is the one of the returned model (the loop stops before another M-step)
    assert np.allclose(total, e_step(x, fit.sizes, fit.wg, fit.mu, fit.var, fit.wo, U)[2], rtol=1e-12)
    assert ll[0] == pytest.approx(n @ np.log(total[:, 0]), rel=1e-12)
    assert dens.shape == (x.size, 2) and dens_o.shape == (1,)


def test_vectors_of_two_pairs_fit_as_the_product_model_written_out() -> None:
    """Each vector counts once; a pair with no value (NaN) adds nothing to that pair's moments."""
    rng = np.random.default_rng(6)
    a = np.stack([rng.normal(-150.0, 20.0, 80), rng.normal(60.0, 30.0, 80)], axis=1)
    b = np.stack([rng.normal(200.0, 25.0, 60), rng.normal(-90.0, 15.0, 60)], axis=1)
    x = np.concatenate([a, b])
    x[::7, 1] = np.nan
    u = np.array([U, 1.0 / 800.0])
    seen = np.isfinite(x)
    stats = np.stack([seen.astype(float), np.where(seen, x, 0.0), np.where(seen, x * x, 0.0)], axis=2)
    p = Packed(np.array([2]), np.array([0.45, 0.45]), np.array([[-100.0, 0.0], [100.0, 0.0]]),
               np.full((2, 2), 2500.0), np.array([0.1]))
    fit, _, n_iter, _ = run_em(x, stats, p, u, max_iter=1, tol=0.0, var_floor=4.0, min_wo=0.0)
    # one M-step by hand from the start's posteriors
    dens = np.array([[p.wg[s] * math.prod(_normal(xb[k], p.mu[s, k], p.var[s, k]) for k in range(2) if seen[i, k])
                      for s in range(2)] for i, xb in enumerate(x)])
    out = np.array([0.1 * math.prod(u[k] for k in range(2) if seen[i, k]) for i in range(x.shape[0])])
    r = dens / (dens.sum(axis=1) + out)[:, None]
    assert n_iter.tolist() == [1]
    assert np.allclose(fit.wg, r.sum(axis=0) / x.shape[0], rtol=1e-10)
    for s in range(2):
        for k in range(2):
            w = r[seen[:, k], s]
            mean = w @ x[seen[:, k], k] / w.sum()
            assert fit.mu[s, k] == pytest.approx(mean, rel=1e-9)
            assert fit.var[s, k] == pytest.approx(w @ (x[seen[:, k], k] - mean) ** 2 / w.sum(), rel=1e-8)


def test_class_sums_and_log_likelihoods_are_the_posterior_sums_written_out() -> None:
    x, n = _data(np.random.default_rng(7))
    stats = np.stack([n, n * x, n * x * x], axis=1)
    p = _models()
    g, o = class_sums(x, stats, p, U)
    ll = log_likelihoods(x, n, p, U)
    for c in range(3):
        s = list(_slots(p, c))
        dens = np.array([[p.wg[j] * _normal(xb, p.mu[j], p.var[j]) for j in s] for xb in x])
        p_x = dens.sum(axis=1) + p.wo[c] * U
        r = dens / p_x[:, None] * n[:, None]
        assert np.allclose(g[s], np.stack([r.sum(axis=0), r.T @ x, r.T @ x ** 2], axis=1), rtol=1e-10)
        assert o[c] == pytest.approx((p.wo[c] * U / p_x) @ n, rel=1e-10)
        assert ll[c] == pytest.approx(n @ np.log(p_x), rel=1e-12)
    g0, o0 = class_sums(np.empty(0), np.empty((0, 3)), p, U)
    assert g0.shape == (6, 3) and not g0.any() and o0.tolist() == [0.0] * 3
    assert log_likelihoods(np.empty(0), np.empty(0), p, U).tolist() == [0.0] * 3


def test_the_fixed_visual_term_is_the_expected_log_likelihood_written_out() -> None:
    """sum_m sum_n alpha_mn log(pi_n P(v_m | n)) + alpha_m,out log(pi_out U), from the per-class sums alone."""
    rng = np.random.default_rng(8)
    v = rng.normal(0.0, 200.0, 40)
    p = _models()
    p.wg[4] = 0.0  # an empty prior: its slot has no data either and adds nothing
    alpha = rng.dirichlet(np.ones(7), 40)  # six slots' posteriors and an outlier's
    alpha[:, 4] = 0.0
    vis_g = np.stack([alpha[:, :6].sum(axis=0), alpha[:, :6].T @ v, alpha[:, :6].T @ v ** 2], axis=1)
    vis_o = np.array([alpha[:, 6].sum(), 0.0, 2.0 * alpha[:, 6].sum()])  # model 1: no outlier mass
    got = fixed_q(vis_g, vis_o, _Live(p), U)
    for c in range(3):
        want = sum(alpha[m, s] * (math.log(p.wg[s]) - 0.5 * math.log(2 * math.pi * p.var[s])
                                  - 0.5 * (v[m] - p.mu[s]) ** 2 / p.var[s])
                   for s in _slots(p, c) for m in range(40) if alpha[m, s] > 0)
        want += vis_o[c] * math.log(p.wo[c] * U) if vis_o[c] > 0 else 0.0
        assert got[c] == pytest.approx(want, rel=1e-10)


def _reference_fusion(vis_g: np.ndarray, vis_o: float, m_total: float, a: np.ndarray, wg: np.ndarray,
                      mu: np.ndarray, var: np.ndarray, wo: float, max_iter: int, tol: float, var_floor: float,
                      min_wo: float) -> tuple:
    """The fusion EM of section 4.1 for one model: E-step on the ITDs only, M-step with the visual sums added."""
    wg, mu, var = wg.copy(), mu.copy(), var.copy()
    w_total = m_total + a.size
    previous = -np.inf
    for it in range(max_iter + 1):
        dens = np.array([[w * _normal(ak, m, s) for w, m, s in zip(wg, mu, var)] for ak in a])
        p_a = dens.sum(axis=1) + wo * U
        sq = vis_g[:, 2] - 2 * mu * vis_g[:, 1] + mu ** 2 * vis_g[:, 0]
        q = float(np.sum(vis_g[:, 0] * (np.log(wg) - 0.5 * np.log(2 * np.pi * var)) - 0.5 * sq / var))
        q += vis_o * math.log(wo * U) + float(np.log(p_a).sum())
        if abs(q - previous) < tol * w_total or it == max_iter:
            return wg, mu, var, wo, it
        previous = q
        r = dens / p_a[:, None]
        gamma = vis_g[:, 0] + r.sum(axis=0)
        wg, wo = gamma / w_total, (vis_o + (wo * U / p_a).sum()) / w_total
        if wo < min_wo:
            wg, wo = wg * (1.0 - min_wo) / wg.sum(), min_wo
        mu = (vis_g[:, 1] + r.T @ a) / gamma
        var = np.maximum((vis_g[:, 2] + r.T @ a ** 2) / gamma - mu ** 2, var_floor)
    raise AssertionError("unreachable")


def test_the_fusion_em_is_section_4_1_written_out() -> None:
    rng = np.random.default_rng(9)
    v = np.concatenate([rng.normal(-200.0, 20.0, 50), rng.normal(150.0, 30.0, 70)])
    alpha = np.zeros((120, 2))
    alpha[:50, 0], alpha[50:, 1] = 0.95, 0.9
    vis_g = np.stack([alpha.sum(axis=0), alpha.T @ v, alpha.T @ v ** 2], axis=1)
    vis_o = float(120 - alpha.sum())
    a = np.concatenate([rng.normal(-190.0, 30.0, 12), rng.normal(170.0, 25.0, 6), rng.uniform(-600, 600, 4)])
    p = Packed(np.array([2]), np.array([0.4, 0.5]), np.array([-210.0, 140.0]), np.array([500.0, 800.0]),
               np.array([0.1]))
    history: list[np.ndarray] = []
    kw = dict(max_iter=100, tol=1e-9, var_floor=4.0, min_wo=0.02)
    fused, n_iter, converged = run_fusion(vis_g, np.array([vis_o]), 120.0, a, p, U, history=history, **kw)
    wg, mu, var, wo, it = _reference_fusion(vis_g, vis_o, 120.0, a, p.wg, p.mu, p.var, 0.1, **kw)
    assert np.allclose(fused.wg, wg, rtol=1e-8) and np.allclose(fused.mu, mu, rtol=1e-8)
    assert np.allclose(fused.var, var, rtol=1e-8) and fused.wo[0] == pytest.approx(wo, rel=1e-8)
    assert n_iter.tolist() == [it] and converged.all()
    values = np.array(history)[:, 0]
    assert np.all(np.diff(values) >= -1e-9 * abs(values[0]))  # the constrained objective never decreases
    none, n0, c0 = run_fusion(vis_g[:0], np.zeros(0), 0.0, a[:0], Packed(np.zeros(0, int), *[np.zeros(0)] * 4), U,
                              **kw)
    assert none.sizes.size == 0 and n0.size == 0 and c0.size == 0


def test_the_default_updates_re_estimate_everything() -> None:
    assert ALL == Updates(means=True, variances=True, var_ceiling=np.inf)


def test_the_fusion_of_several_models_fits_each_as_alone_even_from_one_itd() -> None:
    """Two models fused at once, each as the written-out fusion alone (the objective and the outlier counts are per
    model); a single ITD and no visual data still move a model."""
    rng = np.random.default_rng(10)
    v = np.concatenate([rng.normal(-200.0, 20.0, 30), rng.normal(150.0, 30.0, 40)])
    a = np.concatenate([rng.normal(-190.0, 30.0, 9), rng.uniform(-600, 600, 3)])
    p = Packed(np.array([1, 2]), np.array([0.8, 0.4, 0.4]), np.array([-150.0, -210.0, 140.0]),
               np.array([2500.0, 500.0, 800.0]), np.array([0.2, 0.2]))
    alpha = [np.full((70, 1), 0.7), np.column_stack([np.r_[np.full(30, 0.9), np.zeros(40)],
                                                     np.r_[np.zeros(30), np.full(40, 0.85)]])]
    vis_g = np.concatenate([np.stack([al.sum(axis=0), al.T @ v, al.T @ v ** 2], axis=1) for al in alpha])
    vis_o = np.array([70 - al.sum() for al in alpha])
    kw = dict(max_iter=60, tol=1e-9, var_floor=4.0, min_wo=0.02)
    fused, n_iter, _ = run_fusion(vis_g, vis_o, 70.0, a, p, U, **kw)
    for c in range(2):
        s = list(_slots(p, c))
        wg, mu, var, wo, it = _reference_fusion(vis_g[s], vis_o[c], 70.0, a, p.wg[s], p.mu[s], p.var[s], p.wo[c], **kw)
        assert np.allclose(fused.mu[s], mu, rtol=1e-8) and np.allclose(fused.var[s], var, rtol=1e-8)
        assert np.allclose(fused.wg[s], wg, rtol=1e-8) and fused.wo[c] == pytest.approx(wo, rel=1e-8)
        assert n_iter[c] == it
    one = Packed(np.array([1]), np.array([0.5]), np.array([0.0]), np.array([400.0]), np.array([0.5]))
    moved, _, _ = run_fusion(np.zeros((1, 3)), np.zeros(1), 0.0, np.array([30.0]), one, U, **kw)
    assert moved.mu[0] == pytest.approx(30.0) and moved.wg[0] > 0.5
    nobody = Packed(np.zeros(0, int), np.zeros(0), np.zeros(0), np.zeros(0), np.zeros(0))
    out, n0, c0 = run_fusion(np.zeros((0, 3)), np.zeros(0), 70.0, a, nobody, U, **kw)
    assert out.sizes.size == 0 and n0.size == 0 and c0.size == 0


def test_the_fixed_visual_term_counts_slots_and_outliers_of_less_than_one_point() -> None:
    p = Packed(np.array([1]), np.array([0.6]), np.array([10.0]), np.array([400.0]), np.array([0.4]))
    vis_g = np.array([[0.5, 0.5 * 30.0, 0.5 * 900.0]])  # half a point at 30 us
    got = fixed_q(vis_g, np.array([0.25]), _Live(p), U)
    want = 0.5 * (math.log(0.6) - 0.5 * math.log(2 * math.pi * 400.0) - 0.5 * 400.0 / 400.0)
    want += 0.25 * math.log(0.4 * U)
    assert got[0] == pytest.approx(want, rel=1e-12)


def test_the_likelihood_of_a_single_value() -> None:
    p = _models()
    ll = log_likelihoods(np.array([-90.0]), np.array([2.0]), p, U)
    for c in range(3):
        want = sum(p.wg[s] * _normal(-90.0, p.mu[s], p.var[s]) for s in _slots(p, c)) + p.wo[c] * U
        assert ll[c] == pytest.approx(2.0 * math.log(want), rel=1e-12)
