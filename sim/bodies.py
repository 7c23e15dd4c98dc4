"""Synthetic sequences of people with bodies, for Algorithm 1: motion points where Harris corners fall on
a real person, not a Gaussian blob.

The paper's section 7.1 sequences (:mod:`sim.synthetic`) draw each person's points as an anisotropic Gaussian around
one point. Harris corners on a person lie where the texture is -- hair, eyes and mouth, the collar, clothing folds,
the outline of the arms and the hands -- and HM3D keeps those that move, so the hands of a talker who gestures give
more points than the head. Here each person is a body of simple parts in the scene frame (x right, y down, z
forward, metres): a head (ellipsoid), a neck and a torso (elliptic cylinders), two arms of two segments each ending
in a hand, and two legs when standing. A point is drawn on the surface of a part facing the camera, with a density
that follows the texture (the silhouette, the face's features, the hairline, the collar, a few fold lines per
person) and a share per part that follows how much the part moves in the family; a talker's hands swing through a
gesture during the interval, a walker's whole body moves and its points are smeared along the 0.4 s.

Families (three people, the interval of 0.4 s, about 590 points per person and 230 outliers per interval, the
sensor noise of :class:`sim.synthetic.SyntheticConfig`):

* ``seated``: seated behind a table that hides everything below it; talking with moderate gestures.
* ``standing``: standing still (a little sway), legs visible; head and hands move.
* ``gesturing``: seated, hands and forearms giving most points, wide gestures.
* ``walking``: walking back and forth across the room at 0.3-0.6 m/s, each in a lane of its own depth (1.6-3.4 m,
  0.6 m or more apart, so that they pass in front of each other, not through), the whole body moving, legs
  swinging.
* ``edge``: standing; one person at the edge of the field of view, part of the body outside the image.
* ``close``: two people shoulder to shoulder (0.45-0.6 m between their heads), the third apart.
* ``crossing``: one person walks behind another, hidden where the one in front covers them; the third walks in a
  lane 0.6 m or more from both.

**Ground truth.** A person's position is the centre of their visible moving body: the mean of the noise-free
points the generator would draw for them in that interval (inside the image, not hidden by the table or another person),
computed from 4,000 draws. That is the point a method that locates a person from its motion points estimates; the ITDs
come from the mouth. A person counts in the truth when at least 30 % of their points are visible; the others are
``Interval.hidden_xyz`` (the centre of what is seen of them). Speech is the on/off chain of :mod:`sim.synthetic`, and
the ITDs have its statistics.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from avcore.geometry import MicPair
from sim.synthetic import Interval, SyntheticConfig, _frustum_points, _in_fov, _speaker_itds, _speech

__all__ = ["FAMILIES", "generate_bodies"]

FAMILIES = ("seated", "standing", "gesturing", "walking", "edge", "close", "crossing")

# the parts of a body and their share of the motion points in each family (head, neck, torso, upper arms,
# forearms, hands, legs)
PARTS = ("head", "neck", "torso", "upper_arm", "forearm", "hand", "leg")
_SHARES = {
    "seated": (0.30, 0.03, 0.12, 0.10, 0.18, 0.27, 0.0),
    "standing": (0.30, 0.03, 0.17, 0.10, 0.13, 0.17, 0.10),
    "gesturing": (0.15, 0.02, 0.08, 0.10, 0.25, 0.40, 0.0),
    "walking": (0.15, 0.02, 0.25, 0.10, 0.08, 0.08, 0.32),
    "edge": (0.30, 0.03, 0.17, 0.10, 0.13, 0.17, 0.10),
    "close": (0.30, 0.03, 0.12, 0.10, 0.18, 0.27, 0.0),
    "crossing": (0.15, 0.02, 0.25, 0.10, 0.08, 0.08, 0.32),
}
_SEATED = {"seated", "gesturing", "close"}
_WALKING = {"walking", "crossing"}


@dataclass(frozen=True)
class _Body:
    """One person: head centre at t = 0 and velocity (m/s), posture, gesture amplitude, fold lines."""

    head: np.ndarray
    velocity: np.ndarray
    seated: bool
    gesture_m: float
    folds: np.ndarray  # (4, 2, 2): four short lines (x, y offsets from the torso's front centre) per person
    phase: float


def _unit_sphere(rng: np.random.Generator, n: int) -> np.ndarray:
    v = rng.normal(size=(n, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _ellipsoid(rng: np.random.Generator, n: int, centre: np.ndarray, radii: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """n points on an ellipsoid and their outward normals."""
    s = _unit_sphere(rng, n)
    p = centre + s * radii
    normal = s / radii
    return p, normal / np.linalg.norm(normal, axis=1, keepdims=True)


def _segment(rng: np.random.Generator, n: int, a: np.ndarray, b: np.ndarray, radius: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """n points on the side of a cylinder of ``radius`` from a to b (each row of a, b one segment), and normals."""
    axis = b - a
    length = np.linalg.norm(axis, axis=-1, keepdims=True)
    d = axis / np.maximum(length, 1e-9)
    helper = np.where(np.abs(d[..., 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    e2 = np.cross(d, e1)
    theta = rng.uniform(0.0, 2 * np.pi, n)[:, None]
    normal = np.cos(theta) * e1 + np.sin(theta) * e2
    return a + rng.random(n)[:, None] * axis + radius * normal, normal


class _Sampler:
    """Surface points of a body's parts at given times, weighted by texture, facing the camera."""

    def __init__(self, family: str, interval_s: float) -> None:
        self.family = family
        self.interval_s = interval_s
        self.shares = np.asarray(_SHARES[family])

    def pose(self, body: _Body, t: np.ndarray) -> dict[str, np.ndarray]:
        """Joint positions (n, 3) at times t (n,) seconds."""
        head = body.head + t[:, None] * body.velocity
        walking = np.linalg.norm(body.velocity) > 0
        if not walking:  # a little sway and nodding
            head = head + 0.01 * np.stack([np.sin(1.3 * t + body.phase), 0.5 * np.sin(2.1 * t), 0 * t], axis=1)
        shoulder_y = head[:, 1] + 0.24
        out: dict[str, np.ndarray] = {"head": head}
        for side, sign in (("l", -1.0), ("r", 1.0)):
            shoulder = np.stack([head[:, 0] + sign * 0.19, shoulder_y, head[:, 2] + 0.02], axis=1)
            if walking:  # arms swing along the body
                swing = 0.25 * np.sin(2 * np.pi * 0.9 * t + body.phase + (0 if sign < 0 else np.pi))
                elbow = shoulder + np.stack([0 * t, 0.29 + 0 * t, -swing * 0.3], axis=1)
                wrist = elbow + np.stack([0 * t, 0.25 + 0 * t, -swing * 0.6 - 0.05], axis=1)
            else:  # gestures in front of the torso
                g = body.gesture_m
                w = 2 * np.pi * (0.7 + 0.3 * sign) * t + body.phase
                rest = np.array([sign * 0.12, 0.40 if body.seated else 0.45, -0.28])
                wrist = head + rest + np.stack([g * np.sin(w), 0.6 * g * np.sin(1.7 * w), 0.4 * g * np.cos(w)],
                                               axis=1)
                elbow = 0.5 * (shoulder + wrist) + np.array([sign * 0.08, 0.10, 0.05])
            out[f"shoulder_{side}"], out[f"elbow_{side}"], out[f"wrist_{side}"] = shoulder, elbow, wrist
            if not body.seated:
                hip = np.stack([head[:, 0] + sign * 0.09, head[:, 1] + 0.80, head[:, 2] + 0.02], axis=1)
                stride = 0.3 * np.sin(2 * np.pi * 0.9 * t + body.phase + (0 if sign < 0 else np.pi)) if walking \
                    else 0 * t
                foot = hip + np.stack([0 * t, 0.82 + 0 * t, stride], axis=1)
                out[f"hip_{side}"], out[f"foot_{side}"] = hip, foot
        return out

    def surface(self, rng: np.random.Generator, body: _Body, part: str, t: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points of ``part`` at times t: positions, normals, texture weights."""
        n = t.size
        j = self.pose(body, t)
        side = rng.random(n) < 0.5
        pick = {k: np.where(side[:, None], j[f"{k}_l"], j[f"{k}_r"]) for k in ("shoulder", "elbow", "wrist")}
        if part == "head":
            p, nrm = _ellipsoid(rng, n, j["head"], np.array([0.075, 0.10, 0.09]))
            local = p - j["head"]
            feats = np.array([[-0.03, -0.02, -0.085], [0.03, -0.02, -0.085], [0.0, 0.05, -0.08], [0.0, 0.01, -0.09]])
            d2 = ((local[:, None, :] - feats[None]) ** 2).sum(axis=2).min(axis=1)
            weight = 2.0 * np.exp(-d2 / (2 * 0.015**2)) + 1.5 * (local[:, 1] < -0.06)  # face features, hairline
        elif part == "neck":
            a = j["head"] + np.array([0.0, 0.09, 0.01])
            p, nrm = _segment(rng, n, a, a + np.array([0.0, 0.09, 0.0]), 0.05)
            weight = np.ones(n)
        elif part == "torso":
            top = j["head"][:, 1] + 0.20
            y = top + rng.random(n) * 0.55
            theta = rng.uniform(0.0, 2 * np.pi, n)
            p = np.stack([j["head"][:, 0] + 0.19 * np.sin(theta), y, j["head"][:, 2] + 0.02 - 0.11 * np.cos(theta)],
                         axis=1)
            nrm = np.stack([np.sin(theta) / 0.19, 0 * y, -np.cos(theta) / 0.11], axis=1)
            nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
            offs = np.stack([p[:, 0] - j["head"][:, 0], y - top], axis=1)
            fold_d = np.min([_dist_to_segment(offs, f[0], f[1]) for f in body.folds], axis=0)
            weight = 2.0 * (y - top < 0.04) + 2.0 * np.exp(-fold_d**2 / (2 * 0.01**2))  # collar, folds
        elif part == "upper_arm":
            p, nrm = _segment(rng, n, pick["shoulder"], pick["elbow"], 0.05)
            weight = np.ones(n)
        elif part == "forearm":
            p, nrm = _segment(rng, n, pick["elbow"], pick["wrist"], 0.04)
            weight = np.ones(n)
        elif part == "hand":
            d = pick["wrist"] - pick["elbow"]
            d /= np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
            p, nrm = _ellipsoid(rng, n, pick["wrist"] + 0.06 * d, np.array([0.045, 0.06, 0.025]))
            weight = 2.0 * np.ones(n)  # fingers: many corners
        else:  # leg
            hip = np.where(side[:, None], j["hip_l"], j["hip_r"])
            foot = np.where(side[:, None], j["foot_l"], j["foot_r"])
            p, nrm = _segment(rng, n, hip, foot, 0.07)
            weight = np.ones(n)
        view = -p / np.linalg.norm(p, axis=1, keepdims=True)
        facing = (nrm * view).sum(axis=1)
        edge = np.exp(-(facing / 0.3) ** 2)  # the outline against the background
        return p, nrm, np.where(facing > 0, 0.3 + 1.5 * edge + weight, 0.0)

    def draw(self, rng: np.random.Generator, body: _Body, m: int, t0: float) -> tuple[np.ndarray, np.ndarray]:
        """m noise-free motion points of ``body`` during the interval starting at t0, and their part index."""
        counts = rng.multinomial(m, self.shares)
        pts, parts = [], []
        for k, (part, c) in enumerate(zip(PARTS, counts)):
            if c == 0:
                continue
            t = t0 + rng.random(4 * c) * self.interval_s
            p, _, w = self.surface(rng, body, part, t)
            if w.sum() <= 0:
                continue
            chosen = rng.choice(p.shape[0], size=c, p=w / w.sum())
            pts.append(p[chosen])
            parts.append(np.full(c, k))
        if not pts:
            return np.zeros((0, 3)), np.zeros(0, dtype=np.int64)
        return np.concatenate(pts), np.concatenate(parts)


def _dist_to_segment(x: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    s = np.clip(((x - a) @ ab) / max(ab @ ab, 1e-12), 0.0, 1.0)
    return np.linalg.norm(x - (a + s[:, None] * ab), axis=1)


def _visible(points: np.ndarray, others: list[_Body], cfg: SyntheticConfig, t_mid: float,
             table_y: float | None) -> np.ndarray:
    """In the image, above the table, not behind another person's body (seen from the camera)."""
    ok = _in_fov(points, cfg)
    if table_y is not None:
        ok &= points[:, 1] < table_y
    for other in others:
        head = other.head + t_mid * other.velocity
        closer = head[2] < points[:, 2] - 0.25
        ang_x = points[:, 0] / points[:, 2] - head[0] / head[2]
        ang_y = points[:, 1] / points[:, 2]
        top, bottom = (head[1] - 0.11) / head[2], (head[1] + (0.75 if other.seated else 1.65)) / head[2]
        covered = (np.abs(ang_x) < 0.21 / head[2]) & (ang_y > top) & (ang_y < bottom)
        ok &= ~(closer & covered)
    return ok


def _cast(rng: np.random.Generator, family: str, cfg: SyntheticConfig) -> list[_Body]:
    """Three bodies placed for ``family``."""
    seated = family in _SEATED
    head_y = -0.05 if seated else -0.45  # a seated head near the cameras' height; a standing one above
    while True:  # people sit or stand 0.6 m or more apart (shoulders 0.4 m wide), inside the 60-degree view
        az = np.sort(rng.uniform(-24.0, 24.0, 3))
        if np.all(np.diff(az) >= 18.0):
            break
    depth = rng.uniform(1.8, 3.0, 3)
    if family == "close":
        depth[1] = depth[0] + rng.uniform(-0.1, 0.1)
        gap = rng.uniform(0.45, 0.6)
        az[1] = az[0] + math.degrees(gap / depth[0])
        az[2] = max(az[2], az[1] + 14.0)
    if family == "edge":
        half_fov = cfg.fov_deg[0] / 2
        az[2] = half_fov - rng.uniform(0.5, 3.0)
    heads = np.stack([depth * np.sin(np.radians(az)), head_y + rng.uniform(-0.05, 0.05, 3),
                      depth * np.cos(np.radians(az))], axis=1)
    velocity = np.zeros((3, 3))
    if family in _WALKING:
        speed = rng.uniform(0.3, 0.6, 3) * rng.choice([-1.0, 1.0], 3)
        velocity[:, 0] = speed
        if family == "walking":  # walkers pass each other, so each keeps to a lane of its own depth
            heads[:, [0, 2]] *= (_lanes(rng, [], 3) / heads[:, 2])[:, None]  # same directions, new depths
        if family == "crossing":  # person 1 walks behind person 0, across their line of sight
            heads[1, 2] = heads[0, 2] + rng.uniform(0.9, 1.3)
            heads[1, 0] = heads[0, 0] - 1.2 * np.sign(speed[1] - speed[0] + 1e-9) * heads[1, 2] / heads[0, 2]
            velocity[0, 0] = 0.0
            # the third walks across the room too, so it keeps to a lane clear of both
            lane = _lanes(rng, [heads[0, 2], heads[1, 2]], 1, far_m=4.4)[0]
            heads[2, [0, 2]] *= lane / heads[2, 2]  # same direction, new depth
    gesture = rng.uniform(0.12, 0.25, 3) if family == "gesturing" else rng.uniform(0.04, 0.10, 3)
    folds = rng.uniform([-0.15, 0.05], [0.15, 0.50], (3, 4, 2, 2))
    return [_Body(heads[i], velocity[i], seated, float(gesture[i]), folds[i], float(rng.uniform(0, 6.28)))
            for i in range(3)]


def _lanes(rng: np.random.Generator, taken: list[float], n: int, near_m: float = 1.6, far_m: float = 3.4,
           gap_m: float = 0.6) -> np.ndarray:
    """n walking depths in [near_m, far_m], each ``gap_m`` or more from the others and from ``taken``.

    Walkers go back and forth across the whole room (:func:`_fold`), so any two of them meet; people keep 0.6 m
    apart (as :func:`_cast` places everyone), so two walkers at one depth would have to walk through each other.
    """
    while True:
        depth = rng.uniform(near_m, far_m, n)
        d = np.concatenate([depth, taken])
        if np.all(np.abs(d[:, None] - d[None, :])[np.triu_indices(len(d), 1)] >= gap_m):
            return depth


def _fold(x: np.ndarray, limit: float = 1.2) -> np.ndarray:
    """Walk back and forth between -limit and +limit (a triangle wave of the unbounded position)."""
    period = 4 * limit
    y = np.mod(x + limit, period)
    return np.where(y < 2 * limit, y - limit, 3 * limit - y)


def _at(body: _Body, t: float) -> _Body:
    """The body with its head moved to time t (walkers folded into the room), moving on from there."""
    head = body.head + t * body.velocity
    head = np.array([_fold(np.array([head[0]]))[0], head[1], head[2]])
    # the direction after folding: the sign of the derivative of the fold
    direction = np.sign(_fold(np.array([body.head[0] + (t + 1e-3) * body.velocity[0]]))[0] - head[0]) \
        if body.velocity[0] else 0.0
    velocity = np.array([abs(body.velocity[0]) * direction, 0.0, 0.0])
    return _Body(head, velocity, body.seated, body.gesture_m, body.folds, body.phase)


def generate_bodies(family: str, *, seed: int = 0, n_intervals: int = 60, mics: MicPair | None = None,
                    config: SyntheticConfig | None = None) -> list[Interval]:
    """``n_intervals`` intervals of the family ``family`` (:data:`FAMILIES`), as :class:`sim.synthetic.Interval`.

    The sensor noise, the outliers, the field of view and the speech statistics are ``config``'s (default the
    paper's, :class:`SyntheticConfig`); ``mics`` maps the mouths to ITDs (default ``MicPair()``).
    """
    if family not in FAMILIES:
        raise ValueError(f"family must be one of {', '.join(FAMILIES)}, got {family!r}")
    if not (isinstance(seed, (int, np.integer)) and seed >= 0):
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if n_intervals < 1:
        raise ValueError(f"n_intervals must be >= 1, got {n_intervals}")
    mics = MicPair() if mics is None else mics
    cfg = SyntheticConfig(n_intervals=n_intervals) if config is None else config
    rng = np.random.default_rng([int(seed), 18, FAMILIES.index(family)])
    truth_rng = np.random.default_rng([int(seed), 18, FAMILIES.index(family), 1])
    cast = _cast(rng, family, cfg)
    speaking = _speech(rng, replace(cfg, n_people=3, n_intervals=n_intervals))
    sampler = _Sampler(family, cfg.interval_s)
    out = []
    for k in range(n_intervals):
        t0 = k * cfg.interval_s
        bodies = [_at(b, t0) for b in cast]
        t_mid = 0.5 * cfg.interval_s
        table_y = (bodies[0].head[1] + 0.50) if family in _SEATED else None
        chunks, labels, truth, truth_ids, truth_speaking = [], [], [], [], []
        hidden, hidden_ids, hidden_speaking = [], [], []
        for i, body in enumerate(bodies):
            others = [o for j, o in enumerate(bodies) if j != i]
            m = int(rng.poisson(cfg.points_per_person))
            pts, _ = sampler.draw(rng, body, m, 0.0)
            keep = _visible(pts, others, cfg, t_mid, table_y)
            dense, _ = sampler.draw(truth_rng, body, 4000, 0.0)
            seen = _visible(dense, others, cfg, t_mid, table_y)
            if seen.mean() >= 0.3:
                truth.append(dense[seen].mean(axis=0))
                truth_ids.append(i)
                truth_speaking.append(bool(speaking[k, i]))
            else:  # present, too hidden to be in the truth: the centre of what is seen of them, or of the body
                hidden.append(dense[seen].mean(axis=0) if seen.any() else dense.mean(axis=0))
                hidden_ids.append(i)
                hidden_speaking.append(bool(speaking[k, i]))
            pts = _noisy(rng, pts[keep], cfg)
            chunks.append(pts)
            labels.append(np.full(pts.shape[0], i, dtype=np.int64))
        outliers = _frustum_points(rng, cfg, int(rng.poisson(cfg.outlier_points)))
        chunks.append(outliers)
        labels.append(np.full(outliers.shape[0], -1, dtype=np.int64))
        points, point_ids = np.concatenate(chunks), np.concatenate(labels)
        inside = _in_fov(points, cfg)
        order = rng.permutation(int(inside.sum()))
        points, point_ids = points[inside][order], point_ids[inside][order]
        itds, itd_ids = _itds(rng, cfg, mics, bodies, speaking[k])
        out.append(Interval(
            index=k, t_s=t0, interval_s=cfg.interval_s, points=points, point_ids=point_ids, itds=itds,
            itd_ids=itd_ids, truth_xyz=np.array(truth).reshape(-1, 3),
            truth_speaking=np.array(truth_speaking, dtype=bool), truth_ids=np.array(truth_ids, dtype=np.int64),
            hidden_xyz=np.array(hidden).reshape(-1, 3), hidden_speaking=np.array(hidden_speaking, dtype=bool),
            hidden_ids=np.array(hidden_ids, dtype=np.int64),
        ))
    return out


def _noisy(rng: np.random.Generator, pts: np.ndarray, cfg: SyntheticConfig) -> np.ndarray:
    """Stereo noise as :mod:`sim.synthetic`: along the viewing ray ~ z^2, and a little across."""
    z = np.maximum(pts[:, 2], 1e-3)
    out = pts * (1.0 + rng.normal(size=pts.shape[0]) * cfg.depth_noise_per_m * z)[:, None]
    out[:, :2] += rng.normal(size=(pts.shape[0], 2)) * cfg.lateral_noise_m
    return out


def _itds(rng: np.random.Generator, cfg: SyntheticConfig, mics: MicPair, bodies: list[_Body],
          speaking: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The interval's ITDs: from the talkers' mouths, with reverberation outliers; a few noise ITDs in silence."""
    lo, hi = mics.itd_interval()
    talkers = np.flatnonzero(speaking)
    if talkers.size:
        n_itd = int(rng.poisson(cfg.itds_when_speaking))
        ids = np.where(rng.random(n_itd) < cfg.itd_outlier_fraction, -1, rng.choice(talkers, size=n_itd))
    else:
        n_itd = int(rng.poisson(cfg.itds_when_silent))
        ids = np.full(n_itd, -1)
    times = np.sort(rng.random(n_itd))
    itds = rng.uniform(lo, hi, n_itd)
    mouth = np.array([0.0, 0.05, -0.08])
    for i in np.unique(ids[ids >= 0]):
        sel = ids == i
        start = bodies[i].head + mouth
        end = start + cfg.interval_s * bodies[i].velocity
        itds[sel] = _speaker_itds(rng, cfg, mics, start, end, times[sel])
    return itds, ids.astype(np.int64)
