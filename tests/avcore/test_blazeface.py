"""avcore.blazeface: BlazeFace's outputs decoded as MediaPipe's graph decodes them, and the model on real faces."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from avcore.blazeface import (FULL_RANGE, GRID, INPUT_PX, SHORT_RANGE, BlazeFaceDetector, BlazeFaceNet, FaceDetections,
                              as_full_range, decode, per_image, weighted_nms)


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


def test_short_range_anchors_are_two_grids_with_their_anchors_per_cell() -> None:
    """The short-range model's 896 anchors (SsdAnchorsCalculator, strides 8, 16, 16, 16 at 128 px): a 16x16 grid
    with two anchors a cell, then an 8x8 grid whose cells hold the six anchors of its three layers."""
    a = SHORT_RANGE.anchors
    assert a.shape == (896, 2) and SHORT_RANGE.groups == (512, 384) and FULL_RANGE.groups == (2304,)
    np.testing.assert_allclose(a[0], a[1])
    np.testing.assert_allclose(a[2 * (16 * 3 + 5)], [5.5 / 16, 3.5 / 16])  # row 3, column 5 of the fine grid
    np.testing.assert_allclose(a[512 + 6 * (8 * 7 + 2): 512 + 6 * (8 * 7 + 3)], [[2.5 / 8, 7.5 / 8]] * 6)
    scores = np.full(896, -50.0)
    raw = np.zeros((896, 16))
    scores[512 + 6 * 10 + 4] = 3.0  # cell (1, 2) of the coarse grid
    raw[512 + 6 * 10 + 4, :4] = [6.4, 0.0, 32.0, 32.0]
    found = decode(scores, raw, variant=SHORT_RANGE)
    np.testing.assert_allclose(found.boxes[0], [2.5 / 8 + 0.05 - 0.125, 1.5 / 8 - 0.125, 0.25, 0.25])
    weak = np.where(scores > 0, 0.1, scores)  # 0.525: above the short range's 0.5, below the full range's 0.6
    assert decode(weak, raw, variant=SHORT_RANGE).scores.size == 1
    assert decode(weak, raw, variant=SHORT_RANGE, threshold=0.6).scores.size == 0


def test_a_batch_is_split_per_image_grid_by_grid() -> None:
    """OpenCV gives (1, batch * anchors, c) with each grid's anchors of every image before the next grid's: image
    i's anchors are its fine grid's block, then its coarse grid's; a (batch, anchors, c) output is kept."""
    fine = np.arange(3 * 512 * 2).reshape(3, 512, 2)
    coarse = -np.arange(3 * 384 * 2).reshape(3, 384, 2)
    joined = np.concatenate([fine.reshape(1, -1, 2), coarse.reshape(1, -1, 2)], axis=1)
    split = per_image(joined, 3, SHORT_RANGE)
    for i in range(3):
        np.testing.assert_array_equal(split[i], np.concatenate([fine[i], coarse[i]]))
    batched = np.zeros((3, 896, 2))
    assert per_image(batched, 3, SHORT_RANGE) is batched


def test_a_short_range_box_is_placed_as_the_full_range_places_it() -> None:
    """Centred 0.02 widths below the mean of the eyes, nose tip and mouth, 1 / 0.95 as wide, square; the keypoints
    and scores kept."""
    keypoints = np.array([[[40.0, 50], [60, 50], [50, 60], [50, 70], [30, 55], [70, 55]]])
    short = FaceDetections(np.array([[20.0, 30, 57, 57]]), keypoints, np.array([0.8]))
    full = as_full_range(short)
    side = 57 / 0.95
    np.testing.assert_allclose(full.boxes[0], [50 - side / 2, 57.5 + 0.02 * side - side / 2, side, side])
    assert full.keypoints is keypoints and full.scores is short.scores


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


@pytest.mark.shared_data
def test_the_short_range_model_finds_the_full_ranges_faces_alike_in_a_batch(model: Path, shared_data: Path) -> None:
    """Each labelled photograph's faces as the full range finds them, looked for by the short-range model in
    squares of 2.5 face widths, all of an image in one batch: each square holds its face, its keypoints within
    0.1 of a face's width of the full range's, and its box, once placed as the full range's, within 0.2 widths."""
    import xml.etree.ElementTree as ET

    full, short = BlazeFaceDetector(model), BlazeFaceNet(model.with_name(SHORT_RANGE.file), SHORT_RANGE)
    checked = 0
    for image in ET.parse(shared_data / "faces" / "testing.xml").getroot().iter("image"):
        img = cv2.imread(str(shared_data / "faces" / image.get("file")))
        faces = full.detect_faces(img)
        squares = [(int(x + w / 2 - 1.25 * w), int(y + h / 2 - 1.25 * h), int(2.5 * w)) for x, y, w, h in faces.boxes]
        found = as_full_range(short.run(img, squares))
        for box, keypoints in zip(faces.boxes, faces.keypoints):
            err = np.linalg.norm(found.keypoints - keypoints, axis=2).mean(axis=1) / box[2]
            best = int(np.argmin(err))
            assert err[best] < 0.1
            np.testing.assert_allclose(found.boxes[best], box, atol=0.2 * box[2])
            checked += 1
    assert checked >= 15


def test_the_detector_refuses_a_missing_model(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="not found"):
        BlazeFaceDetector(tmp_path / "none.tflite")
    assert INPUT_PX == 192 and GRID == 48


@pytest.mark.shared_data
def test_tracked_blazeface_finds_every_rendered_face_with_a_square_per_face(model: Path, shared_data: Path,
                                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """The simulated room's three faces (photographs, about 40 px) over 45 frames: every visible face found in
    every frame and nothing else; after the first frame's whole scan (full range), one short-range square per face
    every frame and one full-range square of the scan every second frame."""
    from app.sources.sim import SimSource
    from avcore.blazeface import BlazeFaceNet, TrackingBlazeFace

    room = SimSource.from_preset("S2", duration_s=2.0, seed=2, data_dir=shared_data)
    tracker = TrackingBlazeFace.from_model(model)
    assert tracker.near is not None and tracker.near.variant is SHORT_RANGE
    batches: list[tuple[int, int]] = []
    run = BlazeFaceNet.run_each

    def count(self, bgr, squares, threshold=None):  # noqa: ANN001, ANN202
        batches.append((self.variant.input_px, len(squares)))
        return run(self, bgr, squares, threshold)

    monkeypatch.setattr(BlazeFaceNet, "run_each", count)
    for k in range(45):
        left, _ = room._images(k)
        truth = room.truth(k)
        boxes = tracker.detect(left)
        centres = boxes[:, :2] + boxes[:, 2:] / 2
        faces = truth.boxes_left[truth.visible]
        assert len(boxes) == len(faces) == 3, k
        for face in faces:
            assert (np.abs(centres - (face[:2] + face[2:] / 2)) < face[2:] / 2).all(axis=1).any(), k
    assert batches[0] == (192, 5)  # the whole scan
    later = batches[1:]
    assert [n for px, n in later if px == 128] == [3] * 44
    assert [n for px, n in later if px == 192] == [0, 1] * 22  # frames 1, 2, ...: the scan every second frame
    assert tracker.frames_per_scan == 10  # the whole image and 2 x 2 tiles, one every second frame


@pytest.mark.shared_data
def test_no_face_is_found_on_a_gesturing_hand(model: Path, shared_data: Path) -> None:
    """S3 (seed 9) with bodies, 3.3-4.7 s: a standing person's hand moves over a checked shirt, where BlazeFace
    sees small faces (4-16 px, scores 0.5-0.7); the tracker reports the three faces and nothing else."""
    from app.sources.sim import SimSource
    from avcore.blazeface import TrackingBlazeFace

    room = SimSource.from_preset("S3", seed=9, bodies=True, data_dir=shared_data)
    tracker = TrackingBlazeFace.from_model(model)
    for k in range(100, 140):
        left, _ = room._images(k)
        truth = room.truth(k)
        boxes = tracker.detect(left)
        assert len(boxes) == int(truth.visible.sum()) == 3, k
        assert (boxes[:, 2] >= 20).all()


def test_faces_under_the_minimum_size_are_dropped() -> None:
    boxes = np.array([[0.0, 0, 19.9, 19.9], [100.0, 100, 20, 20], [200.0, 0, 40, 40]])
    found = FaceDetections(boxes, np.zeros((3, 6, 2)), np.array([0.9, 0.8, 0.7]))
    detector = BlazeFaceDetector.__new__(BlazeFaceDetector)  # the suppression alone: no model needed
    detector.nms_iou, detector.min_face_px = 0.3, 20.0
    np.testing.assert_array_equal(detector.suppress(found).boxes, boxes[1:])


def test_a_lost_face_is_looked_for_where_it_was_for_lost_frames_frames() -> None:
    """A face found in frame 0 and missed from frame 1 on: its square is searched in frame 1 (tracked) and again in
    frames 2-4 (lost_frames = 3), not in frame 5; a kept box is never returned. Found again in frame 2, it is
    tracked as before."""
    from avcore.blazeface import FaceDetections, TrackingBlazeFace

    face = np.array([[100.0, 80.0, 40.0, 40.0]])

    class Base:
        def __init__(self, visible: set[int]) -> None:
            self.visible, self.frame, self.asked, self.pending = visible, 0, [], 0

        def squares(self, w: int, h: int) -> list[tuple[int, int, int]]:
            return [(0, 0, 64)]  # one square of the scan, far from the face

        def suppress(self, found: FaceDetections) -> FaceDetections:
            return weighted_nms(found)

        def run_each(self, bgr: np.ndarray, squares: list) -> list[FaceDetections]:
            # squares around the faces: the face in each while visible (the scan's square never holds it)
            self.pending = len(squares)
            visible = self.frame in self.visible
            return [FaceDetections(face.copy(), np.zeros((1, 6, 2)), np.array([0.9])) if visible
                    else FaceDetections.empty() for _ in squares]

        def run(self, bgr: np.ndarray, squares: list) -> FaceDetections:  # the scan, after the squares' run_each
            self.asked.append(len(squares) + self.pending)
            self.pending = 0
            found = self.frame in self.visible and self.frame == 0
            self.frame += 1
            if not found:
                return FaceDetections.empty()
            return FaceDetections(face.copy(), np.zeros((1, 6, 2)), np.array([0.9]))

    image = np.zeros((240, 320, 3), np.uint8)
    base = Base({0})
    tracker = TrackingBlazeFace(base, lost_frames=3, scan_every=1)  # type: ignore[arg-type]
    returned = [len(tracker.detect(image)) for _ in range(6)]
    assert returned == [1, 0, 0, 0, 0, 0]
    assert base.asked == [1, 2, 2, 2, 2, 1]  # the scan's square, plus the face's: tracked, then lost three frames
    base = Base({0, 2})
    tracker = TrackingBlazeFace(base, lost_frames=3, scan_every=1)  # type: ignore[arg-type]
    assert [len(tracker.detect(image)) for _ in range(4)] == [1, 0, 1, 0]
    assert base.asked == [1, 2, 2, 2]
    with pytest.raises(ValueError, match="lost_frames"):
        TrackingBlazeFace(base, lost_frames=-1)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="scan_every"):
        TrackingBlazeFace(base, scan_every=0)  # type: ignore[arg-type]


@pytest.mark.shared_data
def test_a_face_the_short_range_loses_is_looked_for_by_the_full_range(model: Path, shared_data: Path) -> None:
    """A face the short-range model stops finding (a head turned far, the short range's weakness) is looked for in
    its lost square by the full range, which finds it the next frame; the scan never comes round meanwhile."""
    from app.sources.sim import SimSource
    from avcore.blazeface import BlazeFaceDetector, FaceDetections, TrackingBlazeFace

    class Blind:  # a short range that finds nothing
        def run_each(self, bgr: np.ndarray, squares: list) -> list[FaceDetections]:
            return [FaceDetections.empty() for _ in squares]

    left, _ = SimSource.from_preset("S1", duration_s=1.0, seed=0, data_dir=shared_data)._images(0)
    tracker = TrackingBlazeFace(BlazeFaceDetector(model, tiles=2), near=Blind(),  # type: ignore[arg-type]
                                scan_every=100)
    found = [len(tracker.detect(left)) for _ in range(5)]
    assert found[0] == 1 and found[1:] == [0, 1, 0, 1]  # the whole scan; lost; found by the full range; ...
