"""What the operator console draws, computed as plain arrays (no rerun here; :mod:`app.console` logs them).

The three panes of the paper's visualisation tool (section 6, "Modular Structure", figure vtool) and the extra
views of the console are drawn from these helpers:

- the left image: a box per face and a solid circle whose darkness codes the speaking probability;
- the bird's-eye view: the x-z plane of the scene frame seen from above, drawn in 2D as ``(x, -z)`` metres so
  that "forward" points up the screen (a 2D view's vertical axis points down);
- the ITD space: the histogram of the interval's ITDs and, for each mapped face, its fitted Gaussian
  ``pi_n N(x; mu_n, sigma_n^2)`` of eq. (prob_model). Both are drawn in the same unit, the *fraction of the
  interval's ITDs per histogram bin* (counts / K for the histogram, ``pi_n N(x) * bin_s`` for a curve), so that a
  curve lies on top of the bars it explains. The horizontal axis is in microseconds.

Conventions (docs/architecture.md): metres, seconds; scene frame x right, y down, z forward; the scene origin midway
between the two rectified camera centres.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from avcore.geometry import MicPair
from avcore.mixture import Mixture1D
from avcore.stereo import StereoRig

__all__ = [
    "PALETTE",
    "ItdPane",
    "birdseye",
    "camera_centres",
    "speaking_bars_px",
    "fov_strips_birdseye",
    "gaussian_curves",
    "head_circles_px",
    "histogram_outline",
    "itd_histogram",
    "outlier_level",
    "pack_rgba",
    "person_colors",
    "range_rings_birdseye",
    "robot_bounds",
    "speaking_rgba",
]

# Ten well-separated colours (RGB), one per person id modulo 10; stable across frames for a given id.
PALETTE = np.array([
    (31, 119, 180), (255, 127, 14), (44, 160, 44), (214, 39, 40), (148, 103, 189),
    (140, 86, 75), (227, 119, 194), (127, 127, 127), (188, 189, 34), (23, 190, 207),
], dtype=np.uint8)


def person_colors(person_ids: np.ndarray) -> np.ndarray:
    """A stable colour per person: person_ids (N,) int  ->  (N, 3) uint8 RGB."""
    ids = np.asarray(person_ids, dtype=np.int64).reshape(-1)
    return PALETTE[np.mod(ids, len(PALETTE))]


def pack_rgba(colors: np.ndarray) -> np.ndarray:
    """Colours (N, 3) RGB or (N, 4) RGBA uint8  ->  (N,) uint32 ``0xRRGGBBAA``, Rerun's packed form (logged as is,
    which spares Rerun a conversion per call). RGB colours are opaque."""
    c = np.asarray(colors, dtype=np.uint8)
    if c.ndim != 2:
        raise ValueError(f"colors must be an (N, 3) or (N, 4) array of uint8, got shape {c.shape}")
    if c.shape[1] == 3:
        c = np.hstack([c, np.full((c.shape[0], 1), 255, np.uint8)])
    if c.shape[1] != 4:
        raise ValueError(f"colors must be an (N, 3) or (N, 4) array of uint8, got shape {np.shape(colors)}")
    c = c.astype(np.uint32)
    return (c[:, 0] << 24) | (c[:, 1] << 16) | (c[:, 2] << 8) | c[:, 3]


def speaking_rgba(probability: np.ndarray) -> np.ndarray:
    """The colour of the paper's speaking circle: the higher the probability, the darker (section 6).

    probability : (N,) in [0, 1]  ->  (N, 4) uint8 RGBA. Grey level ``255 (1 - p)``; the circle is also more
    opaque as p grows (alpha from 30% to 100%) so that a silent face stays visible under a pale disc.
    """
    p = np.clip(np.asarray(probability, dtype=np.float64).reshape(-1), 0.0, 1.0)
    grey = np.round(255.0 * (1.0 - p))
    alpha = np.round(255.0 * (0.3 + 0.7 * p))
    return np.stack([grey, grey, grey, alpha], axis=1).astype(np.uint8)


def speaking_bars_px(boxes: np.ndarray, probability: np.ndarray, gap_px: float = 5.0) -> np.ndarray:
    """The speaking probability as a bar above each face, leaving the face itself uncovered (the mouth is what
    shows who speaks): from the box's top-left corner, ``gap_px`` above it, as long as ``probability`` of the box's
    width (a bar across the whole box is certain speech).

    boxes : (N, 4) float, pixels (x, y, w, h); probability : (N,) in [0, 1]  ->  (N, 2, 2) pixel segments.
    """
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    p = np.clip(np.asarray(probability, dtype=np.float64).reshape(-1), 0.0, 1.0)
    y = b[:, 1] - gap_px
    return np.stack([np.stack([b[:, 0], y], 1), np.stack([b[:, 0] + p * b[:, 2], y], 1)], axis=1)


def id_labels_px(boxes: np.ndarray, gap_px: float = 5.0, lift_px: float = 12.0) -> np.ndarray:
    """Where each person's id is written in the image: above the speaking bar (:func:`speaking_bars_px`), at the
    box's left edge, clear of the face (a label on the box would sit on the chin and mouth).

    boxes : (N, 4) float, pixels (x, y, w, h)  ->  (N, 2) pixels.
    """
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    return np.stack([b[:, 0], b[:, 1] - gap_px - lift_px], axis=1)


def legend_labels(person_ids: np.ndarray, probability: np.ndarray, speaking: np.ndarray, distance_m: np.ndarray,
                  means_s: np.ndarray | None) -> list[str]:
    """One line a person for the console's shared legend: a disc (filled while speaking), id, state, probability,
    distance and, when a model was fitted, the Gaussian's mean ITD. Fields of fixed width (the viewer centres a
    label on its point, so equal lengths line up); rounded so that a line changes only when it should."""
    lines = []
    for n, pid in enumerate(np.asarray(person_ids).reshape(-1).tolist()):
        mark, state = ("\u25cf", "speaking") if speaking[n] else ("\u25cb", "silent  ")
        line = f"{mark} {pid:>3}  {state} {probability[n]:.1f}   {distance_m[n]:4.1f} m"
        line += f"   mu {means_s[n] * 1e6:+5.0f} us" if means_s is not None else " " * 14
        lines.append(line)
    return lines


def head_circles_px(rig: StereoRig, points_xyz: np.ndarray, head_radius_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Heads without a detected box (motion-guided output) drawn on the rectified left image.

    points_xyz : (N, 3) metres with z > 0  ->  centres (N, 2) pixels, radii (N,) pixels (``f r / z``).
    """
    pts = np.asarray(points_xyz, dtype=np.float64).reshape(-1, 3)
    if pts.shape[0] == 0:
        return np.zeros((0, 2)), np.zeros(0)
    centres, _ = rig.project(pts)
    return centres, rig.focal_px * head_radius_m / pts[:, 2]


def birdseye(points_xyz: np.ndarray) -> np.ndarray:
    """Scene points seen from above: (..., 3) metres  ->  (..., 2) metres ``(x, -z)`` (forward points up)."""
    pts = np.asarray(points_xyz, dtype=np.float64)
    return np.stack([pts[..., 0], -pts[..., 2]], axis=-1)


def voice_rays(azimuths_rad: np.ndarray, length_m: float) -> np.ndarray:
    """Rays from the robot (the origin) along horizontal directions: azimuths (n,) from straight ahead, positive
    to the right  ->  (n, 2, 3) metres, start and end."""
    az = np.asarray(azimuths_rad, dtype=np.float64).reshape(-1)
    ends = length_m * np.stack([np.sin(az), np.zeros(az.size), np.cos(az)], axis=1)
    return np.stack([np.zeros_like(ends), ends], axis=1)


def camera_centres(rig: StereoRig) -> np.ndarray:
    """The two rectified camera centres in the scene frame: (2, 3) metres, left then right."""
    half = 0.5 * rig.baseline_m
    return np.array([[-half, 0.0, 0.0], [half, 0.0, 0.0]])


def fov_strips_birdseye(rig: StereoRig, depth_m: float) -> np.ndarray:
    """The horizontal field of view of each rectified camera as a bird's-eye polyline.

    For each camera: [the left image edge's ray at depth ``depth_m``, the camera centre, the right image edge's ray
    at the same depth]. The edges are those of the rectified pixels (u = -0.5 and u = w - 0.5).
    Returns (2, 3, 2) metres in bird's-eye coordinates, left camera first.
    """
    w = rig.image_size[0]
    out = np.empty((2, 3, 2))
    for i, (centre, proj) in enumerate(zip(camera_centres(rig), (rig.proj_left, rig.proj_right), strict=True)):
        fx, cx = proj[0, 0], proj[0, 2]
        edges = []
        for u in (-0.5, w - 0.5):
            edges.append(centre + depth_m * np.array([(u - cx) / fx, 0.0, 1.0]))
        out[i] = birdseye(np.array([edges[0], centre, edges[1]]))
    return out


def range_rings_birdseye(radii_m: np.ndarray, n_points: int = 61) -> np.ndarray:
    """Half circles in front of the robot at the given ranges, to read distances in the bird's-eye view.

    radii_m : (R,) metres  ->  (R, n_points, 2) bird's-eye metres, from the robot's left (-x) to its right (+x).
    """
    r = np.asarray(radii_m, dtype=np.float64).reshape(-1, 1)
    angle = np.linspace(np.pi, 0.0, n_points)  # angle from +x, counter-clockwise on the ground plane
    x = r * np.cos(angle)
    z = r * np.sin(angle)
    return np.stack([x, -z], axis=-1)


def robot_bounds(mics: MicPair, rig: StereoRig, margin_m: float = 0.04) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box around the sensors (both microphones, both cameras), the robot's head as drawn.

    Returns (lo, hi), each (3,) metres in the scene frame: the sensors' bounding box grown by ``margin_m``.
    """
    pts = np.vstack([np.asarray(mics.left), np.asarray(mics.right), camera_centres(rig)])
    return pts.min(axis=0) - margin_m, pts.max(axis=0) + margin_m


@dataclass(frozen=True)
class ItdPane:
    """The layout of the ITD-space pane.

    range_s : (lo, hi) seconds, the ITDs shown on the horizontal axis (ITDs outside are counted, not drawn).
    bin_s : seconds, the histogram's bin width.
    height_per_fraction : display units (microseconds) that a bin holding every ITD of the interval (fraction 1)
        rises above the axis; the vertical axis points down in a 2D view, so heights are drawn negative.
    """

    range_s: tuple[float, float]
    bin_s: float
    height_per_fraction: float

    def __post_init__(self) -> None:
        lo, hi = (float(v) for v in self.range_s)
        if not (np.isfinite(lo) and np.isfinite(hi) and hi > lo):
            raise ValueError(f"range_s must be (lo, hi) seconds with lo < hi, got {self.range_s!r}")
        if not (np.isfinite(self.bin_s) and 0 < self.bin_s <= hi - lo):
            raise ValueError(f"bin_s must be a positive width in seconds no wider than the range, got {self.bin_s!r}")
        if not (np.isfinite(self.height_per_fraction) and self.height_per_fraction > 0):
            raise ValueError(f"height_per_fraction must be positive, got {self.height_per_fraction!r}")
        object.__setattr__(self, "range_s", (lo, hi))

    @classmethod
    def for_mics(cls, mics: MicPair, *, bin_s: float = 10e-6, widen: float = 0.25, top: float = 0.2,
                 aspect: float = 2.0) -> ItdPane:
        """The reachable ITD interval of ``mics`` widened by ``widen`` of its length on each side (a head and the
        extractor's wider lag search give ITDs beyond the free-field interval), and a vertical scale on which a bin
        holding ``top`` of the interval's ITDs rises to the top of a pane ``aspect`` times as wide as high: a
        speaker's Gaussian (sigma ~ 32 us) peaks near 0.12 per 10 us bin, so it fills most of the pane's height, as
        in the paper's figure 5."""
        lo, hi = mics.itd_interval()
        pad = widen * (hi - lo)
        width_us = (hi - lo + 2 * pad) * 1e6
        return cls((lo - pad, hi + pad), bin_s, width_us / (aspect * top))

    @property
    def edges_s(self) -> np.ndarray:
        """(B + 1,) seconds: bins of width ``bin_s`` centred on the range, covering it."""
        lo, hi = self.range_s
        n_bins = int(np.ceil((hi - lo) / self.bin_s - 1e-9))
        mid = 0.5 * (lo + hi)
        return mid + self.bin_s * (np.arange(n_bins + 1) - 0.5 * n_bins)

    def xy(self, x_s: np.ndarray, fraction: np.ndarray) -> np.ndarray:
        """ITDs (P,) seconds and fractions (P,)  ->  (P, 2) pane coordinates: microseconds, negative height."""
        x = np.asarray(x_s, dtype=np.float64).reshape(-1)
        f = np.asarray(fraction, dtype=np.float64).reshape(-1)
        return np.stack([x * 1e6, -f * self.height_per_fraction], axis=1)


def itd_histogram(itds_s: np.ndarray, edges_s: np.ndarray) -> tuple[np.ndarray, int]:
    """The interval's ITDs binned: itds_s (K,) seconds, edges_s (B + 1,) seconds  ->  counts (B,) int and the
    number of ITDs outside the edges (not drawn, reported). NaN ITDs count as outside."""
    x = np.asarray(itds_s, dtype=np.float64).reshape(-1)
    edges = np.asarray(edges_s, dtype=np.float64)
    inside = np.isfinite(x) & (x >= edges[0]) & (x <= edges[-1])
    counts, _ = np.histogram(x[inside], bins=edges)
    return counts.astype(np.int64), int(x.size - np.count_nonzero(inside))


def histogram_outline(edges: np.ndarray, heights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The histogram as one step polyline along the bars' tops, from the axis back to the axis.

    edges (B + 1,), heights (B,)  ->  xs (2B + 2,), ys (2B + 2,) in the units of the inputs.
    """
    e = np.asarray(edges, dtype=np.float64)
    h = np.asarray(heights, dtype=np.float64)
    xs = np.repeat(e, 2)
    ys = np.concatenate([[0.0], np.repeat(h, 2), [0.0]])
    return xs, ys


def gaussian_curves(model: Mixture1D, bin_s: float, *, n_points: int = 64, n_sigma: float = 4.0,
                    clip_s: tuple[float, float] | None = None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each Gaussian of the fitted model as the fraction of the interval's ITDs it predicts per bin.

    For component n: x over ``mu_n +- n_sigma sigma_n`` (clipped to ``clip_s``), y = ``pi_n N(x; mu_n, sigma_n^2)
    * bin_s`` (eq. prob_model), through :meth:`Mixture1D.component_densities`. Returns N pairs (x (P,) seconds,
    y (P,) fraction per bin), in the model's component order.
    """
    curves = []
    sigma = np.sqrt(model.variances)
    for n in range(model.n_components):
        lo, hi = model.means[n] - n_sigma * sigma[n], model.means[n] + n_sigma * sigma[n]
        if clip_s is not None:
            lo, hi = max(lo, clip_s[0]), min(hi, clip_s[1])
        if hi <= lo:  # the component lies entirely outside the shown range
            curves.append((np.zeros(0), np.zeros(0)))
            continue
        x = np.linspace(lo, hi, n_points)
        y = model.component_densities(x)[:, n] * bin_s
        curves.append((x, y))
    return curves


def outlier_level(model: Mixture1D, bin_s: float) -> float:
    """The uniform (outlier) class of eq. (prob_model) as a fraction of ITDs per bin: ``pi_{N+1} bin_s / |A|``."""
    return float(model.weights[-1] * bin_s / (model.support[1] - model.support[0]))
