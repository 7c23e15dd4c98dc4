"""A simulated audio-visual calibration session (paper section 5.3) with known truth: the face/ITD pairs that
:func:`avcore.calibration.fit_av_calibration` fits, for tests and ``benchmarks/av_calibration.py``."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avcore.geometry import MicPair

__all__ = ["CalibrationSession", "simulate_calibration"]


@dataclass(frozen=True)
class CalibrationSession:
    """Simulated face/ITD pairs of a calibration sequence.

    faces_xyz : (N, 3) metres, the F3D faces as measured (with stereo noise);
    itds_s : (N,) seconds, the extracted ITDs (noise and outliers);
    is_outlier : (N,) bool, ITDs that do not come from the face;
    true_itds_s : (N,) seconds, the noise-free ITD of the true face position with the true microphones;
    true_mics, measured_mics : the rig as it is and as measured by hand (identity correction).
    """

    faces_xyz: np.ndarray
    itds_s: np.ndarray
    is_outlier: np.ndarray
    true_itds_s: np.ndarray
    true_mics: MicPair
    measured_mics: MicPair
    true_faces_xyz: np.ndarray


def simulate_calibration(
    *,
    duration_s: float = 60.0,
    hop_s: float = 0.02,
    mic_error_m: float = 0.015,
    outlier_share: float = 0.15,
    itd_noise_s: float = 10e-6,
    channel_delay_s: float = 0.0,
    true_speed_of_sound: float = 343.0,
    distance_m: tuple[float, float] = (1.0, 3.0),
    half_fov_deg: tuple[float, float] = (28.0, 20.0),
    seed: int = 0,
) -> CalibrationSession:
    """A person holding a white-noise loudspeaker walks a zig-zag across the field of view (section 5.3).

    The face sweeps the horizontal field of view back and forth (a sweep every 6 s), climbs and descends it
    slowly, and walks between ``distance_m[0]`` and ``distance_m[1]`` of depth. One pair per ITD hop. The true
    microphones are 12 cm apart, 4 cm above and 3 cm behind the cyclopean origin; the hand-measured ones are each
    off by ``mic_error_m`` in a random direction. F3D noise: ``1 cm x (z / 1 m)^2`` along the viewing ray
    (stereo) and 5 mm across. ITDs: the true mapping with ``true_speed_of_sound``, a constant ``channel_delay_s`` (sound-card
    inter-channel skew) and Gaussian noise ``itd_noise_s``; a share ``outlier_share`` is replaced by ITDs uniform
    over the ITD interval (reverberation, windows where the loudspeaker is not the source).
    """
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, duration_s, hop_s)
    sweep = 2.0 * np.abs(((t / 6.0) % 2.0) - 1.0) - 1.0  # triangle wave in [-1, 1], 6 s per sweep
    climb = np.sin(2 * np.pi * t / 23.0)
    walk = 0.5 - 0.5 * np.cos(2 * np.pi * t / 37.0)
    az = np.radians(half_fov_deg[0]) * sweep
    el = np.radians(half_fov_deg[1]) * climb
    depth = distance_m[0] + (distance_m[1] - distance_m[0]) * walk
    true_faces = np.stack([depth * np.tan(az), depth * np.tan(el), depth], axis=1)

    true_mics = MicPair(left=(-0.06, -0.04, -0.03), right=(0.06, -0.04, -0.03), speed_of_sound=true_speed_of_sound)

    def off(p: tuple[float, float, float]) -> np.ndarray:
        direction = rng.normal(size=3)
        return np.asarray(p) + mic_error_m * direction / np.linalg.norm(direction)

    measured_mics = MicPair(left=off(true_mics.left), right=off(true_mics.right), speed_of_sound=343.0)

    n = t.size
    # Stereo error: along the viewing ray, growing with depth squared, plus a little across it.
    depth_error = rng.normal(size=n) * 0.01 * true_faces[:, 2] ** 2
    faces = true_faces * (1.0 + depth_error / np.linalg.norm(true_faces, axis=1))[:, None]
    faces[:, :2] += rng.normal(scale=0.005, size=(n, 2))

    true_itds = true_mics.itd(true_faces)
    itds = true_itds + channel_delay_s + rng.normal(scale=itd_noise_s, size=n)
    is_outlier = rng.random(n) < outlier_share
    lo, hi = true_mics.itd_interval()
    itds[is_outlier] = rng.uniform(lo, hi, size=int(is_outlier.sum()))
    return CalibrationSession(
        faces_xyz=faces,
        itds_s=itds,
        is_outlier=is_outlier,
        true_itds_s=true_itds + channel_delay_s,
        true_mics=true_mics,
        measured_mics=measured_mics,
        true_faces_xyz=true_faces,
    )
