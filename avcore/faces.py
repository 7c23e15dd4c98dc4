"""Face detection and F3D, the 3D face features of paper section 5.2.

The paper detects faces with a WaldBoost detector and matches each box centre into the right image before the
stereo reconstruction. Here the default detector is the application's (:func:`default_detector`): MediaPipe's
BlazeFace (:mod:`avcore.blazeface`) when its model is installed, else OpenCV 4's boosted Haar cascade for frontal
faces (:class:`HaarFaceDetector`; OpenCV 5 has none); :class:`YuNetFaceDetector` wraps ``cv2.FaceDetectorYN`` for
users who supply a YuNet ONNX model. Detection runs on down-scaled images, one per octave of face sizes; boxes are
reported in pixels of the full-resolution image. A full Haar scan of a VGA frame costs about 35 ms on one core; on
video, :class:`TrackingFaceDetector` searches around the previous faces and spreads the full scan over frames, so
that no frame costs more than about 15 ms.

Boxes are ``(x, y, w, h)`` float pixels: top-left corner and size (OpenCV's convention).
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Protocol

import cv2
import numpy as np

from avcore.stereo import StereoRig

__all__ = [
    "FaceDetector",
    "FaceLocations",
    "HaarFaceDetector",
    "default_detector",
    "ScanJob",
    "TrackingFaceDetector",
    "YuNetFaceDetector",
    "detect_faces",
    "locate_faces",
    "match_along_row",
    "merge_boxes",
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


WINDOW_PX = 24  # the training window of OpenCV's frontal-face cascades


@dataclass(frozen=True)
class ScanJob:
    """A piece of a full scan: one octave of face sizes over a band of rows.

    octave : the band is scanned at ``scale / 2**octave`` of its size, for faces of 24 to 48 pixels there (the
        coarsest octave: 24 and up); rows : (first, end) full-resolution rows; pixels : the work, in pixels of the
        octave's image.
    """

    octave: int
    rows: tuple[int, int]
    coarsest: bool
    pixels: int


@dataclass(eq=False)
class HaarFaceDetector:
    """OpenCV's frontal-face Haar cascade (a boosted cascade, like the paper's WaldBoost detector), by octaves.

    ``detectMultiScale`` slides its 24 px window with a 2 px step while the window is scaled by less than two and
    with a 1 px step beyond, so on one image the large faces, which are few and need no such precision, cost more
    than half of the scan. Here each octave of face sizes gets its own image, halved from one octave to the next,
    and so its own 2 px step. On the rendered scenes of ``benchmarks/vision_speed.py --skip hm3d`` (VGA, one core,
    scale 0.8, step 1.2) this cuts a full scan from 56 to 35 ms of CPU against one ``detectMultiScale`` call, and
    finds the same 24 faces of 24. A coarse octave sees a face from fewer window positions, so it needs fewer
    overlapping hits (``min_neighbors_coarse``). A full scan is a list of :class:`ScanJob`;
    :class:`TrackingFaceDetector` spreads them over frames.

    scale : the finest octave's image is the input resized by this factor (0.8 keeps faces of 30 px, a face at
        3 m with a 554 px focal length, at the cascade's 24 px window; smaller is faster but loses far faces).
    scale_factor : step between pyramid levels within an octave; min_neighbors, min_neighbors_coarse : how many
        overlapping hits make a detection in the finest octave and in the others.
    min_size_px, max_size_px : face sizes searched, in full-resolution pixels (None: no upper bound).
    cascade : path to a cascade XML; default the frontal-face cascade of ``cv2.data.haarcascades``.
    """

    scale: float = 0.8
    scale_factor: float = 1.2
    min_neighbors: int = 3
    min_neighbors_coarse: int = 1
    min_size_px: int = 24
    max_size_px: int | None = None
    cascade: str | None = None
    _classifier: cv2.CascadeClassifier = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.scale = _check_scale(self.scale)
        if not self.scale_factor > 1:
            raise ValueError(f"scale_factor must be > 1, got {self.scale_factor!r}")
        if self.min_neighbors < 0 or self.min_neighbors_coarse < 0:
            raise ValueError("min_neighbors and min_neighbors_coarse must be >= 0, got "
                             f"{self.min_neighbors!r} and {self.min_neighbors_coarse!r}")
        if not hasattr(cv2, "CascadeClassifier"):
            raise RuntimeError(f"OpenCV {cv2.__version__} has no Haar cascades (OpenCV 5 dropped them): find faces "
                               "with avcore.blazeface, or install OpenCV 4")
        path = self.cascade or str(Path(cv2.data.haarcascades) / HAAR_FRONTAL)
        self._classifier = cv2.CascadeClassifier(path)
        if self._classifier.empty():
            raise ValueError(f"cascade {path!r} could not be loaded; give the path of an OpenCV cascade XML file")

    def scan_jobs(self, image_size: tuple[int, int], *, max_job_px: int | None = None) -> list[ScanJob]:
        """The pieces of a full scan of an image of ``image_size`` (width, height), finest octave first.

        max_job_px : cut each octave into bands of rows so that a job scans at most about this many pixels of its
            octave's image (a band reaches down by the octave's largest face, so every face lies wholly inside the
            band of its top row); None: one job per octave.
        """
        w, h = image_size
        jobs: list[ScanJob] = []
        octave = 0
        while min(w, h) * self.scale / 2**octave >= WINDOW_PX:
            s = self.scale / 2**octave
            coarsest = min(w, h) * s / 2 < WINDOW_PX
            lo, hi = WINDOW_PX / s, (np.inf if coarsest else 2 * WINDOW_PX / s)
            if hi > self.min_size_px and (self.max_size_px is None or lo <= self.max_size_px):
                reach = 0 if coarsest else int(np.ceil(hi))
                bands = 1
                while max_job_px and bands < h // max(reach, 1) and w * s * (h / bands + reach) * s > max_job_px:
                    bands += 1
                edges = np.linspace(0, h, bands + 1).round().astype(int)
                for a, b in itertools.pairwise(edges):
                    rows = (int(a), int(min(h, b + reach)) if bands > 1 else h)
                    jobs.append(ScanJob(octave, rows, coarsest, int(w * s * (rows[1] - rows[0]) * s)))
            octave += 1
        return jobs

    def scan(self, grey: np.ndarray, job: ScanJob) -> np.ndarray:
        """Run one :class:`ScanJob` on a grey image  ->  (n, 4) float boxes in full-resolution pixels."""
        s = self.scale / 2**job.octave
        band = grey[job.rows[0]:job.rows[1]]
        boxes = self._cascade(band, s, lo_px=max(WINDOW_PX / s, self.min_size_px),
                              hi_px=None if job.coarsest else 2 * WINDOW_PX / s - 1e-6,
                              min_neighbors=self.min_neighbors if job.octave == 0 else self.min_neighbors_coarse)
        boxes[:, 1] += job.rows[0]
        return boxes

    def _cascade(self, grey: np.ndarray, s: float, *, lo_px: float, hi_px: float | None, min_neighbors: int,
                 scale_factor: float | None = None) -> np.ndarray:
        """detectMultiScale on ``grey`` resized by ``s``, for faces of lo_px to hi_px full-resolution pixels."""
        if self.max_size_px is not None:
            hi_px = self.max_size_px if hi_px is None else min(hi_px, self.max_size_px)
        small = grey if s == 1.0 else cv2.resize(grey, None, fx=s, fy=s,
                                                 interpolation=cv2.INTER_AREA if s < 1 else cv2.INTER_LINEAR)
        min_px = max(WINDOW_PX, int(round(lo_px * s)))
        max_px = (0, 0) if hi_px is None else (int(hi_px * s),) * 2
        if min(small.shape) < min_px or (hi_px is not None and max_px[0] < min_px):
            return np.zeros((0, 4))
        boxes = self._classifier.detectMultiScale(small, scaleFactor=scale_factor or self.scale_factor,
                                                  minNeighbors=min_neighbors, minSize=(min_px, min_px),
                                                  maxSize=max_px)
        return np.asarray(boxes, dtype=np.float64).reshape(-1, 4) / s

    def search_near(self, grey: np.ndarray, box: np.ndarray, *, margin: float, size_tolerance: float,
                    face_px: float, scale_factor: float) -> np.ndarray:
        """Faces near ``box`` (x, y, w, h) in a grey image: within ``margin`` box sizes of it on each side, of sizes
        within ``size_tolerance`` of its size, searched at the scale that brings it to ``face_px`` pixels (up or
        down) with pyramid step ``scale_factor``  ->  (n, 4) float boxes in image pixels."""
        x, y, w, h = (float(v) for v in box)
        size = max(w, h)
        pad = margin * size
        x0, y0 = max(0, int(x - pad)), max(0, int(y - pad))
        x1, y1 = min(grey.shape[1], int(np.ceil(x + w + pad))), min(grey.shape[0], int(np.ceil(y + h + pad)))
        if x1 - x0 < 8 or y1 - y0 < 8:
            return np.zeros((0, 4))
        out = self._cascade(grey[y0:y1, x0:x1], face_px / size, lo_px=size / size_tolerance,
                            hi_px=size * size_tolerance, min_neighbors=self.min_neighbors, scale_factor=scale_factor)
        out[:, 0] += x0
        out[:, 1] += y0
        return out

    def detect(self, image: np.ndarray) -> np.ndarray:
        """image : (h, w) or (h, w, 3) uint8  ->  (n, 4) float boxes x, y, w, h in full-resolution pixels: a full
        scan, every octave (:meth:`search_near` searches around a known face)."""
        grey = _as_grey(image, "image")
        return merge_boxes([self.scan(grey, job) for job in self.scan_jobs(grey.shape[::-1])])


def merge_boxes(groups: list[np.ndarray], *, contained: float = 0.6) -> np.ndarray:
    """Concatenate lists of boxes, dropping a box when most of it (``contained`` of the smaller box's area) lies
    inside a box kept before it: one face found by two octaves or two overlapping bands is kept once, as first seen.
    """
    kept: list[np.ndarray] = []
    for boxes in groups:
        for box in np.asarray(boxes, dtype=np.float64).reshape(-1, 4):
            if not any(_overlap_of_smaller(box, other) > contained for other in kept):
                kept.append(box)
    return np.array(kept, dtype=np.float64).reshape(-1, 4)


@dataclass(eq=False)
class TrackingFaceDetector:
    """Faces of a video: each frame, a search around the previous faces plus one slice of a full scan.

    A face moves little between two frames, so each previous face is searched in a window ``margin`` face sizes
    wider on each side, for sizes within ``size_tolerance`` of its own, with the window resized so that the face
    spans ``face_px`` pixels (upsampled if it is smaller: a face of 30 px at the cascade's 24 px limit is kept) and
    a fine pyramid step ``scale_factor``: a millisecond or two per face. The full scan that finds newcomers is cut
    into :class:`ScanJob` pieces (:meth:`HaarFaceDetector.scan_jobs`) and each frame runs about
    ``scan_px_per_frame`` pixels of it, so that no frame pays for a whole scan: with the defaults a VGA scan is
    spread over :attr:`frames_per_scan` = 9 frames, and a face entering the view is found within 9 frames
    (0.3 s at 30 FPS). Only the first frame (and the first after :meth:`reset`) gets a whole scan. A face lost in
    its window is searched there again in each of the next ``lost_frames`` frames (0.5 s at 30 FPS): a face the
    cascade finds in only some frames (small, turned, at the edge of the view) comes back at its next detection,
    not at the scan's next pass over it. Only detections are returned, never a kept box. Stateful: one instance
    per video stream.
    """

    base: HaarFaceDetector = field(default_factory=HaarFaceDetector)
    scan_px_per_frame: int = 40_000
    margin: float = 0.3
    size_tolerance: float = 1.3
    face_px: float = 36.0
    scale_factor: float = 1.1
    lost_frames: int = 15
    _previous: np.ndarray = field(init=False, repr=False, default_factory=lambda: np.zeros((0, 4)))
    _lost: list[tuple[np.ndarray, int]] = field(init=False, repr=False, default_factory=list)  # (box, frames lost)
    _jobs: list[ScanJob] = field(init=False, repr=False, default_factory=list)
    _next: int = field(init=False, repr=False, default=-1)
    _size: tuple[int, int] = field(init=False, repr=False, default=(0, 0))

    def __post_init__(self) -> None:
        if not self.scan_px_per_frame >= 1:
            raise ValueError(f"scan_px_per_frame must be >= 1 pixel, got {self.scan_px_per_frame!r}")
        if not self.size_tolerance > 1:
            raise ValueError(f"size_tolerance must be > 1, got {self.size_tolerance!r}")
        if not (isinstance(self.lost_frames, int) and self.lost_frames >= 0):
            raise ValueError(f"lost_frames must be a whole number of frames >= 0, got {self.lost_frames!r}")

    def reset(self) -> None:
        """Forget the previous faces: the next frame gets a whole scan."""
        self._previous = np.zeros((0, 4))
        self._lost = []
        self._next = -1

    @property
    def frames_per_scan(self) -> int:
        """How many frames one full scan is spread over (0 before the first frame)."""
        frames, budget = 0, 0
        for job in self._jobs:
            if budget <= 0:
                frames, budget = frames + 1, self.scan_px_per_frame
            budget -= job.pixels
        return frames

    def detect(self, image: np.ndarray) -> np.ndarray:
        """image : (h, w) or (h, w, 3) uint8  ->  (n, 4) float boxes x, y, w, h in pixels."""
        grey = _as_grey(image, "image")
        size = grey.shape[::-1]
        if size != self._size:
            self._jobs = self.base.scan_jobs(size, max_job_px=self.scan_px_per_frame)
            self._size = size
            self._next = -1
            self._lost = []  # boxes of another image size
        if self._next < 0:
            boxes = self.base.detect(grey)
            self._next = 0
        else:
            tracked, missed = [], []
            for box, lost in [(b, 0) for b in self._previous] + self._lost:
                cand = self.base.search_near(grey, box, margin=self.margin, size_tolerance=self.size_tolerance,
                                             face_px=self.face_px, scale_factor=self.scale_factor)
                if len(cand):
                    dist = np.linalg.norm(cand[:, :2] + cand[:, 2:] / 2 - (box[:2] + box[2:] / 2), axis=1)
                    tracked.append(cand[int(np.argmin(dist))])
                elif lost < self.lost_frames:
                    missed.append((box, lost + 1))
            scanned, budget = [], self.scan_px_per_frame
            while budget > 0:
                job = self._jobs[self._next]
                scanned.append(self.base.scan(grey, job))
                budget -= job.pixels
                self._next = (self._next + 1) % len(self._jobs)
                if self._next == 0:
                    break
            boxes = merge_boxes([np.array(tracked).reshape(-1, 4), *scanned])
            # a lost face the scan found again is no longer lost
            self._lost = [(b, n) for b, n in missed if all(_overlap_of_smaller(b, f) < 0.3 for f in boxes)]
        self._previous = boxes
        return boxes


def _overlap_of_smaller(a: np.ndarray, b: np.ndarray) -> float:
    ix = max(0.0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    return float(ix * iy / min(a[2] * a[3], b[2] * b[3]))


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
def default_detector() -> FaceDetector:
    """The application's detector for one image at a time: BlazeFace (:class:`avcore.blazeface.BlazeFaceDetector`)
    when its model is installed (:mod:`avcore.models`), else OpenCV 4's Haar cascade; a RuntimeError that says how
    to get BlazeFace where neither is there (OpenCV 5 has no cascades)."""
    from avcore.models import BLAZEFACE_FILE, INSTALL_HINT, installed_model

    model = installed_model(BLAZEFACE_FILE)
    if model is not None:
        from avcore.blazeface import BlazeFaceDetector

        return BlazeFaceDetector(model)
    if not hasattr(cv2, "CascadeClassifier"):
        raise RuntimeError(f"no face detector: BlazeFace's model is not installed ({INSTALL_HINT}) and OpenCV "
                           f"{cv2.__version__} has no Haar cascades")
    return HaarFaceDetector()


def detect_faces(image: np.ndarray, detector: FaceDetector | None = None) -> np.ndarray:
    """Faces in one image (paper section 5.2, F3D's first step).

    image : (h, w) or (h, w, 3) uint8; detector : default :func:`default_detector` (BlazeFace when installed).
    Returns (n, 4) float boxes x, y, w, h in pixels of ``image``, sorted left to right; (0, 4) when none.
    """
    boxes = (detector or default_detector()).detect(image)
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
        left, right = rig.rectify(left, right)
        grey_l, grey_r = _as_grey(left, "left"), _as_grey(right, "right")
    boxes = detect_faces(left, detector)  # in colour: a detector trained on colour (BlazeFace) needs it
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
