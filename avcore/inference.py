"""Multimodal inference: Motion-Guided (Algorithm 1) and Face-Guided (Algorithm 2) Robot Hearing.

Both classes keep the paper's method selectable (``Params.paper()``) beside avhear's default, which adds what the
paper's own evaluation showed missing (section 7.1), each measured by ``avhear eval synthetic``:

* a newcomer far from every known cluster is found (``initial_models(grow_at_residual=True)``);
* each 1-D cluster is refined in 3D (:mod:`avcore.refine3d`): people who cross in ITD space are split, 3D outliers
  on the cluster's hyperboloid no longer pull its position, clusters of projected outliers (no compact 3D group)
  are dropped, pieces of one person are merged (``refine_3d``);
* the speaking test asks for more ITDs near a person than stray ITDs would put there by chance, instead of
  tau_A = K / (N + 2) (:class:`avcore.speaking.SpeakingTest`);
* Algorithm 2 keeps its means anchored at the faces (``FaceGuidedParams.anchor_means``).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from avcore._packed_em import Packed, class_sums, log_likelihoods, run_em, run_fusion
from avcore._validate import as_points, as_samples
from avcore.geometry import MicArray, MicPair
from avcore.mixture import (
    US,
    BinnedSamples,
    EMSettings,
    Mixture1D,
    bic_score,
    fit_pairs_em,
    initial_models,
    pack,
    ridgeline_merge,
    unpack,
    warn_not_converged,
)
from avcore.refine3d import (
    Group3D,
    compact_groups,
    group_from_members,
    held_bodies,
    merge_close,
    merge_within_width,
)
from avcore.itd.pairs import FrameBins
from avcore.speaking import SpeakingTest, bin_shares, speaking_threshold

__all__ = [
    "FaceGuidedHearing",
    "FaceGuidedOutput",
    "FaceGuidedParams",
    "MotionGuidedHearing",
    "MotionGuidedOutput",
    "MotionGuidedParams",
    "SpeakingTest",
    "speaking_threshold",
]

# ----------------------------------------------------------------------------------------------------------------
# Motion-Guided Robot Hearing (Algorithm 1)


@dataclass(frozen=True)
class MotionGuidedParams:
    """Parameters of :class:`MotionGuidedHearing`. Numbers the paper gives are its values.

    n_max : N_max = 10 (section 4.4).
    em : iterations, tolerance, variance floor and outlier floor of both EMs.
    bin_width_s : width of the histogram bins of the projected points (2 us; sigmas are tens of us).
    init_outlier_weight : outlier prior of a model seeded without a previous interval.
    min_det_m6 : the paper's spurious-cluster test: drop clusters whose 3D covariance (eq. hat_svect) has a
        determinant below this, m^6 (points on a thin sheet near a hyperboloid). A person-sized blob
        (sd 0.1 x 0.2 x 0.05 m) has about 1e-6; 1e-9 only removes sheets.
    merge_ridgeline : merge components that are unimodal along the ridgeline (section 4.4).
    speaking : the speaking test (:class:`SpeakingTest`); the paper's variant uses beta_bar > tau_A alone.
    refine_3d : replace the alpha-weighted moments of eq. (hat_svect) by compact 3D groups inside each cluster
        (:mod:`avcore.refine3d`): splits people who share a 1-D cluster, ignores 3D outliers on the cluster's
        hyperboloid, and drops clusters with no compact group of at least ``min_points`` points.
    kernel_sd_m : the person-sized kernel of the 3D refinement (x, y, z standard deviations, metres).
    max_sd_m : a 3D group wider than this along any axis is not a person.
    merge_distance_m : 3D groups closer than this are one person (a blob cut into two 1-D clusters).
    merge_vertical_m : the same along the vertical: a body's moving parts (head, hands, legs) are stacked, so
        groups this far apart vertically (and aligned horizontally) are one person.
    merge_reach_per_m : the horizontal merge distance grows by this much per metre that one group lies below the
        other (``avcore.refine3d.merge_close``'s ``reach_per_m``): a gesturing hand is found beside and below its head.
    body_width_m : if set, groups at about one height whose points together span no more than this (between their
        5th and 95th percentiles) are one person (``avcore.refine3d.merge_within_width``): a body moving at both
        its sides (swaying, both hands gesturing) gives two strips a torso apart that ``merge_distance_m`` keeps.
    body_radius_m : if set, an object's position is the alpha-weighted mean of its clusters' points within this
        horizontal radius (and ``merge_vertical_m`` vertically) of its groups, not the groups' mean alone.
    body_keeps_groups : with ``body_radius_m``, the body's points are the union of its groups' members and its
        clusters' points in that cylinder (each point with the larger of its two weights), so that the parts of a
        group outside the cylinder (a swinging arm, a walker smeared along its path) still count. False: the
        cylinder's points alone, or the groups' members alone when they weigh more.
    warm_start_candidates : for every N, start EM from the better (on the new data) of the paper's initialisation
        and the previous interval's fit with N components: people move little between intervals, so EM needs
        fewer iterations (a speed-up; the paper initialises every N from the selected model only). The fit can
        differ too: EM from another start may end at another optimum, and BIC may then pick another N.
    hold_radius_m, hold_share : with ``refine_3d``, a person of the previous interval that this one lost is kept
        where a vertical cylinder of this radius around them holds ``hold_share`` of the points they had when last
        found (:func:`avcore.refine3d.held_bodies`, which says what else it asks). None: each interval decides alone.
    """

    n_max: int = 10
    em: EMSettings = field(default_factory=EMSettings)
    bin_width_s: float = 2e-6
    init_outlier_weight: float = 0.1
    min_det_m6: float = 1e-9
    merge_ridgeline: bool = True
    speaking: SpeakingTest = field(default_factory=SpeakingTest)
    refine_3d: bool = True
    kernel_sd_m: tuple[float, float, float] = (0.10, 0.20, 0.10)
    min_points: float = 15.0
    max_sd_m: float = 0.6
    merge_distance_m: float = 0.3
    merge_vertical_m: float = 1.2
    merge_reach_per_m: float = 0.3
    body_width_m: float | None = 0.6
    body_radius_m: float | None = 0.3
    body_keeps_groups: bool = True
    warm_start_candidates: bool = True
    hold_radius_m: float | None = 0.3
    hold_share: float = 0.5

    def __post_init__(self) -> None:
        if not 0 <= self.n_max <= 50:
            raise ValueError(f"n_max must be in 0..50, got {self.n_max}")
        if not self.bin_width_s > 0:
            raise ValueError(f"bin_width_s must be > 0 seconds, got {self.bin_width_s}")
        if not (self.merge_distance_m > 0 and self.merge_vertical_m > 0):
            raise ValueError(f"merge_distance_m and merge_vertical_m must be > 0 metres, got "
                             f"{self.merge_distance_m}, {self.merge_vertical_m}")
        if not self.merge_reach_per_m >= 0:
            raise ValueError(f"merge_reach_per_m must be >= 0, got {self.merge_reach_per_m}")
        if self.body_width_m is not None and not self.body_width_m > 0:
            raise ValueError(f"body_width_m must be None or > 0 metres, got {self.body_width_m}")
        if self.body_radius_m is not None and not self.body_radius_m > 0:
            raise ValueError(f"body_radius_m must be None or > 0 metres, got {self.body_radius_m}")
        if self.hold_radius_m is not None and not self.hold_radius_m > 0:
            raise ValueError(f"hold_radius_m must be None or > 0 metres, got {self.hold_radius_m}")
        if not 0 <= self.hold_share <= 1:
            raise ValueError(f"hold_share must be in [0, 1], got {self.hold_share}")
        if not isinstance(self.body_keeps_groups, bool):
            raise TypeError(f"body_keeps_groups must be a bool, got {type(self.body_keeps_groups).__name__}")

    @classmethod
    def paper(cls) -> MotionGuidedParams:
        """The method as the paper describes it: moments of eq. (hat_svect), determinant test, tau_A = K/(N+2)."""
        return cls(speaking=SpeakingTest(outlier_aware=False), refine_3d=False, warm_start_candidates=False,
                   hold_radius_m=None)


@dataclass(frozen=True)
class MotionGuidedOutput:
    """Result of one interval of Algorithm 1.

    positions : (N, 3) float, metres - eq. (hat_svect).
    covariances : (N, 3, 3) float, m^2 - the back-projected covariances (second eq. hat_svect).
    speaking : (N,) bool - eq. (audio_act).
    probability : (N,) float in [0, 1], beta_bar / (beta_bar + threshold): above 0.5 exactly when speaking.
    itd_means : (N,) float, seconds - each person's mean in ITD space.
    itd_counts : (N,) float - beta_bar_n, the ITDs assigned to each person.
    point_counts : (N,) float - alpha_bar_n, the projected points assigned to each person.
    model : the selected 1-D model after post-processing (for display).
    bic : (n_max + 1,) the BIC of every candidate N (eq. criteria); ``n_selected`` its argmax.
    tau_a : the paper's threshold K / (N + 2) for this interval.
    """

    positions: np.ndarray
    covariances: np.ndarray
    speaking: np.ndarray
    probability: np.ndarray
    itd_means: np.ndarray
    itd_counts: np.ndarray
    point_counts: np.ndarray
    model: Mixture1D
    bic: np.ndarray
    n_selected: int
    tau_a: float

    @property
    def n(self) -> int:
        return int(self.positions.shape[0])


def _weighted_moments(points: np.ndarray, alpha: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eq. (hat_svect): alpha-weighted means (N, 3) and covariances (N, 3, 3), and alpha_bar (N,)."""
    abar = alpha.sum(axis=0)
    safe = np.where(abar > 0, abar, 1.0)
    means = (alpha.T @ points) / safe[:, None]
    second = np.einsum("mn,mi,mj->nij", alpha, points, points, optimize=True) / safe[:, None, None]
    cov = second - means[:, :, None] * means[:, None, :]
    return means, cov, abar


def _choose(a: Packed, b: Packed, take_b: np.ndarray) -> Packed:
    """Per model, ``b``'s parameters where ``take_b`` else ``a``'s (two batches with the same sizes)."""
    slot_b = np.repeat(take_b, a.sizes)
    return Packed(a.sizes.copy(), np.where(slot_b, b.wg, a.wg), np.where(slot_b, b.mu, a.mu),
                  np.where(slot_b, b.var, a.var), np.where(take_b, b.wo, a.wo))


class MotionGuidedHearing:
    """Motion-Guided Robot Hearing, the paper's Algorithm 1 (section 4.5).

    ``step(points, itds)`` takes the HM3D points and the ITDs of one interval Delta t and returns the number of
    AV objects, their 3D positions and covariances, and their speaking states. The model of the previous interval
    initialises the next (section 4.4); ``reset()`` forgets it.
    """

    def __init__(self, mics: MicPair | MicArray, params: MotionGuidedParams | None = None) -> None:
        self.array = _as_array(mics)
        self.mics = self.array.pair(0)
        self.params = params if params is not None else MotionGuidedParams()
        # the people are found and located on the first pair (the paper's Algorithm 1); with several pairs, who
        # speaks is decided on every pair by the model of avcore.mixture.fit_pairs_em anchored at their positions
        self._pairs = (FaceGuidedHearing(self.array, FaceGuidedParams(speaking=self.params.speaking))
                       if self.array.n_pairs > 1 else None)
        self.support = self.mics.itd_interval()
        self.previous_: Mixture1D | None = None
        self._candidates: Packed | None = None
        self._people: tuple[np.ndarray, np.ndarray] | None = None

    def reset(self) -> None:
        """Forget the previous interval."""
        self.previous_ = None
        self._candidates = None
        self._people = None

    def _empty_output(self, bic: np.ndarray, n_sel: int, tau: float) -> MotionGuidedOutput:
        return MotionGuidedOutput(np.empty((0, 3)), np.empty((0, 3, 3)), np.empty(0, dtype=bool), np.empty(0),
                                  np.empty(0), np.empty(0), np.empty(0), Mixture1D.outliers_only(self.support),
                                  bic, n_sel, tau)

    def fit_candidates(self, v_s: np.ndarray, a_s: np.ndarray) -> tuple[list[Mixture1D], list[Mixture1D], np.ndarray]:
        """Steps (a)-(d) of Algorithm 1 for every N = 0..n_max at once.

        v_s : (M,) projected visual features, seconds; a_s : (K,) ITDs, seconds. Returns the visual EM models,
        the fused models and the BIC of each candidate (index = N).
        """
        inits, vis, fused, bic = self._fit(v_s, a_s)
        n = len(inits)
        return ([inits[0]] + [unpack(vis, c, self.support) for c in range(n - 1)],
                [inits[0]] + [unpack(fused, c, self.support) for c in range(n - 1)], bic)

    def _fit(self, v_s: np.ndarray, a_s: np.ndarray) -> tuple[list[Mixture1D], Packed | None, Packed | None,
                                                                np.ndarray]:
        """The batched work of :meth:`fit_candidates`; the models stay packed (only the chosen one is unpacked)."""
        p = self.params
        em = p.em
        data = BinnedSamples.from_samples(v_s, p.bin_width_s)
        inits = initial_models(self.previous_, p.n_max, self.support, data, outlier_weight=p.init_outlier_weight)
        n_obs = v_s.size + a_s.size
        u = 1.0 / ((self.support[1] - self.support[0]) * US)
        start = pack(inits[1:]) if p.n_max else None
        if p.warm_start_candidates and self._candidates is not None and data.total > 0:
            # per N, start from the better of the paper's initialisation and last interval's fit with N components
            ll_new = log_likelihoods(data.x_us, data.stats[:, 0], start, u)
            ll_old = log_likelihoods(data.x_us, data.stats[:, 0], self._candidates, u)
            start = _choose(start, self._candidates, ll_old > ll_new)
        ll0 = n_obs * np.log(1.0 / (self.support[1] - self.support[0]))  # N = 0: all outliers
        if p.n_max == 0:
            return inits, None, None, np.array([ll0])
        kw = dict(tol=em.tol, var_floor=em.var_floor_s2 * US * US, min_wo=em.min_outlier_weight,
                  max_iter=em.max_iter)
        # (a) initial models, (b) standard EM on the projected visual data: all candidates in one batch
        vis, _, _, _ = run_em(data.x_us, data.stats, start, u, **kw)
        self._candidates = vis
        # alpha is fixed from here on; the fusion EM needs it only as per-class sums
        vis_g, vis_o = class_sums(data.x_us, data.stats, vis, u)
        # (c) vision-guided EM fusion on the ITDs
        a_us = a_s * US
        fused, _, _ = run_fusion(vis_g, vis_o, data.total, a_us, vis, u, **kw)
        # (d) BIC (eq. criteria) from the log-likelihood of eq. (log-like) over both modalities, 1/s densities
        ll = log_likelihoods(data.x_us, data.stats[:, 0], fused, u)
        ll += log_likelihoods(a_us, np.ones(a_us.size), fused, u) + n_obs * np.log(US)
        bic = bic_score(np.append(ll0, ll), np.arange(p.n_max + 1), n_obs)
        return inits, vis, fused, bic

    def step(self, points_xyz: object, itds_s: object) -> MotionGuidedOutput:
        """One interval of Algorithm 1.

        points_xyz : (M, 3) float, metres, HM3D points in the scene frame.
        itds_s : (K, P) float, seconds, one vector per window, or P arrays; (K,) with one pair (as
            :meth:`FaceGuidedHearing.step`).
        """
        pts = as_points(points_xyz, "points_xyz")
        vectors = _itd_vectors(itds_s, self.array.n_pairs, "itds_s")
        first = vectors[:, 0]
        out = self._step(pts, first[np.isfinite(first)])
        if self._pairs is None or out.positions.shape[0] == 0:
            return out
        pairs = self._pairs.step(out.positions, vectors)
        return replace(out, speaking=pairs.speaking, probability=pairs.probability)

    def _step(self, pts: np.ndarray, a: np.ndarray) -> MotionGuidedOutput:
        """:meth:`step` on checked points and one pair's ITDs."""
        p = self.params
        v = self.mics.itd(pts)
        if pts.shape[0] == 0:
            # Nothing to see: no AV object can be formed (the model is vision-guided).
            self.reset()
            return self._empty_output(np.zeros(p.n_max + 1), 0, speaking_threshold(a.size, 0))
        inits, vis_batch, fused_batch, bic = self._fit(v, a)
        n_sel = int(np.argmax(bic))
        if n_sel == 0:
            vis = model = inits[0]
        else:
            vis, model = unpack(vis_batch, n_sel - 1, self.support), unpack(fused_batch, n_sel - 1, self.support)
        # Post-processing (section 4.4) on exact per-point posteriors of the selected model.
        alpha = vis.responsibilities(v)[:, :-1]
        beta = model.responsibilities(a)[:, :-1] if a.size else np.zeros((0, n_sel))
        if p.merge_ridgeline and n_sel > 1:
            model, groups = ridgeline_merge(model)
            alpha = np.stack([alpha[:, g].sum(axis=1) for g in groups], axis=1)
            beta = np.stack([beta[:, g].sum(axis=1) for g in groups], axis=1).reshape(a.size, len(groups))
        if p.refine_3d:
            positions, cov, abar, beta, model = self._refine(pts, v, a, alpha, beta, model)
            mass = abar
            if p.hold_radius_m is not None and self._people is not None:
                positions, cov, abar, beta, model, mass = self._hold(pts, v, a, positions, cov, abar, beta, model)
            self._people = (positions, mass)
        else:
            positions, cov, abar = _weighted_moments(pts, alpha)
            keep = (abar > 1e-9) & (np.linalg.det(cov) >= p.min_det_m6) if model.n_components else abar > 0
            model = self._keep(model, keep)
            positions, cov, abar, beta = positions[keep], cov[keep], abar[keep], beta[:, keep]
        self.previous_ = model
        bbar = beta.sum(axis=0)
        speaking, prob, tau = p.speaking.decide(beta, a[:, None], model.means[:, None], model.variances[:, None],
                                                np.array([self.support]))
        return MotionGuidedOutput(positions, cov, speaking, prob, model.means.copy(), bbar, abar, model, bic, n_sel,
                                  tau)

    def _hold(self, pts: np.ndarray, v: np.ndarray, a: np.ndarray, positions: np.ndarray, cov: np.ndarray,
              abar: np.ndarray, beta: np.ndarray, model: Mixture1D
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Mixture1D, np.ndarray]:
        """The previous interval's people this one lost, kept where their bodies still hold points (``hold_radius_m``).

        Each person held is placed at the mean of the points of its cylinder (eq. hat_svect on the body) and gets a
        1-D component from their projections, weighted by their share of the points; its ITD posteriors are those of
        the model with that component (the other people's stay as the fit gave them). Returns the arguments with
        the people held appended, and every person's mass for the next interval's hold: a person held keeps the
        mass they had when last found, so that holding cannot wear it down to what a few outliers reach.
        """
        p = self.params
        held = held_bodies(pts, *self._people, positions, radius_m=p.hold_radius_m, half_height_m=p.merge_vertical_m,
                           match_m=2 * p.hold_radius_m, min_points=p.min_points, min_share=p.hold_share,
                           merge=(p.merge_distance_m, p.merge_vertical_m, p.merge_reach_per_m))
        if not held:
            return positions, cov, abar, beta, model, abar
        # the cylinder's points as they are (group_from_members expects a chi-square cut and corrects for it)
        groups = [Group3D(m.astype(np.float64), float(m.sum()), pts[m].mean(axis=0), np.cov(pts[m].T, bias=True))
                  for _, m in held]
        m1 = np.array([v[m].mean() for _, m in held])
        s2 = np.array([max(v[m].var(), p.em.var_floor_s2) for _, m in held])
        w = np.append(model.weights[:-1], [g.mass / pts.shape[0] for g in groups])
        w = w * min(1.0, (1.0 - p.em.min_outlier_weight) / w.sum())
        model = Mixture1D(np.append(w, 1.0 - w.sum()), np.append(model.means, m1), np.append(model.variances, s2),
                          self.support)
        n = positions.shape[0]
        beta = np.concatenate([beta, model.responsibilities(a)[:, n:-1]], axis=1) if a.size else \
            np.zeros((0, n + len(held)))
        return (np.concatenate([positions, [g.mean for g in groups]]), np.concatenate([cov, [g.cov for g in groups]]),
                np.append(abar, [g.mass for g in groups]), beta, model,
                np.append(abar, [self._people[1][i] for i, _ in held]))

    def _keep(self, model: Mixture1D, keep: np.ndarray) -> Mixture1D:
        """The model restricted to the kept components; the weight of dropped ones goes to the outlier class."""
        g = model.weights[:-1][keep]
        return Mixture1D(np.append(g, 1.0 - g.sum()), model.means[keep], model.variances[keep], self.support)

    def _body(self, pts: np.ndarray, w: np.ndarray, g: Group3D) -> Group3D:
        """The object's position from all its clusters' points in a body-sized cylinder around its groups.

        Eq. (hat_svect) restricted to the person's body. Compact groups hold the densest moving parts (a head, a
        hand); the rest of the body (sleeves, shoulders, a torso) gives sparser points that no group takes. Their
        alpha-weighted mean inside a vertical cylinder of radius ``body_radius_m`` and half-height
        ``merge_vertical_m`` around the groups is the body's centre. With ``body_keeps_groups`` the groups' members
        count as well where they reach outside the cylinder (each point weighs the larger of its membership and
        its cylinder weight): neither set alone is the whole body.
        """
        p = self.params
        d = pts - g.mean
        inside = (np.hypot(d[:, 0], d[:, 2]) < p.body_radius_m) & (np.abs(d[:, 1]) < p.merge_vertical_m)
        ww = w * inside
        if p.body_keeps_groups:
            ww = np.maximum(ww, g.members)
        elif ww.sum() <= g.mass:
            return g
        return Group3D(g.members, g.mass, (ww @ pts) / ww.sum(), g.cov)

    def _refine(self, pts: np.ndarray, v: np.ndarray, a: np.ndarray, alpha: np.ndarray, beta: np.ndarray,
                model: Mixture1D) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, Mixture1D]:
        """Compact 3D groups of every 1-D cluster (:mod:`avcore.refine3d`) become the AV objects.

        The cluster's ITD posteriors are shared among its groups by the groups' 1-D densities; groups closer than
        ``merge_distance_m`` (``merge_vertical_m`` along the vertical) are one person, placed at its body's centre
        (:meth:`_body`) when ``body_radius_m`` is set. Each object gets its own 1-D component (the moments of its projected
        points), kept for the next interval.
        """
        p = self.params
        groups, betas, weights, sources = [], [], [], []
        for n in range(model.n_components):
            found = compact_groups(pts, alpha[:, n], kernel_sd_m=p.kernel_sd_m, min_mass=p.min_points,
                                   max_sd_m=p.max_sd_m)
            if not found:
                continue
            if len(found) == 1:
                share = np.ones((a.size, 1))
            else:
                dens = []
                for g in found:
                    m1 = (g.members @ v) / g.mass
                    s2 = max((g.members @ (v - m1) ** 2) / g.mass, p.em.var_floor_s2)
                    dens.append(g.mass / np.sqrt(s2) * np.exp(-0.5 * (a - m1) ** 2 / s2))
                dens = np.stack(dens, axis=1).reshape(a.size, len(found))
                share = dens / np.maximum(dens.sum(axis=1, keepdims=True), 1e-300)
            total = alpha[:, n].sum()
            for j, g in enumerate(found):
                groups.append(g)
                sources.append(n)
                betas.append(beta[:, n] * share[:, j])
                weights.append(model.weights[n] * g.mass / total)
        if not groups:
            return (np.empty((0, 3)), np.empty((0, 3, 3)), np.empty(0), np.zeros((a.size, 0)),
                    Mixture1D.outliers_only(self.support))

        def merged(idx: list[int]) -> Group3D:
            g = groups[idx[0]] if len(idx) == 1 else group_from_members(pts, sum(groups[i].members for i in idx))
            if p.body_radius_m is not None:
                g = self._body(pts, alpha[:, sorted({sources[i] for i in idx})].sum(axis=1), g)
            return g

        def close(parts: list[Group3D]) -> list[list[int]]:
            found = merge_close(parts, pts, p.merge_distance_m, p.merge_vertical_m, p.merge_reach_per_m)
            return found if p.body_width_m is None else merge_within_width(parts, pts, found, p.body_width_m)

        clusters = close(groups)
        bodies = [merged(c) for c in clusters]
        if p.body_radius_m is not None and len(clusters) > 1:
            # body centres of a person's merged parts can be closer than the parts were: merge once more on them
            again = close(bodies)
            bodies = [bodies[c[0]] if len(c) == 1 else merged(sum((clusters[i] for i in c), [])) for c in again]
            clusters = [sum((clusters[i] for i in c), []) for c in again]
        objects = []
        for idx, g in zip(clusters, bodies):
            m1 = (g.members @ v) / g.mass
            s2 = max((g.members @ (v - m1) ** 2) / g.mass, p.em.var_floor_s2)
            objects.append((g, sum(betas[i] for i in idx), sum(weights[i] for i in idx), m1, s2))
        w = np.array([o[2] for o in objects])
        new_model = Mixture1D(np.append(w, 1.0 - w.sum()), [o[3] for o in objects], [o[4] for o in objects],
                              self.support)
        return (np.array([o[0].mean for o in objects]), np.array([o[0].cov for o in objects]),
                np.array([o[0].mass for o in objects]), np.stack([o[1] for o in objects], axis=1).reshape(a.size, len(objects)),
                new_model)


# ----------------------------------------------------------------------------------------------------------------
# Face-Guided Robot Hearing (Algorithm 2)


@dataclass(frozen=True)
class FaceGuidedParams:
    """Parameters of :class:`FaceGuidedHearing`.

    sigma2_init_s2 : 1e-9 s^2, the paper's initial variance (section 6, implementation details).
    anchor_means : keep each mean at its mapped face (the paper initialises there and leaves open whether they
        move). Anchored means cannot be pulled away by a talker the cameras do not see; free means follow the
        ITDs (the paper's EM as written).
    update_variances : let EM adapt each variance within ``[var_min_s2, var_max_s2]``.
    init_outlier_weight : the outlier prior before EM.
    em : iterations, tolerance.
    speaking : the speaking test (:class:`SpeakingTest`, each ITD counted for the nearest face); the paper's
        variant uses beta_bar > tau_A alone.
    decision_window_s : when :meth:`FaceGuidedHearing.step` is given the ITDs' times, the speaking test counts
        only the ITDs whose windows are centred within +- this of the frame's stamp, while EM fits on all the ITDs
        of the time frame. The paper decides on the whole time frame (the pipeline's +-0.2 s), which stretches
        each speaking state into the pauses around it; None (the default): the paper's way. A shorter window
        trades misses for false alarms rather than removing either (docs/experiments.md, "The decision window").
    """

    sigma2_init_s2: float = 1e-9
    anchor_means: bool = True
    update_variances: bool = False
    var_min_s2: float = 1e-10
    var_max_s2: float = 4e-9
    init_outlier_weight: float = 0.2
    em: EMSettings = field(default_factory=lambda: EMSettings(max_iter=50, tol=1e-4))
    speaking: SpeakingTest = field(default_factory=lambda: SpeakingTest(count_by="nearest"))
    decision_window_s: float | None = None

    def __post_init__(self) -> None:
        if self.decision_window_s is not None and not self.decision_window_s > 0:
            raise ValueError(f"decision_window_s must be > 0 s or None, got {self.decision_window_s!r}")
        if not self.sigma2_init_s2 > 0:
            raise ValueError(f"sigma2_init_s2 must be > 0 s^2, got {self.sigma2_init_s2}")
        if not 0 < self.var_min_s2 <= self.var_max_s2:
            raise ValueError("need 0 < var_min_s2 <= var_max_s2")
        if not 0 < self.init_outlier_weight < 1:
            raise ValueError(f"init_outlier_weight must be in (0, 1), got {self.init_outlier_weight}")

    @classmethod
    def for_array(cls, mics: MicPair | MicArray) -> FaceGuidedParams:
        """The defaults, with the speaking test's thresholds chosen for the microphones' geometry when they are
        one of the presets (:meth:`SpeakingTest.for_array`)."""
        params = cls()
        return replace(params, speaking=params.speaking.for_array(_as_array(mics)))

    @classmethod
    def paper(cls) -> FaceGuidedParams:
        """Algorithm 2 as written: means start at the faces and move with EM, variances adapt, tau_A = K/(N+2)."""
        return cls(anchor_means=False, update_variances=True, var_min_s2=EMSettings().var_floor_s2,
                   var_max_s2=1.0, speaking=SpeakingTest(outlier_aware=False))


@dataclass(frozen=True)
class FaceGuidedOutput:
    """Result of one interval of Algorithm 2.

    speaking : (N,) bool, eq. (audio_act). probability : (N,) in [0, 1], above 0.5 exactly when speaking.
    itd_means : (N,) seconds. itd_counts : (N,) beta_bar_n. model : the fitted 1-D model (for display).
    tau_a : K / (N + 2). n_iter : EM iterations run.
    pair_itd_means : (N, P) seconds, each person's mean on each pair (``itd_means`` and ``model`` are the first
    pair's); None only in outputs built by hand.
    rescued : (N,) bool, the calls only the speaking test's later looks made
    (:meth:`avcore.speaking.SpeakingTest.decide_all`, for :class:`avcore.speaking.RescueContinuity`); None: none.
    bin_share : (N,) each person's share of the frames' bins (:func:`avcore.speaking.bin_shares`, for
    :class:`avcore.bin_spill.BinSpill`); None: the bins were not looked at.
    """

    speaking: np.ndarray
    probability: np.ndarray
    itd_means: np.ndarray
    itd_counts: np.ndarray
    model: Mixture1D
    tau_a: float
    n_iter: int
    pair_itd_means: np.ndarray | None = None
    rescued: np.ndarray | None = None
    bin_share: np.ndarray | None = None


def _as_array(mics: object) -> MicArray:
    """The hearing's microphones as an array: a :class:`MicPair` is an array of one pair."""
    if isinstance(mics, MicArray):
        return mics
    if isinstance(mics, MicPair):
        return MicArray.from_pair(mics)
    raise TypeError(f"mics must be a MicPair or a MicArray, got {type(mics).__name__}")


def _itd_vectors(itds: object, n_pairs: int, name: str) -> np.ndarray:
    """ITDs as (K, P) vectors, NaN where a pair has none: a (K, P) array is one vector per window (the pairs' ITDs
    of one window, aligned); a sequence of P one-dimensional arrays gives each value alone (its pair only: not
    aligned); with one pair, (K,) values are its column."""
    if n_pairs == 1 and np.ndim(itds) == 1:  # type: ignore[arg-type]
        return as_samples(itds, name)[:, None]
    if isinstance(itds, np.ndarray) and itds.ndim == 2:
        if itds.shape[1] != n_pairs:
            raise ValueError(f"{name} must have one column per pair ({n_pairs}), got shape {itds.shape}")
        out = itds.astype(np.float64)
    else:
        parts = [as_samples(a, f"{name}[{p}]") for p, a in enumerate(itds)]  # type: ignore[union-attr]
        if len(parts) != n_pairs:
            raise ValueError(f"{name} must give {n_pairs} arrays, one per pair, got {len(parts)}")
        out = np.full((sum(a.size for a in parts), n_pairs), np.nan)
        row = 0
        for p, a in enumerate(parts):
            out[row:row + a.size, p] = a
            row += a.size
    if np.isinf(out).any():
        raise ValueError(f"{name} must be finite or NaN (a pair without an ITD)")
    return out


class FaceGuidedHearing:
    """Face-Guided Robot Hearing, the paper's Algorithm 2 (section 5.1).

    N is the number of faces; the means start at the mapped faces (eq. final_av_mapping) with sigma^2 = 1e-9 s^2;
    EM runs on the ITDs only (eq. beta_kn and the M-step restricted to the auditory data); speaking states follow
    eq. (audio_act). With no ITD nobody speaks (probability 0); with no face there is nothing to decide.

    A :class:`MicPair` is an array of one pair: ITDs are vectors, one value per pair, and every face maps to one
    ITD per pair (the model of :func:`avcore.mixture.fit_pairs_em`, the paper's with P = 1). Without ``params``,
    the defaults for the microphones' geometry (:meth:`FaceGuidedParams.for_array`).
    """

    def __init__(self, mics: MicPair | MicArray, params: FaceGuidedParams | None = None) -> None:
        self.array = _as_array(mics)
        self.mics = self.array.pair(0)
        self.params = params if params is not None else FaceGuidedParams.for_array(self.array)
        self.support = self.mics.itd_interval()
        self._supports = self.array.itd_intervals()
        p = self.params
        self._em = replace(p.em, var_floor_s2=p.var_min_s2)

    def step(self, faces_xyz: object, itds_s: object, itd_offsets_s: object = None,
             frame_itds_s: object = None, band_itds_s: object = None, frame_bins: FrameBins | None = None,
             mean_offsets_s: object = None, bin_spill: object = None) -> FaceGuidedOutput:
        """faces_xyz : (N, 3) float, metres. itds_s : (K, P) float, seconds, one vector per window (NaN where a
        pair has none), or P arrays (each pair's values alone, not aligned); (K,) with one pair.
        itd_offsets_s : (K,) seconds, each ITD window's centre minus the frame's stamp, for
        ``params.decision_window_s`` (None: every ITD decides).
        frame_itds_s : the single frames' ITDs of the same time (as ``itds_s``), for the speaking test's second look
        (:class:`SpeakingTest` ``frame_rescue``; EM does not see them); None: none.
        band_itds_s : the peaks of those frames' frequency bands (as ``itds_s``), the third look; None: none.
        frame_bins : the frames' bins on every pair (``PairsItdStream(frame_bins=True)``), the fourth look
        (:func:`avcore.speaking.bin_shares`); None: none.
        mean_offsets_s : (N, P) seconds added to each face's mapped ITD on each pair (where the person's voice is
        heard: :class:`avcore.own_itd.OwnItds`), for EM's anchors and every look; None: the mapping alone.
        bin_spill : (N, N) each talker's learned spill onto each neighbour's bins (:class:`avcore.bin_spill.BinSpill`)
        for the bins' claims; None: none."""
        faces = as_points(faces_xyz, "faces_xyz")
        p, array = self.params, self.array
        n_pairs = array.n_pairs
        x = _itd_vectors(itds_s, n_pairs, "itds_s")
        present = None
        if itd_offsets_s is not None and p.decision_window_s is not None:
            offsets = np.asarray(itd_offsets_s, dtype=np.float64).reshape(-1)
            if offsets.shape != (x.shape[0],):
                raise ValueError(f"itd_offsets_s must give one time per ITD: {offsets.size} times for "
                                 f"{x.shape[0]} ITDs")
            present = np.abs(offsets) <= p.decision_window_s
        n = faces.shape[0]
        means = array.itd(faces).reshape(n, n_pairs)
        if mean_offsets_s is not None:
            shift = np.asarray(mean_offsets_s, dtype=np.float64)
            if shift.shape != means.shape:
                raise ValueError(f"mean_offsets_s must be (faces, pairs) = {means.shape}, got {shift.shape}")
            means = means + shift
        w = np.append(np.full(n, (1.0 - p.init_outlier_weight) / max(n, 1)), p.init_outlier_weight if n else 1.0)
        fit = fit_pairs_em(x, w, means, np.full((n, n_pairs), p.sigma2_init_s2), self._supports, settings=self._em,
                           update_means=not p.anchor_means, update_variances=p.update_variances,
                           max_variance_s2=p.var_max_s2)
        if not fit.converged:
            warn_not_converged("the face-guided EM", p.em)
        beta = fit.beta if n else np.zeros((x.shape[0], 1))
        frames = None if frame_itds_s is None else _itd_vectors(frame_itds_s, n_pairs, "frame_itds_s")
        bands = None if band_itds_s is None else _itd_vectors(band_itds_s, n_pairs, "band_itds_s")
        share = None
        if frame_bins is not None and len(frame_bins) and n:
            if frame_bins.bins.shape[1] != n_pairs:
                raise ValueError(f"frame_bins must hold the array's {n_pairs} pairs, got {frame_bins.bins.shape[1]}")
            share = bin_shares(frame_bins.bins, frame_bins.freqs_hz, means, p.speaking.bin_agreement)
        spill = None if bin_spill is None else np.asarray(bin_spill, dtype=np.float64)
        if spill is not None and spill.shape != (n, n):
            raise ValueError(f"bin_spill must be (faces, faces) = {(n, n)}, got {spill.shape}")
        d = p.speaking.decide_all(beta[:, :-1], x, fit.means, fit.variances, self._supports, present, frames, bands,
                                  share, spill)
        model = Mixture1D.unchecked(fit.weights, fit.means[:, 0].copy(), fit.variances[:, 0].copy(), self.support)
        return FaceGuidedOutput(d.speaking, d.probability, fit.means[:, 0].copy(), beta[:, :-1].sum(axis=0), model,
                                d.tau_a, fit.n_iter, fit.means.copy(), d.rescued, share)
