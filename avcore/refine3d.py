"""Compact 3D groups inside a 1-D cluster: avhear's post-processing beyond the paper's section 4.4.

The 1-D posteriors alpha of Algorithm 1 give every visual point that projects near a cluster's ITD mean to that
cluster, wherever it is in 3D. Two kinds of error follow (the paper's own CTMS3 failures, section 7.2): people
who cross in ITD space share one cluster, and 3D outliers on the cluster's hyperboloid pull its mean (eq.
hat_svect) and covariance. Here each cluster's alpha-weighted points are explained as a few compact 3D Gaussians
(one per person) plus diffuse leftovers:

1. start at the densest cell of an alpha-weighted x-z histogram (5 cm cells, 15 cm smoothing);
2. a Gaussian mean shift with a kernel a little smaller than a person climbs to the density mode;
3. a robust Gaussian fit around the mode (a Gaussian-weighted mean; the covariance of the points within a
   chi-square(3) cut-off, corrected for the truncation and capped at twice the kernel, so that it cannot grow over a neighbour) gives the person's
   position and covariance and its members;
4. a group must look like a blob, not like a piece of a diffuse field: of its points within the cut-off, a
   3-D Gaussian has 20.5 % within one Mahalanobis unit and a uniform ellipsoid 3.7 %; groups below
   ``min_peakedness`` (12 % by default) are diffuse outliers;
5. the members are removed and steps 1-4 repeat on the rest while enough mass is left.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Group3D", "compact_groups", "held_bodies"]


def _chi2_cdf(x: float, dof: int) -> float:
    """The chi-square CDF for 3 or 5 degrees of freedom in closed form (SciPy's stats are slow to import):
    P(3/2, x/2) = erf(sqrt(x/2)) - sqrt(2x/pi) exp(-x/2), and P(5/2, .) = P(3/2, .) - (x/2)^(3/2) exp(-x/2) / G(5/2)."""
    p3 = math.erf(math.sqrt(x / 2)) - math.sqrt(2 * x / math.pi) * math.exp(-x / 2)
    return p3 if dof == 3 else p3 - (x / 2) ** 1.5 * math.exp(-x / 2) / (0.75 * math.sqrt(math.pi))


_CUT2 = 9.0  # squared Mahalanobis cut-off (chi-square with 3 dof: 97.1 % of a Gaussian inside)
# E[d^2 | d^2 < c] / 3 for a 3-D Gaussian: the factor by which the truncated covariance is too small.
_TRUNC = _chi2_cdf(_CUT2, 5) / _chi2_cdf(_CUT2, 3)
GAUSS_PEAKEDNESS = _chi2_cdf(1.0, 3) / _chi2_cdf(_CUT2, 3)  # 0.205
UNIFORM_PEAKEDNESS = 1.0 / 27.0  # volume of the unit ellipsoid over that of radius 3


@dataclass(frozen=True)
class Group3D:
    """One compact group: ``members`` (M,) soft membership weights (<= the cluster's alpha), ``mass`` their sum,
    ``mean`` (3,) metres, ``cov`` (3, 3) m^2."""

    members: np.ndarray
    mass: float
    mean: np.ndarray
    cov: np.ndarray


def _cap(kk: np.ndarray, cov: np.ndarray, max_kernels: float) -> np.ndarray:
    """Clip a covariance to at most ``max_kernels`` kernel widths along every direction (kernel-whitened).

    kk : (3, 3) the outer product of the kernel's standard deviations. ``cov`` may be one (3, 3) matrix or a stack
    (G, 3, 3) of them, each clipped on its own.
    """
    white = cov / kk
    if np.abs(white).sum(axis=-1).max() <= max_kernels**2:
        # no eigenvalue exceeds the largest absolute row sum (Gershgorin): nothing to clip
        return cov
    evals, evecs = np.linalg.eigh(white)
    evals = np.minimum(evals, max_kernels**2)
    return (evecs * evals[..., None, :]) @ np.swapaxes(evecs, -1, -2) * kk


def _mahalanobis2(d: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """Squared Mahalanobis distances of the rows of ``d`` (..., 3) under ``cov`` (3, 3), or under each of a stack
    of covariances (G, 3, 3) for ``d`` (G, M, 3)."""
    q = d @ np.linalg.inv(cov)
    q *= d
    # the three columns added in order: what sum(axis=-1) gives, without its overhead on rows of three
    return q[..., 0] + q[..., 1] + q[..., 2]


def _densest_cell(points: np.ndarray, w: np.ndarray, cell_m: float) -> tuple[np.ndarray, float]:
    """Centre and weight of the densest 3x3-cell window of an x-z histogram of the weighted points."""
    xz = points[:, ::2]  # x and z
    lo = xz.min(axis=0)
    idx = np.floor((xz - lo) / cell_m).astype(np.int64)
    rows, cols = (int(n) + 1 for n in idx.max(axis=0))
    flat = idx[:, 0] * cols + idx[:, 1]
    hist = np.bincount(flat, weights=w, minlength=rows * cols).reshape(rows, cols)
    # 3x3 box sums so that a person split over cell borders still wins (separable, on a zero border)
    pad = np.zeros((rows + 2, cols + 2))
    pad[1:-1, 1:-1] = hist
    band = pad[:-2] + pad[1:-1]
    band += pad[2:]
    box = band[:, :-2] + band[:, 1:-1]
    box += band[:, 2:]
    i, j = divmod(int(np.argmax(box)), cols)
    window = np.zeros((rows, cols), dtype=bool)
    window[max(i - 1, 0):i + 2, max(j - 1, 0):j + 2] = True
    ww = w * window.reshape(-1)[flat]
    mass = float(ww.sum())
    return (ww @ points) / max(mass, 1e-300), mass


def compact_groups(
    points: np.ndarray,
    weights: np.ndarray,
    *,
    kernel_sd_m: tuple[float, float, float] = (0.10, 0.20, 0.10),
    max_kernels: float = 2.0,
    min_mass: float = 60.0,
    max_groups: int = 3,
    max_sd_m: float = 0.6,
    min_peakedness: float = 0.12,
    n_shift: int = 30,
    n_refit: int = 3,
) -> list[Group3D]:
    """Split weighted 3D points into compact person-sized groups (see module docstring).

    points : (M, 3) metres. weights : (M,) non-negative (a cluster's alpha). Groups carrying less than
    ``max_kernels`` caps the fitted standard deviations at that many kernel widths along every direction (in the
    kernel's units), so that a fit cannot grow over a neighbour. Groups carrying less than
    ``min_mass`` weight, wider than ``max_sd_m`` along any axis, or less peaked than ``min_peakedness`` are not
    returned (diffuse outliers).
    """
    weights = np.asarray(weights, dtype=np.float64)
    # most points of the interval have ~0 posterior for this cluster: work on the others only
    support = np.flatnonzero(weights > 0.02)
    sub = _groups(points[support], weights[support], np.asarray(kernel_sd_m, dtype=np.float64), min_mass,
                  max_groups, max_sd_m, min_peakedness, max_kernels, n_shift, n_refit)
    out = []
    for g in sub:
        members = np.zeros_like(weights)
        members[support] = g.members
        out.append(Group3D(members, g.mass, g.mean, g.cov))
    return out


def _groups(points: np.ndarray, weights: np.ndarray, ks: np.ndarray, min_mass: float, max_groups: int,
            max_sd_m: float, min_peakedness: float, max_kernels: float, n_shift: int, n_refit: int) -> list[Group3D]:
    residual = weights.copy()
    groups: list[Group3D] = []
    inv_ks2 = -0.5 / ks**2
    kk = np.outer(ks, ks)
    jitter = np.eye(3) * 1e-6
    for _ in range(max_groups):
        active = residual > 1e-6
        if residual[active].sum() < min_mass:
            break
        pts, res = points[active], residual[active]
        m, window_mass = _densest_cell(pts, res, 0.05)
        if window_mass < 0.2 * min_mass:
            # no 15 x 15 cm window holds a fifth of a minimal person (about 30 % of a person falls in one):
            # the rest is diffuse
            break
        for _ in range(n_shift):
            d = pts - m
            d *= d
            k = np.exp(d @ inv_ks2)
            k *= res
            ksum = k.sum()
            if ksum <= 0:
                break
            m_new = (k @ pts) / ksum
            if np.abs(m_new - m).max() < 5e-4:
                m = m_new
                break
            m = m_new
        cov = np.diag(ks**2)
        r = res
        mass = r.sum()
        d = pts - m  # the points about the current mean, kept up to date with m
        for _ in range(n_refit):
            d2 = _mahalanobis2(d, cov)
            r = res * (d2 < _CUT2)
            mass = r.sum()
            if mass < min_mass:
                break
            # a Gaussian-weighted mean: a neighbour 3 sd away weighs 1 %, so the fit stays on its person
            soft = np.exp(-0.5 * np.minimum(d2, 50.0))
            soft *= res
            m = (soft @ pts) / soft.sum()
            d = pts - m
            cov = _cap(kk, (r[:, None] * d).T @ d / mass / _TRUNC + jitter, max_kernels)
        mass = float(mass)
        if mass < min_mass:
            break
        members = np.zeros_like(residual)
        members[active] = r
        residual -= members
        sd = np.sqrt(np.linalg.eigvalsh(cov)[-1])
        d2 = _mahalanobis2(d, cov)
        peaked = (res @ (d2 < 1.0)) / max(res @ (d2 < _CUT2), 1e-300)
        if sd > max_sd_m or peaked < min_peakedness:
            continue
        groups.append(Group3D(members, mass, m, cov))
    if len(groups) > 1:
        groups = _share(points, weights, groups, kk, max_kernels)
    return groups


def _share(points: np.ndarray, weights: np.ndarray, groups: list[Group3D], kk: np.ndarray, max_kernels: float,
           n_iter: int = 5) -> list[Group3D]:
    """Re-share the points of overlapping groups by their Gaussian densities (a 3D E-step over the groups).

    Groups are found one after another and each takes every point within its cut-off, so a later group misses
    its points on the side of an earlier neighbour and its mean moves away from it. Sharing the points by
    posterior (a few EM iterations of a 3D mixture of the groups, covariances capped as in the fit) undoes that.
    kk : the outer product of the kernel's standard deviations (:func:`_cap`).
    """
    means = np.array([g.mean for g in groups])
    covs = np.array([g.cov for g in groups])
    masses = np.array([g.mass for g in groups])
    resp = np.zeros((len(groups), points.shape[0]))
    jitter = np.eye(3) * 1e-6
    d = points[None, :, :] - means[:, None, :]  # (G, M, 3) the points about each group's mean
    for _ in range(n_iter):
        norm = masses / np.sqrt(np.linalg.det(covs))
        d2 = _mahalanobis2(d, covs)
        dens = np.exp(-0.5 * np.minimum(d2, 50.0))
        dens *= norm[:, None]
        resp = weights * dens / np.maximum(dens.sum(axis=0), 1e-300) * (d2 < _CUT2)
        masses = np.maximum(resp.sum(axis=1), 1e-300)
        means = (resp @ points) / masses[:, None]
        d = points[None, :, :] - means[:, None, :]
        covs = _cap(kk, (resp[:, :, None] * d).transpose(0, 2, 1) @ d / masses[:, None, None] / _TRUNC + jitter,
                    max_kernels)
    return [Group3D(resp[i], float(masses[i]), means[i], covs[i]) for i in range(len(groups))]


def group_from_members(points: np.ndarray, members: np.ndarray) -> Group3D:
    """The group of the given membership weights (already cut at the chi-square bound): mean and covariance."""
    mass = float(members.sum())
    mean = (members @ points) / mass
    d = points - mean
    cov = (members[:, None] * d).T @ d / mass / _TRUNC + np.eye(3) * 1e-6
    return Group3D(members, mass, mean, cov)


def merge_close(groups: list[Group3D], points: np.ndarray, distance_m: float,
                vertical_m: float | None = None, reach_per_m: float = 0.0) -> list[list[int]]:
    """Indices of groups to merge: groups whose means are closer than ``distance_m`` are one person.

    A person's points are sometimes cut into two 1-D clusters (their projection is not Gaussian), each giving a
    group, and a body's moving parts (head, hands, legs) form several compact groups stacked one above the other;
    two real people are never closer than a head's width side by side. ``vertical_m`` (default ``distance_m``)
    stretches the distance along y (the scene's vertical): two groups are one person when their horizontal distance
    ``dh = hypot(dx, dz)`` is below ``r(dy) = sqrt(distance_m^2 - (dy * distance_m / vertical_m)^2)``.

    ``reach_per_m`` widens that by ``reach_per_m * |dy|``: an arm reaches out and down, so a gesturing person's hands
    lie farther to the side of the head the lower they are, while people side by side have their heads at about
    one height. Greedy: the pair with the smallest ``dh / (r(dy) + reach_per_m * |dy|)`` first, merged while below 1.
    """
    vertical_m = distance_m if vertical_m is None else vertical_m
    if not (distance_m > 0 and vertical_m > 0):
        raise ValueError(f"distance_m and vertical_m must be > 0 metres, got {distance_m!r}, {vertical_m!r}")
    if not reach_per_m >= 0:
        raise ValueError(f"reach_per_m must be >= 0, got {reach_per_m!r}")
    clusters = [[i] for i in range(len(groups))]
    means = [g.mean for g in groups]
    masses = [g.mass for g in groups]
    while len(clusters) > 1:
        m = np.asarray(means)
        score = merge_scores(m, m, distance_m, vertical_m, reach_per_m)
        np.fill_diagonal(score, np.inf)
        i, j = np.unravel_index(int(np.argmin(score)), score.shape)
        if score[i, j] >= 1:
            break
        i, j = min(i, j), max(i, j)
        tot = masses[i] + masses[j]
        means[i] = (masses[i] * means[i] + masses[j] * means[j]) / tot
        masses[i] = tot
        clusters[i] += clusters.pop(j)
        means.pop(j)
        masses.pop(j)
    return clusters


def merge_scores(a: np.ndarray, b: np.ndarray, distance_m: float, vertical_m: float, reach_per_m: float
                 ) -> np.ndarray:
    """(A, B) scores of :func:`merge_close` between the means ``a`` (A, 3) and ``b`` (B, 3): below 1, one person."""
    d = np.asarray(a, dtype=np.float64).reshape(-1, 1, 3) - np.asarray(b, dtype=np.float64).reshape(1, -1, 3)
    dh, dy = np.hypot(d[..., 0], d[..., 2]), np.abs(d[..., 1])
    reach = np.sqrt(np.maximum(distance_m**2 - (dy * distance_m / vertical_m) ** 2, 0.0)) + reach_per_m * dy
    return np.where(dy < vertical_m, dh / np.maximum(reach, 1e-12), np.inf)


def _weighted_quantiles(x: np.ndarray, w: np.ndarray, q: tuple[float, float]) -> np.ndarray:
    order = np.argsort(x)
    c = np.cumsum(w[order])
    return np.interp(q, c / c[-1], x[order])


def merge_within_width(groups: list[Group3D], points: np.ndarray, clusters: list[list[int]], width_m: float,
                       max_dy_m: float = 0.25) -> list[list[int]]:
    """``clusters`` (lists of indices into ``groups``) merged while two of them are one body's width across.

    A person who sways or gestures with both hands moves at both sides of the body: the moving points gather in two
    strips at the body's edges, a torso's width apart at one height, which ``merge_close`` keeps apart, as it must
    keep two heads side by side. What tells them apart is the extent: the two strips' points together span one body
    (between their 5th and 95th percentiles along the horizontal line through their means), two people side by side
    span two (docs/method.md). Clusters at
    about one height (means within ``max_dy_m``) whose members together span at most ``width_m`` are merged,
    the narrowest pair first. Its limit: two people whose moving points are heads alone, closer than about
    ``width_m`` minus a head's width, are taken for one.
    """
    if not width_m > 0:
        raise ValueError(f"width_m must be > 0 metres, got {width_m!r}")
    clusters = [list(c) for c in clusters]
    while len(clusters) > 1:
        members = [sum(groups[i].members for i in c) for c in clusters]
        means = [(m @ points) / max(float(m.sum()), 1e-12) for m in members]
        best: tuple[float, int, int] | None = None
        for i in range(len(clusters)):
            for j in range(i + 1, len(clusters)):
                axis = np.array([means[j][0] - means[i][0], 0.0, means[j][2] - means[i][2]])
                norm = float(np.linalg.norm(axis))
                if abs(means[j][1] - means[i][1]) > max_dy_m or norm < 1e-9:
                    continue
                w = members[i] + members[j]
                keep = w > 1e-9
                lo, hi = _weighted_quantiles(points[keep] @ (axis / norm), w[keep], (0.05, 0.95))
                if hi - lo <= width_m and (best is None or hi - lo < best[0]):
                    best = (hi - lo, i, j)
        if best is None:
            break
        _, i, j = best
        clusters[i] += clusters.pop(j)
    return clusters


def held_bodies(points: np.ndarray, previous_m: np.ndarray, previous_mass: np.ndarray, current_m: np.ndarray, *,
                radius_m: float, half_height_m: float, match_m: float, min_points: float, min_share: float,
                min_contrast: float = 5.0, merge: tuple[float, float, float] | None = None, n_shift: int = 5
                ) -> list[tuple[int, np.ndarray]]:
    """The people of the previous interval that this interval's groups lost, where their bodies still hold points.

    Algorithm 1 initialises each interval's model from the previous one (the paper's section 4.4) but decides who
    is there from this interval's data alone, so a person standing still whose points happen to fall into another
    cluster's tail, or to be cut into pieces too small to be groups, is lost for an interval and found again in the
    next. A previous person (``previous_m`` (Q, 3), with the mass ``previous_mass`` (Q,) their group had) that no
    current person (``current_m`` (N, 3)) stands for is looked for in a vertical cylinder (``radius_m``
    horizontally, ``half_height_m`` up and down) around where they were, re-centred ``n_shift`` times on the mean of
    its points (a person moves a little between intervals). A current person stands for the previous one closest to
    them horizontally, within ``match_m`` (a body is vertical: its centre found at the torso once and at the legs
    once is one person), the closest pairs first, so two people side by side found as one lose one. Points in a
    current person's cylinder, or in one held before, are not taken. The person is held when the cylinder keeps at
    least ``min_points`` points and ``min_share`` of their previous mass (a person who left leaves the few outliers
    any cylinder holds), its points are ``min_contrast`` times as dense as those of the ring around it (out to twice
    the radius, points neither taken nor in another previous person's cylinder: a body stands out of its
    surroundings, a patch of outliers does not, so a false person made of outliers is not carried on), its centre
    stays within ``match_m`` of where they were, horizontally, and :func:`merge_close` with ``merge`` (distance_m,
    vertical_m, reach_per_m) would not join it to a current person (then it is a part of them, such as the legs of
    someone walking behind others).

    Returns (index into ``previous_m``, boolean mask (M,) over ``points``) per person held.
    """
    pts = np.asarray(points, dtype=np.float64)
    previous = np.asarray(previous_m, dtype=np.float64).reshape(-1, 3)
    current = np.asarray(current_m, dtype=np.float64).reshape(-1, 3)

    def horizontal(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        d = a - b
        return np.hypot(d[..., 0], d[..., 2])

    def cylinder(centre: np.ndarray, r: float = radius_m) -> np.ndarray:
        return (horizontal(pts, centre) < r) & (np.abs(pts[:, 1] - centre[1]) < half_height_m)

    taken = np.zeros(pts.shape[0], dtype=bool)
    for c in current:
        taken |= cylinder(c)
    found = np.zeros(previous.shape[0], dtype=bool)
    d = horizontal(previous[:, None], current[None])
    for _ in range(min(d.shape)):
        i, j = np.unravel_index(int(np.argmin(d)), d.shape)
        if d[i, j] >= match_m:
            break
        found[i] = True
        d[i, :], d[:, j] = np.inf, np.inf
    around = [cylinder(q) for q in previous]  # each previous person's cylinder: a person, not the background
    cover = np.sum(around, axis=0)  # how many previous cylinders hold each point
    held = []
    for i in np.flatnonzero(~found):
        centre = previous[i]
        for _ in range(n_shift):
            inside = cylinder(centre) & ~taken
            if not inside.any():
                break
            centre = pts[inside].mean(axis=0)
        inside = cylinder(centre) & ~taken
        count = int(inside.sum())
        others = cover - around[i] > 0
        ring = int((cylinder(centre, 2 * radius_m) & ~taken & ~others & ~inside).sum())  # 3 cylinders' area
        part = merge is not None and current.shape[0] > 0 and np.min(merge_scores(centre, current, *merge)) < 1
        if (count >= min_points and count >= min_share * previous_mass[i] and count >= min_contrast * ring / 3
                and horizontal(centre, previous[i]) < match_m and not part):
            held.append((int(i), inside))
            taken |= inside
    return held
