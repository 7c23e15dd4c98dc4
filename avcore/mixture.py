"""The 1-D probabilistic model of section 3.2 and the EM algorithms of section 4 (paper section "Multimodal Inference").

The model (eq. prob_model) is a mixture of N Gaussians in ITD space plus a uniform outlier class on the ITD
interval of the microphone pair:

    p(x; Theta) = sum_n pi_n N(x; mu_n, sigma_n^2) + pi_{N+1} U(x; A)

Two EM algorithms fit it:

* :func:`fit_em` - the standard EM on (weighted) 1-D data: eq. (alpha_m) as E-step and its closed-form M-step.
* :func:`fit_fusion_em` - the *vision-guided EM fusion*: the visual posteriors alpha stay fixed, the E-step updates
  only the auditory posteriors beta (eq. beta_kn), the M-step combines both (eqs. update_mu, update_sigma and
  pi_n = gamma_n / (M + K)).

Speed. Algorithm 1 runs both EMs for every candidate N = 0..N_max on about 2,000 projected points per interval.
The engine here (i) works on a fine histogram of the projected points that keeps the exact per-bin sufficient
statistics (count, sum x, sum x^2), so that the M-step is exact given responsibilities that are constant inside a
bin (1 us wide by default, against sigmas of tens of us); (ii) runs all candidate models at once as one batch of
arrays ``(C, B, N_max + 1)``; (iii) drops each model from the batch as soon as it has converged; (iv) works
internally in microseconds so that the moments are well scaled. During the fusion EM the visual statistics are
fixed, so its cost is O(K N) per iteration whatever M is.

Numerical safety: the outlier weight is kept above ``min_outlier_weight`` (a constrained M-step, which keeps EM
monotone), so every observation has a strictly positive density and the probability-domain E-step cannot divide
by zero; variances are floored; a component that receives no responsibility keeps its mean and variance and gets
zero weight.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from avcore._packed_em import _Z2_CLIP, Packed, Updates, run_em, run_fusion
from avcore._validate import as_samples

__all__ = [
    "BinnedSamples",
    "EMSettings",
    "FitResult",
    "FusionFit",
    "PairsFit",
    "Mixture1D",
    "bic_score",
    "davies_bouldin",
    "fit_em",
    "fit_fusion_em",
    "fit_pairs_em",
    "initial_models",
    "ridgeline_merge",
    "split_at_mean",
]

US = 1e6  # internal unit: microseconds per second


class ConvergenceWarning(UserWarning):
    """EM stopped at ``max_iter`` before the change of the objective fell below ``tol``."""


@dataclass(frozen=True)
class EMSettings:
    """Numerical settings of both EMs.

    max_iter : int
        Iterations at most per EM run.
    tol : float
        Convergence when the objective's change per observation falls below this (unit-free, like scikit-learn's
        ``tol`` on the per-sample lower bound).
    var_floor_s2 : float, s^2
        Smallest variance of a Gaussian component ((5 us)^2 by default): keeps a component from collapsing onto a
        few identical values.
    min_outlier_weight : float
        Lower bound of the outlier prior pi_{N+1}; keeps every density positive (see module docstring).
    """

    max_iter: int = 100
    tol: float = 1e-4
    var_floor_s2: float = 2.5e-11
    min_outlier_weight: float = 1e-3

    def __post_init__(self) -> None:
        if self.max_iter < 1:
            raise ValueError(f"max_iter must be >= 1, got {self.max_iter}")
        if not self.tol > 0:
            raise ValueError(f"tol must be > 0, got {self.tol}")
        if not self.var_floor_s2 > 0:
            raise ValueError(f"var_floor_s2 must be > 0 s^2, got {self.var_floor_s2}")
        if not 0 < self.min_outlier_weight < 1:
            raise ValueError(f"min_outlier_weight must be in (0, 1), got {self.min_outlier_weight}")


def _check_support(support: tuple[float, float]) -> tuple[float, float]:
    lo, hi = float(support[0]), float(support[1])
    if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
        raise ValueError(f"support must be an interval (lo, hi) of seconds with lo < hi, got {support!r}")
    return lo, hi


@dataclass(frozen=True)
class Mixture1D:
    """A fitted or initial model of eq. (prob_model), in seconds.

    weights : (N + 1,) float, the priors pi_1..pi_N and, last, the outlier prior pi_{N+1}; they sum to one.
    means : (N,) float, seconds.
    variances : (N,) float, s^2.
    support : (lo, hi) seconds, the interval of ITD space the uniform outlier density covers.
    """

    weights: np.ndarray
    means: np.ndarray
    variances: np.ndarray
    support: tuple[float, float]

    def __post_init__(self) -> None:
        w = np.asarray(self.weights, dtype=np.float64).reshape(-1)
        mu = np.asarray(self.means, dtype=np.float64).reshape(-1)
        var = np.asarray(self.variances, dtype=np.float64).reshape(-1)
        if w.shape != (mu.size + 1,) or var.shape != mu.shape:
            raise ValueError(
                f"a mixture of N Gaussians needs N + 1 weights, N means and N variances; got {w.size}, {mu.size}, "
                f"{var.size}"
            )
        if not (np.all(np.isfinite(w)) and np.all(np.isfinite(mu)) and np.all(np.isfinite(var))):
            raise ValueError("mixture parameters must be finite")
        if np.any(w < 0) or abs(w.sum() - 1.0) > 1e-6:
            raise ValueError(f"weights must be non-negative and sum to 1, got {w}")
        if np.any(var <= 0):
            raise ValueError(f"variances must be positive, got {var}")
        object.__setattr__(self, "weights", w)
        object.__setattr__(self, "means", mu)
        object.__setattr__(self, "variances", var)
        object.__setattr__(self, "support", _check_support(self.support))

    def shared(self, owner: np.ndarray) -> Mixture1D:
        """One component per member: member i takes component ``owner[i]``, whose weight its members share (the
        density is unchanged). For objects heard as one (faces in one direction) shown one per face."""
        own = np.asarray(owner, dtype=np.intp).reshape(-1)
        members = np.bincount(own[(own >= 0) & (own < self.n_components)], minlength=self.n_components)
        if members.sum() < own.size or np.any(members == 0):
            raise ValueError(f"owner must name each of the {self.n_components} components at least once, "
                             f"got {own.tolist()}")
        return Mixture1D(np.append(self.weights[own] / members[own], self.weights[-1]), self.means[own],
                         self.variances[own], self.support)

    @classmethod
    def unchecked(cls, weights: np.ndarray, means: np.ndarray, variances: np.ndarray,
                  support: tuple[float, float]) -> Mixture1D:
        """Build without validation, for arrays that avcore's fitting code itself made and checked (a hot path: the
        face-guided EM and the candidate models build one per iteration). Anything else: the constructor."""
        obj = object.__new__(cls)
        object.__setattr__(obj, "weights", weights)
        object.__setattr__(obj, "means", means)
        object.__setattr__(obj, "variances", variances)
        object.__setattr__(obj, "support", support)
        return obj

    @property
    def n_components(self) -> int:
        """N, the number of Gaussian components (the outlier class not counted)."""
        return int(self.means.size)

    @property
    def outlier_density(self) -> float:
        """U(x; A): one over the length of the support, 1/s."""
        return 1.0 / (self.support[1] - self.support[0])

    def component_densities(self, x: object) -> np.ndarray:
        """pi_n P(x | n) for every component and the outlier class: ``(len(x), N + 1)``, 1/s.

        The uniform class has the same density for every x: observations a little outside the support (an ITD
        extractor searches lags wider than the free-field geometry) are treated as inside it.
        """
        xs = as_samples(x, "x")
        z2 = (xs[:, None] - self.means[None, :]) ** 2 / self.variances[None, :]
        gauss = np.exp(-0.5 * np.minimum(z2, _Z2_CLIP)) / np.sqrt(2.0 * np.pi * self.variances[None, :])
        out = np.empty((xs.size, self.n_components + 1))
        out[:, :-1] = self.weights[None, :-1] * gauss
        out[:, -1] = self.weights[-1] * self.outlier_density
        return out

    def density(self, x: object) -> np.ndarray:
        """p(x; Theta) of eq. (prob_model), 1/s."""
        return self._density(as_samples(x, "x"))

    def _density(self, xs: np.ndarray) -> np.ndarray:
        """:meth:`density` of a checked 1-D float array (a hot path of the initialisation)."""
        z2 = (xs[:, None] - self.means[None, :]) ** 2 / self.variances[None, :]
        gauss = np.exp(-0.5 * np.minimum(z2, _Z2_CLIP))
        return gauss @ (self.weights[:-1] / np.sqrt(2.0 * np.pi * self.variances)) + self.weights[-1] * (
            self.outlier_density)

    def responsibilities(self, x: object) -> np.ndarray:
        """Posterior of each class given each observation (eqs. alpha_m / beta_kn): ``(len(x), N + 1)``."""
        dens = self.component_densities(x)
        return dens / dens.sum(axis=1, keepdims=True)

    def log_likelihood(self, x: object) -> float:
        """Sum of log p(x; Theta) over the observations (one term of eq. log-like)."""
        return float(np.sum(np.log(self.density(x))))

    def ordered_by_weight(self) -> Mixture1D:
        """The same model with its Gaussian components sorted by decreasing weight."""
        order = np.argsort(-self.weights[:-1], kind="stable")
        return Mixture1D(
            np.append(self.weights[:-1][order], self.weights[-1]), self.means[order], self.variances[order],
            self.support,
        )

    @classmethod
    def outliers_only(cls, support: tuple[float, float]) -> Mixture1D:
        """The N = 0 model: every observation is an outlier."""
        return cls(np.ones(1), np.empty(0), np.empty(0), support)


# ----------------------------------------------------------------------------------------------------------------
# Data: a fine histogram with exact sufficient statistics


@dataclass(frozen=True)
class BinnedSamples:
    """1-D samples summarised by bins that keep their exact count, sum and sum of squares (microseconds).

    x_us : (B,) the mean of the samples in each non-empty bin (where responsibilities are evaluated).
    stats : (B, 3) count, sum x, sum x^2 of each bin (x in microseconds).
    """

    x_us: np.ndarray
    stats: np.ndarray

    @property
    def total(self) -> float:
        return float(self.stats[:, 0].sum())

    @classmethod
    def from_samples(cls, x_s: np.ndarray, bin_width_s: float | None = 1e-6) -> BinnedSamples:
        """Bin seconds-valued samples; ``bin_width_s=None`` keeps one bin per sample (exact EM)."""
        x = np.asarray(x_s, dtype=np.float64) * US
        if x.size == 0:
            return cls(np.empty(0), np.empty((0, 3)))
        if bin_width_s is None:
            return cls(x.copy(), np.stack([np.ones_like(x), x, x * x], axis=1))
        width = bin_width_s * US
        idx = np.floor((x - x.min()) / width).astype(np.int64)
        n_bins = int(idx.max()) + 1
        count = np.bincount(idx, minlength=n_bins)
        keep = count > 0
        s1 = np.bincount(idx, weights=x, minlength=n_bins)[keep]
        s2 = np.bincount(idx, weights=x * x, minlength=n_bins)[keep]
        c = count[keep].astype(np.float64)
        return cls(s1 / c, np.stack([c, s1, s2], axis=1))


# ----------------------------------------------------------------------------------------------------------------
# Packing public models into the engine of avcore._packed_em (microseconds)


def pack(models: list[Mixture1D]) -> Packed:
    """Pack models with N >= 1 components each into one batch (microseconds)."""
    if any(m.n_components == 0 for m in models):
        raise ValueError("only models with at least one Gaussian component can be packed")
    return Packed(
        np.array([m.n_components for m in models], dtype=np.int64),
        np.concatenate([m.weights[:-1] for m in models]),
        np.concatenate([m.means for m in models]) * US,
        np.concatenate([m.variances for m in models]) * US * US,
        np.array([m.weights[-1] for m in models]),
    )


def unpack(p: Packed, c: int, support: tuple[float, float]) -> Mixture1D:
    """Model ``c`` of a batch, back in seconds."""
    wg, mu, var, wo = p.model(c)
    weights = np.append(wg, wo)
    return Mixture1D.unchecked(weights / weights.sum(), mu / US, var / (US * US), support)


# ----------------------------------------------------------------------------------------------------------------
# Public fitting functions


@dataclass(frozen=True)
class FitResult:
    """Output of :func:`fit_em`.

    model_ : the fitted mixture (seconds).
    log_likelihood_ : eq. (log-like) restricted to the data, with densities in 1/s.
    n_iter_, converged_ : iterations run and whether ``tol`` was reached.
    lower_bounds_ : (n_iter_ + 1,) the log-likelihood before each M-step and after the last (EM never lowers it).
    """

    model_: Mixture1D
    log_likelihood_: float
    n_iter_: int
    converged_: bool
    lower_bounds_: np.ndarray


def warn_not_converged(what: str, settings: EMSettings) -> None:
    """Warn :class:`ConvergenceWarning`: ``what`` reached ``settings.max_iter`` before its tolerance."""
    warnings.warn(
        f"{what} did not converge in {settings.max_iter} iterations; try a larger max_iter or a larger tol",
        ConvergenceWarning,
        stacklevel=3,
    )


def fit_em(
    x_s: object,
    init: Mixture1D,
    *,
    settings: EMSettings = EMSettings(),
    bin_width_s: float | None = None,
    update_means: bool = True,
    update_variances: bool = True,
    max_variance_s2: float = np.inf,
) -> FitResult:
    """Fit eq. (prob_model) to 1-D observations with the standard EM (section 4.1, eq. alpha_m and its M-step).

    x_s : (M,) float, seconds. init : the starting model (its support is kept). bin_width_s : None for the exact
    per-observation EM, or a bin width for the histogram engine (see module docstring).
    update_means, update_variances : False keeps those parameters at ``init``'s (the priors are always fitted);
    Algorithm 2 anchors its means at the mapped faces. Variances stay in [settings.var_floor_s2, max_variance_s2].
    Warns :class:`ConvergenceWarning` when ``settings.max_iter`` is reached first.
    """
    if not max_variance_s2 >= settings.var_floor_s2:
        raise ValueError(f"max_variance_s2 must be >= the variance floor {settings.var_floor_s2}, got {max_variance_s2}")
    x = as_samples(x_s, "x_s")
    offset = x.size * np.log(US)  # densities per second, as the paper writes them
    if init.n_components == 0 or x.size == 0:
        ll = init.log_likelihood(x)
        return FitResult(init, ll, 0, True, np.array([ll]))
    data = BinnedSamples.from_samples(x, bin_width_s)
    hist: list[np.ndarray] = []
    fitted, ll, n_iter, conv = run_em(
        data.x_us, data.stats, pack([init]), init.outlier_density / US, max_iter=settings.max_iter,
        tol=settings.tol, var_floor=settings.var_floor_s2 * US * US, min_wo=settings.min_outlier_weight, history=hist,
        updates=Updates(update_means, update_variances, max_variance_s2 * US * US),
    )
    if not conv[0]:
        warn_not_converged("EM", settings)
    bounds = np.array([h[0] for h in hist]) + offset
    return FitResult(unpack(fitted, 0, init.support), float(ll[0] + offset), int(n_iter[0]), bool(conv[0]), bounds)


@dataclass(frozen=True)
class FusionFit:
    """Output of :func:`fit_fusion_em`.

    model_ : the fitted mixture (seconds).
    beta_ : (K, N + 1) the auditory posteriors of eq. (beta_kn) (outlier last).
    log_likelihood_ : eq. (log-like) over both modalities, 1/s densities.
    objective_ : (n_iter_ + 1,) the constrained objective the fusion EM maximises (the expected complete-data
        log-likelihood of the visual data under the fixed alpha plus the auditory log-likelihood); it never
        decreases.
    """

    model_: Mixture1D
    beta_: np.ndarray
    log_likelihood_: float
    n_iter_: int
    converged_: bool
    objective_: np.ndarray


def fit_fusion_em(
    visual_s: object,
    alpha: object,
    itds_s: object,
    init: Mixture1D,
    *,
    settings: EMSettings = EMSettings(),
) -> FusionFit:
    """The vision-guided EM fusion of section 4.1 on projected visual features and ITDs.

    visual_s : (M,) float, seconds, the projected visual features v~_m.
    alpha : (M, N + 1) float, their posteriors from the visual EM (eq. alpha_m), held fixed.
    itds_s : (K,) float, seconds, the auditory features a_k.
    init : the starting model (typically the visual EM's result).
    """
    v = as_samples(visual_s, "visual_s")
    a = as_samples(itds_s, "itds_s")
    al = np.asarray(alpha, dtype=np.float64)
    n = init.n_components
    if al.shape != (v.size, n + 1):
        raise ValueError(f"alpha must have shape (M, N + 1) = ({v.size}, {n + 1}), got {al.shape}")
    if not np.all(np.isfinite(al)) or np.any(al < 0):
        raise ValueError("alpha must hold finite non-negative posteriors")
    if n == 0:
        model = init
        return FusionFit(model, np.ones((a.size, 1)), model.log_likelihood(v) + model.log_likelihood(a), 0, True,
                            np.array([model.log_likelihood(v) + model.log_likelihood(a)]))
    v_us = v * US
    sums = al.T @ np.stack([np.ones_like(v_us), v_us, v_us * v_us], axis=1)
    hist: list[np.ndarray] = []
    fused, n_iter, conv = run_fusion(
        sums[:-1], sums[-1:, 0], float(v.size), a * US, pack([init]), init.outlier_density / US,
        max_iter=settings.max_iter, tol=settings.tol, var_floor=settings.var_floor_s2 * US * US,
        min_wo=settings.min_outlier_weight, history=hist,
    )
    if not conv[0]:
        warn_not_converged("vision-guided EM fusion", settings)
    model = unpack(fused, 0, init.support)
    ll = model.log_likelihood(v) + model.log_likelihood(a)
    objective = np.array([h[0] for h in hist]) + (v.size + a.size) * np.log(US)
    return FusionFit(model, model.responsibilities(a), ll, int(n_iter[0]), bool(conv[0]), objective)


def bic_score(log_likelihood: float | np.ndarray, n_components: int | np.ndarray,
              n_observations: int) -> float | np.ndarray:
    """BIC of eq. (criteria): L - D_N log(M + K) / 2 with D_N = 3 N free parameters (a mean, a variance and a
    weight per person). Arrays of log-likelihoods and N score every candidate at once (Algorithm 1's step (d))."""
    ll = np.asarray(log_likelihood, dtype=np.float64)
    penalty = 1.5 * np.asarray(n_components, dtype=np.float64) * np.log(n_observations) if n_observations > 0 else 0.0
    score = ll - penalty
    return float(score) if score.ndim == 0 else score


# ----------------------------------------------------------------------------------------------------------------
# Initialisation from the previous interval (section 4.4, "Practical concerns")


def davies_bouldin(means: np.ndarray, stds: np.ndarray) -> np.ndarray:
    """DW_i = max_{j != i} (sigma_i + sigma_j) / |mu_i - mu_j| (section 4.4). One component: +inf."""
    mu = np.asarray(means, dtype=np.float64)
    sd = np.asarray(stds, dtype=np.float64)
    if mu.size < 2:
        return np.full(mu.size, np.inf)
    with np.errstate(divide="ignore"):
        ratio = (sd[:, None] + sd[None, :]) / np.abs(mu[:, None] - mu[None, :])
    np.fill_diagonal(ratio, -np.inf)
    return ratio.max(axis=1)


def split_at_mean(model: Mixture1D, index: int) -> Mixture1D:
    """Split component ``index`` at its mean into its two halves (section 4.4).

    Each half gets half the weight and the moments of a half-normal: mean mu +- sigma sqrt(2/pi), variance
    sigma^2 (1 - 2/pi).
    """
    sd = np.sqrt(model.variances[index])
    shift = sd * np.sqrt(2.0 / np.pi)
    var = model.variances[index] * (1.0 - 2.0 / np.pi)
    half = model.weights[index] / 2.0
    rest = np.arange(model.n_components) != index
    means = np.concatenate([model.means[rest], [model.means[index] - shift, model.means[index] + shift]])
    variances = np.concatenate([model.variances[rest], [var, var]])
    g = np.concatenate([model.weights[:-1][rest], [half, half]])
    return Mixture1D.unchecked(np.append(g, model.weights[-1]), means, variances, model.support)


def _seed_model(data: BinnedSamples, support: tuple[float, float], outlier_weight: float) -> Mixture1D:
    """A single broad component on the data's moments (used when there is no previous model)."""
    if data.total > 0:
        mean = data.stats[:, 1].sum() / data.total
        var = max(data.stats[:, 2].sum() / data.total - mean * mean, 1.0)
        mean_s, var_s = mean / US, var / (US * US)
    else:
        mean_s, var_s = 0.5 * (support[0] + support[1]), ((support[1] - support[0]) / 4.0) ** 2
    return Mixture1D(np.array([1.0 - outlier_weight, outlier_weight]), [mean_s], [var_s], support)


class _ResidualGrid:
    """The data's smoothed density on a 2 us grid over the support, computed once per interval."""

    STEP_S = 2e-6

    def __init__(self, data: BinnedSamples, support: tuple[float, float], sd_s: float) -> None:
        lo, hi = support
        self.grid = np.arange(lo, hi, self.STEP_S)
        self.sd_s = sd_s
        self.total = data.total
        step = self.STEP_S
        counts = np.bincount(np.clip(((data.x_us / US - lo) / step).astype(np.int64), 0, self.grid.size - 1),
                             weights=data.stats[:, 0], minlength=self.grid.size)
        half = int(np.ceil(4 * sd_s / step))
        k = np.exp(-0.5 * (np.arange(-half, half + 1) * step / sd_s) ** 2)
        self.smooth = np.convolve(counts, k / k.sum(), mode="same")  # counts per grid step

    def add_component(self, model: Mixture1D, density_on_grid: np.ndarray | None = None) -> Mixture1D | None:
        """``model`` plus a component where the data most exceed what it explains, or None if nowhere.

        The excess is the smoothed data histogram minus the model's expected counts; the new component sits at
        its largest value with variance ``sd_s^2`` and the excess's share of the data as weight (taken from the
        other classes in proportion). ``density_on_grid``: the model's density on ``self.grid``, if the caller
        has it.
        """
        if self.total <= 0:
            return None
        dens = model._density(self.grid) if density_on_grid is None else density_on_grid
        excess = self.smooth - dens * self.STEP_S * self.total
        i = int(np.argmax(excess))
        if excess[i] <= 0:
            return None
        width = self.sd_s / self.STEP_S * np.sqrt(2.0 * np.pi)  # grid steps under a Gaussian of unit peak
        weight = float(np.clip(excess[i] * width / self.total, 0.02, 0.5))
        weights = np.concatenate([model.weights[:-1] * (1.0 - weight), [weight], [model.weights[-1] * (1.0 - weight)]])
        return Mixture1D.unchecked(weights, np.append(model.means, self.grid[i]), np.append(model.variances, self.sd_s**2),
                         model.support)


def initial_models(
    previous: Mixture1D | None,
    n_max: int,
    support: tuple[float, float],
    data: BinnedSamples | None = None,
    *,
    outlier_weight: float = 0.1,
    grow_at_residual: bool = True,
) -> list[Mixture1D]:
    """Initial models for N = 0..n_max from the previous interval's model (section 4.4).

    For N <= N_prev: the N heaviest clusters of the previous model. For N > N_prev: split, one at a time, the
    cluster with the highest Davies-Bouldin index at its mean. With no previous model (or N_prev = 0) the first
    cluster is seeded on the moments of ``data``.

    ``grow_at_residual`` (avhear, beyond the paper): splitting only finds a newcomer next to a known cluster;
    someone who enters far from everybody else is never found, and the model stays stuck at N_prev. So each
    added component is either the split or a new component at the largest unexplained excess of the data
    (``_ResidualGrid.add_component``), whichever explains ``data`` better.
    """
    if n_max < 0:
        raise ValueError(f"n_max must be >= 0, got {n_max}")
    support = _check_support(support)
    if data is None:
        data = BinnedSamples.from_samples(np.empty(0))
    models = [Mixture1D.outliers_only(support)]
    base = _base_model(previous, data, support, outlier_weight)
    n_prev = base.n_components
    for n in range(1, min(n_prev, n_max) + 1):
        g = base.weights[:n]
        g = g * (1.0 - base.weights[-1]) / g.sum() if g.sum() > 0 else np.full(n, (1.0 - base.weights[-1]) / n)
        models.append(Mixture1D.unchecked(np.append(g, base.weights[-1]), base.means[:n], base.variances[:n], support))
    if n_max <= n_prev:
        return models
    return models + _grown(models[-1], n_max + 1 - len(models), data, grow_at_residual)


def _base_model(previous: Mixture1D | None, data: BinnedSamples, support: tuple[float, float],
                outlier_weight: float) -> Mixture1D:
    """The previous interval's model, heaviest cluster first, its outlier prior at least ``outlier_weight / 10``;
    with no previous cluster, one seeded on the moments of ``data``."""
    if previous is None or previous.n_components == 0:
        return _seed_model(data, support, outlier_weight)
    base = Mixture1D(previous.weights, previous.means, previous.variances, support).ordered_by_weight()
    if base.weights[-1] < outlier_weight / 10:
        g = base.weights[:-1] * (1.0 - outlier_weight / 10) / base.weights[:-1].sum()
        base = Mixture1D(np.append(g, outlier_weight / 10), base.means, base.variances, support)
    return base


def _split_change(prev: Mixture1D, idx: int, split: Mixture1D, z: np.ndarray) -> np.ndarray:
    """How splitting component ``idx`` of ``prev`` into ``split``'s last two changes the density at ``z``."""
    halves_mu, halves_var = split.means[-2:], split.variances[-1]
    return prev.weights[idx] * (0.5 * _gauss(z, halves_mu[0], halves_var) + 0.5 * _gauss(z, halves_mu[1], halves_var)
                                - _gauss(z, prev.means[idx], prev.variances[idx]))


def _grown(prev: Mixture1D, count: int, data: BinnedSamples, grow_at_residual: bool) -> list[Mixture1D]:
    """``count`` models, each with one component more than the one before, starting from ``prev``: the split of
    the component with the highest Davies-Bouldin index, or (``grow_at_residual``) a new component at the data's
    largest unexplained excess, whichever explains ``data`` better. The densities of the current model on the
    data bins and on the residual grid are updated incrementally (a split or an added component changes one or
    two terms)."""
    x = data.x_us / US
    cnt = data.stats[:, 0]
    residual = _ResidualGrid(data, prev.support, 15e-6) if grow_at_residual and data.total > 0 else None
    dens_x = prev._density(x)
    dens_g = prev._density(residual.grid) if residual is not None else None
    models = []
    for _ in range(count):
        db = davies_bouldin(prev.means, np.sqrt(prev.variances))
        # ties (e.g. two components) go to the widest component
        idx = int(np.lexsort((-prev.variances, -db))[0])
        split = split_at_mean(prev, idx)
        new, new_x = split, dens_x + _split_change(prev, idx, split, x)
        added = residual.add_component(prev, dens_g) if residual is not None else None
        if added is not None:
            w, mu, var = added.weights[-2], added.means[-1], added.variances[-1]
            added_x = (1.0 - w) * dens_x + w * _gauss(x, mu, var)
            if cnt @ np.log(added_x) > cnt @ np.log(new_x):
                new, new_x = added, added_x
                new_g = (1.0 - w) * dens_g + w * _gauss(residual.grid, mu, var)
            else:
                new_g = dens_g + _split_change(prev, idx, split, residual.grid)
        else:
            new_g = None
        models.append(new)
        prev, dens_x, dens_g = new, new_x, new_g
    return models


def _gauss(x: np.ndarray, mu: float, var: float) -> np.ndarray:
    return np.exp(-0.5 * np.minimum((x - mu) ** 2 / var, _Z2_CLIP)) / np.sqrt(2.0 * np.pi * var)


# ----------------------------------------------------------------------------------------------------------------
# Ridgeline merging (Ray and Lindsay 2005), section 4.4


def _is_unimodal_on_ridgeline(w1: float, m1: float, v1: float, w2: float, m2: float, v2: float,
                              n_grid: int = 257) -> bool:
    """Whether the two-component mixture has a single mode along its ridgeline.

    In one dimension the ridgeline x*(a) = [(1-a)/v1 + a/v2]^-1 [(1-a) m1/v1 + a m2/v2], a in [0, 1], runs
    monotonically from m1 to m2 and holds every critical point of the mixture (Ray and Lindsay 2005); the mixture
    is unimodal iff the elevation profile along it has a single local maximum.
    """
    a = np.linspace(0.0, 1.0, n_grid)
    prec = (1.0 - a) / v1 + a / v2
    x = ((1.0 - a) * m1 / v1 + a * m2 / v2) / prec
    h = w1 * np.exp(-0.5 * (x - m1) ** 2 / v1) / np.sqrt(v1) + w2 * np.exp(-0.5 * (x - m2) ** 2 / v2) / np.sqrt(v2)
    d = np.diff(h)
    d = d[np.abs(d) > 1e-12 * h.max()]
    if d.size == 0:
        return True
    # local maxima of the elevation profile, the ends included
    modes = np.count_nonzero((d[:-1] > 0) & (d[1:] < 0)) + int(d[0] < 0) + int(d[-1] > 0)
    return modes <= 1


def ridgeline_merge(model: Mixture1D) -> tuple[Mixture1D, list[list[int]]]:
    """Merge components whose two-component mixture is unimodal along the ridgeline (section 4.4).

    Components are visited in order of their means; neighbours are merged (by moment matching) while the pair is
    unimodal. Returns the merged model and, for each of its components, the indices of the original components
    it holds (so that the caller can add up their posteriors).
    """
    n = model.n_components
    if n < 2:
        return model, [[i] for i in range(n)]
    order = np.argsort(model.means, kind="stable")
    groups: list[list[int]] = [[int(order[0])]]
    w = [model.weights[order[0]]]
    mu = [model.means[order[0]]]
    var = [model.variances[order[0]]]
    for i in order[1:]:
        wi, mi, vi = model.weights[i], model.means[i], model.variances[i]
        if w[-1] > 0 and wi > 0 and _is_unimodal_on_ridgeline(w[-1], mu[-1] * US, var[-1] * US * US, wi, mi * US,
                                                               vi * US * US):
            tot = w[-1] + wi
            m = (w[-1] * mu[-1] + wi * mi) / tot
            second = (w[-1] * (var[-1] + mu[-1] ** 2) + wi * (vi + mi**2)) / tot
            w[-1], mu[-1], var[-1] = tot, m, max(second - m * m, min(var[-1], vi))
            groups[-1].append(int(i))
        else:
            groups.append([int(i)])
            w.append(wi)
            mu.append(mi)
            var.append(vi)
    merged = Mixture1D(np.append(w, model.weights[-1]), mu, var, model.support)
    return merged, groups


# ----------------------------------------------------------------------------------------------------------------
# Several microphone pairs: one ITD vector per window


@dataclass(frozen=True)
class PairsFit:
    """Output of :func:`fit_pairs_em`.

    weights : (N + 1,) priors, the outlier's last. means, variances : (N, P) seconds, s^2, per person and pair.
    beta : (K, N + 1) the posteriors of the K ITD vectors (eq. beta_kn with the joint density). n_iter, converged :
    as :class:`FitResult`.
    """

    weights: np.ndarray
    means: np.ndarray
    variances: np.ndarray
    beta: np.ndarray
    log_likelihood: float
    n_iter: int
    converged: bool


def fit_pairs_em(
    itds_s: np.ndarray,
    weights: np.ndarray,
    means_s: np.ndarray,
    variances_s2: np.ndarray,
    supports: np.ndarray,
    *,
    settings: EMSettings = EMSettings(),
    update_means: bool = True,
    update_variances: bool = True,
    max_variance_s2: float = np.inf,
) -> PairsFit:
    """EM for the model of eq. (prob_model) extended to P microphone pairs (the paper's conclusion).

    Each window gives one ITD per pair, a vector a_k = (a_k1 .. a_kP), all from the one source that dominates the
    window. Person n maps to one ITD per pair, mu_n = (mu_n1 .. mu_nP) (eq. itd_up per pair), so

        p(a_k; Theta) = sum_n pi_n prod_p N(a_kp; mu_np, sigma_np^2) + pi_{N+1} prod_p U(a_kp; A_p),

    and the posterior beta_kn of eq. (beta_kn) takes the product over the pairs: a vector is a person's only when
    it is near that person on every pair, so a peak that falls between two talkers on one pair (a phantom) is not
    explained on the others and goes to the outlier class. A pair the window has no ITD for (NaN, its energy gate)
    leaves the product. The M-step is the paper's per pair: pi_n = gamma_n / K, and mu_np, sigma_np^2 the
    beta-weighted moments over the vectors that have pair p; ``update_means`` / ``update_variances`` False keep them
    (Algorithm 2's anchored means), variances in ``[settings.var_floor_s2, max_variance_s2]``, the outlier prior at
    least ``settings.min_outlier_weight``. With P = 1 this is :func:`fit_em`.

    itds_s : (K, P) seconds, NaN where a pair has no ITD. weights : (N + 1,). means_s, variances_s2 : (N, P).
    supports : (P, 2) each pair's ITD interval.
    """
    x = np.asarray(itds_s, dtype=np.float64)
    mu = np.asarray(means_s, dtype=np.float64)
    var = np.asarray(variances_s2, dtype=np.float64)
    w = np.asarray(weights, dtype=np.float64)
    sup = np.asarray(supports, dtype=np.float64).reshape(-1, 2)
    if x.ndim != 2 or mu.ndim != 2 or x.shape[1] != mu.shape[1] or var.shape != mu.shape or sup.shape[0] != mu.shape[1]:
        raise ValueError(f"need itds (K, P), means and variances (N, P), supports (P, 2); got {x.shape}, {mu.shape}, "
                         f"{var.shape}, {sup.shape}")
    if w.shape != (mu.shape[0] + 1,):
        raise ValueError(f"weights must have N + 1 = {mu.shape[0] + 1} entries, got {w.shape}")
    k, n = x.shape[0], mu.shape[0]
    if k == 0 or n == 0:
        return PairsFit(w, mu, var, np.ones((k, 1)) if n == 0 else np.zeros((k, w.size)), 0.0, 0, True)
    # the engine of Algorithm 1 (avcore._packed_em, microseconds) with one model and vectors; vectors of one pair
    # that all have it are values, the engine's cheaper form of the same sums
    seen = np.isfinite(x)
    p = x.shape[1]
    x_us = x * US
    u = 1.0 / ((sup[:, 1] - sup[:, 0]) * US)
    start = Packed(np.array([n]), w[:-1], mu * US, var * US * US, w[-1:])
    if p == 1 and seen.all():
        x_us, u = x_us[:, 0], float(u[0])
        start.mu, start.var = start.mu[:, 0], start.var[:, 0]
        stats = np.stack([np.ones(k), x_us, x_us * x_us], axis=1)
    else:
        xs = np.where(seen, x_us, 0.0)
        stats = np.stack([seen.astype(np.float64), xs, xs * xs], axis=2)
    last: list[np.ndarray] = []
    fit, ll_us, n_iter, converged = run_em(
        x_us, stats, start, u, max_iter=settings.max_iter, tol=settings.tol,
        var_floor=settings.var_floor_s2 * US * US, min_wo=settings.min_outlier_weight,
        updates=Updates(update_means, update_variances, max_variance_s2 * US * US), last=last)
    dens, dens_o, total = last  # the posteriors of the parameters returned
    beta = np.empty((k, n + 1))
    beta[:, :n], beta[:, n:] = dens, dens_o
    beta /= total
    ll = float(ll_us[0]) + float(seen.sum()) * np.log(US)  # the last E-step's, in 1/s densities
    weights_out = np.append(fit.wg, fit.wo)
    return PairsFit(weights_out / weights_out.sum(), fit.mu.reshape(n, p) / US, fit.var.reshape(n, p) / (US * US),
                    beta, ll, int(n_iter[0]), bool(converged[0]))
