"""F3D and HM3D with an RGB-D camera: depth read from an aligned depth image instead of a stereo match.

An RGB-D camera (RealSense D4xx, OAK-D, ZED, Orbbec) gives a colour image and a depth image aligned to it (metres
along the optical axis; 0 or NaN where it has no measurement). avhear describes it with the :class:`StereoRig` whose
left camera is the colour camera (:meth:`StereoRig.rgbd` for a camera known by its CameraInfo), so that points land
in the same scene frame as with stereo (docs/architecture.md): :meth:`StereoRig.back_project` turns a colour pixel
and its depth into a scene point. Colour images are used as the camera gives them: a rig that is not rectified
(an RGB-D camera's) has its pixels rectified before they are back-projected.

Depth images have holes (no texture for the projector, dark or shiny surfaces), flying pixels at depth edges (a
mix of foreground and background), and noise that grows with the square of the distance. A face's depth is
therefore read robustly over the inner part of its box (:func:`face_depth`): the valid pixels, the nearest
cluster of them (a face is in front of what lies behind it), its median.
"""
from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from avcore.faces import FaceDetector, FaceLocations, detect_faces
from avcore.motion import MotionPoints, grey_frames, interval_shape, temporal_std
from avcore.stereo import StereoRig

__all__ = ["as_depth_m", "depth_millimetres", "face_depth", "locate_faces_depth", "motion_points_depth"]


def as_depth_m(depth: np.ndarray) -> np.ndarray:
    """A depth image in metres, float32, NaN where invalid: 16UC1 millimetres (0 invalid), as RealSense and
    OpenNI drivers publish, or 32FC1 metres (0, NaN or inf invalid)."""
    d = np.asarray(depth)
    if d.ndim != 2:
        raise ValueError(f"a depth image must be (h, w), got shape {d.shape}")
    if d.dtype == np.uint16:
        out = d.astype(np.float32) * np.float32(1e-3)
    elif d.dtype in (np.float32, np.float64):
        out = d.astype(np.float32, copy=True)
    else:
        raise ValueError(f"a depth image is uint16 millimetres or float metres, got {d.dtype}")
    out[~(np.isfinite(out) & (out > 0))] = np.nan
    return out


def depth_millimetres(depth_m: np.ndarray) -> np.ndarray:
    """The inverse of :func:`as_depth_m`: 16UC1 millimetres, 0 where invalid, as RealSense's driver publishes depth
    and a recording keeps it (values beyond 65.535 m are clipped there)."""
    d = np.where(np.isfinite(depth_m), np.rint(np.asarray(depth_m, np.float64) * 1000.0), 0.0)
    return np.clip(d, 0, 65535).astype(np.uint16)


def face_depth(depth_m: np.ndarray, box: Sequence[float], *, inner: float = 0.5, min_valid: float = 0.2,
               cluster_m: float = 0.15) -> tuple[float, float]:
    """(depth in metres, fraction of valid pixels) of the face in ``box`` (x, y, w, h pixels); NaN depth when too
    few of the inner pixels hold a depth.

    The central ``inner`` part of the box is read; of its valid depths, those within ``cluster_m`` of the nearest
    dense depth (the 10th percentile: flying pixels in front of the face are rarer than that) are the face, and
    their median is its depth. Background leaking into the box at a depth edge is further away and left out."""
    x, y, w, h = (float(v) for v in box)
    mx, my = 0.5 * (1.0 - inner) * w, 0.5 * (1.0 - inner) * h
    rows, cols = depth_m.shape
    r0, r1 = int(max(np.floor(y + my), 0)), int(min(np.ceil(y + h - my), rows))
    c0, c1 = int(max(np.floor(x + mx), 0)), int(min(np.ceil(x + w - mx), cols))
    patch = depth_m[r0:r1, c0:c1]
    if patch.size == 0:
        return float("nan"), 0.0
    valid = patch[np.isfinite(patch)]
    fraction = valid.size / patch.size
    if fraction < min_valid:
        return float("nan"), fraction
    near = np.percentile(valid, 10)
    face = valid[valid <= near + cluster_m]
    return float(np.median(face)), fraction


def locate_faces_depth(image: np.ndarray, depth: np.ndarray, rig: StereoRig, *,
                       detector: FaceDetector | None = None, min_depth_m: float = 0.3,
                       max_depth_m: float = 10.0) -> FaceLocations:
    """F3D (paper section 5.2) with an RGB-D camera: faces detected in the colour image, located in 3D from the
    aligned depth image (:func:`face_depth`) at their box centre.

    image : (h, w[, 3]) uint8 colour image of the rig's left camera; depth : (h, w) depth aligned to it
    (:func:`as_depth_m`'s units). Returns :class:`FaceLocations` whose ``ncc`` holds each face's fraction of
    valid depth pixels; faces without a depth in [min_depth_m, max_depth_m] are ``unmatched``."""
    depth_m = as_depth_m(depth)
    if depth_m.shape != image.shape[:2] or depth_m.shape[::-1] != tuple(rig.image_size):
        raise ValueError(f"the colour and depth images must both be of the rig's size {rig.image_size} (width, "
                         f"height), got {image.shape[1::-1]} and {depth_m.shape[::-1]}")
    boxes = detect_faces(image, detector)  # in colour: a detector trained on colour (BlazeFace) needs it
    keep, centres, depths, fractions = [], [], [], []
    for i, box in enumerate(boxes):
        z, fraction = face_depth(depth_m, box)
        if not min_depth_m <= z <= max_depth_m:
            continue
        keep.append(i)
        centres.append((box[0] + box[2] / 2.0 - 0.5, box[1] + box[3] / 2.0 - 0.5))
        depths.append(z)
        fractions.append(fraction)
    mask = np.zeros(len(boxes), bool)
    mask[keep] = True
    xyz = rig.back_project(np.array(centres).reshape(-1, 2), np.array(depths, dtype=np.float64),
                           rectified=rig.is_rectified)
    return FaceLocations(boxes[mask], xyz, np.asarray(fractions, dtype=np.float64), boxes[~mask])


def motion_points_depth(frames: Sequence[np.ndarray] | np.ndarray, depths: Sequence[np.ndarray], rig: StereoRig,
                        *, tau_m: float = 6.0, max_corners: int = 800, quality_level: float = 0.0015,
                        min_distance_px: int = 3, min_depth_m: float = 0.5, max_depth_m: float = 8.0,
                        max_step_m: float = 0.05) -> MotionPoints:
    """HM3D (paper section 5.2) with an RGB-D camera: the Harris points of the dynamic pixels of each colour frame
    (as :func:`avcore.motion.harris_motion_points`: tau over the interval against ``tau_m``), located in 3D by the
    depth of their pixel in that frame's aligned depth image instead of a stereo match.

    A point is kept when its pixel and its 4 neighbours hold depths within ``max_step_m`` of each other: a flying
    pixel at a depth edge belongs to neither surface. ``ncc`` holds 1.0 (there is no correlation to report)."""
    colour = grey_frames(frames, "frames")
    if len(depths) != colour.shape[0]:
        raise ValueError(f"one depth image per frame: {colour.shape[0]} frames, {len(depths)} depth images")
    t, h, w = interval_shape(colour, rig)
    dynamic = (temporal_std(colour) > tau_m).astype(np.uint8)
    if not dynamic.any():
        return MotionPoints.empty()
    results = []
    for k in range(t):
        corners = cv2.goodFeaturesToTrack(colour[k], max_corners, quality_level, min_distance_px, mask=dynamic,
                                          blockSize=3, useHarrisDetector=True, k=0.04)
        if corners is None:
            continue
        depth_m = as_depth_m(depths[k])
        if depth_m.shape != (h, w):
            raise ValueError(f"depth image {k} is {depth_m.shape[1]}x{depth_m.shape[0]}, the frames {w}x{h}")
        uv = np.rint(corners.reshape(-1, 2)).astype(np.int64)
        u, v = uv[:, 0].clip(1, w - 2), uv[:, 1].clip(1, h - 2)
        z = depth_m[v, u]
        around = np.stack([depth_m[v - 1, u], depth_m[v + 1, u], depth_m[v, u - 1], depth_m[v, u + 1]])
        with np.errstate(invalid="ignore"):
            ok = (np.isfinite(z) & (z >= min_depth_m) & (z <= max_depth_m)
                  & np.all(np.abs(around - z) <= max_step_m, axis=0))
        if not ok.any():
            continue
        uv_l = np.stack([u[ok], v[ok]], axis=1).astype(np.float64)
        results.append((rig.back_project(uv_l, z[ok].astype(np.float64), rectified=rig.is_rectified),
                        np.full(int(ok.sum()), k), uv_l,
                        np.ones(int(ok.sum()))))
    if not results:
        return MotionPoints.empty()
    return MotionPoints(*(np.concatenate(parts) for parts in zip(*results)))
