"""Face detection and F3D, the 3D face features of paper section 5.2.

The paper detects faces with a WaldBoost detector and matches each box centre into the right image before the
stereo reconstruction. Here the default detector is OpenCV's boosted Haar cascade for frontal faces, shipped inside
opencv-python-headless 4.x (nothing to download); :class:`YuNetFaceDetector` wraps ``cv2.FaceDetectorYN`` for users
who supply a YuNet ONNX model. Detection runs on a down-scaled image for speed; boxes are reported in pixels of the
full-resolution image. A full Haar scan of a VGA frame costs tens of milliseconds on one core; on video,
:class:`TrackingFaceDetector` scans fully every few frames and searches only around the previous faces in between.

Boxes are ``(x, y, w, h)`` float pixels: top-left corner and size (OpenCV's convention).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np

from avcore.stereo import StereoRig

__all__ = [
    "FaceDetector",
    "HaarFaceDetector",
    "TrackingFaceDetector",
    "YuNetFaceDetector",
    "FaceLocations",
    "detect_faces",
    "locate_faces",
    "match_along_row",
]

HAAR_FRONTAL = "haarcascade_frontalface_default.xml"


def _as_grey(image: object, name: str) -> np.ndarray:
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim not in (2, 3) \
            or (image.ndim == 3 and image.shape[2] not in (1, 3)) or image.size == 0:
        got = f"{image.dtype} array of shape {image.shape}" if isinstance(image, np.ndarray) else type(image).__name__
        raise ValueError(f"{name} must be a non-empty uint8 grey (h, w) or BGR (h, w, 3) image, got {got}")
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.shape[2] == 3 else image[:, :, 0]
    return image


def _check_scale(scale: float) -> float:
    if not (np.isfinite(scale) and 0 < scale <= 1):
        raise ValueError(f"scale must be in (0, 1] (1 = detect on the full image), got {scale!r}")
    return float(scale)


class FaceDetector(Protocol):
    """Anything with ``detect(image) -> (n, 4)`` boxes in full-resolution pixels."""

    def detect(self, image: np.ndarray) -> np.ndarray: ...


@dataclass(eq=False)
class HaarFaceDetector:
    """OpenCV's frontal-face Haar cascade (a boosted cascade, like the paper's WaldBoost detector).

    scale : the image is resized by this factor before detection (0.8 keeps faces of 30 px, a face at 3 m with a
        554 px focal length, above the cascade's 24 px window; smaller is faster but loses far faces).
    scale_factor, min_neighbors : ``detectMultiScale`` parameters (step between pyramid levels, and how many
        overlapping hits make a detection).
    min_size_px, max_size_px : face sizes searched, in full-resolution pixels (None: no upper bound).
    cascade : path to a cascade XML; default the frontal-face cascade of ``cv2.data.haarcascades``.
    """

    scale: float = 0.8
    scale_factor: float = 1.2
    min_neighbors: int = 3
    min_size_px: int = 24
    max_size_px: int | None = None
    cascade: str | None = None
    _classifier: cv2.CascadeClassifier = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.scale = _check_scale(self.scale)
        if not self.scale_factor > 1:
            raise ValueError(f"scale_factor must be > 1, got {self.scale_factor!r}")
        if self.min_neighbors < 0:
            raise ValueError(f"min_neighbors must be >= 0, got {self.min_neighbors!r}")
        path = self.cascade or str(Path(cv2.data.haarcascades) / HAAR_FRONTAL)
        self._classifier = cv2.CascadeClassifier(path)
        if self._classifier.empty():
            raise ValueError(f"cascade {path!r} could not be loaded; give the path of an OpenCV cascade XML file")

    def detect(self, image: np.ndarray, *, region: tuple[int, int, int, int] | None = None,
               size_range_px: tuple[float, float] | None = None) -> np.ndarray:
        """image : (h, w) or (h, w, 3) uint8  ->  (n, 4) float boxes x, y, w, h in full-resolution pixels.

        region : (x, y, w, h) pixels, search only there (boxes are still reported in image pixels);
        size_range_px : (min, max) face sizes in full-resolution pixels, instead of min_size_px, max_size_px.
        """
        grey = _as_grey(image, "image")
        x0 = y0 = 0
        if region is not None:
            x0, y0 = max(0, int(region[0])), max(0, int(region[1]))
            x1 = min(grey.shape[1], int(region[0] + region[2]))
            y1 = min(grey.shape[0], int(region[1] + region[3]))
            if x1 - x0 < 8 or y1 - y0 < 8:
                return np.zeros((0, 4))
            grey = grey[y0:y1, x0:x1]
        lo, hi = size_range_px if size_range_px is not None else (self.min_size_px, self.max_size_px)
        small = grey if self.scale == 1.0 else cv2.resize(
            grey, None, fx=self.scale, fy=self.scale, interpolation=cv2.INTER_AREA)
        min_px = max(1, int(round(lo * self.scale)))
        max_px = (0, 0) if hi is None else (int(np.ceil(hi * self.scale)),) * 2
        if min(small.shape) < min_px:
            return np.zeros((0, 4))
        boxes = self._classifier.detectMultiScale(small, scaleFactor=self.scale_factor,
                                                  minNeighbors=self.min_neighbors, minSize=(min_px, min_px),
                                                  maxSize=max_px)
        out = np.asarray(boxes, dtype=np.float64).reshape(-1, 4) / self.scale
        out[:, 0] += x0
        out[:, 1] += y0
        return out


@dataclass(eq=False)
class TrackingFaceDetector:
    """Full detections every ``full_every`` frames, and in between a search around the previous faces only.

    A full Haar scan of a VGA frame costs tens of milliseconds; a face moves little between two frames, so
    searching a window ``margin`` face sizes wider on each side, for sizes within ``size_tolerance`` of the
    previous one, costs a few. Faces that enter the view are found at the next full scan (at most
    ``full_every - 1`` frames late); a face lost in its window is dropped until then. Stateful: one instance per
    video stream; :meth:`reset` when the stream jumps.
    """

    base: HaarFaceDetector = field(default_factory=HaarFaceDetector)
    full_every: int = 10
    margin: float = 0.5
    size_tolerance: float = 1.3
    _previous: np.ndarray = field(init=False, repr=False, default_factory=lambda: np.zeros((0, 4)))
    _count: int = field(init=False, repr=False, default=0)

    def __post_init__(self) -> None:
        if self.full_every < 1:
            raise ValueError(f"full_every must be >= 1 frame, got {self.full_every!r}")
        if not self.size_tolerance > 1:
            raise ValueError(f"size_tolerance must be > 1, got {self.size_tolerance!r}")

    def reset(self) -> None:
        """Forget the previous faces: the next frame gets a full scan."""
        self._previous = np.zeros((0, 4))
        self._count = 0

    def detect(self, image: np.ndarray) -> np.ndarray:
        """image : (h, w) or (h, w, 3) uint8  ->  (n, 4) float boxes x, y, w, h in pixels."""
        grey = _as_grey(image, "image")
        if self._count % self.full_every == 0 or len(self._previous) == 0:
            boxes = self.base.detect(grey)
            self._count = 0
        else:
            found = []
            for x, y, w, h in self._previous:
                pad = self.margin * max(w, h)
                region = (int(x - pad), int(y - pad), int(w + 2 * pad), int(h + 2 * pad))
                size = max(w, h)
                cand = self.base.detect(grey, region=region,
                                        size_range_px=(size / self.size_tolerance, size * self.size_tolerance))
                if len(cand):
                    centre = np.array([x + w / 2, y + h / 2])
                    dist = np.linalg.norm(cand[:, :2] + cand[:, 2:] / 2 - centre, axis=1)
                    best = cand[int(np.argmin(dist))]
                    if not any(_iou(best, other) > 0.5 for other in found):
                        found.append(best)
            boxes = np.array(found, dtype=np.float64).reshape(-1, 4)
        self._count += 1
        self._previous = boxes
        return boxes


def _iou(a: np.ndarray, b: np.ndarray) -> float:
    ix = max(0.0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    inter = ix * iy
    return float(inter / (a[2] * a[3] + b[2] * b[3] - inter))


@dataclass(eq=False)
class YuNetFaceDetector:
    """``cv2.FaceDetectorYN`` (YuNet, a small CNN) for users who provide its ONNX model file.

    model : path to e.g. ``face_detection_yunet_2023mar.onnx`` (from the OpenCV model zoo; not shipped here).
    scale : detection image size relative to the input; score_threshold, nms_threshold : YuNet's thresholds.
    """

    model: str | Path
    scale: float = 0.5
    score_threshold: float = 0.7
    nms_threshold: float = 0.3
    _net: object = field(init=False, repr=False, default=None)
    _size: tuple[int, int] = field(init=False, repr=False, default=(0, 0))

    def __post_init__(self) -> None:
        self.scale = _check_scale(self.scale)
        if not Path(self.model).is_file():
            raise ValueError(f"YuNet model file {str(self.model)!r} not found; download "
                             "face_detection_yunet_2023mar.onnx from the OpenCV model zoo and give its path")

    def detect(self, image: np.ndarray) -> np.ndarray:
        """image : (h, w, 3) BGR or (h, w) grey uint8  ->  (n, 4) float boxes in full-resolution pixels."""
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim not in (2, 3):
            _as_grey(image, "image")  # raises the standard message
        bgr = image if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        small = bgr if self.scale == 1.0 else cv2.resize(
            bgr, None, fx=self.scale, fy=self.scale, interpolation=cv2.INTER_AREA)
        size = (small.shape[1], small.shape[0])
        if self._net is None:
            self._net = cv2.FaceDetectorYN.create(str(self.model), "", size, self.score_threshold,
                                                  self.nms_threshold)
        if size != self._size:
            self._net.setInputSize(size)
            self._size = size
        _, faces = self._net.detect(small)
        if faces is None:
            return np.zeros((0, 4))
        return np.asarray(faces[:, :4], dtype=np.float64) / self.scale


@lru_cache(maxsize=1)
def _default_detector() -> HaarFaceDetector:
    return HaarFaceDetector()


def detect_faces(image: np.ndarray, detector: FaceDetector | None = None) -> np.ndarray:
    """Faces in one image (paper section 5.2, F3D's first step).

    image : (h, w) or (h, w, 3) uint8; detector : default a shared :class:`HaarFaceDetector`.
    Returns (n, 4) float boxes x, y, w, h in pixels of ``image``, sorted left to right; (0, 4) when none.
    """
    boxes = (detector or _default_detector()).detect(image)
    boxes = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return boxes[np.argsort(boxes[:, 0], kind="stable")]


# ---------------------------------------------------------------------- F3D
@dataclass(frozen=True, eq=False)
class FaceLocations:
    """F3D features of one stereo pair.

    boxes : (n, 4) float, pixels in the rectified left image; points : (n, 3) float, metres, the scene (cyclopean)
    frame; ncc : (n,) the normalised cross-correlation of each match in [-1, 1]; unmatched : (k, 4) boxes that were
    detected but found no reliable match in the right image (no 3D point; counted, not fatal).
    """

    boxes: np.ndarray
    points: np.ndarray
    ncc: np.ndarray
    unmatched: np.ndarray

    def __len__(self) -> int:
        return int(self.points.shape[0])


def match_along_row(left_grey: np.ndarray, right_grey: np.ndarray, box: np.ndarray, *,
                    max_disparity_px: float, min_disparity_px: float = 0.0, inner: float = 0.6,
                    row_slack_px: int = 2) -> tuple[float, float, float]:
    """Where a patch of the left image lies in the right image of a rectified pair.

    The central ``inner`` part of ``box`` (x, y, w, h pixels, left image) is searched in the right image along
    the same rows (+- ``row_slack_px``) over disparities [min_disparity_px, max_disparity_px], by normalised
    cross-correlation (``TM_CCOEFF_NORMED``); the disparity is refined to sub-pixel by a parabola through the
    peak and its two neighbours.

    Returns (disparity_px, row_offset_px, ncc); ncc is -inf when the search range leaves the image.
    """
    x, y, w, h = (float(v) for v in box)
    tw, th = max(5, int(round(w * inner))), max(5, int(round(h * inner)))
    tx, ty = int(round(x + (w - tw) / 2.0)), int(round(y + (h - th) / 2.0))
    H, W = left_grey.shape
    if tx < 0 or ty < 0 or tx + tw > W or ty + th > H:
        return (np.nan, 0.0, -np.inf)
    template = left_grey[ty:ty + th, tx:tx + tw]
    x_lo = max(0, int(np.floor(tx - max_disparity_px)))
    x_hi = min(W, int(np.ceil(tx - min_disparity_px)) + tw)
    y_lo, y_hi = max(0, ty - row_slack_px), min(H, ty + th + row_slack_px)
    if x_hi - x_lo < tw + 2 or y_hi - y_lo < th:
        return (np.nan, 0.0, -np.inf)
    strip = right_grey[y_lo:y_hi, x_lo:x_hi]
    scores = cv2.matchTemplate(strip, template, cv2.TM_CCOEFF_NORMED)
    r, c = np.unravel_index(int(np.argmax(scores)), scores.shape)
    best = float(scores[r, c])
    sub = 0.0
    if 0 < c < scores.shape[1] - 1:
        s_m, s_0, s_p = float(scores[r, c - 1]), best, float(scores[r, c + 1])
        denom = s_m - 2.0 * s_0 + s_p
        if denom < 0:
            sub = float(np.clip(0.5 * (s_m - s_p) / denom, -0.5, 0.5))
    x_right = x_lo + c + sub
    return (tx - x_right, float(y_lo + r - ty), best)


def locate_faces(
    left: np.ndarray,
    right: np.ndarray,
    rig: StereoRig,
    *,
    detector: FaceDetector | None = None,
    rectified: bool = True,
    min_ncc: float = 0.6,
    min_depth_m: float = 0.3,
) -> FaceLocations:
    """F3D (paper section 5.2): faces detected in the left image, located in 3D.

    Each box centre is matched into the right image along its row (:func:`match_along_row`, over depths from
    ``min_depth_m`` to infinity), then triangulated with :meth:`StereoRig.triangulate` into the scene frame.

    left, right : (h, w[, 3]) uint8 images of the rig; raw images are rectified first unless ``rectified``.
    min_ncc : matches whose correlation falls below this are reported in ``unmatched`` instead.
    """
    grey_l, grey_r = _as_grey(left, "left"), _as_grey(right, "right")
    if grey_l.shape != grey_r.shape or grey_l.shape[::-1] != tuple(rig.image_size):
        raise ValueError(f"left and right must both be images of the rig's size {rig.image_size} (width, height), "
                         f"got {grey_l.shape[::-1]} and {grey_r.shape[::-1]}")
    if not rectified:
        grey_l, grey_r = rig.rectify(grey_l, grey_r)
    boxes = detect_faces(grey_l, detector)
    max_disp = rig.focal_px * rig.baseline_m / min_depth_m
    keep, points, nccs, centres_r = [], [], [], []
    for i, box in enumerate(boxes):
        disparity, dy, ncc = match_along_row(grey_l, grey_r, box, max_disparity_px=max_disp)
        if not (ncc >= min_ncc and disparity > 0):
            continue
        cu, cv_ = box[0] + box[2] / 2.0 - 0.5, box[1] + box[3] / 2.0 - 0.5
        keep.append(i)
        nccs.append(ncc)
        points.append((cu, cv_))
        centres_r.append((cu - disparity, cv_ + dy))
    mask = np.zeros(len(boxes), bool)
    mask[keep] = True
    xyz = rig.triangulate(np.array(points).reshape(-1, 2), np.array(centres_r).reshape(-1, 2))
    return FaceLocations(boxes[mask], xyz, np.asarray(nccs, dtype=np.float64), boxes[~mask])
