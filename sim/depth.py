"""The simulated room seen by an RGB-D camera: a depth image aligned to the left (colour) camera, with the errors
active-stereo depth cameras have.

The ideal depth is exact for the renderer's planar quads (1/z is affine in the pixel coordinates of a plane) and
follows the same painter's order as the colour image, so that what is drawn in front has its depth in front.
:class:`DepthErrors` then degrades it as a RealSense D435 does; its numbers and where they come from:

- noise: the RMS depth error of a stereo depth camera, ``z^2 * subpixel / (focal_px * baseline_m)`` (Intel,
  "Tuning depth cameras for best performance", the D400 series' depth RMS error formula), with the D435's 50 mm
  baseline and subpixel 0.08 (the white paper's figure for a well-textured scene), evaluated at the rig's focal
  length: about 1.9 cm at 2 m for 640x480 at 87 degrees HFOV. It is spatially correlated, as the camera's block
  matching makes it: drawn on a grid ``noise_cell_px`` coarser and interpolated;
- invalid pixels: within ``edge_px`` of a depth step larger than ``edge_step_m`` (the matcher's window straddles
  two surfaces; D400 depth shows such bands at object edges) a pixel has no depth with probability
  ``edge_invalid``; on dark surfaces (grey level below ``dark_grey``, where the projector's pattern is not seen)
  with probability ``dark_invalid``. Shiny surfaces are not modelled (the room has none);
- timing: the depth image is of ``offset_s`` earlier than the colour image it comes with (the two sensors of a
  D435 are not exposed together; a few milliseconds, stated in Intel's multi-camera sync notes), so a moving face
  is a little off.

Invalid pixels are NaN (:func:`avcore.depth.as_depth_m`'s convention).
"""
from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import cv2
import numpy as np

from sim.render import Person, StereoSceneRenderer, drawing_order

__all__ = ["DepthErrors", "DepthRenderer"]


@dataclass(frozen=True)
class DepthErrors:
    """The RGB-D camera's errors (module docstring); ``DepthErrors.none()`` gives the ideal depth."""

    subpixel: float = 0.08
    baseline_m: float = 0.050
    noise_cell_px: int = 8
    edge_step_m: float = 0.10
    edge_px: int = 2
    edge_invalid: float = 0.6
    dark_grey: float = 30.0
    dark_invalid: float = 0.5
    offset_s: float = 0.004

    @classmethod
    def none(cls) -> DepthErrors:
        return cls(subpixel=0.0, edge_invalid=0.0, dark_invalid=0.0, offset_s=0.0)

    def rms_m(self, z_m: np.ndarray | float, focal_px: float) -> np.ndarray | float:
        """The RMS depth error at ``z_m`` metres for a camera of ``focal_px``."""
        return np.square(z_m) * self.subpixel / (focal_px * self.baseline_m)


@dataclass(eq=False)
class DepthRenderer:
    """Depth images of ``renderer``'s room in its left camera, with ``errors``, reproducible per (seed, time);
    ``people_at(t)`` gives the people at time ``t`` (:meth:`app.sources.sim.SimSource.people`)."""

    renderer: StereoSceneRenderer
    people_at: Callable[[float], Sequence[Person]]
    errors: DepthErrors = field(default_factory=DepthErrors)
    seed: int = 0
    _room: np.ndarray | None = field(init=False, default=None, repr=False)

    def ideal(self, t: float) -> np.ndarray:
        """(h, w) float32 metres: the exact depth along the optical axis at time ``t``; inf where nothing is."""
        if self._room is None:
            w, h = self.renderer.rig.image_size
            self._room = np.full((h, w), np.inf, np.float32)
            for corners, texture in self.renderer.room_quads():
                self._fill(self._room, corners, texture)
        depth = self._room.copy()
        for _, _, corners, texture in drawing_order(self.people_at(t), t):
            self._fill(depth, corners, texture)
        return depth

    def render(self, t: float, colour: np.ndarray) -> np.ndarray:
        """(h, w) float32 metres, NaN where invalid: the depth that comes with the colour image of time ``t``."""
        e = self.errors
        depth = self.ideal(t - e.offset_s)
        h, w = depth.shape
        rng = np.random.default_rng([self.seed, 7, int(round(t * 1e6)) % (2**32)])
        if e.subpixel > 0:
            cells = rng.standard_normal((h // e.noise_cell_px + 2, w // e.noise_cell_px + 2)).astype(np.float32)
            # bicubic upsampling keeps the cells' unit variance only roughly: rescale to unit RMS
            field_ = cv2.resize(cells, (w, h), interpolation=cv2.INTER_CUBIC)
            field_ /= max(float(np.sqrt(np.mean(field_ ** 2))), 1e-6)
            with np.errstate(invalid="ignore"):
                depth = depth + field_ * self.errors.rms_m(depth, self.renderer.rig.focal_px).astype(np.float32)
        invalid = ~np.isfinite(depth)
        if e.edge_invalid > 0:
            finite = np.where(np.isfinite(depth), depth, 1e3)
            step = np.maximum(np.abs(np.diff(finite, axis=0, prepend=finite[:1])),
                              np.abs(np.diff(finite, axis=1, prepend=finite[:, :1])))
            band = cv2.dilate((step > e.edge_step_m).astype(np.uint8), np.ones((2 * e.edge_px + 1,) * 2, np.uint8))
            invalid |= (band > 0) & (rng.random((h, w)) < e.edge_invalid)
        if e.dark_invalid > 0:
            grey = cv2.cvtColor(colour, cv2.COLOR_BGR2GRAY) if colour.ndim == 3 else colour
            invalid |= (grey < e.dark_grey) & (rng.random((h, w)) < e.dark_invalid)
        depth[invalid] = np.nan
        return depth

    def _fill(self, depth: np.ndarray, corners: np.ndarray, texture: np.ndarray) -> None:
        """Writes the depth of one planar quad where it is drawn (its alpha, for a 4-channel texture)."""
        uv = self.renderer.rig.project(corners)[0]
        h, w = depth.shape
        x0, y0 = np.maximum(np.floor(uv.min(axis=0)).astype(int) - 1, 0)
        x1, y1 = np.minimum(np.ceil(uv.max(axis=0)).astype(int) + 2, (w, h))
        if x1 <= x0 or y1 <= y0:
            return
        if texture.ndim == 3 and texture.shape[2] == 4:
            th, tw = texture.shape[:2]
            src = np.float32([[-0.5, -0.5], [tw - 0.5, -0.5], [tw - 0.5, th - 0.5], [-0.5, th - 0.5]])
            homography = cv2.getPerspectiveTransform(src, uv.astype(np.float32) - np.float32([x0, y0]))
            alpha = cv2.warpPerspective(texture[..., 3], homography, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
                                        borderMode=cv2.BORDER_CONSTANT, borderValue=0)
            mask = alpha >= 128
        else:
            poly = np.zeros((y1 - y0, x1 - x0), np.uint8)
            cv2.fillConvexPoly(poly, np.rint(uv - [x0, y0]).astype(np.int32), 1)
            mask = poly > 0
        if not mask.any():
            return
        # 1/z of a plane is affine in its pixels: fit it through the four projected corners
        design = np.column_stack([uv, np.ones(4)])
        coef = np.linalg.lstsq(design, 1.0 / corners[:, 2], rcond=None)[0]
        uu, vv = np.meshgrid(np.arange(x0, x1), np.arange(y0, y1))
        inv_z = coef[0] * uu + coef[1] * vv + coef[2]
        roi = depth[y0:y1, x0:x1]
        roi[mask] = (1.0 / np.maximum(inv_z, 1e-6))[mask]
