"""Tests of avcore.motion: HM3D on rendered moving scenes (paper section 5.2)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from avcore.motion import harris_motion_points, temporal_std
from sim.render import default_scene
from avcore.stereo import StereoRig

TIMES = [0.2 + i / 15 for i in range(6)]  # 6 frames at 15 fps: an interval of 0.4 s


def _interval(scene):
    frames = [scene.render(t) for t in TIMES]
    left = np.stack([cv2.cvtColor(f.left, cv2.COLOR_BGR2GRAY) for f in frames])
    right = np.stack([cv2.cvtColor(f.right, cv2.COLOR_BGR2GRAY) for f in frames])
    return left, right


def _share_within(scene, result, limit_m=0.10) -> float:
    d = np.concatenate([scene.distance_to_people(result.points[result.frame_index == k], t)
                        for k, t in enumerate(TIMES)])
    return float(np.mean(d < limit_m))


def test_points_of_moving_people_lie_on_them():
    scene = default_scene(None, moving=True, seed=1)
    left, right = _interval(scene)
    result = harris_motion_points(left, right, scene.rig)
    assert len(result) > 1000  # the paper: about 2,000 per interval of 6 frames
    assert result.points.shape == (len(result), 3) and result.uv_left.shape == (len(result), 2)
    assert _share_within(scene, result) >= 0.90
    assert set(np.unique(result.frame_index)) <= set(range(len(TIMES)))


@pytest.mark.shared_data
def test_real_face_scene(shared_data):
    scene = default_scene(shared_data / "faces", moving=True, seed=0)
    left, right = _interval(scene)
    result = harris_motion_points(left, right, scene.rig)
    assert len(result) > 200
    assert _share_within(scene, result) >= 0.90


def test_a_still_scene_has_no_motion_points():
    """Only sensor noise changes: tau stays below tau_M and the textured room gives no point."""
    scene = default_scene(None, moving=False, seed=1)
    left, right = _interval(scene)
    assert temporal_std(left).max() < 15  # noise only
    result = harris_motion_points(left, right, scene.rig, tau_m=8.0)
    assert len(result) < 5
    assert result.points.shape[1] == 3


def test_temporal_std_matches_numpy():
    rng = np.random.default_rng(0)
    frames = rng.integers(0, 256, size=(5, 6, 7), dtype=np.uint8)
    np.testing.assert_allclose(temporal_std(frames), frames.astype(np.float64).std(axis=0), rtol=1e-4, atol=1e-3)


def test_empty_result_has_the_right_shapes():
    rig = StereoRig.ideal(554.0, (640, 480), 0.12)
    still = np.zeros((3, 480, 640), np.uint8)
    result = harris_motion_points(still, still, rig)
    assert result.points.shape == (0, 3) and result.frame_index.shape == (0,) and result.ncc.shape == (0,)


def test_bad_inputs():
    rig = StereoRig.ideal(554.0, (640, 480), 0.12)
    one = np.zeros((1, 480, 640), np.uint8)
    with pytest.raises(ValueError, match="at least 2 frames"):
        harris_motion_points(one, one, rig)
    with pytest.raises(ValueError, match="rig's images"):
        harris_motion_points(np.zeros((2, 240, 320), np.uint8), np.zeros((2, 240, 320), np.uint8), rig)
    with pytest.raises(ValueError, match="same shape"):
        harris_motion_points(np.zeros((2, 480, 640), np.uint8), np.zeros((3, 480, 640), np.uint8), rig)
    with pytest.raises(ValueError, match="patch_px"):
        harris_motion_points(np.zeros((2, 480, 640), np.uint8), np.zeros((2, 480, 640), np.uint8), rig, patch_px=4)
    with pytest.raises(ValueError, match=r"left_frames\[0\]"):
        harris_motion_points([np.zeros((480, 640), np.float32)] * 2, [np.zeros((480, 640), np.uint8)] * 2, rig)
    with pytest.raises(ValueError, match="no frame"):
        harris_motion_points([], [], rig)


def test_raw_frames_of_a_distorted_rig():
    k_l = np.array([[560.0, 0.0, 330.0], [0.0, 561.0, 240.0], [0.0, 0.0, 1.0]])
    k_r = np.array([[566.0, 0.0, 320.0], [0.0, 565.0, 245.0], [0.0, 0.0, 1.0]])
    rot = cv2.Rodrigues(np.array([0.004, -0.01, 0.003]))[0]
    rig = StereoRig((640, 480), k_l, [-0.2, 0.05, 0.001, -0.0005, 0.0], k_r, [-0.18, 0.03, 0.0, 0.0, 0.0],
                    rot, [-0.12, 0.002, 0.001])
    scene = default_scene(None, moving=True, seed=1, rig=rig)
    raws = [scene.to_raw(scene.render(t)) for t in TIMES]
    left = np.stack([cv2.cvtColor(lr[0], cv2.COLOR_BGR2GRAY) for lr in raws])
    right = np.stack([cv2.cvtColor(lr[1], cv2.COLOR_BGR2GRAY) for lr in raws])
    result = harris_motion_points(left, right, rig, rectified=False)
    assert len(result) > 500
    assert _share_within(scene, result) >= 0.90
