"""avcore.blazeface: BlazeFace's outputs decoded as MediaPipe's graph decodes them, and the model on real faces."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from avcore.blazeface import GRID, INPUT_PX, BlazeFaceDetector, FaceDetections, decode, weighted_nms


def _outputs(cells: dict[tuple[int, int], tuple[float, list[float]]]) -> tuple[np.ndarray, np.ndarray]:
    """Model outputs with the given (row, col) anchors set: (logit, 16 regressors in input pixels)."""
    scores = np.full((1, GRID * GRID, 1), -50.0, np.float32)
    raw = np.zeros((1, GRID * GRID, 16), np.float32)
    for (row, col), (logit, values) in cells.items():
        scores[0, row * GRID + col, 0] = logit
        raw[0, row * GRID + col] = values
    return scores, raw


def test_an_anchor_decodes_to_its_cell_plus_its_offsets() -> None:
    """Anchor (row 10, col 20) is centred at ((20 + 0.5) / 48, (10 + 0.5) / 48) of the input; offsets and sizes are
    input pixels (192 a side); keypoints likewise from the anchor's centre."""
    offsets = [9.6, -4.8, 38.4, 48.0] + [float(v) for v in range(-6, 6)]
    scores, raw = _outputs({(10, 20): (2.0, offsets)})
    found = decode(scores, raw)
    assert len(found) == 1
    cx, cy = 20.5 / 48 + 9.6 / 192, 10.5 / 48 - 4.8 / 192
    np.testing.assert_allclose(found.boxes[0], [cx - 0.1, cy - 0.125, 0.2, 0.25], atol=1e-6)
    np.testing.assert_allclose(found.keypoints[0, 0], [20.5 / 48 - 6 / 192, 10.5 / 48 - 5 / 192], atol=1e-6)
    assert found.scores[0] == pytest.approx(1 / (1 + np.exp(-2.0)))


def test_scores_are_a_sigmoid_with_a_threshold_and_clipped_logits() -> None:
    scores, raw = _outputs({(0, 0): (0.4, [0.0, 0, 10, 10] + [0.0] * 12),   # 0.599: below MediaPipe's 0.6
                            (0, 1): (0.41, [0.0, 0, 10, 10] + [0.0] * 12),  # 0.601: kept
                            (5, 5): (1e6, [0.0, 0, 10, 10] + [0.0] * 12)})  # clipped at 100: no overflow
    found = decode(scores, raw)
    assert sorted(np.round(found.scores, 3)) == [0.601, 1.0]


def test_weighted_suppression_averages_overlapping_faces_by_score() -> None:
    boxes = np.array([[0.0, 0, 10, 10], [1.0, 0, 10, 10], [50.0, 50, 10, 10]])
    keypoints = np.zeros((3, 6, 2)) + boxes[:, None, :2]
    merged = weighted_nms(FaceDetections(boxes, keypoints, np.array([0.9, 0.6, 0.7])))
    assert len(merged) == 2
    np.testing.assert_allclose(merged.boxes[0], [0.6 / 1.5, 0, 10, 10])  # (0.9 * 0 + 0.6 * 1) / 1.5
    np.testing.assert_allclose(merged.keypoints[0, 0], [0.4, 0.0])
    assert list(merged.scores) == [0.9, 0.7]  # the best score of each group


@pytest.fixture(scope="module")
def model() -> Path:
    from app.errors import UserError
    from app.models import blazeface_model

    try:
        return blazeface_model()
    except UserError as exc:
        pytest.skip(str(exc))


@pytest.mark.shared_data
def test_blazeface_finds_the_labelled_faces(model: Path, shared_data: Path) -> None:
    """dlib's labelled photographs (43 faces, 24-100 px): the whole image finds at least 90 % of them (the Haar
    cascade 81 %), tiles more, and nothing that is not a labelled face; each face's eyes lie in its box's upper
    half, the person's right eye on the image's left."""
    import xml.etree.ElementTree as ET

    truth, found, matched = 0, 0, {1: 0, 2: 0}
    for xml in ("training.xml", "testing.xml"):
        for image in ET.parse(shared_data / "faces" / xml).getroot().iter("image"):
            img = cv2.imread(str(shared_data / "faces" / image.get("file")))
            boxes = np.array([[int(b.get(k)) for k in ("left", "top", "width", "height")] for b in image.iter("box")],
                             dtype=float).reshape(-1, 4)
            truth += len(boxes)
            for tiles in (1, 2):
                faces = BlazeFaceDetector(model, tiles=tiles).detect_faces(img)
                centres = faces.boxes[:, :2] + faces.boxes[:, 2:] / 2
                hits = sum(any((np.abs(c - (b[:2] + b[2:] / 2)) < b[2:] / 2).all() for c in centres) for b in boxes)
                matched[tiles] += hits
                if tiles == 1:
                    found += len(faces)
                    for box, eyes in zip(faces.boxes, faces.keypoints[:, :2]):
                        assert (eyes[:, 1] < box[1] + box[3] / 2).all() and eyes[0, 0] < eyes[1, 0]
    assert truth == 43
    assert matched[1] >= 0.9 * truth and matched[2] >= matched[1]
    assert found <= matched[1]  # every detection is a labelled face


def test_the_detector_refuses_a_missing_model(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="not found"):
        BlazeFaceDetector(tmp_path / "none.tflite")
    assert INPUT_PX == 192 and GRID == 48


@pytest.mark.shared_data
def test_tracked_blazeface_finds_every_rendered_face_with_a_square_per_face(model: Path, shared_data: Path,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """The simulated room's three faces (photographs, about 40 px) over 45 frames: every visible face found in
    every frame and nothing else; after the first frame's whole scan, one square per face and one of the scan."""
    from app.sources.sim import SimSource
    from avcore.blazeface import TrackingBlazeFace

    room = SimSource.from_preset("S2", duration_s=2.0, seed=2, data_dir=shared_data)
    tracker = TrackingBlazeFace(BlazeFaceDetector(model, tiles=2))
    batches: list[int] = []
    run = BlazeFaceDetector.run

    def count(self, bgr, squares):  # noqa: ANN001, ANN202
        batches.append(len(squares))
        return run(self, bgr, squares)

    monkeypatch.setattr(BlazeFaceDetector, "run", count)
    for k in range(45):
        left, _ = room._images(k)
        truth = room.truth(k)
        boxes = tracker.detect(left)
        centres = boxes[:, :2] + boxes[:, 2:] / 2
        faces = truth.boxes_left[truth.visible]
        assert len(boxes) == len(faces) == 3, k
        for face in faces:
            assert (np.abs(centres - (face[:2] + face[2:] / 2)) < face[2:] / 2).all(axis=1).any(), k
    assert batches[0] == 5 and set(batches[1:]) == {4}  # the whole scan, then three faces and one square


def test_a_lost_face_is_looked_for_where_it_was_for_lost_frames_frames() -> None:
    """A face found in frame 0 and missed from frame 1 on: its square is searched in frame 1 (tracked) and again in
    frames 2-4 (lost_frames = 3), not in frame 5; a kept box is never returned. Found again in frame 2, it is
    tracked as before."""
    from avcore.blazeface import FaceDetections, TrackingBlazeFace

    face = np.array([[100.0, 80.0, 40.0, 40.0]])

    class Base:
        nms_iou = 0.3

        def __init__(self, visible: set[int]) -> None:
            self.visible, self.frame, self.asked = visible, 0, []

        def squares(self, w: int, h: int) -> list[tuple[int, int, int]]:
            return [(0, 0, 64)]  # one square of the scan, far from the face

        def run(self, bgr: np.ndarray, squares: list) -> FaceDetections:
            self.asked.append(len(squares))
            found = self.frame in self.visible
            self.frame += 1
            if not found:
                return FaceDetections.empty()
            return FaceDetections(face.copy(), np.zeros((1, 6, 2)), np.array([0.9]))

    image = np.zeros((240, 320, 3), np.uint8)
    base = Base({0})
    tracker = TrackingBlazeFace(base, lost_frames=3)  # type: ignore[arg-type]
    returned = [len(tracker.detect(image)) for _ in range(6)]
    assert returned == [1, 0, 0, 0, 0, 0]
    assert base.asked == [1, 2, 2, 2, 2, 1]  # the scan's square, plus the face's: tracked, then lost three frames
    base = Base({0, 2})
    tracker = TrackingBlazeFace(base, lost_frames=3)  # type: ignore[arg-type]
    assert [len(tracker.detect(image)) for _ in range(4)] == [1, 0, 1, 0]
    assert base.asked == [1, 2, 2, 2]
    with pytest.raises(ValueError, match="lost_frames"):
        TrackingBlazeFace(base, lost_frames=-1)  # type: ignore[arg-type]
