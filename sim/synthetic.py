"""Synthetic audio-visual sequences of the paper's section 7.1: StaCon, DynCon, StaVar and DynVar.

The paper evaluates its multimodal inference (section 6) on four synthetic sequences "containing one to three AV
objects [that] can move and [...] are not necessarily visible/audible along the entire sequence" (section 7.1),
with the statistics of section 7: a time interval Delta t = 0.4 s in which about 2,000 visual 3D points (HM3D) and
about 20 ITDs are observed, both "corrupted by noise and by outliers". The paper does not publish its generator;
this one reproduces those statistics with a simple physical story, so that each choice can be argued about:

* **People** (the AV objects) stand or walk 1.5-3.5 m in front of the robot inside a 60 x 45 degree field of view.
  A person's HM3D points are the moving parts of the body (head, hands, torso): an anisotropic Gaussian blob,
  taller than wide and thin in depth, around the person's position, which is the ground truth (section 3: the
  object generates features normally distributed around ``A(S_n)``).
* **Static** ("Sta") people do not move; **dynamic** ("Dyn") people walk at 0.3-0.6 m/s between random waypoints
  around their own place, so that neighbours sometimes cross each other in ITD space. A walking person's points are
  spread along the 0.4 s of motion and the ground truth is the mean position over the interval.
* **Constant** ("Con") sequences keep the three people in view all the time (the paper's tables count 408 = 3 x
  136 ground-truth objects for StaCon and DynCon). In **varying** ("Var") sequences people enter and leave the
  field of view, one at a time, so that one to three are visible (the paper counts 229 objects in 136 intervals,
  1.68 per interval). A person outside the field of view has no visual points and is not in the ground truth, but
  can still be heard: the microphones hear around the robot, the cameras see only in front.
* **Speech**: each person talks in spurts (an on/off Markov chain per interval); a speaking person yields ITDs
  around the mapped position ``mics.itd(S)`` (eq. itd_up) with Gaussian noise; reverberation adds outlier ITDs
  uniform over the ITD interval, and a few noise ITDs pass the energy gate when nobody speaks.
* **Noise and outliers**: stereo reconstruction jitters every point (a centimetre across, and along the viewing
  ray by an amount growing with depth squared, like stereo); wrong matches and background motion give outlier
  points uniform in the 3D viewing frustum (0.5-6 m), whose projections onto ITD space are *not* uniform, as the
  paper observes (section 7).

Scene frame and units follow docs/architecture.md: metres, seconds; x right, y down, z forward; ITD = t_left - t_right.
Everything is drawn from ``np.random.default_rng`` seeded by ``(seed, sequence index)``: a seed gives the same
sequence on every machine.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from avcore.geometry import MicPair
from sim.presets import SEQUENCES

__all__ = [
    "SEQUENCES",
    "SyntheticConfig",
    "Interval",
    "SequenceSummary",
    "generate_sequence",
    "summarize",
    "format_summaries",
]



def _check_positive(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")


def _check_non_negative(name: str, value: float) -> None:
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a non-negative finite number, got {value!r}")


def _check_fraction(name: str, value: float, *, closed_high: bool = False) -> None:
    ok = isinstance(value, (int, float)) and 0 <= value and (value <= 1 if closed_high else value < 1)
    if not ok:
        high = "1]" if closed_high else "1)"
        raise ValueError(f"{name} must be a fraction in [0, {high}, got {value!r}")


def _check_range(name: str, value: object, *, low: float = -math.inf, high: float = math.inf) -> None:
    ok = (
        isinstance(value, tuple)
        and len(value) == 2
        and all(isinstance(v, (int, float)) and math.isfinite(v) for v in value)
        and low <= value[0] <= value[1] <= high
    )
    if not ok:
        raise ValueError(f"{name} must be a tuple (lo, hi) with {low} <= lo <= hi <= {high}, got {value!r}")


@dataclass(frozen=True)
class SyntheticConfig:
    """Parameters of the synthetic sequences; the defaults give the statistics of the paper's sections 7 and 7.1.

    Time
    ----
    n_intervals : int
        Intervals per sequence. 136: the paper's tables count 408 = 3 x 136 ground-truth objects for the
        three-person StaCon and DynCon.
    interval_s : float, seconds
        Delta t of section 7: 0.4 s, six video frames.

    In full (every part, and why): docs/method.md ("The synthetic sequences' parameters").
    """

    n_intervals: int = 136
    interval_s: float = 0.4
    n_people: int = 3
    depth_m: tuple[float, float] = (1.5, 3.5)
    height_m: tuple[float, float] = (-0.15, 0.10)
    max_azimuth_deg: float = 22.0
    visible_azimuth_deg: float = 27.0
    min_separation_deg: float = 15.0
    roam_deg: float = 10.0
    away_azimuth_deg: tuple[float, float] = (35.0, 50.0)
    walk_speed_mps: tuple[float, float] = (0.3, 0.6)
    segment_s: tuple[float, float] = (6.0, 16.0)
    leave_prob: float = 0.8
    points_per_person: float = 590.0
    outlier_points: float = 230.0
    body_sigma_m: tuple[float, float, float] = (0.12, 0.25, 0.08)
    lateral_noise_m: float = 0.01
    depth_noise_per_m: float = 0.005
    fov_deg: tuple[float, float] = (60.0, 45.0)
    outlier_depth_m: tuple[float, float] = (0.5, 6.0)
    speaking_share: float = 0.5
    mean_talk_s: float = 2.0
    itds_when_speaking: float = 22.0
    itds_when_silent: float = 2.0
    itd_outlier_fraction: float = 0.15
    itd_sigma_s: float = 25e-6

    def __post_init__(self) -> None:
        for name in ("n_intervals", "n_people"):
            value = getattr(self, name)
            if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        for name in ("interval_s", "max_azimuth_deg", "visible_azimuth_deg", "mean_talk_s", "itd_sigma_s"):
            _check_positive(name, getattr(self, name))
        for name in (
            "min_separation_deg",
            "roam_deg",
            "points_per_person",
            "outlier_points",
            "lateral_noise_m",
            "depth_noise_per_m",
            "itds_when_speaking",
            "itds_when_silent",
        ):
            _check_non_negative(name, getattr(self, name))
        _check_fraction("leave_prob", self.leave_prob, closed_high=True)
        _check_fraction("speaking_share", self.speaking_share)
        _check_fraction("itd_outlier_fraction", self.itd_outlier_fraction, closed_high=True)
        _check_range("depth_m", self.depth_m, low=0.1)
        _check_range("height_m", self.height_m)
        _check_range("away_azimuth_deg", self.away_azimuth_deg, low=0.0, high=89.0)
        _check_range("walk_speed_mps", self.walk_speed_mps, low=0.0)
        _check_range("segment_s", self.segment_s, low=0.0)
        _check_range("outlier_depth_m", self.outlier_depth_m, low=0.0)
        if self.outlier_depth_m[1] <= self.outlier_depth_m[0]:
            raise ValueError(f"outlier_depth_m must be a non-empty range, got {self.outlier_depth_m!r}")
        sig = self.body_sigma_m
        if not (isinstance(sig, tuple) and len(sig) == 3 and all(isinstance(s, (int, float)) and s >= 0 for s in sig)):
            raise ValueError(f"body_sigma_m must be three non-negative standard deviations in metres, got {sig!r}")
        fov = self.fov_deg
        if not (isinstance(fov, tuple) and len(fov) == 2 and all(isinstance(a, (int, float)) and 0 < a < 180 for a in fov)):
            raise ValueError(f"fov_deg must be (horizontal, vertical) full angles in (0, 180) degrees, got {fov!r}")
        if not self.max_azimuth_deg <= self.visible_azimuth_deg <= fov[0] / 2:
            raise ValueError(
                "need max_azimuth_deg <= visible_azimuth_deg <= fov_deg[0] / 2, got "
                f"{self.max_azimuth_deg!r}, {self.visible_azimuth_deg!r}, {fov[0] / 2!r}"
            )
        if self.away_azimuth_deg[0] <= self.visible_azimuth_deg:
            raise ValueError(
                f"away_azimuth_deg must start beyond visible_azimuth_deg = {self.visible_azimuth_deg!r}, "
                f"got {self.away_azimuth_deg!r}"
            )
        if (self.n_people - 1) * self.min_separation_deg > 2 * self.max_azimuth_deg:
            raise ValueError(
                f"{self.n_people} people {self.min_separation_deg} degrees apart do not fit within "
                f"+-{self.max_azimuth_deg} degrees; lower min_separation_deg or n_people"
            )


@dataclass(frozen=True, eq=False)
class Interval:
    """One time interval of a synthetic sequence: the observations and their ground truth.

    Attributes
    ----------
    index : int
        Position of the interval in the sequence, from 0.
    t_s : float, seconds
        Start time; the interval covers ``[t_s, t_s + interval_s)``.
    interval_s : float, seconds
        Delta t.
    points : (M, 3) float, metres
        Visual 3D points (HM3D-like) in the scene frame, in random order.
    point_ids : (M,) int
        The person id that generated each point, -1 for an outlier (for diagnostics; a method must not use it).
    itds : (K,) float, seconds
        ITD observations, in time order (ITD = t_left - t_right).
    itd_ids : (K,) int
        The person id that generated each ITD, -1 for an outlier.
    truth_xyz : (G, 3) float, metres
        Ground truth: the interval-mean positions of the visible people, what a detector should find.
    truth_speaking : (G,) bool
        Whether each visible person speaks in this interval.
    truth_ids : (G,) int
        Person ids of the visible people, stable across intervals, increasing.
    hidden_xyz : (H, 3) float, metres
        Interval-mean positions of the people present but out of view (Var sequences): audible, not visible, not
        in the ground truth.
    hidden_speaking : (H,) bool
        Whether each hidden person speaks (it then contributes ITDs without points).
    hidden_ids : (H,) int
        Person ids of the hidden people.
    """

    index: int
    t_s: float
    interval_s: float
    points: np.ndarray
    point_ids: np.ndarray
    itds: np.ndarray
    itd_ids: np.ndarray
    truth_xyz: np.ndarray
    truth_speaking: np.ndarray
    truth_ids: np.ndarray
    hidden_xyz: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    hidden_speaking: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    hidden_ids: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def __post_init__(self) -> None:
        for name in (
            "points",
            "point_ids",
            "itds",
            "itd_ids",
            "truth_xyz",
            "truth_speaking",
            "truth_ids",
            "hidden_xyz",
            "hidden_speaking",
            "hidden_ids",
        ):
            getattr(self, name).setflags(write=False)  # frozen means frozen: the arrays too


# --------------------------------------------------------------------------------------------------------------
# People: positions over time


def _position(azimuth_deg: np.ndarray, depth: np.ndarray, height: np.ndarray) -> np.ndarray:
    """Scene-frame positions (..., 3) from azimuth atan2(x, z) in degrees, depth z and height y, metres."""
    az = np.radians(azimuth_deg)
    return np.stack([depth * np.tan(az), height, depth], axis=-1)


def _azimuth_deg(xyz: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(xyz[..., 0], xyz[..., 2]))


def _spot_near(rng: np.random.Generator, cfg: SyntheticConfig, home: np.ndarray) -> np.ndarray:
    """(3,) random waypoint in view within ``roam_deg`` of the azimuth of ``home``."""
    centre = float(_azimuth_deg(home))
    lo = max(-cfg.max_azimuth_deg, centre - cfg.roam_deg)
    hi = min(cfg.max_azimuth_deg, centre + cfg.roam_deg)
    az = rng.uniform(lo, hi)
    return _position(np.array(az), np.array(rng.uniform(*cfg.depth_m)), np.array(rng.uniform(*cfg.height_m)))


def _spot_away(rng: np.random.Generator, cfg: SyntheticConfig, side: float) -> np.ndarray:
    """(3,) random position out of view on one side (side > 0: right, x > 0)."""
    az = math.copysign(rng.uniform(*cfg.away_azimuth_deg), side)
    return _position(np.array(az), np.array(rng.uniform(*cfg.depth_m)), np.array(rng.uniform(*cfg.height_m)))


def _separated_spots(rng: np.random.Generator, cfg: SyntheticConfig) -> np.ndarray:
    """(n_people, 3) positions in view whose azimuths are at least ``min_separation_deg`` apart, in random order.

    Uniform over the allowed azimuth configurations: draw sorted positions in the range shortened by the gaps,
    then put the gaps back.
    """
    n = cfg.n_people
    slack = 2 * cfg.max_azimuth_deg - (n - 1) * cfg.min_separation_deg
    az = np.sort(rng.uniform(0.0, slack, n)) + cfg.min_separation_deg * np.arange(n) - cfg.max_azimuth_deg
    az = rng.permutation(az)
    return _position(az, rng.uniform(*cfg.depth_m, n), rng.uniform(*cfg.height_m, n))


def _random_side(rng: np.random.Generator, x: float) -> float:
    return x if x != 0 else (1.0 if rng.random() < 0.5 else -1.0)


def _simulate_people(
    rng: np.random.Generator, cfg: SyntheticConfig, dynamic: bool, varying: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Positions of the cast at the start and end of every interval.

    Returns ``starts, ends``, each (n_intervals, n_people, 3) metres; within an interval a person moves on the
    straight line from start to end at constant speed (static people: start == end).

    Var sequences change who is in view every ``segment_s``: with one person in view someone enters, with all in
    view someone leaves, otherwise one leaves with probability ``leave_prob``. A person may leave only when another
    person is visible, so that at least one stays in view (the paper's "one to three AV objects"). Static people
    jump between their place in view and their place away; dynamic ones walk there.
    """
    n, p, dt = cfg.n_intervals, cfg.n_people, cfg.interval_s
    homes = _separated_spots(rng, cfg)
    aways = np.stack([_spot_away(rng, cfg, _random_side(rng, homes[i, 0])) for i in range(p)])

    in_view = np.ones(p, dtype=bool)
    if varying:
        n_in = int(rng.integers(1, p + 1))
        in_view[:] = False
        in_view[rng.choice(p, size=n_in, replace=False)] = True
    pos = np.where(in_view[:, None], homes, aways)
    target = pos.copy()
    speed = np.zeros(p)

    def new_leg(i: int) -> None:
        if in_view[i]:
            target[i] = _spot_near(rng, cfg, homes[i])
        else:
            target[i] = _spot_away(rng, cfg, _random_side(rng, pos[i, 0]))
        speed[i] = rng.uniform(*cfg.walk_speed_mps)

    if dynamic:
        for i in range(p):
            new_leg(i)

    def draw_segment() -> int:
        return max(1, int(round(rng.uniform(*cfg.segment_s) / dt)))

    timer = draw_segment()
    starts = np.empty((n, p, 3))
    ends = np.empty((n, p, 3))
    for k in range(n):
        if varying and timer <= 0:
            visible_now = np.abs(_azimuth_deg(pos)) <= cfg.visible_azimuth_deg
            others_visible = [bool(np.any(visible_now & in_view & (np.arange(p) != i))) for i in range(p)]
            leavers = [i for i in range(p) if in_view[i] and others_visible[i]]
            enterers = [i for i in range(p) if not in_view[i]]
            if not enterers:
                leave = True
            elif in_view.sum() <= 1:
                leave = False
            else:
                leave = bool(rng.random() < cfg.leave_prob)
            if leave and not leavers:
                leave = False  # the others are still walking in: nobody may leave yet
            if leave or enterers:
                who = int(rng.choice(leavers if leave else enterers))
                in_view[who] = not leave
                if dynamic:
                    new_leg(who)
                else:
                    pos[who] = homes[who] if in_view[who] else aways[who]
                timer = draw_segment()
            else:
                timer = 1  # all in view and nobody may leave yet: retry at the next interval
        timer -= 1
        starts[k] = pos
        if dynamic:
            for i in range(p):
                step = speed[i] * dt
                to_go = target[i] - pos[i]
                dist = float(np.linalg.norm(to_go))
                if dist <= step:
                    pos[i] = target[i]
                    new_leg(i)
                else:
                    pos[i] = pos[i] + to_go * (step / dist)
        ends[k] = pos
    return starts, ends


def _speech(rng: np.random.Generator, cfg: SyntheticConfig) -> np.ndarray:
    """(n_intervals, n_people) bool speaking states: one two-state Markov chain per person.

    A spurt ends with probability ``interval_s / mean_talk_s`` per interval; a pause ends with the probability that
    makes ``speaking_share`` the stationary fraction of speaking intervals. The first state is drawn from it.
    """
    n, p = cfg.n_intervals, cfg.n_people
    stop = min(1.0, cfg.interval_s / cfg.mean_talk_s)
    start = min(1.0, stop * cfg.speaking_share / (1.0 - cfg.speaking_share))
    on = np.empty((n, p), dtype=bool)
    state = rng.random(p) < cfg.speaking_share
    for k in range(n):
        on[k] = state
        u = rng.random(p)
        state = np.where(state, u >= stop, u < start)
    return on


# --------------------------------------------------------------------------------------------------------------
# Observations of one interval


def _in_fov(points: np.ndarray, cfg: SyntheticConfig) -> np.ndarray:
    z = points[:, 2]
    tan_h = math.tan(math.radians(cfg.fov_deg[0] / 2))
    tan_v = math.tan(math.radians(cfg.fov_deg[1] / 2))
    return (z >= cfg.outlier_depth_m[0]) & (np.abs(points[:, 0]) <= z * tan_h) & (np.abs(points[:, 1]) <= z * tan_v)


def _frustum_points(rng: np.random.Generator, cfg: SyntheticConfig, n: int) -> np.ndarray:
    """(n, 3) points uniform by volume in the viewing frustum between the depths of ``outlier_depth_m``."""
    z0, z1 = cfg.outlier_depth_m
    z = np.cbrt(z0**3 + rng.random(n) * (z1**3 - z0**3))  # the cross-section grows as z^2
    tan_h = math.tan(math.radians(cfg.fov_deg[0] / 2))
    tan_v = math.tan(math.radians(cfg.fov_deg[1] / 2))
    x = rng.uniform(-1.0, 1.0, n) * z * tan_h
    y = rng.uniform(-1.0, 1.0, n) * z * tan_v
    return np.stack([x, y, z], axis=-1)


def _person_points(rng: np.random.Generator, cfg: SyntheticConfig, start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """(m, 3) noisy motion points of one person moving from ``start`` to ``end`` during the interval."""
    m = int(rng.poisson(cfg.points_per_person))
    u = rng.random(m)[:, None]  # when, within the interval, the point was seen: smears a walker along its path
    centres = start + u * (end - start)
    pts = centres + rng.normal(size=(m, 3)) * np.asarray(cfg.body_sigma_m)
    # Stereo noise: a disparity error moves a point along its viewing ray by sigma_z = k z^2, i.e. scales it by
    # (1 + dz / z) with dz / z ~ N(0, k z); plus a small jitter across the ray.
    z = np.maximum(pts[:, 2], 1e-3)
    pts = pts * (1.0 + rng.normal(size=m) * cfg.depth_noise_per_m * z)[:, None]
    pts[:, :2] += rng.normal(size=(m, 2)) * cfg.lateral_noise_m
    return pts


def _speaker_itds(
    rng: np.random.Generator, cfg: SyntheticConfig, mics: MicPair, start: np.ndarray, end: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """ITDs of one speaker at the interval fractions ``u`` (K,), seconds, redrawn until inside the ITD interval."""
    lo, hi = mics.itd_interval()
    clean = mics.itd(start + u[:, None] * (end - start))
    noise = rng.normal(size=u.size) * cfg.itd_sigma_s
    bad = (clean + noise < lo) | (clean + noise > hi)
    for _ in range(100):  # a truncated Gaussian; a mean near the edge needs a few redraws
        if not bad.any():
            break
        noise[bad] = rng.normal(size=int(bad.sum())) * cfg.itd_sigma_s
        bad = (clean + noise < lo) | (clean + noise > hi)
    return np.clip(clean + noise, lo, hi)


def _interval(
    rng: np.random.Generator,
    cfg: SyntheticConfig,
    mics: MicPair,
    k: int,
    starts: np.ndarray,
    ends: np.ndarray,
    speaking: np.ndarray,
) -> Interval:
    mean_pos = 0.5 * (starts + ends)  # the mean position over the interval (constant speed within it)
    visible = np.abs(_azimuth_deg(mean_pos)) <= cfg.visible_azimuth_deg
    ids = np.arange(cfg.n_people)

    # Visual observations.
    chunks, labels = [], []
    for i in np.flatnonzero(visible):
        pts = _person_points(rng, cfg, starts[i], ends[i])
        chunks.append(pts)
        labels.append(np.full(len(pts), i, dtype=np.int64))
    outliers = _frustum_points(rng, cfg, int(rng.poisson(cfg.outlier_points)))
    chunks.append(outliers)
    labels.append(np.full(len(outliers), -1, dtype=np.int64))
    points = np.concatenate(chunks)
    point_ids = np.concatenate(labels)
    keep = _in_fov(points, cfg)
    order = rng.permutation(int(keep.sum()))
    points, point_ids = points[keep][order], point_ids[keep][order]

    # Auditory observations: one ITD per analysis window, each dominated by one speaker or by reverberation.
    lo, hi = mics.itd_interval()
    talkers = np.flatnonzero(speaking)
    if talkers.size:
        n_itd = int(rng.poisson(cfg.itds_when_speaking))
        itd_ids = np.where(
            rng.random(n_itd) < cfg.itd_outlier_fraction, -1, rng.choice(talkers, size=n_itd)
        ).astype(np.int64)
    else:
        n_itd = int(rng.poisson(cfg.itds_when_silent))
        itd_ids = np.full(n_itd, -1, dtype=np.int64)
    times = np.sort(rng.random(n_itd))  # fractions of the interval: the ITD track is in time order
    itds = rng.uniform(lo, hi, n_itd)
    for i in np.unique(itd_ids[itd_ids >= 0]):
        sel = itd_ids == i
        itds[sel] = _speaker_itds(rng, cfg, mics, starts[i], ends[i], times[sel])

    hidden = ~visible
    return Interval(
        index=k,
        t_s=k * cfg.interval_s,
        interval_s=cfg.interval_s,
        points=points,
        point_ids=point_ids,
        itds=itds,
        itd_ids=itd_ids,
        truth_xyz=mean_pos[visible],
        truth_speaking=speaking[visible].copy(),
        truth_ids=ids[visible],
        hidden_xyz=mean_pos[hidden],
        hidden_speaking=speaking[hidden].copy(),
        hidden_ids=ids[hidden],
    )


def generate_sequence(
    name: str, *, seed: int = 0, mics: MicPair | None = None, config: SyntheticConfig | None = None
) -> list[Interval]:
    """Generate one synthetic sequence of section 7.1.

    Parameters
    ----------
    name : {"StaCon", "DynCon", "StaVar", "DynVar"}
        The sequence type: static or dynamic people, constant or varying number in view.
    seed : int >= 0
        Seed of ``np.random.default_rng``, combined with the sequence type (the four types differ for one seed).
    mics : MicPair, optional
        The microphone pair and its affine correction that map positions to ITDs (eq. itd_up); default ``MicPair()``.
    config : SyntheticConfig, optional
        The generator's parameters; default ``SyntheticConfig()``, the paper's statistics.

    Returns
    -------
    list of Interval
        ``config.n_intervals`` consecutive intervals of ``config.interval_s`` seconds.
    """
    if name not in SEQUENCES:
        raise ValueError(f"name must be one of {', '.join(SEQUENCES)}, got {name!r}")
    if not (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0):
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    mics = MicPair() if mics is None else mics
    if not isinstance(mics, MicPair):
        raise TypeError(f"mics must be a MicPair, got {type(mics).__name__}")
    cfg = SyntheticConfig() if config is None else config
    if not isinstance(cfg, SyntheticConfig):
        raise TypeError(f"config must be a SyntheticConfig, got {type(cfg).__name__}")
    dynamic, varying = name.startswith("Dyn"), name.endswith("Var")
    if varying and cfg.n_people < 2:
        raise ValueError(f"{name} needs config.n_people >= 2 so that the number in view can vary, got {cfg.n_people}")

    rng = np.random.default_rng([int(seed), SEQUENCES.index(name)])
    starts, ends = _simulate_people(rng, cfg, dynamic, varying)
    speaking = _speech(rng, cfg)
    return [_interval(rng, cfg, mics, k, starts[k], ends[k], speaking[k]) for k in range(cfg.n_intervals)]


# --------------------------------------------------------------------------------------------------------------
# Summary


@dataclass(frozen=True)
class SequenceSummary:
    """Statistics of a generated sequence, to compare with the paper's (sections 7 and 7.1).

    Attributes
    ----------
    name : str
        Label given to :func:`summarize`.
    n_intervals : int
    mean_points, mean_itds : float
        Mean M and mean K per interval (the paper: about 2,000 and 20).
    object_intervals : int
        Ground-truth objects summed over the intervals (the paper: 408 for StaCon/DynCon, 229 for StaVar/DynVar).
    min_visible, max_visible : int
        Fewest and most people in view in one interval.
    speaking_share : float
        Fraction of the ground-truth objects that speak (the denominator of table 2's TP + FN).
    hidden_speaking_intervals : int
        Intervals in which someone out of view speaks (ITDs without points).
    silent_intervals : int
        Intervals in which nobody speaks.
    point_outlier_share, itd_outlier_share : float
        Fractions of the points and ITDs that are outliers.
    mean_speed_mps : float, m/s
        Mean speed of the ground truth between consecutive intervals (0 for static sequences).
    """

    name: str
    n_intervals: int
    mean_points: float
    mean_itds: float
    object_intervals: int
    min_visible: int
    max_visible: int
    speaking_share: float
    hidden_speaking_intervals: int
    silent_intervals: int
    point_outlier_share: float
    itd_outlier_share: float
    mean_speed_mps: float


def summarize(intervals: list[Interval], name: str = "") -> SequenceSummary:
    """Summarise a generated sequence (see :class:`SequenceSummary`)."""
    if not intervals:
        raise ValueError("intervals must hold at least one Interval, got none")
    n_points = np.array([len(iv.points) for iv in intervals])
    n_itds = np.array([len(iv.itds) for iv in intervals])
    n_visible = np.array([len(iv.truth_ids) for iv in intervals])
    speaking = np.concatenate([iv.truth_speaking for iv in intervals])
    point_ids = np.concatenate([iv.point_ids for iv in intervals])
    itd_ids = np.concatenate([iv.itd_ids for iv in intervals])
    anyone = [bool(iv.truth_speaking.any() or iv.hidden_speaking.any()) for iv in intervals]
    speeds = []
    for a, b in zip(intervals[:-1], intervals[1:]):
        common, ia, ib = np.intersect1d(a.truth_ids, b.truth_ids, return_indices=True)
        if common.size:
            step = np.linalg.norm(b.truth_xyz[ib] - a.truth_xyz[ia], axis=1) / (b.t_s - a.t_s)
            speeds.extend(step.tolist())
    return SequenceSummary(
        name=name,
        n_intervals=len(intervals),
        mean_points=float(n_points.mean()),
        mean_itds=float(n_itds.mean()),
        object_intervals=int(n_visible.sum()),
        min_visible=int(n_visible.min()),
        max_visible=int(n_visible.max()),
        speaking_share=float(speaking.mean()) if speaking.size else math.nan,
        hidden_speaking_intervals=sum(bool(iv.hidden_speaking.any()) for iv in intervals),
        silent_intervals=len(intervals) - sum(anyone),
        point_outlier_share=float(np.mean(point_ids < 0)) if point_ids.size else math.nan,
        itd_outlier_share=float(np.mean(itd_ids < 0)) if itd_ids.size else math.nan,
        mean_speed_mps=float(np.mean(speeds)) if speeds else 0.0,
    )


def format_summaries(summaries: list[SequenceSummary]) -> str:
    """A plain-text table of summaries, one row per sequence (for documentation and the CLI)."""
    header = (
        f"{'sequence':<10}{'intervals':>10}{'mean M':>9}{'mean K':>8}{'objects':>9}{'in view':>9}"
        f"{'speaking':>10}{'hidden spk':>11}{'silent':>8}{'pt out':>8}{'itd out':>9}{'speed':>8}"
    )
    rows = [header]
    for s in summaries:
        rows.append(
            f"{s.name:<10}{s.n_intervals:>10d}{s.mean_points:>9.0f}{s.mean_itds:>8.1f}{s.object_intervals:>9d}"
            f"{f'{s.min_visible}-{s.max_visible}':>9}{s.speaking_share:>10.2f}{s.hidden_speaking_intervals:>11d}"
            f"{s.silent_intervals:>8d}{s.point_outlier_share:>8.2f}{s.itd_outlier_share:>9.2f}"
            f"{s.mean_speed_mps:>8.2f}"
        )
    return "\n".join(rows)
