from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from avcore.calibration import (
    CALIBRATION_BURST_S,
    calibration_signal,
    fit_av_calibration,
    fit_av_calibration_report,
)
from avcore.geometry import MicPair
from sim.calibration import simulate_calibration

US = 1e-6


def faces_across_the_view(n: int, seed: int = 0) -> np.ndarray:
    """Faces spread over +-28 degrees of azimuth at 1-3 m."""
    rng = np.random.default_rng(seed)
    az = np.radians(rng.uniform(-28, 28, n))
    z = rng.uniform(1.0, 3.0, n)
    return np.stack([z * np.tan(az), rng.uniform(-0.3, 0.3, n), z], axis=1)


@pytest.mark.parametrize("method", ["lstsq", "robust"])
def test_recovers_an_exact_affine_correction(method: str) -> None:
    mics = MicPair()
    faces = faces_across_the_view(200)
    itds = mics.with_correction(1.3, 20 * US).itd(faces)
    report = fit_av_calibration_report(faces, itds, mics, method=method)
    assert report.c1 == pytest.approx(1.3, rel=1e-9)
    assert report.c0 == pytest.approx(20 * US, abs=1e-12)
    assert report.inliers.all()
    assert np.max(np.abs(report.residuals_after_s)) < 1e-12
    fitted = fit_av_calibration(faces, itds, mics, method=method)
    assert isinstance(fitted, MicPair)
    assert (fitted.left, fitted.right, fitted.speed_of_sound) == (mics.left, mics.right, mics.speed_of_sound)
    assert (fitted.c1, fitted.c0) == (report.c1, report.c0)


def test_robust_fit_ignores_outliers_that_pull_least_squares_away() -> None:
    rng = np.random.default_rng(1)
    mics = MicPair()
    faces = faces_across_the_view(1500, seed=1)
    itds = mics.with_correction(1.1, -15 * US).itd(faces) + rng.normal(scale=10 * US, size=1500)
    outlier = rng.random(1500) < 0.25
    lo, hi = mics.itd_interval()
    itds[outlier] = rng.uniform(lo, hi, outlier.sum())
    robust = fit_av_calibration_report(faces, itds, mics)
    plain = fit_av_calibration_report(faces, itds, mics, method="lstsq")
    assert robust.c1 == pytest.approx(1.1, abs=0.01)
    assert robust.c0 == pytest.approx(-15 * US, abs=1 * US)
    assert abs(plain.c1 - 1.1) > 0.1  # uniform outliers flatten the least-squares line
    assert robust.converged and robust.n_iter < 50
    assert robust.scale_s == pytest.approx(10 * US, rel=0.15)
    # The inlier mask finds the face's ITDs; the outliers it keeps are those that fell near the line by chance.
    assert robust.inliers[~outlier].mean() > 0.99
    far = np.abs(itds - mics.with_correction(1.1, -15 * US).itd(faces)) > 60 * US
    assert not robust.inliers[far].any()
    assert robust.median_abs_after_s < robust.median_abs_before_s


def test_robust_fit_ignores_a_second_fixed_source() -> None:
    # A third of the windows hear a television at a fixed direction instead of the loudspeaker.
    rng = np.random.default_rng(2)
    mics = MicPair()
    faces = faces_across_the_view(900, seed=2)
    itds = mics.with_correction(0.9, 5 * US).itd(faces) + rng.normal(scale=8 * US, size=900)
    tv = rng.random(900) < 0.33
    itds[tv] = 150 * US + rng.normal(scale=8 * US, size=tv.sum())
    robust = fit_av_calibration_report(faces, itds, mics)
    assert robust.c1 == pytest.approx(0.9, abs=0.015)
    assert robust.c0 == pytest.approx(5 * US, abs=1.5 * US)
    assert fit_av_calibration_report(faces, itds, mics, method="lstsq").c1 < 0.75


@pytest.mark.parametrize("mic_error_m", [0.01])
def test_calibration_target_on_a_simulated_session(mic_error_m: float) -> None:
    """Issue 5: hand-measured microphones off by 1-2 cm, 15 % outlier ITDs -> median |residual| <= 8 us.

    ``benchmarks/av_calibration.py`` measures the whole grid over several sessions. With the affine model of eq.
    (itd_up) alone the target holds at 1 cm; from 1.5 cm on it depends on the direction of the errors (the parallax
    of a misplaced pair is not affine), see the next test.
    """
    session = simulate_calibration(duration_s=30.0, mic_error_m=mic_error_m, outlier_share=0.15, seed=3)
    face_itds = ~session.is_outlier

    def median_residual_us(mics: MicPair) -> float:
        return float(np.median(np.abs(session.itds_s - mics.itd(session.faces_xyz))[face_itds]) / US)

    before = median_residual_us(session.measured_mics)
    robust = median_residual_us(fit_av_calibration(session.faces_xyz, session.itds_s, session.measured_mics))
    plain = median_residual_us(
        fit_av_calibration(session.faces_xyz, session.itds_s, session.measured_mics, method="lstsq")
    )
    assert before > 12.0
    assert robust <= 8.0
    assert plain > robust + 3.0


def test_refining_positions_removes_the_parallax_the_affine_model_cannot() -> None:
    # Seed 2 draws errors for which the affine correction alone leaves about 19 us at 2 cm.
    session = simulate_calibration(duration_s=30.0, mic_error_m=0.02, outlier_share=0.15, seed=2)
    face_itds = ~session.is_outlier

    def median_residual_us(mics: MicPair) -> float:
        return float(np.median(np.abs(session.itds_s - mics.itd(session.faces_xyz))[face_itds]) / US)

    def mapping_error_us(mics: MicPair) -> float:
        return float(np.median(np.abs(mics.itd(session.true_faces_xyz) - session.true_itds_s)) / US)

    affine = fit_av_calibration_report(session.faces_xyz, session.itds_s, session.measured_mics)
    refined = fit_av_calibration_report(session.faces_xyz, session.itds_s, session.measured_mics,
                                        refine_positions=True)
    assert median_residual_us(affine.mics) > 12.0
    assert median_residual_us(refined.mics) <= 8.0
    assert mapping_error_us(refined.mics) < 1.5
    assert mapping_error_us(affine.mics) > 10.0
    moved = np.linalg.norm(refined.position_shift_m, axis=1)
    assert np.all(moved > 0.002) and np.all(moved < 0.05)
    np.testing.assert_allclose(refined.mics.left, np.add(session.measured_mics.left, refined.position_shift_m[0]))
    assert np.all(affine.position_shift_m == 0)


def test_refining_right_positions_keeps_the_mapping() -> None:
    # One minute of pairs (3000). The positions are only weakly determined -- a shift of the pair's centre resembles
    # a change of c0 at these depths -- and wander within the prior; the mapping over the calibrated volume stays
    # within a microsecond or two of the truth (the affine fit alone does better here, having fewer parameters).
    rng = np.random.default_rng(7)
    mics = MicPair()
    truth = mics.with_correction(1.2, 10 * US)
    faces = faces_across_the_view(3000, seed=7)
    itds = truth.itd(faces) + rng.normal(scale=10 * US, size=3000)
    refined = fit_av_calibration_report(faces, itds, mics, refine_positions=True)
    assert np.max(np.abs(refined.position_shift_m)) < 0.02
    held_out = faces_across_the_view(300, seed=8)
    error = np.abs(refined.mics.itd(held_out) - truth.itd(held_out))
    assert np.median(error) < 1 * US and np.max(error) < 2.5 * US


def test_same_data_same_fit() -> None:
    session = simulate_calibration(duration_s=10.0, seed=4)
    a = fit_av_calibration_report(session.faces_xyz, session.itds_s, session.measured_mics)
    b = fit_av_calibration_report(session.faces_xyz, session.itds_s, session.measured_mics)
    assert (a.c1, a.c0) == (b.c1, b.c0)
    np.testing.assert_array_equal(a.inliers, b.inliers)


@settings(max_examples=30, deadline=None)
@given(scale=st.floats(0.5, 2.0), offset_us=st.floats(-50.0, 50.0), method=st.sampled_from(["lstsq", "robust"]))
def test_fit_is_equivariant_to_an_affine_change_of_the_itds(scale: float, offset_us: float, method: str) -> None:
    """ITDs a * tau + b give the correction (a c1, a c0 + b): the fit does not depend on the ITDs' unit or origin."""
    session = simulate_calibration(duration_s=8.0, outlier_share=0.2, seed=5)
    base = fit_av_calibration_report(session.faces_xyz, session.itds_s, session.measured_mics, method=method)
    moved = fit_av_calibration_report(
        session.faces_xyz, scale * session.itds_s + offset_us * US, session.measured_mics, method=method
    )
    assert moved.c1 == pytest.approx(scale * base.c1, rel=1e-6)
    assert moved.c0 == pytest.approx(scale * base.c0 + offset_us * US, abs=1e-6 * US * 100)
    np.testing.assert_array_equal(moved.inliers, base.inliers)


def test_clear_errors() -> None:
    mics = MicPair()
    faces = faces_across_the_view(50)
    itds = mics.itd(faces)
    with pytest.raises(ValueError, match="method must be one of"):
        fit_av_calibration(faces, itds, mics, method="ransac")
    with pytest.raises(ValueError, match="at least 10 face/ITD pairs, got 9"):
        fit_av_calibration(faces[:9], itds[:9], mics)
    with pytest.raises(ValueError, match="at least 3 face/ITD pairs, got 2"):
        fit_av_calibration(faces[:2], itds[:2], mics, method="lstsq")
    with pytest.raises(ValueError, match="50 faces and 49 ITDs"):
        fit_av_calibration(faces, itds[:49], mics)
    bad_faces = faces.copy()
    bad_faces[3, 2] = np.nan
    with pytest.raises(ValueError, match="faces_xyz holds 1 row"):
        fit_av_calibration(bad_faces, itds, mics)
    bad_itds = itds.copy()
    bad_itds[[1, 7]] = np.nan
    with pytest.raises(ValueError, match="itds_s holds 2 NaN"):
        fit_av_calibration(faces, bad_itds, mics)
    with pytest.raises(ValueError, match=r"must be an \(n, 3\) array"):
        fit_av_calibration(faces[:, :2], itds, mics)
    with pytest.raises(ValueError, match="position_prior_m"):
        fit_av_calibration(faces, itds, mics, refine_positions=True, position_prior_m=0.0)
    with pytest.raises(TypeError, match="MicPair"):
        fit_av_calibration(faces, itds, {"left": (-0.06, 0, 0)})  # type: ignore[arg-type]


@pytest.mark.parametrize("method", ["lstsq", "robust"])
def test_faces_at_one_azimuth_leave_c1_undetermined(method: str) -> None:
    mics = MicPair()
    z = np.linspace(1.0, 3.0, 40)
    faces = np.stack([0.3 * z, np.zeros_like(z), z], axis=1)  # one direction, many depths
    itds = mics.itd(faces) + np.random.default_rng(6).normal(scale=5 * US, size=40)
    with pytest.raises(ValueError, match="c1 cannot be determined.*whole field of view"):
        fit_av_calibration(faces, itds, mics, method=method)


def test_swapped_channels_are_reported() -> None:
    mics = MicPair()
    faces = faces_across_the_view(100)
    with pytest.raises(ValueError, match="channels are probably swapped"):
        fit_av_calibration(faces, -mics.itd(faces), mics)


def test_calibration_signal_is_bursts_of_white_noise() -> None:
    fs = 16000
    x = calibration_signal(fs, 10.0, seed=3, level_dbfs=-18.0)
    on, off = CALIBRATION_BURST_S
    assert x.shape == (10 * fs,) and np.all(np.abs(x) <= 1.0)
    period, burst = round((on + off) * fs), round(on * fs)
    cycles = x[: (x.size // period) * period].reshape(-1, period)
    assert np.all(cycles[:, burst:] == 0.0)  # silence between the bursts
    middle = cycles[:, 100:burst - 100]  # inside the bursts, past the ramps
    assert np.sqrt(np.mean(middle**2)) == pytest.approx(10 ** (-18 / 20), rel=0.05)
    spectrum = np.abs(np.fft.rfft(middle, axis=1)) ** 2  # white: flat from low to high frequencies
    bands = spectrum.mean(axis=0)[1:1097].reshape(8, -1).mean(axis=1)
    assert bands.max() / bands.min() < 1.3
    assert np.array_equal(x, calibration_signal(fs, 10.0, seed=3))  # deterministic for a seed
    for bad in ({"samplerate_hz": 0, "duration_s": 5.0}, {"samplerate_hz": 16000, "duration_s": 0.1},
                {"samplerate_hz": 16000, "duration_s": 5.0, "level_dbfs": 3.0}):
        with pytest.raises(ValueError):
            calibration_signal(**bad)
