"""The deterministic part of the model: the auditory mapping from the scene to ITD space.

Conventions (DESIGN.md): metres and seconds; the scene frame is the cyclopean frame of the rectified stereo pair
(x right, y down, z forward); ITD = (arrival time at the LEFT microphone) - (arrival time at the RIGHT
microphone), so a source on the right, closer to the right microphone, has a positive ITD.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MicPair", "SPEED_OF_SOUND"]

SPEED_OF_SOUND = 343.0  # m/s, DESIGN.md default


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
