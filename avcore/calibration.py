"""Audio-visual calibration (paper section 5.3): the affine correction c1, c0 of eq. (itd_up).

The microphone positions M_L, M_R are measured by hand, to a centimetre or two, and the ITD extractor and the
sound card add their own small scale and offset errors. The paper corrects the auditory mapping with

    A_bar(S) = c1 * A(S) + c0 = c1 * (|S - M_L| - |S - M_R|) / nu + c0          (eq. itd_up)

and fits c1, c0 by least squares on a one-minute sequence of a person holding a loudspeaker that plays white noise
while moving in a zig-zag across the cameras' field of view: each F3D face position S_k is paired with an ITD
tau_k of the same moment, and the projected faces then follow the ITDs (eq. final_av_mapping, figure
"calibration").

The fit is a straight line ``tau = c1 * x + c0`` through the points ``(x_k, tau_k)`` with ``x_k = A(S_k)``.
Plain least squares (the paper's, ``method="lstsq"``) is pulled away by ITDs that do not belong to the face:
reverberation, and windows where the loudspeaker was silent or another sound dominated. The default
``method="robust"`` starts from a least-median-of-squares line (random pairs of points, seeded) and refines it by
iteratively reweighted least squares with Tukey's biweight on a MAD-based scale: ITDs further than ``tukey_c``
scales from the line get zero weight, so up to half of the pairs can be outliers.

An affine correction absorbs a wrong microphone distance, speed of sound or inter-channel delay, but not all of a
misplaced microphone: a pair whose centre is off by a centimetre sees faces at 1 m and at 3 m under different angles
(parallax), which no single c1, c0 can follow. With ``refine_positions=True`` (beyond the paper, off by default)
the fit then also moves M_L and M_R, by nonlinear least squares on the same inlier pairs with a Gaussian prior
of ``position_prior_m`` around the hand measurements; see ``benchmarks/av_calibration.py`` for what it gains.

:func:`sim.calibration.simulate_calibration` produces such a session with known truth, for tests and
``benchmarks/av_calibration.py``.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field

import numpy as np

from avcore._validate import as_points, as_samples
from avcore.geometry import MicPair

__all__ = [
    "CALIBRATION_BURST_S",
    "calibration_signal",
    "CalibrationReport",
    "fit_av_calibration",
    "fit_av_calibration_report",
]

logger = logging.getLogger(__name__)

METHODS = ("lstsq", "robust")
MAD_TO_SIGMA = 1.482602218505602  # sigma of a Gaussian = 1.4826 * its median absolute deviation
MIN_PAIRS = {"lstsq": 3, "robust": 10}
LMEDS_SAMPLE = 1000
MIN_SPAN_FRACTION = 0.1  # faces must cover this share of the ITD interval [-d/nu, d/nu]
TRUNCATED_SD_2_5 = 0.954597  # standard deviation of a standard normal truncated to [-2.5, 2.5]
SCALE_FLOOR_S = 1e-9  # 1 ns: below any ITD resolution; keeps the weights finite on exact data


CALIBRATION_BURST_S: tuple[float, float] = (0.15, 0.35)
"""Seconds on and off of the calibration loudspeaker's white noise.

The fitted correction c1, c0 absorbs what the room and the ITD extractor do to the ITDs, so the calibration signal
must meet the extractor as speech does. The default extractor (``gcc-phat-robust``) weights onsets, where the direct
sound leads its reflections (precedence): speech is all onsets, continuous noise has none, and continuous noise's
ITDs are pulled further towards zero by the reflections. Bursts of syllable length at a syllable rate give the
extractor onsets as speech does (measured: docs/experiments.md, "The calibration signal").
"""


def calibration_signal(samplerate_hz: int, duration_s: float, *, seed: int = 0, level_dbfs: float = -18.0,
                       ramp_s: float = 0.002) -> np.ndarray:
    """What the calibration loudspeaker plays: white-noise bursts of :data:`CALIBRATION_BURST_S`, ``(n,)`` float in
    [-1, 1]. Gaussian noise at ``level_dbfs`` RMS during the bursts (at -18 dBFS a peak of 7 sigma stays below full
    scale; louder levels are clipped there), raised-cosine ramps of ``ramp_s`` against clicks, silence between."""
    if not samplerate_hz > 0 or int(samplerate_hz) != samplerate_hz:
        raise ValueError(f"samplerate_hz must be a positive whole number of hertz, got {samplerate_hz!r}")
    if not 1.0 <= duration_s <= 3600.0:
        raise ValueError(f"duration_s must be between 1 and 3600 seconds, got {duration_s!r}")
    if not level_dbfs <= 0:
        raise ValueError(f"level_dbfs must be <= 0 dBFS, got {level_dbfs!r}")
    fs = int(samplerate_hz)
    on, off = CALIBRATION_BURST_S
    out = np.zeros(round(duration_s * fs))
    burst = round(on * fs)
    ramp = max(1, round(ramp_s * fs))
    envelope = np.ones(burst)
    rise = 0.5 - 0.5 * np.cos(np.pi * (np.arange(ramp) + 0.5) / ramp)
    envelope[:ramp] = rise
    envelope[-ramp:] = rise[::-1]
    rng = np.random.default_rng(seed)
    rms = 10 ** (level_dbfs / 20)
    for start in range(0, out.size - burst + 1, round((on + off) * fs)):
        out[start:start + burst] = rms * rng.standard_normal(burst) * envelope
    return np.clip(out, -1.0, 1.0)


@dataclass(frozen=True)
class CalibrationReport:
    """The fitted correction and its diagnostics.

    Attributes
    ----------
    mics : MicPair
        The input microphones with the fitted ``c1``, ``c0`` (eq. itd_up).
    c1 : float, dimensionless;  c0 : float, seconds
    method : "lstsq" | "robust"
    inliers : (N,) bool
        Pairs that carry weight in the final fit (all of them for ``lstsq``).
    residuals_before_s : (N,) float, seconds
        ``itds - mics_in.itd(faces)``: the ITDs minus the faces mapped with the input correction (usually identity).
    residuals_after_s : (N,) float, seconds
        ``itds - mics.itd(faces)`` with the fitted correction.
    scale_s : float, seconds
        Robust standard deviation of the final residuals of the face's ITDs (see ``_robust_scale``).
    n_iter : int
        Reweighting iterations (0 for ``lstsq``).
    converged : bool
    position_shift_m : (2, 3) float, metres
        How far ``refine_positions`` moved M_L (row 0) and M_R (row 1) from the input; zeros without it.
    """

    mics: MicPair
    c1: float
    c0: float
    method: str
    inliers: np.ndarray = field(repr=False)
    residuals_before_s: np.ndarray = field(repr=False)
    residuals_after_s: np.ndarray = field(repr=False)
    scale_s: float
    n_iter: int
    converged: bool
    position_shift_m: np.ndarray = field(default_factory=lambda: np.zeros((2, 3)), repr=False)

    @property
    def n_pairs(self) -> int:
        return int(self.inliers.size)

    @property
    def inlier_share(self) -> float:
        return float(np.mean(self.inliers)) if self.inliers.size else 0.0

    @property
    def median_abs_before_s(self) -> float:
        """Median |residual| over the inliers, before the correction (seconds)."""
        return float(np.median(np.abs(self.residuals_before_s[self.inliers])))

    @property
    def median_abs_after_s(self) -> float:
        """Median |residual| over the inliers, after the correction (seconds)."""
        return float(np.median(np.abs(self.residuals_after_s[self.inliers])))


def fit_av_calibration(
    faces_xyz: object,
    itds_s: object,
    mics: MicPair,
    *,
    method: str = "robust",
    **options: object,
) -> MicPair:
    """Fit c1 and c0 of eq. (itd_up); return ``mics`` with that correction.

    Parameters
    ----------
    faces_xyz : (N, 3) float, metres
        F3D face positions in the scene frame (section 5.2), one per pair.
    itds_s : (N,) float, seconds
        The ITD observed at the moment of each face (docs/architecture.md's sign: left arrival minus right arrival).
    mics : MicPair
        The hand-measured microphone positions and speed of sound; its own ``c1``, ``c0`` are replaced.
    method : "robust" (default) or "lstsq" (the paper's plain least squares)
    options
        Passed to :func:`fit_av_calibration_report` (``refine_positions``, ``position_prior_m``, ``tukey_c``,
        ``max_iter``, ``n_trials``, ``seed``).
    """
    return fit_av_calibration_report(faces_xyz, itds_s, mics, method=method, **options).mics  # type: ignore[arg-type]


def fit_av_calibration_report(
    faces_xyz: object,
    itds_s: object,
    mics: MicPair,
    *,
    method: str = "robust",
    refine_positions: bool = False,
    position_prior_m: float = 0.02,
    tukey_c: float = 4.685,
    max_iter: int = 50,
    n_trials: int = 500,
    seed: int = 0,
) -> CalibrationReport:
    """Fit c1 and c0 of eq. (itd_up) and report the residuals before and after.

    Parameters
    ----------
    faces_xyz, itds_s, mics, method
        As in :func:`fit_av_calibration`.
    refine_positions : bool
        Also move the microphones (beyond the paper's eq. itd_up): after the fit of c1, c0, minimise over M_L, M_R,
        c1, c0 the squared residuals of the inlier pairs (a soft-L1 loss for ``robust``) plus
        ``|M - M_measured|^2 / position_prior_m^2`` for each microphone. It removes the parallax error that the
        affine model leaves when the hand measurements are off by 1-2 cm, but its eight parameters need the full
        calibration minute: with a few hundred pairs, or positions that were right, it adds a microsecond or two
        of variance to the mapping.
    position_prior_m : float, metres
        Standard deviation of the hand measurement of each microphone position, for ``refine_positions``.
    tukey_c : float
        Tukey biweight cut-off in robust scales (4.685: 95 % efficiency on Gaussian noise).
    max_iter : int
        Reweighting iterations at most.
    n_trials : int
        Random pairs tried for the least-median-of-squares start.
    seed : int
        Seed of those pairs: the same data give the same fit.

    Raises
    ------
    ValueError
        Unknown method; shapes that do not match; NaN or infinite values; fewer pairs than the method needs (3 for
        lstsq, 10 for robust); faces that span too little of the ITD interval for c1 to be determined (all at one
        azimuth); a fitted c1 <= 0 (the ITDs decrease as the face moves right: the channels are probably swapped).
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {METHODS}, got {method!r}")
    if not isinstance(mics, MicPair):
        raise TypeError(f"mics must be an avcore.geometry.MicPair, got {type(mics).__name__}")
    faces = as_points(faces_xyz, "faces_xyz")
    itds = as_samples(itds_s, "itds_s")
    if faces.shape[0] != itds.shape[0]:
        raise ValueError(
            f"faces_xyz and itds_s must pair up one to one, got {faces.shape[0]} faces and {itds.shape[0]} ITDs"
        )
    n = itds.shape[0]
    if n < MIN_PAIRS[method]:
        raise ValueError(
            f"the {method} fit needs at least {MIN_PAIRS[method]} face/ITD pairs, got {n}; record a longer "
            "calibration sequence (the paper uses one minute)"
        )
    if not (tukey_c > 0 and max_iter >= 1 and n_trials >= 1):
        raise ValueError("tukey_c must be positive, max_iter and n_trials at least 1")
    if not (np.isfinite(position_prior_m) and position_prior_m > 0):
        raise ValueError(f"position_prior_m must be a positive number of metres, got {position_prior_m!r}")

    x = mics.raw_itd(faces)
    _check_span(x, mics, "faces_xyz")

    if method == "lstsq":
        c1, c0 = _line_fit(x, itds, None)
        inliers = np.ones(n, dtype=bool)
        n_iter, converged = 0, True
        scale = _robust_scale(itds - (c1 * x + c0))
    else:
        c1, c0, inliers, scale, n_iter, converged = _robust_line(x, itds, tukey_c, max_iter, n_trials, seed)
        if not converged:
            logger.warning("the robust calibration fit did not converge in %d iterations; the last line is used "
                           "(raise max_iter, or check the pairs)", max_iter)
        _check_span(x[inliers], mics, "the inlier faces")

    _check_positive_scale(c1)
    fitted = mics.with_correction(float(c1), float(c0))
    shift = np.zeros((2, 3))
    if refine_positions:
        fitted = _refine_positions(faces[inliers], itds[inliers], fitted, scale, position_prior_m,
                                   loss="linear" if method == "lstsq" else "soft_l1")
        shift = np.array([np.subtract(fitted.left, mics.left), np.subtract(fitted.right, mics.right)])
        c1, c0 = fitted.c1, fitted.c0
        _check_positive_scale(c1)
        residuals = itds - fitted.itd(faces)
        scale = _robust_scale(residuals)
        if method == "robust":
            inliers = np.abs(residuals) < tukey_c * scale
    return CalibrationReport(
        mics=fitted,
        c1=float(c1),
        c0=float(c0),
        method=method,
        inliers=inliers,
        residuals_before_s=itds - mics.itd(faces),
        residuals_after_s=itds - fitted.itd(faces),
        scale_s=float(scale),
        n_iter=n_iter,
        converged=converged,
        position_shift_m=shift,
    )


def _check_positive_scale(c1: float) -> None:
    if not c1 > 0:
        raise ValueError(
            f"the fitted scale c1 = {c1:.3g} is not positive: the ITDs decrease as the face moves to the right. "
            "The left and right channels are probably swapped (docs/architecture.md: ITD = t_left - t_right)"
        )


def _refine_positions(
    faces: np.ndarray, itds: np.ndarray, mics: MicPair, scale_s: float, prior_m: float, loss: str
) -> MicPair:
    """Nonlinear least squares over (M_L, M_R, c1, c0) from the affine fit, with a prior on the positions."""
    left0, right0 = np.asarray(mics.left), np.asarray(mics.right)
    nu = mics.speed_of_sound
    n = itds.size
    prior_rows = np.hstack([np.eye(6) / prior_m, np.zeros((6, 2))])

    def geometry(p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        to_left = faces - (left0 + p[0:3])
        to_right = faces - (right0 + p[3:6])
        d_left = np.linalg.norm(to_left, axis=1)
        d_right = np.linalg.norm(to_right, axis=1)
        return to_left, to_right, d_left, d_right

    # Parameters: the two position shifts (metres), c1, and c0 in units of the residual scale (all of order one).
    def residuals(p: np.ndarray) -> np.ndarray:
        _, _, d_left, d_right = geometry(p)
        mapped = p[6] * (d_left - d_right) / nu + p[7] * scale_s
        return np.concatenate([(itds - mapped) / scale_s, p[:6] / prior_m])

    def jacobian(p: np.ndarray) -> np.ndarray:
        to_left, to_right, d_left, d_right = geometry(p)
        jac = np.empty((n + 6, 8))
        # d|S - M| / dM = -(S - M) / |S - M|; the residual is (itd - mapped) / scale.
        jac[:n, 0:3] = p[6] / (nu * scale_s) * to_left / d_left[:, None]
        jac[:n, 3:6] = -p[6] / (nu * scale_s) * to_right / d_right[:, None]
        jac[:n, 6] = -(d_left - d_right) / (nu * scale_s)
        jac[:n, 7] = -1.0
        jac[n:] = prior_rows
        return jac

    from scipy.optimize import least_squares  # here: the calibration's signal and constants import no SciPy

    start = np.concatenate([np.zeros(6), [mics.c1, mics.c0 / scale_s]])
    # Residuals are in robust scales: soft-L1 turns linear beyond 3 of them.
    p = least_squares(residuals, start, jac=jacobian, loss=loss, f_scale=3.0).x
    return MicPair(left0 + p[0:3], right0 + p[3:6], nu, float(p[6]), float(p[7] * scale_s))


def _check_span(x: np.ndarray, mics: MicPair, what: str) -> None:
    """c1 is the slope of the line through (A(S_k), tau_k): the A(S_k) must spread, i.e. the faces must move."""
    span = float(np.ptp(x)) if x.size else 0.0
    needed = MIN_SPAN_FRACTION * 2.0 * mics.max_itd_s
    if span < needed:
        raise ValueError(
            f"{what} span {span * 1e6:.1f} us of the mapped ITD, less than {needed * 1e6:.1f} us "
            f"({MIN_SPAN_FRACTION:.0%} of the interval [-d/nu, d/nu]): c1 cannot be determined when the faces "
            "stay at one azimuth; move across the whole field of view (section 5.3: a zig-zag)"
        )


def _line_fit(x: np.ndarray, y: np.ndarray, w: np.ndarray | None) -> tuple[float, float]:
    """Weighted least-squares line y = c1 x + c0, in closed form about the weighted means."""
    if w is None:
        w = np.ones_like(x)
    total = w.sum()
    mx = (w * x).sum() / total
    my = (w * y).sum() / total
    dx = x - mx
    sxx = (w * dx * dx).sum()
    c1 = (w * dx * (y - my)).sum() / sxx
    return float(c1), float(my - c1 * mx)


def _robust_scale(residuals: np.ndarray) -> float:
    """Standard deviation of the residuals of the face's ITDs, among outliers.

    The MAD (x 1.4826) is robust but inflated by outliers (by about 1.5 with 25 % uniform outliers). As in
    Rousseeuw and Leroy's reweighted least squares, it only selects the residuals within 2.5 MADs, whose root mean
    square, divided by that of a standard normal truncated at +-2.5 (0.9546), is the scale.
    """
    mad = max(MAD_TO_SIGMA * float(np.median(np.abs(residuals))), SCALE_FLOOR_S)
    core = residuals[np.abs(residuals) <= 2.5 * mad]
    if core.size < 3:
        return mad
    return max(float(np.sqrt(np.mean(core * core))) / TRUNCATED_SD_2_5, SCALE_FLOOR_S)


def _lmeds_start(x: np.ndarray, y: np.ndarray, n_trials: int, seed: int) -> tuple[float, float]:
    """Least-median-of-squares line from random pairs of points (Rousseeuw's LMedS): robust to < 50 % outliers."""
    rng = np.random.default_rng(seed)
    n = x.size
    # The median over a thousand points is plenty to rank candidate lines.
    sample = rng.choice(n, size=LMEDS_SAMPLE, replace=False) if n > LMEDS_SAMPLE else np.arange(n)
    i = rng.integers(0, n, size=n_trials)
    j = rng.integers(0, n, size=n_trials)
    dx = x[j] - x[i]
    ok = np.abs(dx) > 1e-3 * np.ptp(x)
    if not np.any(ok):
        return _line_fit(x, y, None)
    slope = (y[j] - y[i])[ok] / dx[ok]
    intercept = y[i][ok] - slope * x[i][ok]
    residuals = y[sample][None, :] - (slope[:, None] * x[sample][None, :] + intercept[:, None])
    best = int(np.argmin(np.median(np.abs(residuals), axis=1)))
    return float(slope[best]), float(intercept[best])


def _robust_line(
    x: np.ndarray, y: np.ndarray, tukey_c: float, max_iter: int, n_trials: int, seed: int
) -> tuple[float, float, np.ndarray, float, int, bool]:
    """Tukey-biweight IRLS from an LMedS start; the scale is re-estimated (MAD) at every iteration."""
    c1, c0 = _lmeds_start(x, y, n_trials, seed)
    converged = False
    n_iter = 0
    span = float(np.ptp(x))
    for n_iter in range(1, max_iter + 1):
        r = y - (c1 * x + c0)
        scale = _robust_scale(r)
        u = r / (tukey_c * scale)
        w = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
        if np.count_nonzero(w) < 3:
            break
        new_c1, new_c0 = _line_fit(x, y, w)
        # Converged when the line moves by less than 1e-6 of the robust scale anywhere on the data.
        moved = abs(new_c1 - c1) * span + abs(new_c0 - c0)
        c1, c0 = new_c1, new_c0
        if moved < 1e-6 * scale:
            converged = True
            break
    r = y - (c1 * x + c0)
    scale = _robust_scale(r)
    inliers = np.abs(r) < tukey_c * scale
    return c1, c0, inliers, scale, n_iter, converged


# ---------------------------------------------------------------------------------------------------------------
# A calibration session with known truth (section 5.3's protocol), for tests and benchmarks
