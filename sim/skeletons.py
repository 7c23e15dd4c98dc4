"""Feature-level sequences of people with bodies, a second generator: posed skeletons, frame by frame.

:mod:`sim.bodies` draws points on a body's parts with a share per part; this module poses a skeleton at each of
the interval's six frames and keeps a surface point with a probability that grows with its speed, so the two were
written independently and a default can be chosen on one and checked on the other.

The section-7.1 sequences (:mod:`sim.synthetic`) draw each person as a Gaussian blob, the paper's own model
(section 3). Real Harris-motion points (section 4.2) are not a blob: a Harris corner needs texture (hair, the eyes
and mouth, a collar, clothing folds, sleeves, cuffs, fingers) and the motion filter keeps it only where the image
changes during the interval, so a seated talker yields points on the head and on the gesturing hands, few on a
plain shirt, none below the table. This module builds such sequences from geometry, with the same
:class:`sim.synthetic.Interval` objects, so that :func:`app.eval.synthetic` scoring applies unchanged.

Body
----
Each person is a set of rigid parts, each an elliptic cylinder or an ellipsoid around a segment between joints:
head (ellipsoid 16 x 23 x 19 cm), neck, torso (34 cm wide, 20 cm deep, 52 cm from the neck base to the pelvis),
two upper arms, two forearms, two hands, two thighs and two shins. Joint positions come from a small skeleton
(shoulders 19 cm from the spine, upper arm 29 cm, forearm 26 cm, thigh 45 cm, shin 43 cm) posed at every one of
the interval's six video frames: head sway and breathing for everyone; arm gestures (elbow and shoulder angles
moving sinusoidally, in bursts) that make the hands move much more than the head; walking (the body travels
between waypoints, legs and arms swing).

In full (every part, and why): docs/method.md ("The skeletons generator").
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from avcore.geometry import MicPair
# the room and the sensor (field of view, outliers, speech turns) are sim.synthetic's; the bodies are this module's
from sim.synthetic import Interval, _frustum_points, _in_fov, _speech

__all__ = ["FAMILIES", "STATIC_FAMILIES", "BodyConfig", "generate_family"]

FAMILIES = ("seated", "standing", "gesturing", "edge", "close", "behind")
STATIC_FAMILIES = ("seated", "gesturing", "edge", "close")

_N_FRAMES = 6  # video frames per interval (section 7: Delta t = 0.4 s, six frames)


@dataclass(frozen=True)
class BodyConfig:
    """Parameters of the body sequences (metres, seconds).

    n_intervals, interval_s : sequence length and Delta t (0.4 s, six frames).
    n_people : 3.
    camera_height_m : height of the cameras above the floor (a robot head at 1.2 m).
    candidates_per_person : mean number (Poisson) of candidate surface points per person and interval; about one
        in six becomes a motion point for an active talker, which gives a few hundred points per person, the
        paper's order of magnitude (2,000 points for three people and the outliers).
    motion_speed_mps : v0 of the motion filter: a point moving at v0 has half the detection probability of a
        fast one.
    max_points_per_person : at most this many motion points per person and interval (a Harris detector keeps
        a bounded number of corners per image; a walking person would otherwise give thousands).
    outlier_points : mean number (Poisson) of outliers uniform in the viewing frustum per interval.
    mismatch_fraction : share of a person's points matched wrongly in stereo: their depth is scaled by a factor
        uniform in 0.6-1.6 (the point slides along its viewing ray).
    lateral_noise_m, depth_noise_per_m : stereo noise as in :class:`sim.synthetic.SyntheticConfig`.
    fov_deg : (horizontal, vertical) full field of view, degrees.
    outlier_depth_m : depth range of the frustum outliers; also the nearest depth kept.
    min_visible_fraction : a person is in the ground truth when at least this share of its camera-facing surface
        above the table is visible.
    truth_point : "moving" (default): a person's ground-truth position is the centre of its visible moving body;
        "points": the mean of its motion points' distribution; "body": of its visible body, moving or not;
        "head": the centre of its head (see the module docstring).
    speaking_share, mean_talk_s, itds_when_speaking, itds_when_silent, itd_outlier_fraction, itd_sigma_s : the
        auditory side, as in :class:`sim.synthetic.SyntheticConfig`.
    """

    n_intervals: int = 60
    interval_s: float = 0.4
    n_people: int = 3
    camera_height_m: float = 1.2
    candidates_per_person: float = 10000.0
    motion_speed_mps: float = 0.04
    max_points_per_person: int = 700
    outlier_points: float = 230.0
    mismatch_fraction: float = 0.03
    lateral_noise_m: float = 0.01
    depth_noise_per_m: float = 0.005
    fov_deg: tuple[float, float] = (60.0, 45.0)
    outlier_depth_m: tuple[float, float] = (0.5, 6.0)
    min_visible_fraction: float = 0.3
    truth_point: str = "moving"
    speaking_share: float = 0.5
    mean_talk_s: float = 2.0
    itds_when_speaking: float = 22.0
    itds_when_silent: float = 2.0
    itd_outlier_fraction: float = 0.15
    itd_sigma_s: float = 25e-6

    def __post_init__(self) -> None:
        if not (isinstance(self.n_intervals, int) and self.n_intervals >= 1):
            raise ValueError(f"n_intervals must be a positive integer, got {self.n_intervals!r}")
        if self.n_people != 3:
            raise ValueError(f"n_people must be 3 (the families are scenes of three people), got {self.n_people!r}")
        for name in ("interval_s", "camera_height_m", "candidates_per_person", "motion_speed_mps", "itd_sigma_s",
                     "mean_talk_s"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        for name in ("mismatch_fraction", "min_visible_fraction", "itd_outlier_fraction"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0 <= v < 1):
                raise ValueError(f"{name} must be a fraction in [0, 1), got {v!r}")
        if self.truth_point not in ("moving", "points", "body", "head"):
            raise ValueError(f"truth_point must be 'moving', 'points', 'body' or 'head', got {self.truth_point!r}")
        if not 0 < self.speaking_share < 1:
            raise ValueError(f"speaking_share must be in (0, 1), got {self.speaking_share!r}")


# --------------------------------------------------------------------------------------------------------------
# Parts of a body. Kind 0: elliptic cylinder from joint a to joint b; kind 1: ellipsoid whose axis is a-b.

_PARTS = ("head", "neck", "torso", "upper_l", "upper_r", "fore_l", "fore_r", "hand_l", "hand_r",
          "thigh_l", "thigh_r", "shin_l", "shin_r")
_KIND = np.array([1, 0, 0, 0, 0, 0, 0, 1, 1, 0, 0, 0, 0])
# cross-section radii: rx along the part's side axis, rz along its forward axis (metres)
_RX = np.array([0.080, 0.055, 0.170, 0.045, 0.045, 0.038, 0.038, 0.045, 0.045, 0.075, 0.075, 0.050, 0.050])
_RZ = np.array([0.095, 0.055, 0.100, 0.045, 0.045, 0.038, 0.038, 0.020, 0.020, 0.075, 0.075, 0.050, 0.050])
_LEN = np.array([0.230, 0.090, 0.520, 0.290, 0.290, 0.260, 0.260, 0.100, 0.100, 0.450, 0.450, 0.430, 0.430])
_IDX = {name: i for i, name in enumerate(_PARTS)}


def _area() -> np.ndarray:
    r = 0.5 * (_RX + _RZ)
    cyl = 2 * np.pi * r * _LEN
    ell = 4 * np.pi * r * (0.5 * (r + 0.5 * _LEN))
    return np.where(_KIND == 1, ell, cyl)


_AREA = _area()


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _direction(down: np.ndarray, fwd: np.ndarray, side: np.ndarray, elev: float, azim: float) -> np.ndarray:
    """A limb direction: ``elev`` radians up from hanging down, turned ``azim`` radians from forward to ``side``."""
    return math.cos(elev) * down + math.sin(elev) * (math.cos(azim) * fwd + math.sin(azim) * side)


@dataclass
class _Person:
    """The state of one person; ``pose(t)`` gives the joints at time t (seconds)."""

    root: np.ndarray  # (3,) floor point under the pelvis at time 0 (y = camera height)
    seated: bool
    yaw: float  # radians: turn from facing the camera
    sway_amp: float
    sway_freq: float
    sway_phase: float
    gesture_amp: float
    gesture_freq: float
    gesture_phase: np.ndarray  # (4,)
    walk_speed: float = 0.0
    waypoints: tuple[np.ndarray, ...] = ()
    folds: np.ndarray | None = None  # (5, 4): s, phi, angle, length of clothing folds on the torso
    plain: float = 0.12  # texture of plain clothing

    def joints(self, t: float, pos: np.ndarray, moving: bool, gesturing: float) -> dict[str, np.ndarray]:
        down = np.array([0.0, 1.0, 0.0])
        to_cam = -pos * np.array([1.0, 0.0, 1.0])
        fwd0 = _unit(to_cam)
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        fwd = np.array([c * fwd0[0] - s * fwd0[2], 0.0, s * fwd0[0] + c * fwd0[2]])
        side = np.array([-fwd[2], 0.0, fwd[0]])
        w = 2 * math.pi * self.sway_freq * t + self.sway_phase
        sway = self.sway_amp * np.array([math.sin(w), 0.3 * math.sin(2 * w), 0.5 * math.cos(0.7 * w)])
        breath = 0.004 * math.sin(2 * math.pi * 0.25 * t + self.sway_phase)
        pelvis = pos + np.array([0.0, -(0.50 if self.seated else 0.95), 0.0])
        neck = pelvis + np.array([0.0, -0.52 + breath, 0.0]) + 0.3 * sway
        head_bottom = neck + np.array([0.0, -0.09, 0.0])
        head_centre = head_bottom + np.array([0.0, -0.115, 0.0]) + sway
        j: dict[str, np.ndarray] = {"fwd": fwd, "side": side}
        j["head"] = (head_centre + np.array([0.0, 0.115, 0.0]), head_centre - np.array([0.0, 0.115, 0.0]))
        j["neck"] = (neck, head_bottom)
        j["torso"] = (neck, pelvis)
        walk = 2 * math.pi * 0.9 * t
        for k, (sgn, lr) in enumerate(((1.0, "l"), (-1.0, "r"))):
            shoulder = neck + np.array([0.0, 0.04, 0.0]) + sgn * 0.19 * side
            g = self.gesture_amp * gesturing
            ph = self.gesture_phase[2 * k: 2 * k + 2]
            wg = 2 * math.pi * self.gesture_freq * t
            if moving and not self.seated:
                up_el, up_az = 0.25 * math.sin(walk + math.pi * k), 0.0
                fo_el = 0.4 + 0.2 * math.sin(walk + math.pi * k)
                fo_az = 0.0
            elif self.seated:
                up_el, up_az = 0.35, -0.2
                fo_el, fo_az = 1.45, -0.35
            else:
                up_el, up_az = 0.1, 0.1
                fo_el, fo_az = 0.9, -0.4
            up_el += 0.8 * g * (0.5 + 0.5 * math.sin(wg + ph[0]))
            up_az += 0.4 * g * math.sin(0.6 * wg + ph[1])
            fo_el += 0.9 * g * math.sin(wg + ph[1])
            fo_az += 0.8 * g * math.sin(1.3 * wg + ph[0])
            elbow = shoulder + _LEN[_IDX["upper_l"]] * _direction(down, fwd, sgn * side, up_el, up_az)
            d_fore = _direction(down, fwd, sgn * side, fo_el, fo_az)
            wrist = elbow + _LEN[_IDX["fore_l"]] * d_fore
            j["upper_" + lr] = (shoulder, elbow)
            j["fore_" + lr] = (elbow, wrist)
            j["hand_" + lr] = (wrist, wrist + 0.10 * d_fore)
            hip = pelvis + sgn * 0.09 * side
            if self.seated:
                knee = hip + 0.45 * fwd
                ankle = knee + 0.43 * down
            else:
                swing = 0.35 * math.sin(walk + math.pi * k) if moving else 0.0
                knee = hip + 0.45 * _direction(down, fwd, side, swing, 0.0)
                ankle = knee + 0.43 * _direction(down, fwd, side, swing - (0.3 if moving else 0.0), 0.0)
            j["thigh_" + lr] = (hip, knee)
            j["shin_" + lr] = (knee, ankle)
        return j


def _frames(joints: list[dict[str, np.ndarray]]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(F, P, 3) arrays a, b, e1 (side axis), e2 (forward axis) of every part at every frame."""
    a = np.array([[j[name][0] for name in _PARTS] for j in joints])
    b = np.array([[j[name][1] for name in _PARTS] for j in joints])
    fwd_dir = np.array([j["fwd"] for j in joints])[:, None, :]
    axis = _unit(b - a)
    fwd = fwd_dir - np.sum(fwd_dir * axis, axis=-1, keepdims=True) * axis
    # a limb pointing forward: use the down direction instead
    alt = np.array([0.0, 1.0, 0.0]) - axis[..., 1:2] * axis
    fwd = np.where(np.linalg.norm(fwd, axis=-1, keepdims=True) < 1e-3, alt, fwd)
    e2 = _unit(fwd)
    e1 = np.cross(axis, e2)
    return a, b, e1, e2


def _surface(a: np.ndarray, b: np.ndarray, e1: np.ndarray, e2: np.ndarray, part: np.ndarray, s: np.ndarray,
             phi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points and outward normals (n, 3) of the parts ``part`` at surface coordinates (s, phi); a, b, e1, e2 (n, 3)."""
    rx, rz = _RX[part][:, None], _RZ[part][:, None]
    ring = np.cos(phi)[:, None] * e1, np.sin(phi)[:, None] * e2
    ell = _KIND[part] == 1
    ct = np.where(ell, 1.0 - 2.0 * s, 0.0)[:, None]
    st = np.where(ell, np.sqrt(np.maximum(0.0, 1.0 - ct[:, 0] ** 2)), 1.0)[:, None]
    centre = np.where(ell[:, None], 0.5 * (a + b), a + s[:, None] * (b - a))
    half = 0.5 * (b - a)
    along = np.where(ell[:, None], ct * half, 0.0)
    pts = centre + along + st * (rx * ring[0] + rz * ring[1])
    hl = np.maximum(np.linalg.norm(half, axis=1, keepdims=True), 1e-6)
    normal = st * (ring[0] / rx + ring[1] / rz) + np.where(ell[:, None], ct * half / hl**2, 0.0)
    return pts, _unit(normal)


def _texture(person: _Person, part: np.ndarray, s: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Probability that a surface place holds a Harris corner (when it moves): 0..1.

    head: hair on top and at the back 0.9, eyes / nose / mouth 1.0, other skin 0.25; neck 0.2; torso: collar 1.0,
    clothing folds 0.9, belt line 0.6, plain cloth ``person.plain``; arms: elbow creases 0.7, cuffs 0.9, sleeve
    0.3; hands (fingers) 1.0; legs: knees and shoes 0.6-0.8, trousers 0.2.
    """
    tex = np.full(s.shape, 0.2)
    front = np.sin(phi)
    h = part == _IDX["head"]
    face = (front > 0.55) & (((s > 0.36) & (s < 0.5)) | ((s > 0.5) & (s < 0.62) & (np.abs(np.cos(phi)) < 0.3))
                             | ((s > 0.68) & (s < 0.8) & (np.abs(np.cos(phi)) < 0.45)))
    hair = (s < 0.32) | (front < -0.2)
    tex[h] = np.where(face[h], 1.0, np.where(hair[h], 0.9, 0.25))
    t = part == _IDX["torso"]
    tt = np.full(int(t.sum()), person.plain)
    st, pt = s[t], phi[t]
    if person.folds is not None:
        r = 0.5 * (_RX[_IDX["torso"]] + _RZ[_IDX["torso"]])
        for fs, fp, ang, length in person.folds:
            du = (st - fs) * _LEN[_IDX["torso"]]
            dv = np.angle(np.exp(1j * (pt - fp))) * r
            along = du * math.cos(ang) + dv * math.sin(ang)
            across = -du * math.sin(ang) + dv * math.cos(ang)
            tt = np.where((np.abs(across) < 0.012) & (np.abs(along) < 0.5 * length), 0.9, tt)
    tt = np.where(st > 0.93, 0.6, tt)
    tt = np.where(st < 0.06, 1.0, tt)
    tex[t] = tt
    for name in ("upper_l", "upper_r"):
        m = part == _IDX[name]
        tex[m] = np.where(s[m] > 0.85, 0.7, 0.3)
    for name in ("fore_l", "fore_r"):
        m = part == _IDX[name]
        tex[m] = np.where(s[m] < 0.12, 0.7, np.where(s[m] > 0.85, 0.9, 0.3))
    for name in ("hand_l", "hand_r"):
        tex[part == _IDX[name]] = 1.0
    for name in ("thigh_l", "thigh_r"):
        m = part == _IDX[name]
        tex[m] = np.where(s[m] > 0.85, 0.6, 0.2)
    for name in ("shin_l", "shin_r"):
        m = part == _IDX[name]
        tex[m] = np.where(s[m] > 0.85, 0.8, 0.2)
    return tex


# --------------------------------------------------------------------------------------------------------------
# Visibility


def _behind_table(pts: np.ndarray, table: tuple[float, float] | None) -> np.ndarray:
    """Points hidden by a table (with a front panel) whose top is at scene height y_top, front edge at depth z_front."""
    if table is None:
        return np.zeros(len(pts), dtype=bool)
    y_top, z_front = table
    # below the top and behind the front edge: hidden by the top or the front panel (the camera is above the top)
    return (pts[:, 1] > y_top) & (pts[:, 2] >= z_front)


def _occluded(pts: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Points covered in the image by any of the parts a-b (P, 3) of a nearer person (parts as projected capsules)."""
    u = pts[:, :2] / pts[:, 2:3]
    hidden = np.zeros(len(pts), dtype=bool)
    r = np.maximum(_RX, _RZ)
    for k in range(len(a)):
        zk = 0.5 * (a[k, 2] + b[k, 2])
        pa, pb = a[k, :2] / a[k, 2], b[k, :2] / b[k, 2]
        d = pb - pa
        t = np.clip(((u - pa) @ d) / max(float(d @ d), 1e-12), 0.0, 1.0)
        dist = np.linalg.norm(u - (pa + t[:, None] * d), axis=1)
        hidden |= (dist < r[k] / zk) & (pts[:, 2] > zk + r[k])
    return hidden


# --------------------------------------------------------------------------------------------------------------
# Scenes


@dataclass
class _Scene:
    people: list[_Person]
    table: tuple[float, float] | None
    gesture_on: np.ndarray  # (n_intervals, n_people) gesture level 0..1
    moving: np.ndarray  # (n_people,) bool


def _person(rng: np.random.Generator, x: float, z: float, cfg: BodyConfig, seated: bool, gesture: float) -> _Person:
    folds = np.stack([rng.uniform(0.1, 0.9, 5), rng.uniform(0.3, np.pi - 0.3, 5), rng.uniform(-1.2, 1.2, 5),
                      rng.uniform(0.08, 0.25, 5)], axis=1)
    return _Person(root=np.array([x, cfg.camera_height_m, z]), seated=seated, yaw=float(rng.uniform(-0.4, 0.4)),
                   sway_amp=float(rng.uniform(0.01, 0.025)), sway_freq=float(rng.uniform(0.2, 0.5)),
                   sway_phase=float(rng.uniform(0, 2 * np.pi)), gesture_amp=gesture,
                   gesture_freq=float(rng.uniform(0.5, 1.1)), gesture_phase=rng.uniform(0, 2 * np.pi, 4),
                   folds=folds, plain=float(rng.uniform(0.06, 0.25)))


def _at(az_deg: float, z: float) -> tuple[float, float]:
    return z * math.tan(math.radians(az_deg)), z


def _gesture_bursts(rng: np.random.Generator, n: int, p: int, on_share: float) -> np.ndarray:
    """(n, p) gesture levels: on/off bursts (mean 3 s on), smoothed over one interval."""
    stop = 0.4 / 3.0
    start = stop * on_share / (1 - on_share)
    state = rng.random(p) < on_share
    out = np.empty((n, p))
    for k in range(n):
        out[k] = state
        u = rng.random(p)
        state = np.where(state, u >= stop, u < start)
    return 0.3 + 0.7 * out


def _scene(family: str, rng: np.random.Generator, cfg: BodyConfig) -> _Scene:
    n, p = cfg.n_intervals, cfg.n_people
    table = None
    moving = np.zeros(p, dtype=bool)
    talk = 0.25  # gesture amplitude of an ordinary talker
    if family in ("seated", "close"):
        if family == "seated":
            az = np.sort(rng.uniform(-20, 20, 3))
            while np.min(np.diff(az)) < 14:
                az = np.sort(rng.uniform(-20, 20, 3))
            zs = rng.uniform(1.6, 3.0, 3)
            spots = [_at(a, z) for a, z in zip(az, zs)]
        else:
            side = float(rng.choice([-1.0, 1.0]))
            z = rng.uniform(1.7, 2.6)
            gap = rng.uniform(0.45, 0.60)
            x0 = _at(side * rng.uniform(3, 10), z)[0] - 0.5 * gap
            other = _at(-side * rng.uniform(15, 21), rng.uniform(1.6, 3.0))
            spots = [(x0, z), (x0 + gap, z + rng.uniform(-0.1, 0.1)), other]
        people = [_person(rng, x, z, cfg, True, talk) for x, z in spots]
        z_front = min(z for _, z in spots) - 0.55
        table = (cfg.camera_height_m - 0.75, z_front)
        gest = _gesture_bursts(rng, n, p, 0.5)
    elif family == "gesturing":
        az = np.sort(rng.uniform(-20, 20, 3))
        while np.min(np.diff(az)) < 14:
            az = np.sort(rng.uniform(-20, 20, 3))
        seated = rng.random(3) < 0.5
        people = [_person(rng, *_at(a, rng.uniform(1.7, 3.2)), cfg, bool(s), float(rng.uniform(0.6, 1.0)))
                  for a, s in zip(az, seated)]
        gest = _gesture_bursts(rng, n, p, 0.6)
    elif family == "edge":
        side = rng.choice([-1.0, 1.0])
        azs = [side * rng.uniform(27, 31), rng.uniform(-8, 8), -side * rng.uniform(18, 30)]
        people = [_person(rng, *_at(a, rng.uniform(1.8, 3.0)), cfg, False, talk) for a in azs]
        gest = _gesture_bursts(rng, n, p, 0.5)
    elif family == "standing":
        az = np.sort(rng.uniform(-18, 18, 3))
        while np.min(np.diff(az)) < 12:
            az = np.sort(rng.uniform(-18, 18, 3))
        people = []
        for a in az:
            home = np.array(_at(a, rng.uniform(2.0, 3.2)))
            pts = [home] + [np.array(_at(a + rng.uniform(-9, 9), rng.uniform(2.0, 3.4))) for _ in range(20)]
            person = _person(rng, home[0], home[1], cfg, False, talk)
            person.walk_speed, person.waypoints = float(rng.uniform(0.3, 0.6)), tuple(pts)
            people.append(person)
        moving[:] = True
        gest = _gesture_bursts(rng, n, p, 0.3)
    elif family == "behind":
        front = _at(rng.uniform(-5, 5), rng.uniform(1.6, 2.0))
        z_back = rng.uniform(3.0, 3.6)
        xa, xb = _at(-18, z_back)[0], _at(18, z_back)[0]
        walker = _person(rng, xa, z_back, cfg, False, talk)
        walker.walk_speed = float(rng.uniform(0.35, 0.55))
        walker.waypoints = tuple(np.array([x, z_back]) for x in [xa, xb] * 10)
        third = _at(rng.choice([-1, 1]) * rng.uniform(20, 24), rng.uniform(1.8, 2.6))
        people = [_person(rng, *front, cfg, False, talk), walker, _person(rng, *third, cfg, True, talk)]
        moving[1] = True
        gest = _gesture_bursts(rng, n, p, 0.5)
    else:
        raise ValueError(f"family must be one of {', '.join(FAMILIES)}, got {family!r}")
    return _Scene(people, table, gest, moving)


def _path(person: _Person, times: np.ndarray, cam_h: float) -> np.ndarray:
    """(len(times), 3) floor positions of a walker following its waypoints at constant speed, round a closed loop."""
    if not person.waypoints:
        return np.repeat(person.root[None], len(times), axis=0)
    wp = np.array([[w[0], w[1]] for w in person.waypoints] + [[person.waypoints[0][0], person.waypoints[0][1]]])
    seg = np.linalg.norm(np.diff(wp, axis=0), axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    d = np.mod(times * person.walk_speed, cum[-1])
    x = np.interp(d, cum, wp[:, 0])
    z = np.interp(d, cum, wp[:, 1])
    return np.stack([x, np.full_like(x, cam_h), z], axis=1)


def generate_family(family: str, *, seed: int = 0, mics: MicPair | None = None,
                    config: BodyConfig | None = None) -> list[Interval]:
    """Generate one sequence of the body family ``family`` (one of ``FAMILIES``; see the module docstring).

    Returns ``config.n_intervals`` :class:`sim.synthetic.Interval` objects; ``truth_xyz`` holds the centres of the
    visible bodies of the people in the ground truth, ``hidden_xyz`` those of the people present but too hidden.
    """
    if family not in FAMILIES:
        raise ValueError(f"family must be one of {', '.join(FAMILIES)}, got {family!r}")
    if not (isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0):
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    mics = MicPair() if mics is None else mics
    if not isinstance(mics, MicPair):
        raise TypeError(f"mics must be a MicPair, got {type(mics).__name__}")
    cfg = BodyConfig() if config is None else config
    if not isinstance(cfg, BodyConfig):
        raise TypeError(f"config must be a BodyConfig, got {type(cfg).__name__}")
    rng = np.random.default_rng([int(seed), 1000 + FAMILIES.index(family)])
    scene = _scene(family, rng, cfg)
    speaking = _speech(rng, cfg)
    return [_interval(rng, cfg, mics, scene, k, speaking[k]) for k in range(cfg.n_intervals)]


def _interval(rng: np.random.Generator, cfg: BodyConfig, mics: MicPair, scene: _Scene, k: int,
              speaking: np.ndarray) -> Interval:
    dt = cfg.interval_s
    times = k * dt + dt * np.arange(_N_FRAMES + 1) / _N_FRAMES
    frames = []
    mouths, heads = [], []
    for i, person in enumerate(scene.people):
        roots = _path(person, times, cfg.camera_height_m)
        moving = bool(scene.moving[i])
        js = [person.joints(float(t), roots[f], moving, float(scene.gesture_on[k, i]))
              for f, t in enumerate(times)]
        frames.append(_frames(js))
        heads.append(np.mean([0.5 * (j["head"][0] + j["head"][1]) for j in js], axis=0))
        head_a, head_b = js[_N_FRAMES // 2]["head"]
        mouths.append(0.5 * (head_a + head_b) + 0.3 * (head_a - head_b) + 0.09 * js[_N_FRAMES // 2]["fwd"])
    # nearest people first: a person can only be hidden by those in front
    depth = np.array([fr[0][_N_FRAMES // 2, _IDX["torso"], 2] for fr in frames])
    chunks, labels = [], []
    truth, visible = [], []
    for i in range(cfg.n_people):
        a, b, e1, e2 = frames[i]
        n_c = int(rng.poisson(cfg.candidates_per_person))
        part = rng.choice(len(_PARTS), size=n_c, p=_AREA / _AREA.sum())
        s, phi = rng.random(n_c), rng.uniform(0, 2 * np.pi, n_c)
        f = rng.integers(0, _N_FRAMES, n_c)
        p0, normal = _surface(a[f, part], b[f, part], e1[f, part], e2[f, part], part, s, phi)
        p1, _ = _surface(a[f + 1, part], b[f + 1, part], e1[f + 1, part], e2[f + 1, part], part, s, phi)
        facing = np.einsum("ij,ij->i", normal, -p0) > 0
        shown = facing & ~_behind_table(p0, scene.table)
        vis = shown & _in_fov(p0, cfg)
        for j in np.flatnonzero(depth < depth[i]):
            aj, bj = frames[j][0][_N_FRAMES // 2], frames[j][1][_N_FRAMES // 2]
            vis &= ~_occluded(p0, aj, bj)
        frac = vis.sum() / max(shown.sum(), 1)
        visible.append(frac >= cfg.min_visible_fraction)
        speed = np.linalg.norm(p1 - p0, axis=1) / (dt / _N_FRAMES)
        v0 = cfg.motion_speed_mps
        moves = speed**2 / (speed**2 + v0**2)  # the motion filter's share, without the texture
        texture = _texture(scene.people[i], part, s, phi)
        if cfg.truth_point == "head":
            truth.append(heads[i])
        elif cfg.truth_point in ("moving", "points"):
            w = moves * vis * (texture if cfg.truth_point == "points" else 1.0)
            truth.append((w @ p0) / w.sum() if w.sum() > 1e-9 else heads[i])
        else:
            truth.append(p0[vis].mean(axis=0) if vis.any() else p0[shown].mean(axis=0))
        prob = texture * moves
        take = vis & (rng.random(n_c) < prob)
        if take.sum() > cfg.max_points_per_person:  # the corner detector keeps a bounded number per image
            take[rng.choice(np.flatnonzero(take), int(take.sum()) - cfg.max_points_per_person, replace=False)] = False
        pts = 0.5 * (p0[take] + p1[take])
        m = len(pts)
        z = np.maximum(pts[:, 2], 1e-3)
        scale = 1.0 + rng.normal(size=m) * cfg.depth_noise_per_m * z
        bad = rng.random(m) < cfg.mismatch_fraction
        scale[bad] = rng.uniform(0.6, 1.6, int(bad.sum()))
        pts = pts * scale[:, None]
        pts[:, :2] += rng.normal(size=(m, 2)) * cfg.lateral_noise_m
        chunks.append(pts)
        labels.append(np.full(m, i, dtype=np.int64))
    out = _frustum_points(rng, cfg, int(rng.poisson(cfg.outlier_points)))
    chunks.append(out)
    labels.append(np.full(len(out), -1, dtype=np.int64))
    points, point_ids = np.concatenate(chunks), np.concatenate(labels)
    keep = _in_fov(points, cfg)
    order = rng.permutation(int(keep.sum()))
    points, point_ids = points[keep][order], point_ids[keep][order]

    lo, hi = mics.itd_interval()
    talkers = np.flatnonzero(speaking)
    if talkers.size:
        n_itd = int(rng.poisson(cfg.itds_when_speaking))
        itd_ids = np.where(rng.random(n_itd) < cfg.itd_outlier_fraction, -1,
                           rng.choice(talkers, size=n_itd)).astype(np.int64)
    else:
        n_itd = int(rng.poisson(cfg.itds_when_silent))
        itd_ids = np.full(n_itd, -1, dtype=np.int64)
    itds = rng.uniform(lo, hi, n_itd)
    for i in np.unique(itd_ids[itd_ids >= 0]):
        sel = itd_ids == i
        itds[sel] = np.clip(mics.itd(np.repeat(mouths[i][None], int(sel.sum()), axis=0))
                            + rng.normal(size=int(sel.sum())) * cfg.itd_sigma_s, lo, hi)
    vis = np.array(visible)
    ids = np.arange(cfg.n_people)
    truth_xyz = np.array(truth).reshape(-1, 3)
    return Interval(index=k, t_s=k * dt, interval_s=dt, points=points, point_ids=point_ids, itds=itds,
                    itd_ids=itd_ids, truth_xyz=truth_xyz[vis], truth_speaking=speaking[vis].copy(),
                    truth_ids=ids[vis], hidden_xyz=truth_xyz[~vis], hidden_speaking=speaking[~vis].copy(),
                    hidden_ids=ids[~vis])
