"""avcore.facemesh: the crop MediaPipe's graphs describe, the mesh on real faces checked against BlazeFace's own
keypoints (another network), and the mouth's opening read from the lips."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from avcore.facemesh import (INPUT_PX, LEFT_EYE_CORNERS, LIP_CORNERS, LIP_INNER_LOWER, LIP_INNER_UPPER, N_LANDMARKS,
                             RIGHT_EYE_CORNERS, FaceMesh, _crop_transforms, eye_centres, mouth_opening)

SHARED_DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"  # as tests/conftest.py finds it


def test_the_crop_is_a_level_square_one_and_a_half_faces_wide() -> None:
    """A face box (x, y, w, h) = (100, 50, 40, 60) is cropped around its centre (120, 80), 1.5 x 60 = 90 px a side
    (the longer side), to 192 px; with eyes at 30 degrees the crop turns so that the eyes are level."""
    (m,) = _crop_transforms(np.array([[100.0, 50.0, 40.0, 60.0]]), None)
    corner, centre = m @ [75.0, 35.0, 1.0], m @ [120.0, 80.0, 1.0]
    np.testing.assert_allclose(centre, [INPUT_PX / 2, INPUT_PX / 2])
    np.testing.assert_allclose(corner, [0.0, 0.0], atol=1e-9)
    eyes = np.array([[[110.0, 70.0], [110.0 + 20 * np.cos(np.pi / 6), 70.0 + 20 * np.sin(np.pi / 6)]]])
    (turned,) = _crop_transforms(np.array([[100.0, 50.0, 40.0, 60.0]]), eyes)
    right, left = (turned @ [*p, 1.0] for p in eyes[0])
    assert right[1] == pytest.approx(left[1]) and left[0] > right[0]  # level, and the right eye on the left
    assert np.linalg.norm(left - right) == pytest.approx(20 * INPUT_PX / 90)


def test_mouth_opening_is_the_lips_gap_over_the_mouths_width() -> None:
    marks = np.zeros((2, N_LANDMARKS, 3))
    marks[:, LIP_CORNERS[0], :2], marks[:, LIP_CORNERS[1], :2] = [10.0, 50.0], [50.0, 50.0]
    marks[0, LIP_INNER_UPPER, :2], marks[0, LIP_INNER_LOWER, :2] = [30.0, 48.0], [30.0, 60.0]
    marks[1, LIP_INNER_UPPER, :2] = marks[1, LIP_INNER_LOWER, :2] = [30.0, 50.0]
    np.testing.assert_allclose(mouth_opening(marks), [12.0 / 40.0, 0.0])
    assert np.isnan(mouth_opening(np.full((N_LANDMARKS, 3), np.nan)))


def test_each_eyes_centre_is_the_middle_of_its_corners() -> None:
    marks = np.full((2, N_LANDMARKS, 3), np.nan)
    marks[0, RIGHT_EYE_CORNERS[0], :2], marks[0, RIGHT_EYE_CORNERS[1], :2] = [10.0, 40.0], [20.0, 42.0]
    marks[0, LEFT_EYE_CORNERS[0], :2], marks[0, LEFT_EYE_CORNERS[1], :2] = [40.0, 42.0], [50.0, 40.0]
    eyes = eye_centres(marks)
    assert eyes.shape == (2, 2, 2)
    np.testing.assert_allclose(eyes[0], [[15.0, 41.0], [45.0, 41.0]])  # the person's right eye first
    assert np.isnan(eyes[1]).all()  # no mesh, no eyes


@pytest.fixture(scope="module")
def models() -> tuple[Path, Path]:
    from app.errors import UserError
    from app.models import blazeface_model

    from app.models import facemesh_model

    try:
        return blazeface_model(), facemesh_model()
    except UserError as exc:
        pytest.skip(str(exc))


@pytest.fixture(scope="module")
def faces(models: tuple[Path, Path]) -> list[tuple[np.ndarray, object]]:
    from avcore.blazeface import BlazeFaceDetector

    if not SHARED_DATA.is_dir():
        pytest.skip(f"../shared/data not found at {SHARED_DATA}")
    detector = BlazeFaceDetector(models[0])
    out = []
    for path in sorted((SHARED_DATA / "faces").glob("20*.jpg")):
        img = cv2.imread(str(path))
        out.append((img, detector.detect_faces(img)))
    return out


@pytest.mark.shared_data
def test_the_mesh_lands_on_real_faces_where_blazeface_puts_their_eyes_and_mouth(
        models: tuple[Path, Path], faces: list) -> None:
    """On the photographs' faces (found by BlazeFace, another network), the mesh sees a face in each crop, puts each
    eye's centre within 12 % of the face's width of BlazeFace's eye and the inner lips' middle within 15 % of its
    mouth point, and every landmark inside the crop."""
    mesh = FaceMesh(models[1])
    n = 0
    for img, found in faces:
        result = mesh.run(img, found.boxes, found.keypoints[:, :2])
        assert (result.presence > 0.5).all()
        for marks, box, keys in zip(result.landmarks, found.boxes, found.keypoints, strict=True):
            width = box[2]
            right, left = eye_centres(marks[None])[0]
            assert np.linalg.norm(right - keys[0]) < 0.12 * width
            assert np.linalg.norm(left - keys[1]) < 0.12 * width
            lips = marks[[LIP_INNER_UPPER, LIP_INNER_LOWER], :2].mean(0)
            assert np.linalg.norm(lips - keys[3]) < 0.15 * width
            centre, half = box[:2] + box[2:] / 2, 0.75 * box[2:].max() * np.sqrt(2)
            assert (np.abs(marks[:, :2] - centre) <= half).all()
            n += 1
    assert n >= 40  # the photographs hold 43 labelled faces


@pytest.mark.shared_data
def test_an_open_mouth_reads_as_open(models: tuple[Path, Path], faces: list) -> None:
    """Each face of 50 px or more whose mouth is closed (opening under 0.12), opened by hand (a dark cavity drawn
    between its lips, as tall as 0.4 of its mouth's width): the measured opening rises by more than 0.1. (Faces of
    30-45 px rise less: their mouths are a dozen pixels wide.)"""
    mesh = FaceMesh(models[1])
    tried = 0
    for img, found in faces:
        for i in range(len(found)):
            if found.boxes[i, 2] < 50:
                continue
            box, eyes = found.boxes[i:i + 1], found.keypoints[i:i + 1, :2]
            before = mesh.run(img, box, eyes).landmarks[0]
            if not mouth_opening(before) < 0.12:
                continue
            opened = img.copy()
            lips = before[[LIP_INNER_UPPER, LIP_INNER_LOWER], :2].mean(0)
            width = np.linalg.norm(before[LIP_CORNERS[1], :2] - before[LIP_CORNERS[0], :2])
            cv2.ellipse(opened, (int(lips[0]), int(lips[1])), (int(0.4 * width), int(0.2 * width)), 0, 0, 360,
                        (25, 15, 20), -1, cv2.LINE_AA)
            after = mesh.run(opened, box, eyes).landmarks[0]
            assert mouth_opening(after) > mouth_opening(before) + 0.1
            tried += 1
    assert tried >= 3


@pytest.mark.shared_data
def test_the_mesh_turns_with_a_turned_head(models: tuple[Path, Path], faces: list) -> None:
    """The photograph turned by 25 degrees about a face, the eyes given turned with it: the mesh's points are the
    first mesh's points turned (within 4 % of the face's width)."""
    mesh = FaceMesh(models[1])
    img, found = faces[1]
    i = int(np.argmax(found.boxes[:, 2]))
    box, keys = found.boxes[i], found.keypoints[i, :2]
    first = mesh.run(img, box[None], keys[None]).landmarks[0]
    centre = tuple(float(v) for v in box[:2] + box[2:] / 2)
    turn = cv2.getRotationMatrix2D(centre, 25.0, 1.0)
    turned_img = cv2.warpAffine(img, turn, img.shape[1::-1], borderMode=cv2.BORDER_REPLICATE)
    turned_keys = keys @ turn[:, :2].T + turn[:, 2]
    second = mesh.run(turned_img, box[None], turned_keys[None]).landmarks[0]
    expected = first[:, :2] @ turn[:, :2].T + turn[:, 2]
    assert np.median(np.linalg.norm(second[:, :2] - expected, axis=1)) < 0.04 * box[2]


def test_no_face_no_landmarks(models: tuple[Path, Path]) -> None:
    mesh = FaceMesh(models[1])
    result = mesh.run(np.full((200, 200, 3), 128, np.uint8), np.array([[50.0, 50.0, 80.0, 80.0]]))
    assert result.presence[0] < 0.5 and np.isnan(result.landmarks).all()
    empty = mesh.run(np.zeros((10, 10), np.uint8), np.zeros((0, 4)))
    assert empty.landmarks.shape == (0, N_LANDMARKS, 3)
    with pytest.raises(ValueError, match="not found"):
        FaceMesh(Path("/nonexistent/face_landmark.tflite"))
