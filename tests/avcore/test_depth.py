"""F3D and HM3D from an RGB-D camera's depth: units, robustness of a face's depth, and the geometry of a pixel and
its depth in the scene frame."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.depth import as_depth_m, depth_millimetres, face_depth, locate_faces_depth, motion_points_depth
from avcore.stereo import StereoRig

RIG = StereoRig.ideal(focal_px=554.0, image_size=(640, 480), baseline_m=0.12)


def test_depth_units_and_invalid_pixels() -> None:
    mm = np.array([[0, 1500], [65535, 800]], np.uint16)  # 16UC1: millimetres, 0 = no depth
    got = as_depth_m(mm)
    assert np.isnan(got[0, 0]) and got[0, 1] == pytest.approx(1.5) and got[1, 1] == pytest.approx(0.8)
    metres = np.array([[0.0, np.inf], [np.nan, 2.25]], np.float32)  # 32FC1: metres, 0/inf/NaN = no depth
    got = as_depth_m(metres)
    assert np.isnan(got[:, 0]).all() and np.isnan(got[0, 1]) and got[1, 1] == 2.25
    with pytest.raises(ValueError, match="uint16 millimetres or float metres"):
        as_depth_m(np.zeros((2, 2), np.int32))
    back = depth_millimetres(np.array([[1.2344, np.nan], [70.0, 0.5]], np.float32))
    assert back.dtype == np.uint16 and back.tolist() == [[1234, 0], [65535, 500]]  # 0 = invalid, clipped at 65.535 m


def test_a_faces_depth_ignores_holes_background_and_flying_pixels() -> None:
    """Inside the box: the face at 1.50 m with 1 cm noise, background at 4 m over half of the inner region (a
    depth edge: a plain median would fall on either), 25 % holes, and a few flying pixels halfway: the face's depth
    within 5 mm."""
    rng = np.random.default_rng(0)
    depth = np.full((100, 100), 4.0, np.float32)
    depth[20:80, 20:70] = 1.5 + rng.normal(0, 0.01, (60, 50))
    depth[rng.random((100, 100)) < 0.25] = np.nan
    flying = rng.random((100, 100)) < 0.03
    depth[flying] = 2.7
    z, fraction = face_depth(depth, (20, 20, 100, 60))  # the box reaches past the face's right edge
    assert z == pytest.approx(1.5, abs=0.005)
    assert 0.65 < fraction < 0.85


def test_a_face_without_enough_depth_has_none() -> None:
    depth = np.full((60, 60), np.nan, np.float32)
    depth[28:31, 28:31] = 1.2  # 9 of the inner 900 pixels
    z, fraction = face_depth(depth, (0, 0, 60, 60))
    assert np.isnan(z) and fraction == pytest.approx(9 / 900)


def test_back_project_inverts_project() -> None:
    rng = np.random.default_rng(1)
    points = np.column_stack([rng.uniform(-1, 1, 20), rng.uniform(-0.5, 0.5, 20), rng.uniform(0.5, 6, 20)])
    uv_left, _ = RIG.project(points)
    np.testing.assert_allclose(RIG.back_project(uv_left, points[:, 2]), points, atol=1e-9)
    assert np.isnan(RIG.back_project([[320.0, 240.0]], [0.0])).all()


class _Boxes:
    def __init__(self, boxes: list[list[float]]) -> None:
        self.boxes = boxes

    def detect(self, image: np.ndarray) -> list[list[float]]:
        return self.boxes


def test_faces_located_from_depth_land_where_the_depth_says() -> None:
    """Two faces, one with a depth and one over a hole: the first at the back-projection of its box centre, the
    second reported unmatched."""
    image = np.zeros((480, 640, 3), np.uint8)
    depth = np.full((480, 640), 3000, np.uint16)  # millimetres
    depth[200:260, 100:150] = 1800
    depth[100:160, 400:450] = 0
    faces = locate_faces_depth(image, depth, RIG, detector=_Boxes([[100, 200, 50, 60], [400, 100, 50, 60]]))
    assert faces.boxes.tolist() == [[100, 200, 50, 60]] and faces.unmatched.tolist() == [[400, 100, 50, 60]]
    expected = RIG.back_project([[124.5, 229.5]], [1.8])[0]
    np.testing.assert_allclose(faces.points[0], expected, atol=1e-6)
    assert faces.points[0][0] < -0.5  # left of the rig's centre, as the box is in the left of the image


def test_faces_and_depth_of_another_size_are_refused() -> None:
    with pytest.raises(ValueError, match="rig's size"):
        locate_faces_depth(np.zeros((480, 640, 3), np.uint8), np.zeros((240, 320), np.uint16), RIG,
                           detector=_Boxes([]))


def test_motion_points_take_their_pixels_depth_and_skip_edges() -> None:
    """A textured square moving across a flat wall at 3 m, the square at 1.5 m: the dynamic Harris points come back
    at the square's depth or the wall's, never between (flying pixels at the edge are left out)."""
    rng = np.random.default_rng(2)
    texture = rng.integers(0, 255, (80, 80), np.uint8)
    frames, depths = [], []
    for k in range(6):
        img = np.full((480, 640), 100, np.uint8)
        depth = np.full((480, 640), 3.0, np.float32)
        x = 200 + 6 * k
        img[200:280, x:x + 80] = texture
        depth[200:280, x:x + 80] = 1.5
        depth[200:280, x - 1] = 2.2  # a flying pixel column at the square's left edge
        frames.append(img)
        depths.append(depth)
    points = motion_points_depth(frames, depths, RIG)
    assert len(points) > 20
    z = points.points[:, 2]
    assert np.all(np.isclose(z, 1.5) | np.isclose(z, 3.0))
    assert set(np.unique(points.frame_index)) <= set(range(6))
    with pytest.raises(ValueError, match="one depth image per frame"):
        motion_points_depth(frames, depths[:3], RIG)
