"""sim.relief: a turned head shows its near cheek, hides its far one behind the nose, and the tracker still finds it
(issue 30's faces turned up to 60 degrees)."""
from __future__ import annotations

import numpy as np
import pytest

from sim.relief import CENTRE_DEPTH, relief, turned_span, turned_view
from sim.face_textures import FaceTexture


def _marked_face() -> FaceTexture:
    """A grey 160 px texture, its face box 100 px wide in the middle, with one coloured dot at each of the places the
    test follows: each cheek, the nose's tip and the middle of the forehead."""
    image = np.full((160, 160, 3), 128, np.uint8)
    face = FaceTexture(image, (30.0, 30.0, 100.0, 100.0), "marked")
    for (x, y), colour in zip(MARKS.values(), COLOURS):
        px, py = round(80 + 100 * x), round(80 + 100 * y)
        image[py - 1:py + 2, px - 1:px + 2] = colour
    return face


MARKS = {"left cheek": (-0.38, 0.1), "right cheek": (0.38, 0.1), "nose": (0.0, 0.12), "forehead": (0.0, -0.3)}
COLOURS = ((255, 0, 0), (0, 255, 0), (0, 0, 255), (0, 255, 255))


def _where(view: np.ndarray, colour: tuple[int, int, int]) -> float | None:
    """The mean column of a mark in a turned view, None when it is hidden."""
    near = np.all(np.abs(view[..., :3].astype(int) - colour) < 60, axis=2) & (view[..., 3] > 0)
    cols = np.nonzero(near)[1]
    return float(cols.mean()) if cols.size else None


def test_the_relief_has_a_nose_in_front_of_the_cheeks_and_the_head_s_centre_behind() -> None:
    face = _marked_face()
    z = relief(face)
    depth = {name: z[round(80 + 100 * y), round(80 + 100 * x)] for name, (x, y) in MARKS.items()}
    assert depth["nose"] < -0.08 < 0.0 < depth["left cheek"] == pytest.approx(depth["right cheek"], abs=0.01)
    assert abs(z[80, 100]) < 0.05  # the face box's plane passes through the face beside the nose
    assert z[0, 0] == z[159, 159] == CENTRE_DEPTH  # outside the head's outline: the plane through its centre
    # continuous where the outline meets that plane (steep there, as a head's side seen from the front): sampled
    # eight times finer, the largest step between neighbours shrinks, where a jump would stay
    coarse, fine = (np.abs(np.diff(relief(face, supersample=k), axis=1)).max() for k in (8, 64))
    assert fine < 0.6 * coarse


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_head_turned_60_degrees_hides_its_far_cheek_and_shows_its_near_one_where_the_turn_puts_it(
        sign: float) -> None:
    face = _marked_face()
    z = relief(face)
    view = turned_view(face, face.image, np.radians(60.0 * sign))
    c, s = np.cos(np.radians(60.0)), np.sin(np.radians(60.0)) * sign
    near, far = ("right cheek", "left cheek") if sign > 0 else ("left cheek", "right cheek")
    assert _where(view, COLOURS[list(MARKS).index(far)]) is None  # behind the nose
    for name in (near, "nose", "forehead"):
        x, y = MARKS[name]
        expected = 80 + 100 * (c * x + s * z[round(80 + 100 * y), round(80 + 100 * x)])
        assert _where(view, COLOURS[list(MARKS).index(name)]) == pytest.approx(expected, abs=1.5), name
    # nothing of the head left of its outline: the room shows there
    assert view[..., 3].min() == 0 and view[..., 3].max() == 255


def test_an_unturned_head_is_its_texture_and_its_span_the_face_box() -> None:
    face = _marked_face()
    view = turned_view(face, face.image, 0.0)
    assert (view[..., 3] == 255).all()
    assert np.abs(view[..., :3].astype(int) - face.image).mean() < 1.0
    assert turned_span(face, 0.0) == pytest.approx((29.5, 130.5), abs=0.6)
    lo, hi = turned_span(face, np.radians(45.0))
    # the far edge comes in past the box's middle less than a flat turn would take it; the near edge goes out
    assert 30 < lo < 80 - 50 * np.cos(np.radians(45.0)) + 30 and hi > 80 + 50 * np.cos(np.radians(45.0))


def test_the_tracker_follows_a_head_turning_to_60_degrees(face_finder) -> None:  # noqa: ANN001
    from app.models import blazeface_model
    from avcore.blazeface import BlazeFaceDetector, TrackingBlazeFace
    from avcore.stereo import StereoRig
    from sim.face_textures import load_textures
    from sim.render import Person, StereoSceneRenderer

    if not isinstance(face_finder, BlazeFaceDetector):
        pytest.skip("BlazeFace's model is not installed")
    textures, kind = load_textures()
    if kind != "faces":
        pytest.skip("the photographed faces of ../shared/data are absent")
    scene = StereoSceneRenderer(StereoRig.ideal(554.0, (640, 480), 0.12), [])
    for face in textures[:4]:
        for sign in (1.0, -1.0):
            tracker = TrackingBlazeFace.from_model(blazeface_model())
            for deg in range(0, 61, 5):
                scene.people = [Person(face, (-0.06, -0.05, 2.1), yaw_rad=float(np.radians(sign * deg)))]
                frame = scene.render(0.0)
                for _ in range(2):
                    dets = tracker.detect(frame.left)
            x, y, w, h = frame.face_boxes_left[0]
            centres = dets[:, :2] + dets[:, 2:] / 2
            assert ((centres[:, 0] >= x) & (centres[:, 0] <= x + w) & (centres[:, 1] >= y)
                    & (centres[:, 1] <= y + h)).any(), (face.source, sign)
