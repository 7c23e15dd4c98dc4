"""Tests of avcore.stereo: triangulation, the rig dict, and calibration on OpenCV's real chessboard pairs."""
from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from avcore.stereo import (
    StereoRig,
    calibrate_camera,
    calibrate_stereo,
    chessboard_points,
    find_chessboard,
)

NAMES = ["01", "02", "03", "04", "05", "06", "07", "08", "09", "11", "12", "13", "14"]


def _random_points(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform([-1.0, -0.8, 0.8], [1.0, 0.8, 5.0], size=(n, 3))


def _real_rig() -> StereoRig:
    """A rig with distortion, a slight rotation and a small vertical offset (not rectified)."""
    k_l = np.array([[530.0, 0.0, 330.0], [0.0, 531.0, 240.0], [0.0, 0.0, 1.0]])
    k_r = np.array([[536.0, 0.0, 320.0], [0.0, 535.0, 245.0], [0.0, 0.0, 1.0]])
    rot = cv2.Rodrigues(np.array([0.004, -0.01, 0.003]))[0]
    return StereoRig((640, 480), k_l, [-0.2, 0.05, 0.001, -0.0005, 0.0], k_r, [-0.18, 0.03, 0.0, 0.0, 0.0],
                     rot, [-0.12, 0.002, 0.001])


def test_ideal_rig_geometry():
    rig = StereoRig.ideal(focal_px=554.0, image_size=(640, 480), baseline_m=0.12)
    assert rig.is_rectified
    assert rig.focal_px == pytest.approx(554.0)
    assert rig.baseline_m == pytest.approx(0.12)
    # the origin of the scene frame is midway between the cameras: a point straight ahead of it has
    # symmetric image columns about the principal point
    ul, ur = rig.project([[0.0, 0.0, 2.0]])
    assert ul[0, 0] - 319.5 == pytest.approx(319.5 - ur[0, 0])
    assert ul[0, 0] - ur[0, 0] == pytest.approx(554.0 * 0.12 / 2.0)


def test_triangulation_of_projected_points_is_exact():
    rig = StereoRig.ideal(focal_px=554.0, image_size=(640, 480), baseline_m=0.12)
    pts = _random_points(50)
    ul, ur = rig.project(pts)
    np.testing.assert_allclose(rig.triangulate(ul, ur), pts, atol=1e-12, rtol=0)


def test_triangulation_through_distortion_and_rectification():
    rig = _real_rig()
    assert not rig.is_rectified
    pts = _random_points(40, seed=1)
    # raw pixels: scene frame -> rectified left frame -> each camera's raw frame -> distorted pixels
    shift = np.array([0.5 * rig.baseline_m, 0.0, 0.0])
    x_left_rect = pts + shift
    x_left = x_left_rect @ rig.rect_left  # rect_left maps camera -> rectified; its transpose maps back
    x_right = x_left @ rig.rotation.T + rig.translation
    raw_l = cv2.projectPoints(x_left, np.zeros(3), np.zeros(3), rig.camera_matrix_left, rig.dist_left)[0]
    raw_r = cv2.projectPoints(x_right, np.zeros(3), np.zeros(3), rig.camera_matrix_right, rig.dist_right)[0]
    got = rig.triangulate(raw_l.reshape(-1, 2), raw_r.reshape(-1, 2), rectified=False)
    np.testing.assert_allclose(got, pts, atol=1e-6)


def test_ideal_rig_agrees_with_the_same_rig_built_from_calibration_numbers():
    ideal = StereoRig.ideal(focal_px=600.0, image_size=(640, 480), baseline_m=0.1)
    k = np.array([[600.0, 0.0, 319.5], [0.0, 600.0, 239.5], [0.0, 0.0, 1.0]])
    built = StereoRig((640, 480), k, np.zeros(5), k, np.zeros(5), np.eye(3), [-0.1, 0.0, 0.0])
    np.testing.assert_allclose(built.proj_left, ideal.proj_left)
    np.testing.assert_allclose(built.proj_right, ideal.proj_right)
    uv = np.array([[100.0, 200.0], [400.0, 50.0]])
    np.testing.assert_allclose(built.triangulate(uv, uv - [30.0, 0.0]), ideal.triangulate(uv, uv - [30.0, 0.0]))


def test_non_positive_disparity_gives_nan_rows_not_an_error():
    rig = StereoRig.ideal(focal_px=500.0, image_size=(640, 480), baseline_m=0.1)
    out = rig.triangulate([[300.0, 200.0], [300.0, 200.0]], [[310.0, 200.0], [290.0, 200.0]])
    assert np.isnan(out[0]).all() and np.isfinite(out[1]).all()


def test_empty_inputs_give_empty_outputs():
    rig = StereoRig.ideal(focal_px=500.0, image_size=(640, 480), baseline_m=0.1)
    assert rig.triangulate(np.zeros((0, 2)), np.zeros((0, 2))).shape == (0, 3)
    assert rig.triangulate([], [], rectified=False).shape == (0, 3)


def test_dict_round_trip_is_exact():
    rig = _real_rig()
    back = StereoRig.from_dict(rig.to_dict())
    assert back.to_dict() == rig.to_dict()
    np.testing.assert_array_equal(back.proj_right, rig.proj_right)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"focal_px": -1.0}, "focal_px"),
        ({"baseline_m": 0.0}, "baseline_m"),
        ({"image_size": (640,)}, "image_size"),
    ],
)
def test_ideal_rejects_bad_values(kwargs, match):
    args = {"focal_px": 500.0, "image_size": (640, 480), "baseline_m": 0.1} | kwargs
    with pytest.raises(ValueError, match=match):
        StereoRig.ideal(**args)


def test_bad_rigs_are_rejected_with_clear_errors():
    k = np.array([[500.0, 0.0, 320.0], [0.0, 500.0, 240.0], [0.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match="swap the two cameras"):
        StereoRig((640, 480), k, np.zeros(5), k, np.zeros(5), np.eye(3), [0.1, 0.0, 0.0])
    with pytest.raises(ValueError, match="rotation"):
        StereoRig((640, 480), k, np.zeros(5), k, np.zeros(5), 2 * np.eye(3), [-0.1, 0.0, 0.0])
    with pytest.raises(ValueError, match="vertically"):
        StereoRig((640, 480), k, np.zeros(5), k, np.zeros(5), np.eye(3), [0.0, -0.1, 0.0])
    with pytest.raises(ValueError, match="unknown key"):
        StereoRig.from_dict(StereoRig.ideal(500.0, (640, 480), 0.1).to_dict() | {"baseline": 1})
    rig = StereoRig.ideal(500.0, (640, 480), 0.1)
    with pytest.raises(ValueError, match="uv_left"):
        rig.triangulate(np.zeros((3, 3)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="same shape"):
        rig.triangulate(np.zeros((3, 2)), np.zeros((2, 2)))


def test_calibration_recovers_a_synthetic_rig():
    truth = StereoRig.ideal(focal_px=520.0, image_size=(640, 480), baseline_m=0.12)
    obj = chessboard_points((9, 6), 0.03)
    rng = np.random.default_rng(3)
    left, right = [], []
    for _ in range(8):
        rvec = rng.uniform(-0.4, 0.4, 3)
        tvec = np.array([-0.12, -0.08, 0.0]) + rng.uniform([-0.05, -0.05, 0.7], [0.05, 0.05, 1.0])
        rmat = cv2.Rodrigues(rvec)[0]
        x_left = obj @ rmat.T + tvec
        # ideal rig: the left camera is the rectified left frame, so the scene frame is shifted by -b/2
        ul, ur = truth.project(x_left - [0.06, 0.0, 0.0])
        left.append(ul.astype(np.float32))
        right.append(ur.astype(np.float32))
    cal = calibrate_stereo(left, right, (9, 6), 0.03, (640, 480))
    assert cal.rms_px < 1e-3
    assert cal.rig.baseline_m == pytest.approx(0.12, rel=1e-3)
    np.testing.assert_allclose(cal.rig.rotation, np.eye(3), atol=1e-4)
    assert cal.per_view_rms_px.shape == (8, 2)


def test_a_pair_whose_pictures_disagree_is_left_out():
    """View 5 pairs a left picture with the right picture of view 0: its left-to-right pose is an outlier."""
    truth = StereoRig.ideal(focal_px=520.0, image_size=(640, 480), baseline_m=0.12)
    obj = chessboard_points((9, 6), 0.03)
    rng = np.random.default_rng(5)
    left, right = [], []
    for _ in range(7):
        rmat = cv2.Rodrigues(rng.uniform(-0.4, 0.4, 3))[0]
        tvec = np.array([-0.12, -0.08, 0.0]) + rng.uniform([-0.05, -0.05, 0.7], [0.05, 0.05, 1.0])
        ul, ur = truth.project(obj @ rmat.T + tvec - [0.06, 0.0, 0.0])
        left.append(ul.astype(np.float32))
        right.append(ur.astype(np.float32))
    right[5] = right[0]
    cal = calibrate_stereo(left, right, (9, 6), 0.03, (640, 480))
    assert list(np.flatnonzero(~cal.used)) == [5]
    assert np.isnan(cal.per_view_rms_px[5]).all()
    assert cal.pose_deviation[5, 1] > 0.1 and np.all(cal.pose_deviation[cal.used] < 0.01)
    assert cal.rig.baseline_m == pytest.approx(0.12, rel=1e-3)
    kept_all = calibrate_stereo(left, right, (9, 6), 0.03, (640, 480), max_pose_deviation=None)
    assert kept_all.used.all() and kept_all.rms_px > 1.0


def test_calibration_needs_enough_views_and_matching_corners():
    obj = chessboard_points((9, 6), 0.03)
    corners = [np.zeros((54, 2), np.float32)] * 2
    with pytest.raises(ValueError, match="at least 3"):
        calibrate_camera(corners, (9, 6), 0.03, (640, 480))
    with pytest.raises(ValueError, match="holds 53 corners"):
        calibrate_camera([np.zeros((53, 2))] * 3, (9, 6), 0.03, (640, 480))
    with pytest.raises(ValueError, match="pattern_size"):
        chessboard_points((9,), 0.03)
    assert obj.shape == (54, 3)


def test_find_chessboard_returns_none_without_a_board():
    assert find_chessboard(np.full((480, 640), 128, np.uint8), (9, 6)) is None
    with pytest.raises(ValueError, match="uint8"):
        find_chessboard(np.zeros((480, 640), np.float32), (9, 6))


# ---------------------------------------------------------------------- real data: OpenCV's chessboard pairs
_CACHE: dict[str, tuple] = {}


@pytest.fixture
def chessboard_corners(shared_data):
    """Corners of the 13 real pairs, detected once per test session."""
    if "corners" in _CACHE:
        return _CACHE["corners"]
    shared = shared_data / "stereo-chessboard"
    left, right = [], []
    for n in NAMES:
        for side, out in (("left", left), ("right", right)):
            img = cv2.imread(str(shared / f"{side}{n}.jpg"), cv2.IMREAD_GRAYSCALE)
            assert img is not None, f"{side}{n}.jpg"
            corners = find_chessboard(img, (9, 6))
            assert corners is not None, f"no chessboard in {side}{n}.jpg"
            out.append(corners)
    reference = json.loads((shared / "published_reference.json").read_text())
    _CACHE["corners"] = (left, right, reference)
    return _CACHE["corners"]


@pytest.mark.shared_data
def test_left_camera_reproduces_opencv_published_result(chessboard_corners):
    left, _, ref = chessboard_corners
    cal = calibrate_camera(left, tuple(ref["pattern_size_inner_corners"]), ref["square_size"], (640, 480),
                           flags=ref["calibrateCamera_flags"])
    assert abs(cal.rms_px - ref["rms"]) < ref["rms_tolerance_abs"]
    assert np.abs(cal.camera_matrix - np.array(ref["camera_matrix"])).sum() < ref["camera_matrix_tolerance_L1"]
    # distortion is weakly determined (SOURCES.md): compare loosely
    assert np.abs(cal.dist_coeffs - np.array(ref["dist_coeffs"])).sum() < 0.05


@pytest.mark.shared_data
def test_stereo_calibration_on_all_thirteen_real_pairs(chessboard_corners):
    left, right, _ = chessboard_corners
    cal = calibrate_stereo(left, right, (9, 6), 1.0, (640, 480))
    assert cal.rms_px < 1.0
    assert cal.per_view_rms_px.shape == (13, 2)
    assert cal.used.all()  # every real pair is consistent
    angle = np.linalg.norm(cv2.Rodrigues(cal.rig.rotation)[0])
    assert angle < np.radians(2.0)
    assert cal.rig.baseline_m == pytest.approx(3.3, abs=0.15)  # in squares (square size 1)
    # the adjacent corners of a triangulated board are one square apart
    pts = cal.rig.triangulate(left[0], right[0], rectified=False).reshape(6, 9, 3)
    spacing = np.linalg.norm(np.diff(pts, axis=1), axis=2)
    assert np.median(spacing) == pytest.approx(1.0, abs=0.02)
