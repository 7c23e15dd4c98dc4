"""People in plain clothes for Algorithm 1: motion points spread evenly over a head and a torso, without texture.

A third generator, beside :mod:`sim.bodies` and :mod:`sim.skeletons`, whose people carry no texture (no hair, face,
collar or folds that gather the Harris points): each person's points lie evenly over the surface of a head
(an ellipsoid) and of a torso (a rounded box), with their outline as likely as their middle. What it has that the
others lack: outliers spread through the whole room (not near the people), few ITDs (about ``itds_per_talker`` per
interval from a talker, ``stray_itds`` from nowhere), long silences (each person speaks in about one interval in
``talk_every``), and people far off axis (up to ``max_azimuth_deg``).

Families: ``static`` (people standing still, swaying a little) and ``moving`` (each walks slowly to and fro across
the view at a depth of its own). The truth is the paper's (section 7.1): the mean of each person's ground-truth
points in the interval (:attr:`sim.synthetic.Interval.truth_xyz`).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avcore.geometry import MicPair
from sim.synthetic import Interval

__all__ = ["FAMILIES", "PlainConfig", "generate_plain"]

FAMILIES = ("static", "moving")


@dataclass(frozen=True)
class PlainConfig:
    """points_per_person : points of one person in an interval (about 600); outlier_share : of all points, spread
    uniformly through the view from 0.8 to 6 m; itds_per_talker, stray_itds : Poisson means per interval;
    talk_every : a person speaks in about one interval in this many; near_m, far_m : the people's depths;
    max_azimuth_deg : how far off the cameras' axis; itd_sd_s : the talker's ITD spread; interval_s : Delta t."""

    n_intervals: int = 60
    points_per_person: int = 600
    outlier_share: float = 0.12
    itds_per_talker: float = 7.0
    stray_itds: float = 5.0
    talk_every: int = 4
    near_m: float = 1.2
    far_m: float = 3.2
    max_azimuth_deg: float = 49.0
    itd_sd_s: float = 25e-6
    interval_s: float = 0.4
    point_noise_m: float = 0.01


def _ellipsoid_surface(rng: np.random.Generator, n: int, radii: np.ndarray) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True) * radii


def _box_surface(rng: np.random.Generator, n: int, half: np.ndarray) -> np.ndarray:
    """Points spread evenly over the surface of a box of half-sides ``half`` (each face by its area)."""
    areas = np.array([half[1] * half[2], half[0] * half[2], half[0] * half[1]]).repeat(2)
    face = rng.choice(6, size=n, p=areas / areas.sum())
    p = rng.uniform(-1, 1, (n, 3)) * half
    axis, sign = face // 2, np.where(face % 2 == 0, -1.0, 1.0)
    p[np.arange(n), axis] = sign * half[axis]
    return p


def _person_points(rng: np.random.Generator, n: int, centre: np.ndarray) -> np.ndarray:
    """A head (a third of the points) above a torso, evenly over their surfaces; ``centre`` is the torso's."""
    n_head = n // 3
    head = _ellipsoid_surface(rng, n_head, np.array([0.08, 0.11, 0.09])) + [0.0, -0.42, 0.0]
    torso = _box_surface(rng, n - n_head, np.array([0.21, 0.30, 0.10]))
    return np.concatenate([head, torso]) + centre


def _outliers(rng: np.random.Generator, n: int) -> np.ndarray:
    z = rng.uniform(0.8, 6.0, n)
    x = rng.uniform(-1, 1, n) * z * np.tan(np.radians(30))
    y = rng.uniform(-1, 1, n) * z * np.tan(np.radians(22))
    return np.c_[x, y, z]


def generate_plain(family: str, *, seed: int = 0, mics: MicPair | None = None,
                   config: PlainConfig | None = None) -> list[Interval]:
    """A sequence of ``config.n_intervals`` intervals of three people in plain clothes (module docstring)."""
    if family not in FAMILIES:
        raise ValueError(f"unknown family {family!r}; choose one of {', '.join(FAMILIES)}")
    cfg = config or PlainConfig()
    mics = mics if mics is not None else MicPair()
    rng = np.random.default_rng(seed)
    depths = np.sort(rng.uniform(cfg.near_m, cfg.far_m, 3))
    while np.min(np.diff(depths)) < 0.4:  # each person on a depth of their own
        depths = np.sort(rng.uniform(cfg.near_m, cfg.far_m, 3))
    azimuths = np.radians(np.sort(rng.uniform(-cfg.max_azimuth_deg, cfg.max_azimuth_deg, 3)))
    heights = rng.uniform(-0.05, 0.25, 3)  # standing or seated: the torso's centre, y down
    speeds = rng.uniform(0.15, 0.35, 3) * rng.choice([-1, 1], 3)  # m/s across the view (moving)
    talking = np.zeros(3, dtype=bool)
    out = []
    for k in range(cfg.n_intervals):
        t = k * cfg.interval_s
        centres = []
        for i in range(3):
            x = depths[i] * np.tan(azimuths[i])
            if family == "moving":
                span = 0.8
                x = x + span * np.sin(speeds[i] * t / span + i)
            sway = 0.02 * np.sin(2 * np.pi * 0.3 * t + i)
            centres.append(np.array([x + sway, heights[i], depths[i]]))
        if k % 2 == 0:  # turns of 0.8 s: one person at most, each in about one interval in talk_every
            talking[:] = False
            if rng.random() < 3.0 / cfg.talk_every:
                talking[rng.integers(3)] = True
        pts, ids = [], []
        for i, c in enumerate(centres):
            p = _person_points(rng, rng.poisson(cfg.points_per_person), c)
            pts.append(p + rng.normal(0, cfg.point_noise_m, p.shape))
            ids.append(np.full(p.shape[0], i))
        n_people = sum(p.shape[0] for p in pts)
        n_out = int(round(n_people * cfg.outlier_share / (1 - cfg.outlier_share)))
        pts.append(_outliers(rng, n_out))
        ids.append(np.full(n_out, -1))
        points, point_ids = np.concatenate(pts), np.concatenate(ids)
        order = rng.permutation(points.shape[0])
        points, point_ids = points[order], point_ids[order]
        truth = np.array([points[point_ids == i].mean(axis=0) for i in range(3)])
        itds, itd_ids = [rng.uniform(*mics.itd_interval(), rng.poisson(cfg.stray_itds))], [None]
        itd_ids = [np.full(itds[0].size, -1)]
        for i in np.flatnonzero(talking):
            mouth = centres[i] + [0.0, -0.36, -0.09]
            n = rng.poisson(cfg.itds_per_talker)
            itds.append(rng.normal(float(mics.itd(mouth)), cfg.itd_sd_s, n))
            itd_ids.append(np.full(n, i))
        out.append(Interval(index=k, t_s=t, interval_s=cfg.interval_s, points=points, point_ids=point_ids,
                            itds=np.concatenate(itds), itd_ids=np.concatenate(itd_ids), truth_xyz=truth,
                            truth_speaking=talking.copy(), truth_ids=np.arange(3)))
    return out
