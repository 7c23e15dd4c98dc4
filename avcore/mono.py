"""F3D with one camera: a face's distance from its size in the image (beyond the paper, which uses a stereo pair).

A face of physical size S metres that spans s pixels of a camera of focal length f pixels lies at z = f S / s
(pinhole, the face roughly facing the camera). The size read is the distance between the eyes when the detector
gives them (BlazeFace's keypoints): adults' interpupillary distance is about 63 mm with a standard deviation of about
3.5 mm (Dodgson 2004, "Variation and extrema of human interpupillary distance"). A detector with boxes alone (Haar)
gives the box's width, which spans ``HAAR_BOX_PER_IPD`` interpupillary distances, a ratio measured on the labelled
photographs of ``../shared/data/faces`` (BlazeFace's eyes inside OpenCV's boxes; docs/experiments.md, 2026-11-26).
With the face mesh running (the lips read) its eye centres replace BlazeFace's keypoints: a network made for
landmarks, on a crop levelled by the detector's eyes (measured in docs/experiments.md, 2026-11-27 (sixth)).

The depth error model is in docs/method.md ("One camera"): the person's own size against the population's, the
size's measurement in pixels (growing with the distance), and the head's turn (a face turned by a shows its eyes
closer by cos a). The direction of the face (its pixel) is exact to the detector's box, so the error lies along the
line of sight: an ITD, which depends on the direction, is barely affected.
"""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

from avcore.faces import FaceDetector, FaceLocations, detect_faces
from avcore.stereo import StereoRig

__all__ = ["HAAR_BOX_PER_IPD", "INTERPUPILLARY_M", "face_distances", "locate_faces_mono"]

INTERPUPILLARY_M = 0.063  # adults' mean interpupillary distance (Dodgson 2004)
HAAR_BOX_PER_IPD = 2.64  # OpenCV's frontal-face box width in interpupillary distances (measured, module docstring)


def face_distances(boxes: np.ndarray, eyes_px: np.ndarray | None, focal_px: float, *,
                   interpupillary_m: float = INTERPUPILLARY_M, box_per_ipd: float = HAAR_BOX_PER_IPD) -> np.ndarray:
    """(n,) metres along the optical axis of faces ``boxes`` (n, 4) x, y, w, h pixels: from their eyes ``eyes_px``
    (n, 2, 2) pixels (the two eye centres) when given, else from the boxes' widths."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if eyes_px is None:
        span_px, span_m = b[:, 2], box_per_ipd * interpupillary_m
    else:
        eyes = np.asarray(eyes_px, dtype=np.float64).reshape(-1, 2, 2)
        if eyes.shape[0] != b.shape[0]:
            raise ValueError(f"one pair of eyes per box: {b.shape[0]} boxes, {eyes.shape[0]} pairs of eyes")
        span_px, span_m = np.linalg.norm(eyes[:, 0] - eyes[:, 1], axis=1), interpupillary_m
    with np.errstate(divide="ignore"):
        return np.where(span_px > 0, focal_px * span_m / span_px, np.nan)


def locate_faces_mono(image: np.ndarray, rig: StereoRig, *, detector: FaceDetector | None = None,
                      min_depth_m: float = 0.3, max_depth_m: float = 10.0,
                      eyes_from: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None
                      ) -> FaceLocations:
    """F3D (paper section 5.2) with one camera, the rig's left one: faces detected in ``image`` (its size), each at
    its box centre and at the distance its size gives (:func:`face_distances`; the eyes when the detector has
    ``detect_faces`` with keypoints, as BlazeFace, else the box). ``eyes_from(image, boxes, eyes)`` -> (n, 2, 2)
    pixels may give better eyes (the face mesh's: :func:`avcore.facemesh.eye_centres`); a face it gives NaN for
    keeps the detector's. Faces outside [min_depth_m, max_depth_m] are ``unmatched``; ``ncc`` holds 1.0 (there is
    no correlation to report)."""
    if image.shape[1::-1] != tuple(rig.image_size):
        raise ValueError(f"the image must be of the rig's size {rig.image_size} (width, height), got "
                         f"{image.shape[1::-1]}")
    eyes = None
    if detector is not None and hasattr(detector, "detect_faces"):
        found = detector.detect_faces(image)
        order = np.argsort(found.boxes[:, 0], kind="stable")  # left to right, as detect_faces sorts
        boxes, eyes = found.boxes[order], found.keypoints[order][:, :2]
        if eyes_from is not None and len(boxes):
            better = np.asarray(eyes_from(image, boxes, eyes), dtype=np.float64).reshape(-1, 2, 2)
            eyes = np.where(np.isfinite(better).all(axis=(1, 2))[:, None, None], better, eyes)
    else:
        boxes = detect_faces(image, detector)
    uv = boxes[:, :2] + boxes[:, 2:] / 2.0 - 0.5
    if not rig.is_rectified:
        uv = rig.rectify_points(uv, "left") if len(uv) else uv
        if eyes is not None and len(eyes):
            eyes = rig.rectify_points(eyes.reshape(-1, 2), "left").reshape(-1, 2, 2)
    z = face_distances(boxes, eyes, rig.focal_px)
    with np.errstate(invalid="ignore"):
        keep = (z >= min_depth_m) & (z <= max_depth_m)
    xyz = rig.back_project(uv[keep].reshape(-1, 2), z[keep])
    return FaceLocations(boxes[keep], xyz, np.ones(int(keep.sum())), boxes[~keep])
