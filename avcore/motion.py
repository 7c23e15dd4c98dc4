"""HM3D, the Harris-motion 3D points of paper section 5.2.

Over the frames of one time interval (Delta t): Harris interest points are detected in the left images; each
point's temporal standard deviation of intensity tau, at the same pixel over the interval, classifies it as static
(tau <= tau_M) or dynamic (tau > tau_M); dynamic points are matched into the right image of the same instant along
their rectified row by normalised cross-correlation, and triangulated into the scene (cyclopean) frame.

Two choices of this implementation: the Harris detector is given the mask of dynamic pixels, so that its budget of
corners is spent on moving regions rather than on a textured static background (the classification is the same as
detecting everywhere and discarding static points); a match is kept only if the right pixel it lands on is dynamic
too, so that the right image's motion confirms the left one's (the paper detects points in both images).
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from avcore.stereo import StereoRig

__all__ = ["MotionPoints", "grey_frames", "harris_motion_points", "interval_shape", "temporal_std"]


@dataclass(frozen=True, eq=False)
class MotionPoints:
    """HM3D features of one interval.

    points : (m, 3) float, metres, scene (cyclopean) frame; frame_index : (m,) int, the frame of the interval each
    point was seen in; uv_left : (m, 2) float, rectified left pixels; ncc : (m,) match correlation in [-1, 1].
    """

    points: np.ndarray
    frame_index: np.ndarray
    uv_left: np.ndarray
    ncc: np.ndarray

    def __len__(self) -> int:
        return int(self.points.shape[0])

    @classmethod
    def empty(cls) -> MotionPoints:
        return cls(np.zeros((0, 3)), np.zeros(0, int), np.zeros((0, 2)), np.zeros(0))


def grey_frames(frames: Sequence[np.ndarray] | np.ndarray, name: str) -> np.ndarray:
    """The frames of an interval as one (t, h, w) uint8 grey stack; ValueError naming ``name`` otherwise."""
    if isinstance(frames, np.ndarray) and frames.ndim == 3 and frames.dtype == np.uint8:
        return frames
    if len(frames) == 0:
        raise ValueError(f"{name} holds no frame; an interval needs at least 2")
    grey = []
    for i, img in enumerate(frames):
        if not isinstance(img, np.ndarray) or img.dtype != np.uint8 or img.ndim not in (2, 3):
            got = f"{img.dtype} {img.shape}" if isinstance(img, np.ndarray) else type(img).__name__
            raise ValueError(f"{name}[{i}] must be a uint8 grey (h, w) or BGR (h, w, 3) image, got {got}")
        grey.append(cv2.cvtColor(img, cv2.COLOR_BGR2GRAY) if img.ndim == 3 else img)
    shapes = {g.shape for g in grey}
    if len(shapes) != 1:
        raise ValueError(f"{name} frames differ in size: {sorted(shapes)}")
    return np.stack(grey)


def interval_shape(frames: np.ndarray, rig: StereoRig) -> tuple[int, int, int]:
    """(t, h, w) of an interval's grey stack; ValueError unless it has 2 frames or more of the rig's size."""
    t, h, w = frames.shape
    if t < 2:
        raise ValueError(f"an interval needs at least 2 frames to measure motion, got {t}")
    if (w, h) != tuple(rig.image_size):
        raise ValueError(f"frames are {w}x{h} but the rig's images are {rig.image_size[0]}x{rig.image_size[1]}")
    return t, h, w


def temporal_std(frames: np.ndarray) -> np.ndarray:
    """tau of paper section 5.2: the standard deviation of each pixel's intensity over the interval.

    frames : (t, h, w) uint8  ->  (h, w) float32, grey levels.
    """
    f = frames.astype(np.float32)
    mean = f.mean(axis=0)
    return np.sqrt(np.maximum((f * f).mean(axis=0) - mean * mean, 0.0))


def _row_scores(left: np.ndarray, right: np.ndarray, u: np.ndarray, v: np.ndarray, half: int, d_lo: int,
                n_disp: int) -> np.ndarray:
    """Normalised cross-correlation of each left patch with the right image along its row.

    left, right : (h, w) uint8; u, v : (n,) int patch centres in the left image, at least ``half`` from the border.
    Returns (n, n_disp) float: column j holds the score at disparity ``d_lo + j`` (right centre u - d_lo - j),
    -inf where the right patch would leave the image.
    """
    w = left.shape[1]
    p = 2 * half + 1
    d_hi = d_lo + n_disp - 1
    scores = np.full((u.size, n_disp), -np.inf, dtype=np.float32)
    for i in range(u.size):
        ui, vi = int(u[i]), int(v[i])
        c0 = max(0, ui - d_hi - half)            # first column of the strip
        c1 = min(w, ui - d_lo + half + 1)        # one past its last column
        if c1 - c0 < p:
            continue
        res = cv2.matchTemplate(right[vi - half:vi + half + 1, c0:c1],
                                left[vi - half:vi + half + 1, ui - half:ui + half + 1], cv2.TM_CCOEFF_NORMED)[0]
        # res[m] is centred on right column c0 + m + half, i.e. disparity ui - c0 - m - half = d_lo + j
        j = ui - c0 - half - d_lo - np.arange(res.size)
        scores[i, j] = res
    scores[~np.isfinite(scores) & ~np.isneginf(scores)] = -np.inf
    return scores


def harris_motion_points(
    left_frames: Sequence[np.ndarray] | np.ndarray,
    right_frames: Sequence[np.ndarray] | np.ndarray,
    rig: StereoRig,
    *,
    tau_m: float = 6.0,
    max_corners: int = 800,
    quality_level: float = 0.0015,
    min_distance_px: int = 3,
    patch_px: int = 9,
    min_ncc: float = 0.85,
    min_margin: float = 0.05,
    min_depth_m: float = 0.5,
    max_depth_m: float = 8.0,
    rectified: bool = True,
) -> MotionPoints:
    """HM3D (paper section 5.2) of one interval of rectified stereo frames.

    left_frames, right_frames : t >= 2 frames each, (h, w) or (h, w, 3) uint8, or (t, h, w) uint8 arrays;
        frame i of one taken with frame i of the other; rectified frames, or raw ones with ``rectified=False``.
    tau_m : tau_M of the paper, grey levels: a point is dynamic when its temporal std exceeds it. Keep it above
        the sensor noise (a static pixel's tau is about the noise std).
    max_corners, quality_level, min_distance_px : Harris detection per frame (``cv2.goodFeaturesToTrack``); the
        defaults give about 2,000 points per interval of 6 frames on a scene of 3-5 moving people, the paper's
        figure (section 7: Delta t = 0.4 s, 6 frames).
    patch_px : side of the correlation window; min_ncc : weakest accepted match; min_margin : how much the best
        correlation must beat the best one elsewhere on the row (more than 2 px away), which rejects ambiguous
        matches on repeated patterns (two eyes, stripes).
    min_depth_m, max_depth_m : the depth range searched (it bounds the disparities).

    Returns :class:`MotionPoints`, the points of every frame of the interval together.
    """
    left = grey_frames(left_frames, "left_frames")
    right = grey_frames(right_frames, "right_frames")
    if left.shape != right.shape:
        raise ValueError(f"left_frames and right_frames must have the same shape, got {left.shape} and {right.shape}")
    t, h, w = interval_shape(left, rig)
    if not rectified:
        pairs = [rig.rectify(left[i], right[i]) for i in range(t)]
        left = np.stack([p[0] for p in pairs])
        right = np.stack([p[1] for p in pairs])
    if not (np.isfinite(tau_m) and tau_m >= 0):
        raise ValueError(f"tau_m must be a non-negative number of grey levels, got {tau_m!r}")
    if patch_px < 3 or patch_px % 2 == 0:
        raise ValueError(f"patch_px must be an odd number >= 3, got {patch_px!r}")
    if not 0 <= min_margin < 2:
        raise ValueError(f"min_margin must be a correlation difference in [0, 2), got {min_margin!r}")
    if not 0 < min_depth_m < max_depth_m:
        raise ValueError(f"need 0 < min_depth_m < max_depth_m, got {min_depth_m!r} and {max_depth_m!r}")

    tau_l = temporal_std(left)
    dynamic_l = (tau_l > tau_m).astype(np.uint8)
    fb = rig.focal_px * rig.baseline_m
    p1, p2 = rig.proj_left, rig.proj_right
    offset = p1[0, 2] - p2[0, 2]  # disparity = (u_l - u_r) - offset
    d_lo = int(np.floor(fb / max_depth_m + offset)) - 1  # one more on each side for the sub-pixel parabola
    d_hi = int(np.ceil(fb / min_depth_m + offset)) + 1
    n_disp = d_hi - d_lo + 1
    half = patch_px // 2
    empty = MotionPoints.empty()
    if not dynamic_l.any():
        return empty

    match = _RowMatch(half, d_lo, n_disp, min_ncc, min_margin)
    results = []
    for k in range(t):
        corners = cv2.goodFeaturesToTrack(left[k], max_corners, quality_level, min_distance_px, mask=dynamic_l,
                                          blockSize=3, useHarrisDetector=True, k=0.04)
        if corners is None:
            continue
        uv = np.rint(corners.reshape(-1, 2)).astype(np.int64)
        u, v = uv[:, 0], uv[:, 1]
        inside = (v >= half) & (v < h - half) & (u >= half) & (u < w - half)
        u, v = u[inside], v[inside]
        if u.size == 0:
            continue
        ok, d, s0 = match(left[k], right[k], u, v)
        u_r = np.rint(u - d).astype(np.int64).clip(0, w - 1)
        # the right pixel must move too: its own temporal std over the interval
        ok[ok] &= right[:, v[ok], u_r[ok]].astype(np.float32).std(axis=0) > tau_m
        if not ok.any():
            continue
        uv_l = np.stack([u[ok], v[ok]], axis=1).astype(np.float64)
        uv_r = uv_l - np.stack([d[ok], np.zeros(int(ok.sum()))], axis=1)
        xyz = rig.triangulate(uv_l, uv_r)
        in_range = np.isfinite(xyz[:, 2]) & (xyz[:, 2] >= min_depth_m) & (xyz[:, 2] <= max_depth_m)
        results.append((xyz[in_range], np.full(int(in_range.sum()), k), uv_l[in_range], s0[ok][in_range]))
    if not results:
        return empty
    return MotionPoints(*(np.concatenate(parts) for parts in zip(*results)))


class _RowMatch:
    """The stereo match of left pixels along their rectified row: the best normalised correlation over the
    disparities ``d_lo .. d_lo + n_disp - 1`` (padded by one on each side for a sub-pixel parabola), accepted when
    it reaches ``min_ncc``, is a true peak, and beats the best correlation more than 2 px away by ``min_margin``."""

    def __init__(self, half: int, d_lo: int, n_disp: int, min_ncc: float, min_margin: float) -> None:
        self.half, self.d_lo, self.n_disp, self.min_ncc, self.min_margin = half, d_lo, n_disp, min_ncc, min_margin

    def __call__(self, left: np.ndarray, right: np.ndarray, u: np.ndarray, v: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(n,) accepted, (n,) sub-pixel disparity, (n,) best correlation of the pixels ``(u, v)``."""
        scores = _row_scores(left, right, u, v, self.half, self.d_lo, self.n_disp)  # (n, D), j <-> d_lo + j
        best = np.argmax(scores[:, 1:-1], axis=1) + 1                               # peak inside the padding
        n = np.arange(u.size)
        s0, sm, sp = scores[n, best], scores[n, best - 1], scores[n, best + 1]
        finite = np.isfinite(s0) & np.isfinite(sm) & np.isfinite(sp)
        near_peak = np.abs(np.arange(self.n_disp)[None, :] - best[:, None]) <= 2
        runner_up = np.where(near_peak, -np.inf, scores).max(axis=1)
        with np.errstate(invalid="ignore"):  # a flat patch has no correlation (NaN): ``finite`` rejects it
            denom = np.where(finite, sm - 2.0 * s0 + sp, 0.0)
            ok = finite & (s0 >= self.min_ncc) & (denom < 0) & (s0 - runner_up >= self.min_margin)
        sub = np.zeros(u.size)
        sub[ok] = np.clip(0.5 * (sm[ok] - sp[ok]) / denom[ok], -0.5, 0.5)
        return ok, self.d_lo + best + sub, s0
