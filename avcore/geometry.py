"""The deterministic part of the model: the auditory mapping from the scene to ITD space.

Conventions (docs/architecture.md): metres and seconds; the scene frame is the cyclopean frame of the rectified stereo
pair (x right, y down, z forward); ITD = (arrival time at the LEFT microphone) - (arrival time at the RIGHT microphone),
so a source on the right, closer to the right microphone, has a positive ITD.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ARRAY_PRESETS", "MicArray", "MicPair", "SPEED_OF_SOUND"]

SPEED_OF_SOUND = 343.0  # m/s, docs/architecture.md default


def _as_position(value: object, name: str) -> tuple[float, float, float]:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be three finite coordinates in metres, got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


@dataclass(frozen=True)
class MicPair:
    """Two microphones in the scene frame and the affine audio-visual correction.

    Parameters
    ----------
    left, right : (3,) float, metres
        Microphone positions M_L and M_R in the scene (cyclopean) frame.
    speed_of_sound : float, m/s
        nu of the paper's eq. (itd).
    c1, c0 : float (dimensionless, seconds)
        The affine correction of eq. (itd_up): ``A_bar(S) = c1 * A(S) + c0``, fitted by the audio-visual
        calibration (section 5.3). The defaults are the identity.
    """

    left: tuple[float, float, float] = (-0.06, 0.0, 0.0)
    right: tuple[float, float, float] = (0.06, 0.0, 0.0)
    speed_of_sound: float = SPEED_OF_SOUND
    c1: float = 1.0
    c0: float = 0.0

    def __post_init__(self) -> None:
        left = _as_position(self.left, "left")
        right = _as_position(self.right, "right")
        object.__setattr__(self, "left", left)
        object.__setattr__(self, "right", right)
        if left == right:
            raise ValueError("left and right microphones are at the same position; give their two positions")
        if not (np.isfinite(self.speed_of_sound) and self.speed_of_sound > 0):
            raise ValueError(f"speed_of_sound must be a positive number of m/s, got {self.speed_of_sound!r}")
        if not (np.isfinite(self.c1) and self.c1 != 0):
            raise ValueError(f"c1 must be a finite non-zero scale, got {self.c1!r}")
        if not np.isfinite(self.c0):
            raise ValueError(f"c0 must be a finite offset in seconds, got {self.c0!r}")

    @property
    def distance_m(self) -> float:
        """Distance between the two microphones, metres."""
        return float(np.linalg.norm(np.subtract(self.right, self.left)))

    @property
    def max_itd_s(self) -> float:
        """Largest |A(S)| of eq. (itd) over the whole scene: the microphone distance over nu (triangle inequality)."""
        return self.distance_m / self.speed_of_sound

    def raw_itd(self, points: object) -> np.ndarray:
        """The auditory mapping A of eq. (itd), without the affine correction.

        points : (..., 3) float, metres  ->  (...) float, seconds
        """
        pts = np.asarray(points, dtype=np.float64)
        if pts.shape[-1:] != (3,):
            raise ValueError(f"points must be an array of shape (..., 3) in metres, got shape {pts.shape}")
        d_left = np.linalg.norm(pts - np.asarray(self.left), axis=-1)
        d_right = np.linalg.norm(pts - np.asarray(self.right), axis=-1)
        return (d_left - d_right) / self.speed_of_sound

    def itd(self, points: object) -> np.ndarray:
        """The corrected audio-visual mapping of eqs. (itd_up) and (final_av_mapping): ``c1 * A(S) + c0``.

        points : (..., 3) float, metres  ->  (...) float, seconds
        """
        return self.c1 * self.raw_itd(points) + self.c0

    def itd_interval(self) -> tuple[float, float]:
        """The interval of ITD space that the mapping can reach, seconds.

        A(S) lies in [-d / nu, d / nu] for every S (d the microphone distance); the affine correction maps that
        onto ``c0 +- |c1| d / nu``. This is the support of the uniform outlier density of eq. (prob_model).
        """
        half = abs(self.c1) * self.max_itd_s
        return (self.c0 - half, self.c0 + half)

    def with_correction(self, c1: float, c0: float) -> MicPair:
        """A copy with another affine correction (the output of the audio-visual calibration)."""
        return MicPair(self.left, self.right, self.speed_of_sound, c1, c0)


def _head_to_scene(x_forward: float, y_left: float, z_up: float) -> tuple[float, float, float]:
    """A point of a robot head's frame (x forward, y left, z up: ROS's REP-103) in the scene frame (x right,
    y down, z forward)."""
    return (0.0 - y_left, 0.0 - z_up, x_forward + 0.0)


def _ring(radius_m: float, n: int, start_deg: float = 0.0) -> list[tuple[float, float, float]]:
    """``n`` microphones evenly on a horizontal circle (the scene's x-z plane) around the origin."""
    angles = np.radians(start_deg + 360.0 * np.arange(n) / n)
    return [(float(radius_m * np.cos(a)), 0.0, float(radius_m * np.sin(a))) for a in angles]


# Positions in each array's own frame, metres, as the makers and ODAS's configuration files give them; the rig
# places the array in the scene with a rotation and a translation (MicArray.placed). NAO's are in its head frame.
_NAO_HEAD = {"front": (0.0489, 0.0, 0.076), "rear": (-0.046, 0.0, 0.0814),
             "left": (-0.0195, 0.0606, 0.0331), "right": (-0.0195, -0.0606, 0.0331)}
ARRAY_PRESETS: dict[str, dict[str, object]] = {
    "pair": {"positions": [(-0.06, 0.0, 0.0), (0.06, 0.0, 0.0)], "channels": (0, 1),
             "about": "today's pair: two microphones 12 cm apart on the cameras' baseline"},
    "laptop": {"positions": [(-0.05, 0.0, 0.0), (0.05, 0.0, 0.0)], "channels": (0, 1),
               "about": "a laptop's two microphones on the screen's top edge, either side of the webcam, 10 cm "
                        "apart (measure yours: --mic-spacing)"},
    "nao": {"positions": [_head_to_scene(*_NAO_HEAD[k]) for k in ("front", "rear", "left", "right")],
            "channels": (0, 1, 2, 3), "about": "NAO's head: front, rear, left, right (band 300 Hz-8 kHz)"},
    "respeaker4": {"positions": _ring(0.0405, 4, 45.0), "channels": (0, 1, 2, 3),
                   "about": "ReSpeaker 4-Mic Pi HAT: a square of radius 40.5 mm"},
    "respeaker-usb": {"positions": _ring(0.032, 4), "channels": (1, 2, 3, 4),
                      "about": "ReSpeaker USB Mic Array v2.0: 4 microphones on radius 32 mm, raw channels 1-4 of "
                               "the 6-channel firmware (0 is processed, 5 is playback), at most 16 kHz"},
    "respeaker6": {"positions": _ring(0.0463, 6), "channels": tuple(range(6)),
                   "about": "ReSpeaker 6-Mic: a hexagon of radius 46.3 mm"},
    "ps3eye": {"positions": [(x, 0.0, 0.0) for x in (-0.03, -0.01, 0.01, 0.03)], "channels": (0, 1, 2, 3),
               "about": "PS3 Eye: a line, x = -30, -10, 10, 30 mm"},
    "uma8": {"positions": [(0.0, 0.0, 0.0), *_ring(0.043, 6)], "channels": tuple(range(7)),
             "about": "miniDSP UMA-8: a centre microphone and 6 on radius 43 mm, 48 kHz"},
}


def _default_pairs(positions: np.ndarray) -> tuple[tuple[int, int], ...]:
    """Every pair once, ``i`` the microphone more to the left (smaller x; for a tie, the one further back), so
    that a source on the right gives a positive ITD as for the paper's pair; the widest left-right pair first
    (it is the one shown where a single ITD axis is drawn), the others by decreasing left-right spread."""
    pairs = []
    for a in range(len(positions)):
        for b in range(a + 1, len(positions)):
            key_a, key_b = (positions[a, 0], positions[a, 2]), (positions[b, 0], positions[b, 2])
            pairs.append((a, b) if key_a <= key_b else (b, a))
    return tuple(sorted(pairs, key=lambda ij: -round(abs(positions[ij[0], 0] - positions[ij[1], 0]), 9)))


def _distances(positions: np.ndarray) -> np.ndarray:
    """(Q, Q) the distances between every two microphones (unchanged by a rigid motion)."""
    return np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=2)


@dataclass(frozen=True)
class MicArray:
    """Several microphones in the scene frame, used in pairs; each pair is a :class:`MicPair` of its own.

    Parameters
    ----------
    positions : (Q, 3) float, metres
        The microphones in the scene frame (x right, y down, z forward).
    pairs : sequence of (i, j)
        The pairs used, each giving the ITD ``t_i - t_j`` (docs/architecture.md's sign with ``i`` as "left"); default:
        every pair, ``i`` the one more to the left.
    speed_of_sound : float, m/s
    c1, c0 : per pair (length P), the affine correction of eq. (itd_up) from the audio-visual calibration;
        default the identity for every pair.
    channels : (Q,) the audio channel of each microphone in the input stream; default 0 .. Q-1.
    """

    positions: tuple[tuple[float, float, float], ...]
    pairs: tuple[tuple[int, int], ...] | None = None
    speed_of_sound: float = SPEED_OF_SOUND
    c1: tuple[float, ...] | None = None
    c0: tuple[float, ...] | None = None
    channels: tuple[int, ...] | None = None

    def __post_init__(self) -> None:
        pos = tuple(_as_position(p, f"positions[{k}]") for k, p in enumerate(self.positions))
        if len(pos) < 2:
            raise ValueError(f"a microphone array needs at least 2 positions, got {len(pos)}")
        object.__setattr__(self, "positions", pos)
        arr = np.asarray(pos)
        pairs = _default_pairs(arr) if self.pairs is None else tuple((int(i), int(j)) for i, j in self.pairs)
        if not pairs:
            raise ValueError("pairs must name at least one pair (i, j) of microphones")
        for i, j in pairs:
            if not (0 <= i < len(pos) and 0 <= j < len(pos)) or i == j:
                raise ValueError(f"each pair must be two different microphone numbers below {len(pos)}, got {(i, j)}")
            if pos[i] == pos[j]:
                raise ValueError(f"pair {(i, j)} has both microphones at {pos[i]}")
        object.__setattr__(self, "pairs", pairs)
        for name, default in (("c1", 1.0), ("c0", 0.0)):
            values = getattr(self, name)
            values = (default,) * len(pairs) if values is None else tuple(float(v) for v in values)
            if len(values) != len(pairs):
                raise ValueError(f"{name} must give one value per pair ({len(pairs)}), got {len(values)}")
            object.__setattr__(self, name, values)
        channels = tuple(range(len(pos))) if self.channels is None else tuple(int(c) for c in self.channels)
        if len(channels) != len(pos) or min(channels) < 0 or len(set(channels)) != len(channels):
            raise ValueError(f"channels must give {len(pos)} different channel numbers >= 0, got {channels}")
        object.__setattr__(self, "channels", channels)
        # each pair validates its own speed of sound and correction
        object.__setattr__(self, "_pairs", tuple(
            MicPair(pos[i], pos[j], self.speed_of_sound, c1, c0) for (i, j), c1, c0 in zip(pairs, self.c1, self.c0)))
        # for itd: every microphone's distance once, then each pair's difference (as MicPair.itd computes it)
        object.__setattr__(self, "_positions", np.asarray(pos, dtype=np.float64))
        object.__setattr__(self, "_ends", (np.array([i for i, _ in pairs]), np.array([j for _, j in pairs])))

    @classmethod
    def from_pair(cls, mics: MicPair, channels: tuple[int, int] = (0, 1)) -> MicArray:
        """The one-pair array of a :class:`MicPair` (same positions, speed of sound and correction), its left and
        right microphones on ``channels`` of the input stream."""
        return cls((mics.left, mics.right), ((0, 1),), mics.speed_of_sound, (mics.c1,), (mics.c0,), tuple(channels))

    @classmethod
    def preset(cls, name: str, *, rotation: object = None, translation_m: object = None,
               speed_of_sound: float = SPEED_OF_SOUND) -> MicArray:
        """One of :data:`ARRAY_PRESETS`, placed in the scene by ``rotation`` (3, 3) and ``translation_m`` (3,)
        (default: at the origin, as in its own frame)."""
        if name not in ARRAY_PRESETS:
            raise ValueError(f"unknown microphone array {name!r}; choose one of {', '.join(ARRAY_PRESETS)}")
        spec = ARRAY_PRESETS[name]
        array = cls(tuple(spec["positions"]), speed_of_sound=speed_of_sound,  # type: ignore[arg-type]
                    channels=tuple(spec["channels"]))  # type: ignore[arg-type]
        if rotation is None and translation_m is None:
            return array
        return array.placed(np.eye(3) if rotation is None else rotation,
                            np.zeros(3) if translation_m is None else translation_m)

    def placed(self, rotation: object, translation_m: object) -> MicArray:
        """The array moved rigidly: each position ``p`` becomes ``rotation @ p + translation_m``; the pairs keep
        their order (the rig YAML places a preset on the robot this way)."""
        rot = np.asarray(rotation, dtype=np.float64)
        t = np.asarray(translation_m, dtype=np.float64)
        if rot.shape != (3, 3) or not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6) or np.linalg.det(rot) < 0:
            raise ValueError(f"rotation must be a (3, 3) rotation matrix, got {rotation!r}")
        if t.shape != (3,) or not np.all(np.isfinite(t)):
            raise ValueError(f"translation_m must be three finite coordinates in metres, got {translation_m!r}")
        moved = tuple(tuple(float(v) for v in rot @ np.asarray(p) + t) for p in self.positions)
        return MicArray(moved, self.pairs, self.speed_of_sound, self.c1, self.c0, self.channels)

    def turned(self, yaw_rad: float) -> MicArray:
        """The array turned by ``yaw_rad`` about the vertical (the scene's y axis) through its microphones' centroid;
        a positive angle turns its front (+z) towards +x. The correction, pairs and channels stay."""
        if not math.isfinite(yaw_rad):
            raise ValueError(f"yaw_rad must be a finite angle in radians, got {yaw_rad!r}")
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        rot = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
        centre = np.mean(np.asarray(self.positions), axis=0)
        return self.placed(rot, centre - rot @ centre)

    @property
    def preset_name(self) -> str | None:
        """The :data:`ARRAY_PRESETS` entry whose microphones these are, wherever the rig placed them (the same
        distances between every two microphones, in the same order, within 1 mm), or None for an array of its own.
        Some of the speaking test's thresholds are chosen per array (:meth:`avcore.speaking.SpeakingTest.for_array`)."""
        own = _distances(np.asarray(self.positions))
        for name, spec in ARRAY_PRESETS.items():
            theirs = _distances(np.asarray(spec["positions"], dtype=np.float64))
            if theirs.shape == own.shape and np.allclose(own, theirs, rtol=0.0, atol=1e-3):
                return name
        return None

    @property
    def n_pairs(self) -> int:
        """P, the number of pairs (of ITD spaces)."""
        return len(self.pairs)  # type: ignore[arg-type]

    def pair(self, k: int) -> MicPair:
        """Pair ``k`` as a :class:`MicPair` (its left is microphone ``pairs[k][0]``)."""
        return self._pairs[k]  # type: ignore[attr-defined]

    def raw_itd(self, points: object) -> np.ndarray:
        """Eq. (itd) for every pair: ``(..., 3)`` metres -> ``(..., P)`` seconds, ``(|S - M_i| - |S - M_j|) / nu``."""
        return np.stack([p.raw_itd(points) for p in self._pairs], axis=-1)  # type: ignore[attr-defined]

    def itd(self, points: object) -> np.ndarray:
        """Eq. (itd_up) for every pair, each with its own ``c1, c0``: ``(..., 3)`` metres -> ``(..., P)`` seconds."""
        pts = np.asarray(points, dtype=np.float64)
        if pts.shape[-1:] != (3,):
            raise ValueError(f"points must be an array of shape (..., 3) in metres, got shape {pts.shape}")
        dist = np.linalg.norm(pts[..., None, :] - self._positions, axis=-1)  # type: ignore[attr-defined]
        i, j = self._ends  # type: ignore[attr-defined]
        return np.asarray(self.c1) * ((dist[..., i] - dist[..., j]) / self.speed_of_sound) + np.asarray(self.c0)

    def itd_intervals(self) -> np.ndarray:
        """``(P, 2)``: each pair's reachable ITD interval (:meth:`MicPair.itd_interval`), seconds."""
        return np.array([p.itd_interval() for p in self._pairs])  # type: ignore[attr-defined]
