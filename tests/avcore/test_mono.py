"""F3D with one camera: a face's distance from the span of its eyes, or of its box, in the image."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from avcore.faces import HaarFaceDetector
from avcore.mono import HAAR_BOX_PER_IPD, INTERPUPILLARY_M, face_distances, locate_faces_mono
from sim.render import default_scene


def test_the_pinhole_distance_of_eyes_and_boxes() -> None:
    """z = f S / s: eyes 63 mm apart spanning 17.5 px at f = 700 px lie 2.52 m away; a box spanning 2.64 of those
    distances reads the same; no span is no distance."""
    boxes = np.array([[100.0, 50.0, 17.5 * HAAR_BOX_PER_IPD, 40.0], [0.0, 0.0, 0.0, 0.0]])
    eyes = np.array([[[110.0, 60.0], [127.5, 60.0]], [[5.0, 5.0], [5.0, 5.0]]])
    by_eyes = face_distances(boxes, eyes, 700.0)
    by_box = face_distances(boxes, None, 700.0)
    assert by_eyes[0] == pytest.approx(700.0 * INTERPUPILLARY_M / 17.5) == pytest.approx(2.52)
    assert by_box[0] == pytest.approx(by_eyes[0])
    assert np.isnan(by_eyes[1]) and np.isnan(by_box[1])
    with pytest.raises(ValueError, match="one pair of eyes per box"):
        face_distances(boxes, eyes[:1], 700.0)


def _depth_errors(detector: object, eyes_from: object = None) -> np.ndarray:
    """Relative depth errors of the faces of the rendered scene (three people 1.3-2.9 m away), left image alone."""
    scene = default_scene()
    errors = []
    for t in (0.0, 0.5, 1.0):
        frame = scene.render(t)
        found = locate_faces_mono(frame.left, scene.rig, detector=detector,  # type: ignore[arg-type]
                                  eyes_from=eyes_from)  # type: ignore[arg-type]
        assert len(found) == len(frame.faces) and found.unmatched.shape == (0, 4)
        for true in frame.faces:
            near = found.points[np.argmin(np.linalg.norm(found.points[:, :2] - true[:2], axis=1))]
            errors.append(abs(near[2] - true[2]) / true[2])
            # the direction is the box's: the error lies along the line of sight
            assert np.degrees(np.arccos(near @ true / np.linalg.norm(near) / np.linalg.norm(true))) < 1.5
    return np.asarray(errors)


@pytest.mark.shared_data
@pytest.mark.haar
def test_one_camera_places_real_faces_by_their_box(shared_data: Path) -> None:
    """OpenCV's boxes with the box-to-eyes ratio measured on real photographs, on the simulated room's real faces
    (S3: three people 1.6-2.6 m away, every 10th frame of 4 s): within 10 % of the true depth in median. (The drawn
    faces of ``default_scene`` have no real proportions: Haar's boxes on them are 1.3 times the face's.)"""
    from app.sources.sim import SimSource

    source = SimSource.from_preset("S3", duration_s=4.0, fps=10, data_dir=shared_data, camera="mono")
    errors = []
    for frame in list(source.frames(realtime=False))[::4]:
        assert frame.right is None and frame.depth_m is None
        truth = source.truth(frame.index)
        found = locate_faces_mono(frame.left, source.stereo, detector=HaarFaceDetector())
        for true in truth.positions_m[truth.visible]:
            if len(found):
                near = found.points[np.argmin(np.linalg.norm(found.points[:, :2] - true[:2], axis=1))]
                errors.append(abs(near[2] - true[2]) / true[2])
    assert len(errors) >= 25 and np.median(errors) < 0.10


def test_one_camera_places_the_rendered_faces_by_their_eyes() -> None:
    """BlazeFace's eyes with the population's interpupillary distance, on the drawn faces: within 10 % of the true
    depth in median, 20 % at worst."""
    from app.errors import UserError
    from app.models import blazeface_model
    from avcore.blazeface import BlazeFaceDetector

    try:
        model: Path = blazeface_model()
    except UserError as exc:
        pytest.skip(str(exc))
    errors = _depth_errors(BlazeFaceDetector(model, tiles=2))
    assert np.median(errors) < 0.10 and errors.max() < 0.20


def test_better_eyes_replace_the_detectors_where_they_are_given() -> None:
    """``eyes_from`` gets the image, the boxes and the detector's eyes; its eyes twice as far apart halve a face's
    distance, and a face it has none for (NaN) keeps the detector's."""
    from avcore.blazeface import FaceDetections

    scene = default_scene()
    frame = scene.render(0.0)
    boxes = np.array([[100.0, 100.0, 40.0, 40.0], [400.0, 100.0, 40.0, 40.0]])
    keypoints = np.zeros((2, 6, 2))
    keypoints[:, 0], keypoints[:, 1] = boxes[:, :2] + [10.0, 15.0], boxes[:, :2] + [30.0, 15.0]

    class _Finder:
        def detect_faces(self, image: np.ndarray) -> FaceDetections:
            return FaceDetections(boxes.copy(), keypoints.copy(), np.ones(2))

    seen = []

    def wider(image: np.ndarray, b: np.ndarray, eyes: np.ndarray) -> np.ndarray:
        seen.append((image, b.copy(), eyes.copy()))
        out = np.full((2, 2, 2), np.nan)
        out[0] = [eyes[0, 0] - [10.0, 0.0], eyes[0, 1] + [10.0, 0.0]]  # 40 px apart instead of 20
        return out

    plain = locate_faces_mono(frame.left, scene.rig, detector=_Finder())
    better = locate_faces_mono(frame.left, scene.rig, detector=_Finder(), eyes_from=wider)
    assert seen[0][0] is frame.left and np.array_equal(seen[0][1], boxes)
    np.testing.assert_array_equal(seen[0][2], keypoints[:, :2])
    assert better.points[0, 2] == pytest.approx(plain.points[0, 2] / 2)
    assert better.points[1, 2] == pytest.approx(plain.points[1, 2])


def test_the_face_meshs_eyes_place_the_rendered_faces_too() -> None:
    """The mesh's eye centres (``--read-lips``) in place of BlazeFace's keypoints: within 10 % in median."""
    from app.errors import UserError
    from app.models import blazeface_model, facemesh_model
    from avcore.blazeface import BlazeFaceDetector
    from avcore.facemesh import FaceMesh, eye_centres

    try:
        detector, mesh = BlazeFaceDetector(blazeface_model(), tiles=2), FaceMesh(facemesh_model())
    except UserError as exc:
        pytest.skip(str(exc))
    errors = _depth_errors(detector, lambda image, b, eyes: eye_centres(mesh.run(image, b, eyes).landmarks))
    assert np.median(errors) < 0.10 and errors.max() < 0.20


def test_faces_out_of_range_are_unmatched(face_finder) -> None:  # noqa: ANN001
    scene = default_scene()
    frame = scene.render(0.0)
    found = locate_faces_mono(frame.left, scene.rig, max_depth_m=1.0, detector=face_finder)
    assert len(found) == 0 and found.unmatched.shape[0] == len(frame.faces)
    with pytest.raises(ValueError, match="rig's size"):
        locate_faces_mono(frame.left[:100], scene.rig, detector=face_finder)
