"""Where a rendered person is for a motion-guided method: the centre of the visible moving body (issue 18).

Algorithm 1 (motion-guided, :class:`avcore.inference.MotionGuidedHearing`) locates a person from the HM3D points of
an interval, which lie on whatever part of the person moves and can be seen: with a body, the head that nods, the
shoulders, the arms and the hands that gesture. Its default reports the centre of those points. Scored against the
face, a near person whose hands gesture in front of the chest is found more than tau_loc = 0.35 m from the truth; so
the motion-guided scoring of the rendered scenarios takes, as :mod:`sim.bodies` and :mod:`sim.skeletons` do for their
point clouds, **the centre of the visible moving body**:

* the instants: ``times_s``, the frames of the interval (:func:`interval_times`: 5 instants over its 0.4 s);
* the moving parts: a person's parts (:meth:`sim.render.Person.parts`: the head, the torso, the arms, the hands,
  the legs; the flat body of a person without one) whose corners are not in the same place at every instant;
* the visible surface: a grid of points on each moving part, kept where it projects inside the left image and is not
  covered by anything drawn after it (another person, the same person's arm, a table), as the renderer draws;
* the centre: the mean of these points over the instants, each point weighted by the area of its part it stands for.

A person none of whose visible parts moves (a listener of a flat scene) or who is not seen at all is at the mean of
their face centres over the instants: there is nothing for a motion-guided method to find, and the face is the
truth of the face-guided scoring. The texture does not weigh (a plain part counts as much as a checked one): the
truth does not follow what the detector happens to like. Without bodies only the head nods, so the truth is the
head's centre, within a few millimetres of the face.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from avcore.stereo import StereoRig
from sim.render import Person, drawing_order

__all__ = ["interval_times", "visible_moving_centres"]

GRID = 6  # points per side of each part
MOVED_M = 1e-4  # a part moves when a corner moves more than this during the interval


def interval_times(stamp_s: float, interval_s: float, n: int = 5) -> np.ndarray:
    """(n,) instants spread over the interval of ``interval_s`` centred on ``stamp_s`` (a motion-guided result)."""
    return stamp_s + interval_s * (np.arange(n) + 0.5 - n / 2) / n


def _grid(corners: np.ndarray) -> tuple[np.ndarray, float]:
    """GRID x GRID points at the cell centres of a parallelogram (TL, TR, BR, BL), and the area of one cell."""
    u = (np.arange(GRID) + 0.5) / GRID
    a, b = corners[1] - corners[0], corners[3] - corners[0]
    pts = corners[0] + u[:, None, None] * a + u[None, :, None] * b
    return pts.reshape(-1, 3), float(np.linalg.norm(np.cross(a, b))) / GRID**2


def _inside(uv: np.ndarray, polygons: np.ndarray) -> np.ndarray:
    """(n,) bool: each point (n, 2) inside any of the convex quadrilaterals (q, 4, 2)."""
    if not len(polygons):
        return np.zeros(len(uv), dtype=bool)
    edges = np.roll(polygons, -1, axis=1) - polygons  # (q, 4, 2)
    rel = uv[:, None, None, :] - polygons[None]  # (n, q, 4, 2)
    cross = edges[None, ..., 0] * rel[..., 1] - edges[None, ..., 1] * rel[..., 0]
    return np.any(np.all(cross >= 0, axis=2) | np.all(cross <= 0, axis=2), axis=1)


def _surface(rig: StereoRig, people: Sequence[Person], t: float) -> list[tuple[int, str, int, np.ndarray, np.ndarray]]:
    """The visible grid points of every person's parts at ``t``: [(person, part name, k-th part of that person,
    points (m, 3), weights (m,)), ...]."""
    order = drawing_order(people, t)
    w, h = rig.image_size
    projected = np.array([rig.project(corners)[0] for _, _, corners, _ in order]).reshape(-1, 4, 2)
    count: dict[int, int] = {}
    out = []
    for rank, (i, name, corners, _) in enumerate(order):
        if name == "prop":
            continue
        k = count[i] = count.get(i, -1) + 1
        pts, cell = _grid(corners)
        uv = rig.project(pts)[0]
        keep = (pts[:, 2] > 0.05) & (uv[:, 0] >= -0.5) & (uv[:, 0] <= w - 0.5) & (uv[:, 1] >= -0.5) \
            & (uv[:, 1] <= h - 0.5)
        keep &= ~_inside(uv, projected[rank + 1:])
        out.append((i, name, k, pts[keep], np.full(int(keep.sum()), cell)))
    return out


def visible_moving_centres(rig: StereoRig, people_at: Sequence[Sequence[Person]],
                           times_s: Sequence[float]) -> np.ndarray:
    """(N, 3) metres: each person's centre of the visible moving body over the instants (see the module docstring).

    people_at : the people at each of ``times_s`` (the same N people in the same order, e.g.
    ``[source.people(t) for t in times_s]``; a :class:`sim.render.StereoSceneRenderer`'s fixed people repeated).
    """
    if len(people_at) != len(times_s) or not len(times_s):
        raise ValueError(f"need the people at each instant: {len(people_at)} lists for {len(times_s)} instants")
    n = len(people_at[0])
    surfaces = [_surface(rig, people, float(t)) for people, t in zip(people_at, times_s)]
    corners = [[[c for _, c, _ in p.parts(float(t))] for p in people] for people, t in zip(people_at, times_s)]
    out = np.zeros((n, 3))
    for i in range(n):
        moving = {k for k in range(len(corners[0][i]))
                  if max(np.abs(c[i][k] - corners[0][i][k]).max() for c in corners) > MOVED_M}
        out[i] = _centre([(k, pts, wts) for surf in surfaces for j, _, k, pts, wts in surf if j == i], moving,
                         np.mean([people[i].face_centre(float(t)) for people, t in zip(people_at, times_s)], axis=0))
    return out


def _centre(parts: list[tuple[int, np.ndarray, np.ndarray]], moving: set[int], fallback: np.ndarray) -> np.ndarray:
    """The weighted mean of the moving parts' visible points, or ``fallback`` when none is visible."""
    chosen = [p for p in parts if p[0] in moving]
    wts = np.concatenate([w for _, _, w in chosen]) if chosen else np.zeros(0)
    if wts.sum() <= 0:
        return fallback
    pts = np.concatenate([p for _, p, _ in chosen])
    return (pts * wts[:, None]).sum(axis=0) / wts.sum()
