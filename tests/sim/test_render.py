"""Tests of sim.render: the stereo scene renderer and its ground truth."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.faces import HaarFaceDetector
from sim.render import Person, StereoSceneRenderer, default_scene, drawn_face_texture, load_face_textures
from avcore.stereo import StereoRig


def test_frames_have_the_rig_size_and_are_reproducible():
    scene = default_scene(None, moving=True, seed=4)
    a, b = scene.render(0.25), scene.render(0.25)
    assert a.left.shape == (480, 640, 3) and a.right.shape == (480, 640, 3) and a.left.dtype == np.uint8
    np.testing.assert_array_equal(a.left, b.left)
    assert not np.array_equal(a.left, a.right)  # parallax
    assert a.faces.shape == (3, 3) and a.face_boxes_left.shape == (3, 4)


def test_ground_truth_boxes_are_where_the_faces_are_drawn():
    """A face alone on a black background: the drawn pixels lie inside its ground-truth box."""
    rig = StereoRig.ideal(554.0, (640, 480), 0.12)
    face = drawn_face_texture()
    scene = StereoSceneRenderer(rig, [Person(face, (0.2, 0.1, 1.5))], noise_std=0.0)
    scene._background["left"] = np.zeros((480, 640, 3), np.uint8)  # no room: only the person is drawn
    scene._background["right"] = np.zeros((480, 640, 3), np.uint8)
    frame = scene.render(0.0)
    x, y, w, h = frame.face_boxes_left[0]
    # the face box is 0.16 m wide at 1.5 m
    assert w == pytest.approx(554.0 * 0.16 / 1.5, rel=1e-6)
    # the box centre triangulates back to the ground-truth face centre through the rig
    centre_l = np.array([[x + w / 2 - 0.5, y + h / 2 - 0.5]])
    disparity = 554.0 * 0.12 / 1.5
    np.testing.assert_allclose(rig.triangulate(centre_l, centre_l - [disparity, 0.0]), frame.faces, atol=1e-9)
    # the skin colour is inside the box
    skin = np.all(np.abs(frame.left.astype(int) - (150, 180, 220)) < 12, axis=2)
    ys, xs = np.nonzero(skin)
    assert xs.min() >= x - 1 and xs.max() <= x + w + 1 and ys.min() >= y - 0.25 * h


def test_moving_people_move_and_still_people_do_not():
    still = default_scene(None, moving=False, seed=1)
    moving = default_scene(None, moving=True, seed=1)
    np.testing.assert_allclose(still.render(0.0).faces, still.render(0.5).faces)
    assert np.abs(moving.render(0.0).faces - moving.render(0.5).faces).max() > 0.01


def test_distance_to_people():
    rig = StereoRig.ideal(554.0, (640, 480), 0.12)
    scene = StereoSceneRenderer(rig, [Person(drawn_face_texture(), (0.0, 0.0, 2.0))])
    d = scene.distance_to_people(np.array([[0.0, 0.0, 2.0], [0.0, 0.5, 2.3], [3.0, 0.0, 2.0]]), 0.0)
    assert d[0] == pytest.approx(0.0, abs=1e-12)
    # at chest height, 0.24 m behind the body plane (which is 0.06 m behind the face)
    assert d[1] == pytest.approx(0.24, abs=1e-9)
    assert d[2] > 2.5


@pytest.mark.shared_data
def test_real_face_crops(shared_data):
    textures = load_face_textures(shared_data / "faces")
    assert len(textures) >= 8
    for t in textures:
        x, y, w, h = t.face_box
        assert w == pytest.approx(96.0)
        assert 0 <= x and x + w <= t.image.shape[1] + 1e-9 and y + h <= t.image.shape[0] + 1e-9


def test_missing_face_folder_falls_back_to_drawn_faces(tmp_path):
    with pytest.raises(FileNotFoundError):
        load_face_textures(tmp_path)
    scene = default_scene(tmp_path)
    assert all(p.face.source == "drawn" for p in scene.people)


def test_person_validation():
    with pytest.raises(ValueError, match="position"):
        Person(drawn_face_texture(), (0.0, 0.0, -1.0))


@pytest.mark.parametrize("skin", [(150, 180, 220), (110, 140, 190), (90, 120, 160), (130, 160, 205), (70, 95, 130)])
def test_every_drawn_skin_is_found_by_the_default_detector(skin):
    """The drawn faces stand in for real ones on a clean machine: the Haar cascade must find each skin colour, at
    the distances of the scenarios and nodding (the darkest skin was missed when its eyes were pure white)."""
    rig = StereoRig.ideal(focal_px=554.0, image_size=(640, 480), baseline_m=0.12)
    face = drawn_face_texture(skin_bgr=skin)
    detector = HaarFaceDetector()
    for z in (1.3, 2.0, 2.9):
        scene = StereoSceneRenderer(rig, [Person(face=face, position=(0.4, -0.1, z), nod_rad=0.17)], seed=0)
        for t in (0.0, 0.45):
            frame = scene.render(t)
            boxes = detector.detect(frame.left)
            truth = frame.face_boxes_left[0]
            centres = boxes[:, :2] + boxes[:, 2:] / 2
            assert len(boxes) and np.min(np.linalg.norm(centres - (truth[:2] + truth[2:] / 2), axis=1)) < 15, (z, t)


def test_people_with_arms_gesture_and_a_table_hides_their_lower_body():
    """Bodies in the rendered scenes (issue 18): forearms and hands in front of the chest that swing while the person
    gestures, and a table front that covers the lower body; the table is not a person."""
    rig = StereoRig.ideal(554.0, (640, 480), 0.12)
    face = drawn_face_texture()
    plain = Person(face=face, position=(0.0, -0.1, 2.0))
    body = Person(face=face, position=(0.0, -0.1, 2.0), arms=True, gesture_m=0.15, table=True)
    assert len(body.quads(0.0)) == len(plain.quads(0.0)) + 4 and not plain.props(0.0)
    hands = [np.concatenate([q.mean(axis=0) for q, _ in body.quads(t)[-3::2]]) for t in (0.0, 0.3)]
    assert np.abs(hands[0] - hands[1]).max() > 0.03  # the hands moved
    img_plain = StereoSceneRenderer(rig, [plain], noise_std=0.0).render(0.0).left
    img_body = StereoSceneRenderer(rig, [body], noise_std=0.0).render(0.0).left
    (table,) = body.props(0.0)
    below = rig.project(np.array([[0.0, table[0][0][1] + 0.2, 2.0]]))[0][0]  # the shirt, 20 cm below the table top
    x, y = int(round(below[0])), int(round(below[1]))
    assert not np.array_equal(img_plain[y, x], img_body[y, x])  # covered by the table
    scene = StereoSceneRenderer(rig, [body], noise_std=0.0)
    table_centre = table[0].mean(axis=0)[None]
    assert scene.distance_to_people(table_centre, 0.0)[0] > 0.05
