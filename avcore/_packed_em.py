"""The EM engine behind :mod:`avcore.mixture`: many candidate models fitted at once (internal).

A batch holds C models with N_c >= 1 Gaussian components each, packed along one axis of S = sum N_c slots (no
padding, so the N_max = 10 candidates of Algorithm 1 cost 55 slots, not 100). Values are in microseconds so that
moments are well scaled. Each model leaves the batch as soon as its objective has converged.

The maths is the paper's section 4.1: E-step eq. (alpha_m) / (beta_kn), M-step for pi, mu, sigma^2 (and eqs.
update_mu, update_sigma in the fusion EM), with two safeguards described in :mod:`avcore.mixture` (outlier prior
floor, variance floor).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_LOG_2PI = float(np.log(2.0 * np.pi))
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
        return np.concatenate([[0], np.cumsum(self.sizes)[:-1]]).astype(np.int64)

    @property
    def owner(self) -> np.ndarray:
        return np.repeat(np.arange(self.sizes.size), self.sizes)

    def slots(self, models: np.ndarray) -> np.ndarray:
        """Slot indices of the given models, in order."""
        starts = self.starts
        return np.concatenate([np.arange(starts[c], starts[c] + self.sizes[c]) for c in models]).astype(np.int64)

    def model(self, c: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
        s = self.starts[c]
        sl = slice(s, s + self.sizes[c])
        return self.wg[sl], self.mu[sl], self.var[sl], float(self.wo[c])

    def copy(self) -> Packed:
        return Packed(self.sizes.copy(), self.wg.copy(), self.mu.copy(), self.var.copy(), self.wo.copy())


def e_step(x: np.ndarray, sizes: np.ndarray, wg: np.ndarray, mu: np.ndarray, var: np.ndarray, wo: np.ndarray,
           u: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Class densities pi_n P(x | n) of packed models.

    Returns ``dens_g`` (B, S), ``dens_o`` (C,) (the same for every x) and ``total`` (B, C) = p(x; Theta_c).
    """
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    dens = x[:, None] - mu[None, :]
    dens *= dens
    dens /= var
    np.minimum(dens, _Z2_CLIP, out=dens)
    dens *= -0.5
    np.exp(dens, out=dens)
    dens *= wg / np.sqrt(2.0 * np.pi * var)
    dens_o = wo * u
    total = np.add.reduceat(dens, starts, axis=1) if dens.shape[0] else np.zeros((0, sizes.size))
    total += dens_o
    return dens, dens_o, total


def m_step(g_sums: np.ndarray, o_counts: np.ndarray, w_total: float, sizes: np.ndarray, mu_old: np.ndarray,
           var_old: np.ndarray, var_floor: float, min_wo: float
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Closed-form M-step from the responsibility-weighted sums.

    g_sums : (S, 3) sums of r, r x, r x^2 per Gaussian slot; o_counts : (C,) outlier responsibilities.
    The outlier prior is kept >= ``min_wo`` with the other priors proportional to their gamma: the exact
    maximiser of sum_n gamma_n log pi_n under that constraint, so EM stays monotone.
    Returns wg, mu, var, wo.
    """
    gamma = g_sums[:, 0]
    wg = gamma / w_total
    wo = o_counts / w_total
    low = wo < min_wo
    if np.any(low):
        starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
        rest = np.add.reduceat(wg, starts)
        scale = np.where(low, (1.0 - min_wo) / np.maximum(rest, 1e-300), 1.0)
        wg = wg * np.repeat(scale, sizes)
        wo = np.where(low, min_wo, wo)
    alive = gamma > 1e-10
    safe = np.where(alive, gamma, 1.0)
    mu = np.where(alive, g_sums[:, 1] / safe, mu_old)
    var = np.where(alive, g_sums[:, 2] / safe - mu * mu, var_old)
    np.maximum(var, var_floor, out=var)
    return wg, mu, var, wo


def _select(p: Packed, live: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    slots = p.slots(live)
    return slots, p.sizes[live]


def run_em(x: np.ndarray, stats: np.ndarray, p: Packed, u: float, *, max_iter: int, tol: float, var_floor: float,
           min_wo: float, history: list[np.ndarray] | None = None) -> tuple[Packed, np.ndarray, np.ndarray, np.ndarray]:
    """Standard EM on weighted 1-D data (bins with exact stats) for packed models.

    x : (B,) where responsibilities are evaluated; stats : (B, 3) count, sum x, sum x^2 per bin.
    Returns the fitted models, their final log-likelihood (C,), n_iter (C,), converged (C,). ``history`` receives
    the log-likelihood of every model before each M-step (np.nan for models that have left the batch).
    """
    p = p.copy()
    c = p.sizes.size
    n_iter = np.zeros(c, dtype=np.int64)
    converged = np.zeros(c, dtype=bool)
    loglik = np.full(c, -np.inf)
    cnt = stats[:, 0]
    w_total = float(cnt.sum())
    if x.size == 0 or c == 0:
        return p, np.zeros(c), n_iter, np.ones(c, dtype=bool)
    live = np.arange(c)
    slots, sizes = _select(p, live)
    for it in range(max_iter + 1):
        dens, dens_o, total = e_step(x, sizes, p.wg[slots], p.mu[slots], p.var[slots], p.wo[live], u)
        ll = cnt @ np.log(total)
        if history is not None:
            full = np.full(c, np.nan)
            full[live] = ll
            history.append(full)
        done = np.abs(ll - loglik[live]) < tol * w_total
        loglik[live] = ll
        converged[live[done]] = True
        if it == max_iter or np.all(done):
            break
        if np.any(done):
            keep = ~done
            owner_keep = np.repeat(keep, sizes)
            live, dens, dens_o, total = live[keep], dens[:, owner_keep], dens_o[keep], total[:, keep]
            slots, sizes = slots[owner_keep], sizes[keep]
        owner = np.repeat(np.arange(sizes.size), sizes)
        dens /= total[:, owner]
        g_sums = dens.T @ stats
        o_counts = (dens_o[None, :] / total).T @ cnt
        p.wg[slots], p.mu[slots], p.var[slots], p.wo[live] = m_step(
            g_sums, o_counts, w_total, sizes, p.mu[slots], p.var[slots], var_floor, min_wo
        )
        n_iter[live] += 1
    return p, loglik, n_iter, converged


def class_sums(x: np.ndarray, stats: np.ndarray, p: Packed, u: float) -> tuple[np.ndarray, np.ndarray]:
    """Posterior-weighted sums of the data under fixed models: (S, 3) per Gaussian slot and (C,) outlier counts."""
    if x.size == 0:
        return np.zeros((p.mu.size, 3)), np.zeros(p.sizes.size)
    dens, dens_o, total = e_step(x, p.sizes, p.wg, p.mu, p.var, p.wo, u)
    dens /= total[:, p.owner]
    return dens.T @ stats, (dens_o[None, :] / total).T @ stats[:, 0]


def fixed_q(vis_g: np.ndarray, vis_o: np.ndarray, p: Packed, slots: np.ndarray, live: np.ndarray, u: float
            ) -> np.ndarray:
    """Expected complete-data log-likelihood of the visual data under their fixed posteriors, per model.

    sum_m sum_n alpha_mn log(pi_n P(v_m | n)), from the per-class sums only (cost independent of M).
    """
    wg, mu, var, wo = p.wg[slots], p.mu[slots], p.var[slots], p.wo[live]
    cnt = vis_g[slots, 0]
    sq = vis_g[slots, 2] - 2.0 * mu * vis_g[slots, 1] + mu * mu * cnt
    log_wg = np.log(np.where(wg > 0, wg, 1.0))
    per_slot = np.where(cnt > 0, cnt * (log_wg - 0.5 * (_LOG_2PI + np.log(var))) - 0.5 * sq / var, 0.0)
    sizes = p.sizes[live]
    starts = np.concatenate([[0], np.cumsum(sizes)[:-1]]).astype(np.int64)
    log_wo = np.log(np.where(wo > 0, wo, 1.0))
    outl = np.where(vis_o[live] > 0, vis_o[live] * (log_wo + np.log(u)), 0.0)
    return np.add.reduceat(per_slot, starts) + outl


def run_fusion(vis_g: np.ndarray, vis_o: np.ndarray, m_total: float, a: np.ndarray, p: Packed, u: float, *,
               max_iter: int, tol: float, var_floor: float, min_wo: float,
               history: list[np.ndarray] | None = None) -> tuple[Packed, np.ndarray, np.ndarray]:
    """The vision-guided EM fusion (section 4.1) for packed models.

    vis_g (S, 3), vis_o (C,): the fixed visual posteriors alpha, as per-class sums. a : (K,) ITDs. E-step:
    eq. (beta_kn) on the ITDs only; M-step: pi_n = gamma_n / (M + K), eqs. (update_mu) and (update_sigma).
    Returns the fused models, n_iter (C,), converged (C,). ``history`` receives the constrained objective
    (fixed_q + auditory log-likelihood), which never decreases.
    """
    p = p.copy()
    c = p.sizes.size
    k = a.size
    n_iter = np.zeros(c, dtype=np.int64)
    converged = np.zeros(c, dtype=bool)
    objective = np.full(c, -np.inf)
    w_total = m_total + k
    if w_total == 0 or c == 0:
        return p, n_iter, np.ones(c, dtype=bool)
    a_stats = np.stack([np.ones(k), a, a * a], axis=1)
    live = np.arange(c)
    slots, sizes = _select(p, live)
    for it in range(max_iter + 1):
        dens, dens_o, total = e_step(a, sizes, p.wg[slots], p.mu[slots], p.var[slots], p.wo[live], u)
        obj = fixed_q(vis_g, vis_o, p, slots, live, u) + np.log(total).sum(axis=0)
        if history is not None:
            full = np.full(c, np.nan)
            full[live] = obj
            history.append(full)
        done = np.abs(obj - objective[live]) < tol * w_total
        objective[live] = obj
        converged[live[done]] = True
        if it == max_iter or np.all(done):
            break
        if np.any(done):
            keep = ~done
            owner_keep = np.repeat(keep, sizes)
            live, dens, dens_o, total = live[keep], dens[:, owner_keep], dens_o[keep], total[:, keep]
            slots, sizes = slots[owner_keep], sizes[keep]
        owner = np.repeat(np.arange(sizes.size), sizes)
        dens /= total[:, owner]
        g_sums = vis_g[slots] + dens.T @ a_stats
        o_counts = vis_o[live] + (dens_o[None, :] / total).sum(axis=0)
        p.wg[slots], p.mu[slots], p.var[slots], p.wo[live] = m_step(
            g_sums, o_counts, w_total, sizes, p.mu[slots], p.var[slots], var_floor, min_wo
        )
        n_iter[live] += 1
    return p, n_iter, converged


def log_likelihoods(x: np.ndarray, cnt: np.ndarray, p: Packed, u: float) -> np.ndarray:
    """sum_b cnt_b log p(x_b; Theta_c) for every packed model (C,)."""
    if x.size == 0:
        return np.zeros(p.sizes.size)
    return cnt @ np.log(e_step(x, p.sizes, p.wg, p.mu, p.var, p.wo, u)[2])
