"""The stereo rig: calibration from chessboards, rectification and triangulation into the scene frame.

Paper section 5.2 (visual features are 3D points from binocular vision, expressed in cyclopean coordinates) and
section 5.3 (the stereo calibration, done there with Bouguet's toolbox and here with OpenCV).

Conventions (docs/architecture.md): metres; OpenCV's camera axes (x right, y down, z forward). The **scene frame** is
the cyclopean frame of the *rectified* pair: its axes are those of the rectified left camera and its origin lies midway
between the two camera centres. Image coordinates are pixels ``(u, v)`` with the origin at the centre of the
top-left pixel (OpenCV's convention).

OpenCV's extrinsics are kept: ``rotation`` R and ``translation`` T map a point from the left camera frame to the
right camera frame, ``x_right = R @ x_left + T``; for a right camera 12 cm to the right, T = (-0.12, 0, 0).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import cv2
import numpy as np

__all__ = [
    "StereoRig",
    "CameraCalibration",
    "StereoCalibration",
    "chessboard_points",
    "find_chessboard",
    "calibrate_camera",
    "calibrate_stereo",
]

_RIG_KEYS = ("image_size", "left", "right", "rotation", "translation_m")
_CAMERA_KEYS = ("camera_matrix", "dist_coeffs")
RGBD_TWIN_M = 0.001  # StereoRig.rgbd: how far the virtual right camera of an RGB-D camera stands


def _matrix(value: object, name: str, shape: tuple[int, ...]) -> np.ndarray:
    arr = np.array(value, dtype=np.float64)
    if arr.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} holds NaN or infinite values: {arr.tolist()}")
    arr.setflags(write=False)
    return arr


def _camera_matrix(value: object, name: str) -> np.ndarray:
    k = _matrix(value, name, (3, 3))
    if k[0, 0] <= 0 or k[1, 1] <= 0 or k[2, 2] != 1 or k[1, 0] != 0 or k[2, 0] != 0 or k[2, 1] != 0:
        raise ValueError(
            f"{name} must be an upper-triangular camera matrix [[fx, s, cx], [0, fy, cy], [0, 0, 1]] "
            f"with positive focal lengths in pixels, got {k.tolist()}"
        )
    return k


def _dist_coeffs(value: object, name: str) -> np.ndarray:
    arr = np.array(value, dtype=np.float64).ravel()
    if arr.size not in (4, 5, 8, 12, 14):
        raise ValueError(f"{name} must hold 4, 5, 8, 12 or 14 distortion coefficients (OpenCV order), got {arr.size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} holds NaN or infinite values: {arr.tolist()}")
    arr.setflags(write=False)
    return arr


def _image_size(value: object) -> tuple[int, int]:
    try:
        w, h = value  # type: ignore[misc]
    except (TypeError, ValueError):
        raise ValueError(f"image_size must be (width, height) in pixels, got {value!r}") from None
    if not all(isinstance(x, (int, np.integer)) and not isinstance(x, bool) and x > 0 for x in (w, h)):
        raise ValueError(f"image_size must be two positive integers (width, height) in pixels, got {value!r}")
    return (int(w), int(h))


def _as_uv(uv: object, name: str) -> np.ndarray:
    arr = np.asarray(uv, dtype=np.float64)
    if arr.ndim == 1 and arr.size == 0:
        arr = arr.reshape(0, 2)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ValueError(f"{name} must be an (n, 2) array of pixel coordinates (u, v), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} holds NaN or infinite pixel coordinates; drop them before the call")
    return arr


@dataclass(frozen=True, eq=False)
class StereoRig:
    """A calibrated stereo pair and its rectification (paper section 5.3).

    Parameters
    ----------
    image_size : (width, height) int, pixels
        Size of the images of both cameras.
    camera_matrix_left, camera_matrix_right : (3, 3) float, pixels
        Intrinsics ``[[fx, s, cx], [0, fy, cy], [0, 0, 1]]``.
    dist_left, dist_right : (k,) float
        OpenCV distortion coefficients (k1, k2, p1, p2[, k3 ...]).
    rotation : (3, 3) float
        R, from the left camera frame to the right camera frame.
    translation : (3,) float, metres
        T, with ``x_right = R @ x_left + T``.

    Derived (from ``cv2.stereoRectify`` with ``CALIB_ZERO_DISPARITY`` and ``alpha=0``, so that rectified images
    hold valid pixels only): ``rect_left``, ``rect_right`` (3, 3) rotations from each camera frame to its rectified
    frame; ``proj_left``, ``proj_right`` (3, 4) projection matrices of the rectified cameras, in the rectified left
    frame; ``disparity_to_depth`` Q (4, 4).
    """

    image_size: tuple[int, int]
    camera_matrix_left: np.ndarray
    dist_left: np.ndarray
    camera_matrix_right: np.ndarray
    dist_right: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray
    rect_left: np.ndarray = field(init=False, repr=False)
    rect_right: np.ndarray = field(init=False, repr=False)
    proj_left: np.ndarray = field(init=False, repr=False)
    proj_right: np.ndarray = field(init=False, repr=False)
    disparity_to_depth: np.ndarray = field(init=False, repr=False)
    _maps: dict[str, Any] = field(init=False, repr=False, default_factory=dict)

    def __post_init__(self) -> None:
        size = _image_size(self.image_size)
        k_l = _camera_matrix(self.camera_matrix_left, "camera_matrix_left")
        k_r = _camera_matrix(self.camera_matrix_right, "camera_matrix_right")
        d_l = _dist_coeffs(self.dist_left, "dist_left")
        d_r = _dist_coeffs(self.dist_right, "dist_right")
        rot = _matrix(self.rotation, "rotation", (3, 3))
        if not np.allclose(rot @ rot.T, np.eye(3), atol=1e-6) or np.linalg.det(rot) < 0:
            raise ValueError(f"rotation must be a proper rotation matrix (R R^T = I, det R = +1), got {rot.tolist()}")
        t = _matrix(np.asarray(self.translation, dtype=np.float64).ravel(), "translation", (3,))
        if np.linalg.norm(t) <= 0:
            raise ValueError("translation is zero: the two cameras are at the same place; a stereo rig needs a "
                             "baseline")
        for name, value in (
            ("image_size", size), ("camera_matrix_left", k_l), ("camera_matrix_right", k_r),
            ("dist_left", d_l), ("dist_right", d_r), ("rotation", rot), ("translation", t),
        ):
            object.__setattr__(self, name, value)

        r1, r2, p1, p2, q, _, _ = cv2.stereoRectify(
            k_l, d_l, k_r, d_r, size, rot, t.reshape(3, 1), flags=cv2.CALIB_ZERO_DISPARITY, alpha=0
        )
        if abs(p2[1, 3]) > abs(p2[0, 3]):
            raise ValueError(
                "the cameras are stacked vertically (translation mostly along y); avhear needs a horizontal rig "
                f"with the right camera beside the left one, got translation {t.tolist()} m"
            )
        if p2[0, 3] >= 0:
            raise ValueError(
                "the 'right' camera is on the left of the 'left' camera (translation x must be negative in "
                f"OpenCV's convention); swap the two cameras, got translation {t.tolist()} m"
            )
        for name, value in (("rect_left", r1), ("rect_right", r2), ("proj_left", p1), ("proj_right", p2),
                            ("disparity_to_depth", q)):
            arr = np.array(value, dtype=np.float64)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)

    # ------------------------------------------------------------------ construction
    @classmethod
    def ideal(
        cls,
        focal_px: float,
        image_size: tuple[int, int],
        baseline_m: float,
        principal_point: tuple[float, float] | None = None,
    ) -> StereoRig:
        """An already rectified rig: identical pinhole cameras, no distortion, side by side ``baseline_m`` apart.

        focal_px : float, pixels; image_size : (width, height) pixels; baseline_m : float, metres;
        principal_point : (cx, cy) pixels, default the image centre ``((w - 1) / 2, (h - 1) / 2)``.
        """
        size = _image_size(image_size)
        if not (np.isfinite(focal_px) and focal_px > 0):
            raise ValueError(f"focal_px must be a positive number of pixels, got {focal_px!r}")
        if not (np.isfinite(baseline_m) and baseline_m > 0):
            raise ValueError(f"baseline_m must be a positive distance in metres, got {baseline_m!r}")
        if principal_point is None:
            principal_point = ((size[0] - 1) / 2.0, (size[1] - 1) / 2.0)
        cx, cy = (float(c) for c in principal_point)
        k = np.array([[focal_px, 0.0, cx], [0.0, focal_px, cy], [0.0, 0.0, 1.0]])
        return cls(size, k, np.zeros(5), k.copy(), np.zeros(5), np.eye(3), np.array([-float(baseline_m), 0.0, 0.0]))

    @classmethod
    def rgbd(cls, camera_matrix: object, image_size: tuple[int, int]) -> StereoRig:
        """An RGB-D camera as a rig (:mod:`avcore.depth`): its colour camera ``camera_matrix`` (a CameraInfo's K)
        is the left camera, and a virtual twin 1 mm to its right stands in for the right one, so that the scene
        frame is the colour camera's optical frame within half a millimetre. Only :meth:`back_project` and
        :meth:`project`'s left image are meant for it; the colour image is used as the camera gives it (RGB-D
        drivers publish it with negligible distortion)."""
        k = _camera_matrix(camera_matrix, "camera_matrix")
        return cls(_image_size(image_size), k, np.zeros(5), k.copy(), np.zeros(5), np.eye(3),
                   np.array([-RGBD_TWIN_M, 0.0, 0.0]))

    def to_dict(self) -> dict[str, Any]:
        """Plain lists and numbers (for YAML or JSON); :meth:`from_dict` reads it back exactly."""
        return {
            "image_size": [int(self.image_size[0]), int(self.image_size[1])],
            "left": {"camera_matrix": self.camera_matrix_left.tolist(), "dist_coeffs": self.dist_left.tolist()},
            "right": {"camera_matrix": self.camera_matrix_right.tolist(), "dist_coeffs": self.dist_right.tolist()},
            "rotation": self.rotation.tolist(),
            "translation_m": self.translation.tolist(),
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> StereoRig:
        """Inverse of :meth:`to_dict`; unknown or missing keys raise ``ValueError`` naming them."""
        if not isinstance(data, Mapping):
            raise TypeError(f"a stereo rig must be a mapping with keys {_RIG_KEYS}, got {type(data).__name__}")
        _check_keys(data, _RIG_KEYS, "stereo")
        for side in ("left", "right"):
            if not isinstance(data[side], Mapping):
                raise TypeError(f"stereo.{side} must be a mapping with keys {_CAMERA_KEYS}, got {data[side]!r}")
            _check_keys(data[side], _CAMERA_KEYS, f"stereo.{side}")
        return cls(
            image_size=tuple(data["image_size"]),  # type: ignore[arg-type]
            camera_matrix_left=data["left"]["camera_matrix"],
            dist_left=data["left"]["dist_coeffs"],
            camera_matrix_right=data["right"]["camera_matrix"],
            dist_right=data["right"]["dist_coeffs"],
            rotation=data["rotation"],
            translation=data["translation_m"],
        )

    # ------------------------------------------------------------------ rectified geometry
    @property
    def focal_px(self) -> float:
        """Horizontal focal length of the rectified cameras, pixels."""
        return float(self.proj_left[0, 0])

    @property
    def baseline_m(self) -> float:
        """Distance between the two camera centres, metres."""
        return float(-self.proj_right[0, 3] / self.proj_right[0, 0])

    @property
    def is_rectified(self) -> bool:
        """True when the raw images are already rectified (no distortion, identical cameras, pure x baseline)."""
        return bool(
            not np.any(self.dist_left) and not np.any(self.dist_right)
            and np.allclose(self.rect_left, np.eye(3)) and np.allclose(self.rect_right, np.eye(3))
            and np.allclose(self.proj_left[:, :3], self.camera_matrix_left)
            and np.allclose(self.proj_right[:, :3], self.camera_matrix_right)
        )

    def rectify_points(self, uv: object, side: str) -> np.ndarray:
        """Raw pixel coordinates of one camera -> pixel coordinates in its rectified image.

        uv : (n, 2) float, raw pixels; side : "left" or "right"  ->  (n, 2) float, rectified pixels.
        """
        pts = _as_uv(uv, "uv")
        if side == "left":
            k, d, r, p = self.camera_matrix_left, self.dist_left, self.rect_left, self.proj_left
        elif side == "right":
            k, d, r, p = self.camera_matrix_right, self.dist_right, self.rect_right, self.proj_right
        else:
            raise ValueError(f"side must be 'left' or 'right', got {side!r}")
        if pts.shape[0] == 0:
            return pts.copy()
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-9)
        if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4
            out = cv2.undistortPointsIter(pts.reshape(-1, 1, 2), k, d, r, p, criteria)
        else:  # OpenCV 5: undistortPoints takes the criteria itself
            out = cv2.undistortPoints(pts.reshape(-1, 1, 2), k, d, R=r, P=p, criteria=criteria)
        return out.reshape(-1, 2).astype(np.float64)

    def rectify(self, left: np.ndarray, right: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Raw images -> rectified images (same size); a no-op returning the inputs for an ideal rig.

        left, right : (h, w) or (h, w, 3) uint8 images of ``image_size``.
        """
        for name, img in (("left", left), ("right", right)):
            if not isinstance(img, np.ndarray) or img.ndim not in (2, 3) or img.shape[1::-1] != self.image_size:
                got = getattr(img, "shape", type(img).__name__)
                raise ValueError(f"{name} must be an image of size {self.image_size} (width, height), got {got}")
        if self.is_rectified:
            return left, right
        if not self._maps:
            size = self.image_size
            self._maps["left"] = cv2.initUndistortRectifyMap(
                self.camera_matrix_left, self.dist_left, self.rect_left, self.proj_left, size, cv2.CV_16SC2)
            self._maps["right"] = cv2.initUndistortRectifyMap(
                self.camera_matrix_right, self.dist_right, self.rect_right, self.proj_right, size, cv2.CV_16SC2)
        out = []
        for side, img in (("left", left), ("right", right)):
            m1, m2 = self._maps[side]
            out.append(cv2.remap(img, m1, m2, cv2.INTER_LINEAR))
        return out[0], out[1]

    def triangulate(self, uv_left: object, uv_right: object, *, rectified: bool = True) -> np.ndarray:
        """Matched pixels in the two images -> 3D points in the scene (cyclopean) frame (paper section 5.2).

        uv_left, uv_right : (n, 2) float, pixels, row i of one matched with row i of the other; rectified-image
        pixels by default, raw pixels with ``rectified=False``.

        Returns (n, 3) float, metres. Depth comes from the horizontal disparity; the height from the mean of the
        two rows (equal for a perfect match). Pairs with a disparity <= 0 (a point at or beyond infinity, a wrong
        match) give a row of NaN, so that one bad match does not stop a batch; drop them with ``np.isfinite``.
        """
        ul = _as_uv(uv_left, "uv_left")
        ur = _as_uv(uv_right, "uv_right")
        if ul.shape != ur.shape:
            raise ValueError(f"uv_left and uv_right must have the same shape, got {ul.shape} and {ur.shape}")
        if not rectified:
            ul = self.rectify_points(ul, "left")
            ur = self.rectify_points(ur, "right")
        p1, p2 = self.proj_left, self.proj_right
        fx, fy, cy = p1[0, 0], p1[1, 1], p1[1, 2]
        disparity = (ul[:, 0] - p1[0, 2]) - (ur[:, 0] - p2[0, 2])
        ok = disparity > 0
        z = np.full(ul.shape[0], np.nan)
        z[ok] = fx * self.baseline_m / disparity[ok]
        v = 0.5 * (ul[:, 1] + ur[:, 1])
        x = (ul[:, 0] - p1[0, 2]) * z / fx - 0.5 * self.baseline_m
        y = (v - cy) * z / fy
        return np.stack([x, y, z], axis=1)

    def back_project(self, uv_left: object, depth_m: object, *, rectified: bool = True) -> np.ndarray:
        """Pixels of the left image and their depth -> 3D points in the scene (cyclopean) frame: what an RGB-D
        camera whose colour camera is the left camera measures (:mod:`avcore.depth`).

        uv_left : (n, 2) float, pixels of the rectified left image, or of the raw one with ``rectified=False``;
        depth_m : (n,) float, metres along the optical axis. Returns (n, 3) float, metres; the inverse of
        :meth:`project`'s left image. A depth that is not positive gives a row of NaN."""
        uv = _as_uv(uv_left, "uv_left")
        if not rectified:
            uv = self.rectify_points(uv, "left")
        z = np.asarray(depth_m, dtype=np.float64).reshape(-1)
        if z.shape[0] != uv.shape[0]:
            raise ValueError(f"one depth per pixel: {uv.shape[0]} pixels, {z.shape[0]} depths")
        z = np.where(z > 0, z, np.nan)
        p1 = self.proj_left
        x = (uv[:, 0] - p1[0, 2]) * z / p1[0, 0] - 0.5 * self.baseline_m
        y = (uv[:, 1] - p1[1, 2]) * z / p1[1, 1]
        return np.stack([x, y, z], axis=1)

    def project(self, points: object) -> tuple[np.ndarray, np.ndarray]:
        """3D points in the scene frame -> pixels in the two rectified images (the inverse of :meth:`triangulate`).

        points : (n, 3) float, metres, in front of the cameras (z > 0)  ->  uv_left, uv_right : (n, 2) float, pixels.
        """
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim == 1 and pts.size == 0:
            pts = pts.reshape(0, 3)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"points must be an (n, 3) array of metres, got shape {pts.shape}")
        if np.any(~(pts[:, 2] > 0)):
            raise ValueError("points must all lie in front of the cameras (z > 0 metres, finite)")
        homog = np.hstack([pts + np.array([0.5 * self.baseline_m, 0.0, 0.0]), np.ones((pts.shape[0], 1))])
        out = []
        for p in (self.proj_left, self.proj_right):
            q = homog @ p.T
            out.append(q[:, :2] / q[:, 2:3])
        return out[0], out[1]


def _check_keys(data: Mapping[str, Any], keys: Sequence[str], where: str) -> None:
    unknown = sorted(set(data) - set(keys))
    missing = [k for k in keys if k not in data]
    if unknown:
        raise ValueError(f"unknown key(s) {unknown} in {where}; expected {list(keys)}")
    if missing:
        raise ValueError(f"missing key(s) {missing} in {where}; expected {list(keys)}")


# ---------------------------------------------------------------------- calibration
@dataclass(frozen=True, eq=False)
class CameraCalibration:
    """One camera calibrated from chessboard views.

    camera_matrix : (3, 3) pixels; dist_coeffs : (5,); rms_px : overall reprojection RMS, pixels;
    per_view_rms_px : (n_views,) pixels; rotations : (n_views, 3, 3) and translations : (n_views, 3), units of
    the square size: the pose of the board in each view (board frame -> camera frame).
    """

    camera_matrix: np.ndarray
    dist_coeffs: np.ndarray
    rms_px: float
    per_view_rms_px: np.ndarray
    rotations: np.ndarray
    translations: np.ndarray


@dataclass(frozen=True, eq=False)
class StereoCalibration:
    """A stereo rig calibrated from chessboard pairs.

    rig : the calibrated :class:`StereoRig`; rms_px : stereo reprojection RMS over both cameras, pixels;
    per_view_rms_px : (n_views, 2) pixels, columns left and right, NaN for excluded views;
    pose_deviation : (n_views, 2): how far each view's own left-to-right pose (from the two single-camera fits) is
    from the consensus of all views, as (rotation in degrees, translation as a fraction of the baseline); a pair
    whose two pictures were not taken together, or a wrong corner order, stands out here;
    used : (n_views,) bool, the views kept for the stereo step; left, right : each camera's own calibration
    (the intrinsics are fixed from these during the stereo step).
    """

    rig: StereoRig
    rms_px: float
    per_view_rms_px: np.ndarray
    pose_deviation: np.ndarray
    used: np.ndarray
    left: CameraCalibration
    right: CameraCalibration


_SUBPIX_CRITERIA = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 30, 0.1)


def _pattern(pattern_size: tuple[int, int]) -> tuple[int, int]:
    try:
        cols, rows = pattern_size
    except (TypeError, ValueError):
        raise ValueError(f"pattern_size must be (columns, rows) of inner corners, got {pattern_size!r}") from None
    if not all(isinstance(x, (int, np.integer)) and x >= 2 for x in (cols, rows)):
        raise ValueError(f"pattern_size must be two integers >= 2 (inner corners per row, per column), "
                         f"got {pattern_size!r}")
    return (int(cols), int(rows))


def chessboard_points(pattern_size: tuple[int, int], square_m: float) -> np.ndarray:
    """The inner corners of a chessboard in its own plane, in the order OpenCV detects them.

    Returns (cols * rows, 3) float32, metres (z = 0).
    """
    cols, rows = _pattern(pattern_size)
    if not (np.isfinite(square_m) and square_m > 0):
        raise ValueError(f"square_m must be a positive side length in metres, got {square_m!r}")
    obj = np.zeros((cols * rows, 3), np.float32)
    obj[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * square_m
    return obj


def find_chessboard(image: np.ndarray, pattern_size: tuple[int, int]) -> np.ndarray | None:
    """The inner corners of a chessboard in an image, refined to sub-pixel (5x5 window, as OpenCV's own test).

    image : (h, w) or (h, w, 3) uint8.  Returns (cols * rows, 2) float32 pixels, or None when not found.
    """
    pattern = _pattern(pattern_size)
    if not isinstance(image, np.ndarray) or image.ndim not in (2, 3) or image.dtype != np.uint8:
        raise ValueError(f"image must be a uint8 grey or BGR array, got "
                         f"{getattr(image, 'dtype', type(image).__name__)} {getattr(image, 'shape', '')}")
    grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    found, corners = cv2.findChessboardCorners(
        grey, pattern, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
    if not found:
        return None
    corners = cv2.cornerSubPix(grey, corners, (5, 5), (-1, -1), _SUBPIX_CRITERIA)
    return corners.reshape(-1, 2).astype(np.float32)


def _check_views(corners: Sequence[np.ndarray], n_points: int, name: str, min_views: int) -> list[np.ndarray]:
    views = [np.asarray(c, dtype=np.float32).reshape(-1, 2) for c in corners]
    if len(views) < min_views:
        raise ValueError(f"{name} holds {len(views)} chessboard view(s); calibration needs at least {min_views} "
                         "views with the board at different angles: take more pictures")
    for i, v in enumerate(views):
        if v.shape[0] != n_points:
            raise ValueError(f"{name}[{i}] holds {v.shape[0]} corners, the pattern has {n_points}")
    return views


def calibrate_camera(
    corners: Sequence[np.ndarray],
    pattern_size: tuple[int, int],
    square_m: float,
    image_size: tuple[int, int],
    *,
    flags: int = 0,
    min_views: int = 3,
) -> CameraCalibration:
    """Intrinsics of one camera from chessboard corners (``cv2.calibrateCameraExtended``).

    corners : sequence of (cols * rows, 2) pixels, one per view, from :func:`find_chessboard`;
    square_m : side of a square, metres; image_size : (width, height) pixels.
    """
    obj = chessboard_points(pattern_size, square_m)
    views = _check_views(corners, obj.shape[0], "corners", min_views)
    size = _image_size(image_size)
    rms, k, d, rvecs, tvecs, _, _, per_view = cv2.calibrateCameraExtended(
        [obj] * len(views), [v.reshape(-1, 1, 2) for v in views], size, None, None, flags=flags)
    rotations = np.array([cv2.Rodrigues(r)[0] for r in rvecs])
    translations = np.array([np.asarray(t).ravel() for t in tvecs])
    return CameraCalibration(k, d.ravel(), float(rms), per_view.ravel(), rotations, translations)


def _pose_deviation(left: CameraCalibration, right: CameraCalibration) -> np.ndarray:
    """Per view: (degrees, fraction of the baseline) between its left-to-right pose and the consensus pose."""
    rel_r = right.rotations @ np.transpose(left.rotations, (0, 2, 1))           # R_i = R_r R_l^T
    rel_t = right.translations - np.einsum("nij,nj->ni", rel_r, left.translations)
    n = rel_r.shape[0]
    angles = np.zeros((n, n))
    for i in range(n):
        cos = (np.einsum("nij,nij->n", rel_r, np.broadcast_to(rel_r[i], rel_r.shape)) - 1.0) / 2.0  # tr(R_j^T R_i)
        angles[i] = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    medoid = int(np.argmin(np.median(angles, axis=1)))
    t_ref = np.median(rel_t, axis=0)
    scale = max(float(np.linalg.norm(t_ref)), 1e-12)
    return np.stack([angles[medoid], np.linalg.norm(rel_t - t_ref, axis=1) / scale], axis=1)


def calibrate_stereo(
    corners_left: Sequence[np.ndarray],
    corners_right: Sequence[np.ndarray],
    pattern_size: tuple[int, int],
    square_m: float,
    image_size: tuple[int, int],
    *,
    min_views: int = 3,
    max_pose_deviation: tuple[float, float] | None = (2.0, 0.1),
) -> StereoCalibration:
    """A :class:`StereoRig` from chessboard corners seen by both cameras (paper section 5.3).

    Each camera is first calibrated alone (``calibrateCamera``, flags 0, as OpenCV's reference test); each view
    then gives its own left-to-right pose, and views whose pose deviates from the consensus by more than
    ``max_pose_deviation`` (degrees, fraction of the baseline; None keeps every view) are left out, as long as
    ``min_views`` remain. The stereo step estimates R and T from the kept views with the intrinsics fixed
    (``stereoCalibrate`` with ``CALIB_FIX_INTRINSIC``), which keeps the intrinsics as good as the single-camera
    fits and the extrinsics well conditioned.

    corners_left, corners_right : sequences of (cols * rows, 2) pixels, view i of one seen with view i of the other.
    """
    obj = chessboard_points(pattern_size, square_m)
    left = _check_views(corners_left, obj.shape[0], "corners_left", min_views)
    right = _check_views(corners_right, obj.shape[0], "corners_right", min_views)
    if len(left) != len(right):
        raise ValueError(f"corners_left and corners_right must hold the same views, got {len(left)} and {len(right)}")
    size = _image_size(image_size)
    cal_l = calibrate_camera(left, pattern_size, square_m, size, min_views=min_views)
    cal_r = calibrate_camera(right, pattern_size, square_m, size, min_views=min_views)
    deviation = _pose_deviation(cal_l, cal_r)
    used = np.ones(len(left), bool)
    if max_pose_deviation is not None:
        keep = (deviation[:, 0] <= max_pose_deviation[0]) & (deviation[:, 1] <= max_pose_deviation[1])
        if keep.sum() >= min_views:
            used = keep
    idx = np.flatnonzero(used)
    out = cv2.stereoCalibrateExtended(
        [obj] * idx.size, [left[i].reshape(-1, 1, 2) for i in idx], [right[i].reshape(-1, 1, 2) for i in idx],
        cal_l.camera_matrix.copy(), cal_l.dist_coeffs.copy(), cal_r.camera_matrix.copy(), cal_r.dist_coeffs.copy(),
        size, None, None, flags=cv2.CALIB_FIX_INTRINSIC,
    )
    rms, rot, t, per_view_used = out[0], out[5], out[6], out[-1]
    per_view = np.full((len(left), 2), np.nan)
    per_view[idx] = np.asarray(per_view_used, dtype=np.float64).reshape(-1, 2)
    rig = StereoRig(size, cal_l.camera_matrix, cal_l.dist_coeffs, cal_r.camera_matrix, cal_r.dist_coeffs,
                    rot, t.ravel())
    return StereoCalibration(rig, float(rms), per_view, deviation, used, cal_l, cal_r)
