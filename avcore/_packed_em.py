"""The EM engine behind :mod:`avcore.mixture`: many candidate models fitted at once (internal).

A batch holds C models with N_c >= 1 Gaussian components each, packed along one axis of S = sum N_c slots (no
padding, so the N_max = 10 candidates of Algorithm 1 cost 55 slots, not 100). Values are in microseconds so that
moments are well scaled. Each model leaves the batch as soon as its objective has converged.

The maths is the paper's section 4.1: E-step eq. (alpha_m) / (beta_kn), M-step for pi, mu, sigma^2 (and eqs.
update_mu, update_sigma in the fusion EM), with two safeguards described in :mod:`avcore.mixture` (outlier prior
floor, variance floor).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

_TWO_PI = 2.0 * np.pi
_LOG_2PI = float(np.log(_TWO_PI))
_Z2_CLIP = 1400.0  # exp(-700) ~ 1e-304: a Gaussian kernel never underflows to exactly zero


@dataclass
class Packed:
    """Parameters of C packed models (microseconds).

    sizes : (C,) N_c. wg, mu, var : (S,) Gaussian weights, means, variances. wo : (C,) outlier weights.
    """

    sizes: np.ndarray
    wg: np.ndarray
    mu: np.ndarray
    var: np.ndarray
    wo: np.ndarray

    @property
    def starts(self) -> np.ndarray:
        return _starts(self.sizes)

    def model(self, c: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        s = self.starts[c]
        sl = slice(s, s + self.sizes[c])
        return self.wg[sl], self.mu[sl], self.var[sl], float(self.wo[c])

    def copy(self) -> Packed:
        return Packed(self.sizes.copy(), self.wg.copy(), self.mu.copy(), self.var.copy(), self.wo.copy())


def _indicator(sizes: np.ndarray) -> np.ndarray:
    """(S, C) 0/1 matrix of which model each slot belongs to: sums over a model's slots as one matmul
    (several times faster than np.add.reduceat on these small arrays)."""
    owner = np.repeat(np.arange(sizes.size), sizes)
    return (owner[:, None] == np.arange(sizes.size)[None, :]).astype(np.float64)


def _starts(sizes: np.ndarray) -> np.ndarray:
    out = np.zeros(sizes.size, dtype=np.int64)
    np.cumsum(sizes[:-1], out=out[1:])
    return out


def e_step(x: np.ndarray, sizes: np.ndarray, wg: np.ndarray, mu: np.ndarray, var: np.ndarray, wo: np.ndarray,
           u: float | np.ndarray, indicator: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Class densities pi_n P(x | n) of packed models.

    x : (B,) values with mu, var (S,) and u the outlier density; or (B, P) vectors, one value per microphone pair
    (NaN where a pair has none), with mu, var (S, P) and u (P,): a Gaussian's density is the product over the
    pairs a vector has, and so is the outlier's (the model of :func:`avcore.mixture.fit_pairs_em`).
    Returns ``dens_g`` (B, S), ``dens_o`` ((C,), the same for every x, unless some vectors lack a pair: (B, C))
    and ``total`` (B, C) = p(x; Theta_c).
    """
    if x.ndim == 1:
        dens = x[:, None] - mu[None, :]
        dens *= dens
        dens *= -0.5 / var
        scale = wg / np.sqrt(_TWO_PI * var)
        dens_o = wo * u
    else:
        seen = np.isfinite(x)
        complete = bool(seen.all())  # the common case: every vector has every pair
        d = x[:, None, :] - mu[None, :, :] if complete else np.where(seen[:, None, :], x[:, None, :] - mu[None], 0.0)
        d *= d
        d *= -0.5 / var
        dens = d.sum(axis=2)
        if complete:
            scale = wg / np.sqrt(_TWO_PI * var).prod(axis=1)
            dens_o = wo * u.prod()
        else:
            scale = wg / np.where(seen[:, None, :], np.sqrt(_TWO_PI * var)[None, :, :], 1.0).prod(axis=2)
            dens_o = wo[None, :] * np.where(seen, u[None, :], 1.0).prod(axis=1)[:, None]
    np.maximum(dens, -0.5 * _Z2_CLIP, out=dens)
    np.exp(dens, out=dens)
    dens *= scale
    if dens.shape[0]:
        total = dens @ (_indicator(sizes) if indicator is None else indicator)
    else:
        total = np.zeros((0, sizes.size))
    total += dens_o
    return dens, dens_o, total


@dataclass(frozen=True)
class Updates:
    """Which parameters the M-step re-estimates besides the priors (which it always does).

    means : False keeps every mean where it started (Algorithm 2's means anchored at the faces).
    variances : False keeps every variance where it started.
    var_ceiling : largest variance (us^2) the M-step may give; the floor is the engine's ``var_floor``.
    """

    means: bool = True
    variances: bool = True
    var_ceiling: float = np.inf


ALL = Updates()


def m_step(g_sums: np.ndarray, o_counts: np.ndarray, w_total: float, sizes: np.ndarray, mu_old: np.ndarray,
           var_old: np.ndarray, var_floor: float, min_wo: float, indicator: np.ndarray | None = None,
           updates: Updates = ALL, gamma: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                           np.ndarray]:
    """Closed-form M-step from the responsibility-weighted sums.

    g_sums : (S, 3) sums of r, r x, r x^2 per Gaussian slot, or (S, P, 3) per slot and pair for vectors (r where
    the pair has a value); gamma : (S,) each slot's responsibilities, by default ``g_sums[:, 0]`` (values);
    o_counts : (C,) outlier responsibilities.
    The outlier prior is kept >= ``min_wo`` with the other priors proportional to their gamma: the exact
    maximiser of sum_n gamma_n log pi_n under that constraint, so EM stays monotone. With a fixed mean the
    variance's maximiser is the second moment about that mean; a variance bounded to [floor, ceiling] is
    clipped, the maximiser of its (unimodal) term under the bounds.
    Returns wg, mu, var, wo.
    """
    if gamma is None:
        gamma = g_sums[:, 0]
    wg = gamma / w_total
    wo = o_counts / w_total
    if wo.min() < min_wo:
        low = wo < min_wo
        rest = wg @ (_indicator(sizes) if indicator is None else indicator)
        scale = np.where(low, (1.0 - min_wo) / np.maximum(rest, 1e-300), 1.0)
        wg = wg * np.repeat(scale, sizes)
        wo = np.where(low, min_wo, wo)
    if not (updates.means or updates.variances):
        return wg, mu_old, var_old, wo
    mass = g_sums[..., 0]
    alive = mass > 1e-10  # an empty component keeps its mean and variance (on a pair: where it has no value)
    every = bool(alive.all())  # the common case: every component holds some data
    safe = mass if every else np.where(alive, mass, 1.0)
    m1, m2 = g_sums[..., 1] / safe, g_sums[..., 2] / safe
    if updates.means:
        mu = m1 if every else np.where(alive, m1, mu_old)
        var = m2 - mu * mu
    else:
        mu = mu_old
        var = m2 - (2.0 * m1 - mu) * mu
    if not every:
        var = np.where(alive, var, var_old)
    if not updates.variances:
        return wg, mu, var_old, wo
    if updates.var_ceiling == np.inf:
        np.maximum(var, var_floor, out=var)  # np.clip's result, at a fraction of its overhead
    else:
        np.clip(var, var_floor, updates.var_ceiling, out=var)
    return wg, mu, var, wo


class _Live:
    """The models still iterating, as compact local arrays; converged ones are written back to ``p``."""

    def __init__(self, p: Packed) -> None:
        self.p = p
        self.idx = np.arange(p.sizes.size)
        self.slots = np.arange(p.mu.shape[0])
        self._load()

    def _load(self) -> None:
        p = self.p
        self.sizes = p.sizes[self.idx]
        self.indicator = _indicator(self.sizes)
        self.wg, self.mu, self.var, self.wo = p.wg[self.slots], p.mu[self.slots], p.var[self.slots], p.wo[self.idx]

    def store(self) -> None:
        p = self.p
        p.wg[self.slots], p.mu[self.slots], p.var[self.slots], p.wo[self.idx] = self.wg, self.mu, self.var, self.wo

    def drop(self, done: np.ndarray) -> np.ndarray:
        """Remove the models flagged ``done`` (local order); returns the slot mask of those kept."""
        self.store()
        keep = ~done
        slot_keep = np.repeat(keep, self.sizes)
        self.idx, self.slots = self.idx[keep], self.slots[slot_keep]
        self._load()
        return slot_keep


def _em_loop(p: Packed, x: np.ndarray, u: float, objective: Callable[[_Live, np.ndarray], np.ndarray],
             sums: Callable[[_Live, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray | None]],
             w_total: float, *,
             max_iter: int, tol: float, var_floor: float, min_wo: float, history: list[np.ndarray] | None,
             updates: Updates = ALL, last: list[np.ndarray] | None = None
             ) -> tuple[Packed, np.ndarray, np.ndarray, np.ndarray]:
    """The EM loop, written once for both EMs: E-step on ``x``, convergence of ``objective``, M-step.

    objective(live, total) -> (C_live,) the quantity EM must not lower, from the E-step's densities;
    sums(live, resp, resp_outlier) -> (:func:`m_step`'s ``g_sums``, its ``o_counts`` (C_live,), its ``gamma`` or
    None), from the responsibilities of ``x``. Returns the models, the final objective (C,), n_iter (C,) and
    converged (C,); ``history`` receives the objective of every model at every E-step (nan once it has left);
    ``last`` receives the final E-step's ``dens_g, dens_o, total`` (:func:`e_step`), those of the models still in
    the batch then: every model's for a batch of one, whose posteriors they give without another E-step.
    """
    p = p.copy()
    c = p.sizes.size
    n_iter = np.zeros(c, dtype=np.int64)
    converged = np.zeros(c, dtype=bool)
    value = np.full(c, -np.inf)
    lv = _Live(p)
    for it in range(max_iter + 1):
        dens, dens_o, total = e_step(x, lv.sizes, lv.wg, lv.mu, lv.var, lv.wo, u, lv.indicator)
        obj = objective(lv, total)
        if history is not None:
            full = np.full(c, np.nan)
            full[lv.idx] = obj
            history.append(full)
        done = np.abs(obj - value[lv.idx]) < tol * w_total
        value[lv.idx] = obj
        converged[lv.idx[done]] = True
        # a model leaving the batch (or the loop ending) at iteration ``it`` has had ``it`` M-steps
        if it == max_iter or done.all():
            n_iter[lv.idx] = it
            if last is not None:
                last[:] = [dens, dens_o, total]
            break
        if done.any():
            n_iter[lv.idx[done]] = it
            slot_keep = lv.drop(done)
            dens, dens_o, total = dens[:, slot_keep], dens_o[..., ~done], total[:, ~done]
        inv_total = 1.0 / total
        dens *= np.repeat(inv_total, lv.sizes, axis=1)  # each model's 1 / p(x) on its slots
        g_sums, o_counts, gamma = sums(lv, dens, dens_o * inv_total)
        lv.wg, lv.mu, lv.var, lv.wo = m_step(g_sums, o_counts, w_total, lv.sizes, lv.mu, lv.var, var_floor, min_wo,
                                             lv.indicator, updates, gamma)
    lv.store()
    return p, value, n_iter, converged


def run_em(x: np.ndarray, stats: np.ndarray, p: Packed, u: float | np.ndarray, *, max_iter: int, tol: float,
           var_floor: float, min_wo: float, history: list[np.ndarray] | None = None, updates: Updates = ALL,
           last: list[np.ndarray] | None = None) -> tuple[Packed, np.ndarray, np.ndarray, np.ndarray]:
    """Standard EM (eq. alpha_m and its M-step) on weighted data for packed models.

    Values: x (B,) where responsibilities are evaluated, stats (B, 3) count, sum x, sum x^2 per bin (exact stats of
    binned data). Vectors (several pairs, see :func:`e_step`): x (B, P), stats (B, P, 3), each pair's 1 (0 where it
    has no value), value and square, every vector counting once. ``updates`` restricts the M-step
    (:class:`Updates`).
    Returns the fitted models, their final log-likelihood (C,), n_iter (C,), converged (C,). ``history`` receives
    the log-likelihood of every model before each M-step (np.nan for models that have left the batch); ``last``
    the final E-step's densities (:func:`_em_loop`).
    """
    c = p.sizes.size
    if x.size == 0 or c == 0:
        return p.copy(), np.zeros(c), np.zeros(c, dtype=np.int64), np.ones(c, dtype=bool)
    if x.ndim == 1:
        cnt = stats[:, 0]
        sums = lambda lv, resp, resp_o: (resp.T @ stats, cnt @ resp_o, None)  # noqa: E731
    else:
        cnt = np.ones(x.shape[0])
        flat = stats.reshape(x.shape[0], -1)
        complete = bool(np.isfinite(x).all())  # then a slot's r on the first pair is all of its r

        def sums(lv: _Live, resp: np.ndarray, resp_o: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            g = (resp.T @ flat).reshape(-1, *stats.shape[1:])
            return g, cnt @ resp_o, g[:, 0, 0] if complete else cnt @ resp
    return _em_loop(
        p, x, u,
        objective=lambda lv, total: cnt @ np.log(total),
        sums=sums,
        w_total=float(cnt.sum()), max_iter=max_iter, tol=tol, var_floor=var_floor, min_wo=min_wo, history=history,
        updates=updates, last=last,
    )


def class_sums(x: np.ndarray, stats: np.ndarray, p: Packed, u: float) -> tuple[np.ndarray, np.ndarray]:
    """Posterior-weighted sums of the data under fixed models: (S, 3) per Gaussian slot and (C,) outlier counts."""
    if x.size == 0:
        return np.zeros((p.mu.size, 3)), np.zeros(p.sizes.size)
    dens, dens_o, total = e_step(x, p.sizes, p.wg, p.mu, p.var, p.wo, u)
    dens /= total @ _indicator(p.sizes).T
    return dens.T @ stats, (dens_o[None, :] / total).T @ stats[:, 0]


def fixed_q(vis_g: np.ndarray, vis_o: np.ndarray, lv: _Live, u: float) -> np.ndarray:
    """Expected complete-data log-likelihood of the visual data under their fixed posteriors, per live model.

    sum_m sum_n alpha_mn log(pi_n P(v_m | n)), from the per-class sums only (cost independent of M).
    """
    g = vis_g[lv.slots]
    cnt = g[:, 0]
    sq = g[:, 2] - 2.0 * lv.mu * g[:, 1] + lv.mu * lv.mu * cnt
    log_wg = np.log(np.where(lv.wg > 0, lv.wg, 1.0))
    per_slot = np.where(cnt > 0, cnt * (log_wg - 0.5 * (_LOG_2PI + np.log(lv.var))) - 0.5 * sq / lv.var, 0.0)
    o = vis_o[lv.idx]
    outl = np.where(o > 0, o * (np.log(np.where(lv.wo > 0, lv.wo, 1.0)) + np.log(u)), 0.0)
    return per_slot @ lv.indicator + outl


def run_fusion(vis_g: np.ndarray, vis_o: np.ndarray, m_total: float, a: np.ndarray, p: Packed, u: float, *,
               max_iter: int, tol: float, var_floor: float, min_wo: float,
               history: list[np.ndarray] | None = None) -> tuple[Packed, np.ndarray, np.ndarray]:
    """The vision-guided EM fusion (section 4.1) for packed models.

    vis_g (S, 3), vis_o (C,): the fixed visual posteriors alpha, as per-class sums. a : (K,) ITDs. E-step:
    eq. (beta_kn) on the ITDs only; M-step: pi_n = gamma_n / (M + K), eqs. (update_mu) and (update_sigma).
    Returns the fused models, n_iter (C,), converged (C,). ``history`` receives the constrained objective
    (fixed_q + auditory log-likelihood), which never decreases.
    """
    c = p.sizes.size
    w_total = m_total + a.size
    if w_total == 0 or c == 0:
        return p.copy(), np.zeros(c, dtype=np.int64), np.ones(c, dtype=bool)
    a_stats = np.stack([np.ones(a.size), a, a * a], axis=1)
    fused, _, n_iter, converged = _em_loop(
        p, a, u,
        objective=lambda lv, total: fixed_q(vis_g, vis_o, lv, u) + np.log(total).sum(axis=0),
        sums=lambda lv, resp, resp_o: (vis_g[lv.slots] + resp.T @ a_stats, vis_o[lv.idx] + resp_o.sum(axis=0),
                                       None),
        w_total=w_total, max_iter=max_iter, tol=tol, var_floor=var_floor, min_wo=min_wo, history=history,
    )
    return fused, n_iter, converged


def log_likelihoods(x: np.ndarray, cnt: np.ndarray, p: Packed, u: float) -> np.ndarray:
    """sum_b cnt_b log p(x_b; Theta_c) for every packed model (C,)."""
    if x.size == 0:
        return np.zeros(p.sizes.size)
    return cnt @ np.log(e_step(x, p.sizes, p.wg, p.mu, p.var, p.wo, u)[2])
