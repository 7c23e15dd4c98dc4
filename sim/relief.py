"""A head's relief, so that a head turned about the vertical shows what a turned head shows.

A photograph turned as a plane stays a whole frontal face, narrowed: both eyes, both cheeks, the nose inside the
outline. A head turned by 60 degrees shows its near cheek widened, its far cheek behind the nose, and the nose at
the outline. The head here is an ellipsoid flattened in front, with a nose and eye sockets, laid under the face
texture (its depth per texture pixel, :func:`relief`), and seen turned from far away (orthographically: a head is
small beside its distance) row by row, the nearest surface winning (:func:`turned_view`).

Proportions (fractions of the labelled face box's width, an adult's face box about 16 cm): the head 0.56 wide on
each side of the face's middle (the hair and ears beside the face), its centre 0.6 behind the face (an adult head
is about 19.5 cm from front to back), 0.72 high on each side of a centre 0.22 above the box's; the nose 0.15 in
front of the cheeks at its tip (about 2.5 cm), rising from the eyes' height (0.12 above the box's middle) to its tip
0.12 below, and its base 0.2 below; eye sockets 0.04 deep. What lies outside the head's outline in the texture (the
photograph's background) is a plane through the head's centre. Depth is 0 on the plane of the face box, through
the point the head turns about (:class:`sim.render.Person`), and positive away from the cameras.
"""
from __future__ import annotations

from functools import lru_cache
from typing import TYPE_CHECKING

import cv2
import numpy as np

if TYPE_CHECKING:
    from sim.face_textures import FaceTexture

__all__ = ["relief", "turned_view", "turned_span"]

HALF_WIDTH, HALF_HEIGHT, CENTRE_DEPTH, CENTRE_UP = 0.5, 0.72, 0.6, 0.22
FLATNESS = 3.0  # the front's power: 2 is an ellipsoid, more is flatter across the face
NOSE_TIP, EYES_Y, TIP_Y, BASE_Y = 0.15, -0.12, 0.12, 0.2
SOCKET_DEPTH, SOCKET_X, SOCKET_SIZE = 0.04, 0.2, 0.08
SUPERSAMPLE = 8  # samples a texture pixel along a row: a surface seen eight times wider still leaves no gap


def _depth(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Depth (face-box widths, away from the cameras) at face-plane positions x right, y down (face-box widths from
    the box's centre)."""
    r2 = (x / HALF_WIDTH) ** 2 + ((y + CENTRE_UP) / HALF_HEIGHT) ** 2
    inside = r2 < 1.0
    r = np.sqrt(np.minimum(r2, 1.0))
    z = CENTRE_DEPTH * (1.0 - (1.0 - r ** FLATNESS) ** (1.0 / FLATNESS))
    rise = np.clip((y - EYES_Y) / (TIP_Y - EYES_Y), 0.0, 1.0)
    fall = np.clip((BASE_Y - y) / (BASE_Y - TIP_Y), 0.0, 1.0)
    height = NOSE_TIP * np.where(y <= TIP_Y, 0.3 + 0.7 * rise, fall) * (y >= EYES_Y - 0.05)
    width = 0.05 + 0.05 * rise
    z = z - height * np.exp(-(x / width) ** 2)
    for side in (-1.0, 1.0):
        z = z + SOCKET_DEPTH * np.exp(-((x - side * SOCKET_X) ** 2 + (y - EYES_Y) ** 2) / SOCKET_SIZE ** 2)
    return np.where(inside, z, CENTRE_DEPTH)


def _columns(face: FaceTexture, supersample: int) -> tuple[np.ndarray, np.ndarray]:
    """The samples along a row: their texture column u and their place x across the face (face-box widths)."""
    bx, _, bw, _ = face.face_box
    u = (np.arange(face.image.shape[1] * supersample) + 0.5) / supersample - 0.5
    return u, (u - (bx + bw / 2.0)) / bw


def relief(face: FaceTexture, supersample: int = 1) -> np.ndarray:
    """(h, w * supersample) float: the depth under each texture pixel (``supersample`` samples a pixel along
    rows), in face-box widths, 0 on the face box's plane, positive away from the cameras."""
    _, by, bw, bh = face.face_box
    y = (np.arange(face.image.shape[0]) - (by + bh / 2.0)) / bw
    return _depth(_columns(face, supersample)[1][None, :], y[:, None])


@lru_cache(maxsize=512)
def _turn_map(face: FaceTexture, yaw_key: int) -> tuple[np.ndarray, np.ndarray]:
    """For each pixel of the turned view, the texture column seen there (NaN where no part of the head is) and the
    turned face box's span; ``yaw_key`` is the turn in tenths of a degree."""
    yaw = np.radians(yaw_key / 10.0)
    c, s = np.cos(yaw), np.sin(yaw)
    h, w = face.image.shape[:2]
    bx, _, bw, _ = face.face_box
    fx = bx + bw / 2.0
    z = relief(face, SUPERSAMPLE)
    u, x = _columns(face, SUPERSAMPLE)
    seen_x = fx + (c * x[None, :] + s * z) * bw
    seen_z = -s * x[None, :] + c * z
    col = np.rint(seen_x).astype(np.int64)
    rows = np.broadcast_to(np.arange(h)[:, None], col.shape)
    ok = (col >= 0) & (col < w)
    key = (rows * w + col)[ok]
    order = np.lexsort((seen_z[ok], key))  # by pixel, nearest first
    first = np.ones(order.size, dtype=bool)
    first[1:] = key[order][1:] != key[order][:-1]
    winners = order[first]
    source = np.full(h * w, np.nan)
    source[key[winners]] = np.broadcast_to(u, col.shape)[ok][winners]
    source = source.reshape(h, w)
    for row in source:  # a surface stretched past the supersampling: fill inside the row's outline
        hit = np.flatnonzero(np.isfinite(row))
        if hit.size and hit[-1] - hit[0] + 1 > hit.size:
            gap = np.arange(hit[0], hit[-1] + 1)
            row[gap] = np.interp(gap, hit, row[hit])
    box = (np.abs(x) <= 0.5)[None, :] & (np.abs((np.arange(h) - face.face_box[1] - face.face_box[3] / 2.0)
                                                 / face.face_box[3]) <= 0.5)[:, None] & (z < CENTRE_DEPTH)
    span = np.array([seen_x[box].min(), seen_x[box].max()])
    return source, span


def _key(yaw_rad: float) -> int:
    return int(round(np.degrees(float(yaw_rad)) * 10.0))


def turned_view(face: FaceTexture, image: np.ndarray, yaw_rad: float) -> np.ndarray:
    """(h, w, 4) uint8 BGRA: ``image`` (the face's texture, its mouth and hand drawn) on the head turned by
    ``yaw_rad`` (a positive turn brings the texture's right edge nearer), seen from the front, in the texture's own
    pixel frame; alpha 0 where no part of the head is. The turn is rounded to 0.1 degree (its maps are kept)."""
    source, _ = _turn_map(face, _key(yaw_rad))
    h, w = source.shape
    seen = np.isfinite(source)
    map_x = np.where(seen, source, -10.0).astype(np.float32)
    map_y = np.broadcast_to(np.arange(h, dtype=np.float32)[:, None], (h, w)).copy()
    out = cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return np.dstack([out, np.where(seen, 255, 0).astype(np.uint8)])


def turned_span(face: FaceTexture, yaw_rad: float) -> tuple[float, float]:
    """Where the labelled face box lies across the turned view: its leftmost and rightmost texture columns."""
    lo, hi = _turn_map(face, _key(yaw_rad))[1]
    return float(lo), float(hi)
