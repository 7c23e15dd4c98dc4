"""The simulated RGB-D camera: exact depth of the room's planes, and the errors it is documented to have."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.depth import locate_faces_depth
from sim.depth import DepthErrors, DepthRenderer
from sim.render import default_scene


def _renderer(errors: DepthErrors, *, moving: bool = False) -> DepthRenderer:
    scene = default_scene(moving=moving)
    return DepthRenderer(scene, lambda t: scene.people, errors)


def test_the_ideal_depth_is_the_planes_depth() -> None:
    """The back wall at z = 6 m (the room's depth) and each face at its centre's depth, at the pixel where its
    centre projects (the faces are planes facing the camera)."""
    depth = _renderer(DepthErrors.none()).ideal(0.0)
    scene = default_scene()
    frame = scene.render(0.0)
    uv, _ = scene.rig.project(frame.faces)
    for (u, v), face in zip(np.rint(uv).astype(int), frame.faces):
        assert depth[v, u] == pytest.approx(face[2], abs=1e-4)
    wall = scene.rig.project(np.array([[2.5, -1.0, 6.0]]))[0][0]
    assert depth[int(round(wall[1])), int(round(wall[0]))] == pytest.approx(6.0, abs=1e-3)


def test_the_noise_grows_with_the_square_of_the_distance() -> None:
    """On a face (about 1.3 m) and on the back wall (6 m) the depth's RMS error is the documented z^2 law within 25 %."""
    errors = DepthErrors(edge_invalid=0.0, dark_invalid=0.0, offset_s=0.0)
    dr = _renderer(errors)
    ideal = dr.ideal(0.0)
    colour = np.full(ideal.shape + (3,), 128, np.uint8)
    noisy = np.stack([dr.render(k / 30, colour) for k in range(20)])
    scene = dr.renderer
    x, y, w, h = np.rint(scene.render(0.0).face_boxes_left[0]).astype(int)  # the nearest face, 1.3 m away
    face = (slice(y + h // 4, y + 3 * h // 4), slice(x + w // 4, x + 3 * w // 4))
    wall = (slice(150, 200), slice(530, 590))  # the back wall, right of everybody
    for where, z in ((face, 1.3), (wall, 6.0)):
        region = ideal[where]
        assert np.all(np.abs(region - z) < 0.1), "the region is not on the plane it is meant to be on"
        rms = float(np.sqrt(np.nanmean((noisy[(slice(None), *where)] - region) ** 2)))
        assert rms == pytest.approx(errors.rms_m(z, scene.rig.focal_px), rel=0.25)


def test_edges_and_dark_surfaces_lose_their_depth() -> None:
    """Invalid pixels gather at depth steps and on dark pixels; elsewhere nearly every pixel has a depth."""
    dr = _renderer(DepthErrors(subpixel=0.0, offset_s=0.0))
    ideal = dr.ideal(0.0)
    colour = np.full(ideal.shape + (3,), 128, np.uint8)
    colour[400:, :100] = 10  # a dark corner
    depth = dr.render(0.0, colour)
    step = np.abs(np.diff(ideal, axis=1)) > 0.1
    edge_rows, edge_cols = np.nonzero(step)
    assert np.isnan(depth[edge_rows, edge_cols]).mean() > 0.4
    assert np.isnan(depth[400:, :100]).mean() > 0.35
    assert np.isnan(depth[:300, 300:600][~step[:300, 300:600]]).mean() < 0.1


def test_rgbd_faces_within_two_centimetres(face_finder) -> None:  # noqa: ANN001
    """F3D from the simulated D435's depth (noise, holes, a 4 ms offset on swaying people): every face found, its
    median error within 2 cm of its centre at 1.3-2.9 m (the RGB-D target)."""
    scene = default_scene(moving=True)
    dr = DepthRenderer(scene, lambda t: scene.people)
    errors = []
    for k in range(10):
        frame = scene.render(k / 15)
        faces = locate_faces_depth(frame.left, dr.render(k / 15, frame.left), scene.rig, detector=face_finder)
        nearest = np.linalg.norm(frame.faces[:, None] - faces.points[None], axis=2).min(axis=1)
        assert np.all(nearest < 0.05), (k, nearest)  # every face found, none far off
        errors += nearest.tolist()
    assert np.median(errors) < 0.02
