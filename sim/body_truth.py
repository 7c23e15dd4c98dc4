"""Where a rendered person is for a motion-guided method: the centre of the visible moving body.

Algorithm 1 (motion-guided, :class:`avcore.inference.MotionGuidedHearing`) locates a person from the HM3D points of
an interval, which lie on whatever part of the person moves and can be seen: with a body, the head that nods, the
shoulders, the arms and the hands that gesture. Its default reports the centre of those points. Scored against the
face, a near person whose hands gesture in front of the chest is found more than tau_loc = 0.35 m from the truth; so
the motion-guided scoring of the rendered scenarios takes, as :mod:`sim.bodies` and :mod:`sim.skeletons` do for their
point clouds, **the centre of the visible moving body**:

* the instants: ``times_s``, the frames of the interval (:func:`interval_times`: 5 instants over its 0.4 s);
* the surface: a grid of points on each of a person's parts (:meth:`sim.render.Person.parts`: the head, the torso,
  the arms, the hands, the legs; the flat body of a person without one), each point at the same place on its part
  at every instant;
* moving: how far the point's image in the left camera moves during the interval, counted up to a pixel: a point
  that moves a pixel or more counts fully, one that moves less in proportion, one that does not move not at all (a
  torso that rocks at the shoulders moves at the top, not at the hips; a nodding head's points move a fraction of
  a pixel to a pixel);
* visible, at an instant: the point projects inside the left image and is not covered by anything drawn after its
  part (another person, the same person's arm, a table), as the renderer draws;
* the centre: the mean of the points over the instants at which they are visible, each weighted by how much it
  moves and by the area of its part it stands for.

A person none of whose visible points moves (a listener of a flat scene) or who is not seen at all is at the mean of
their face centres over the instants: there is nothing for a motion-guided method to find, and the face is the
truth of the face-guided scoring. The texture does not weigh (a plain part counts as much as a checked one): the
truth does not follow what the detector happens to like. Without bodies only the head nods, so the truth is the
head's centre, within a few centimetres of the face.
"""
from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from avcore.stereo import StereoRig
from sim.render import Person, distance_to_quad, drawing_order

__all__ = ["LABEL_M", "interval_times", "labelled_point_means", "visible_moving_centres"]

GRID = 6  # points per side of each part
MOVED_PX = 1.0  # a point whose image moves this much during the interval counts fully; one that moves less, less
LABEL_M = 0.25  # an HM3D point this close to a person's surface at some instant of its interval is that person's


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


def _surface(rig: StereoRig, people: Sequence[Person], t: float) -> dict[tuple[int, int], tuple]:
    """Every person's parts at ``t`` as grid points: {(person, k-th part of that person): (points (G, 3), left
    pixels (G, 2), visible (G,) bool, cell area)}, visible where inside the left image and not covered by anything
    drawn after the part."""
    order = drawing_order(people, t)
    w, h = rig.image_size
    projected = np.array([rig.project(corners)[0] for _, _, corners, _ in order]).reshape(-1, 4, 2)
    count: dict[int, int] = {}
    out = {}
    for rank, (i, name, corners, _) in enumerate(order):
        if name == "prop":
            continue
        k = count[i] = count.get(i, -1) + 1
        pts, cell = _grid(corners)
        uv = rig.project(pts)[0]
        seen = (pts[:, 2] > 0.05) & (uv[:, 0] >= -0.5) & (uv[:, 0] <= w - 0.5) & (uv[:, 1] >= -0.5) \
            & (uv[:, 1] <= h - 0.5)
        seen &= ~_inside(uv, projected[rank + 1:])
        out[(i, k)] = (pts, uv, seen, cell)
    return out


def visible_moving_centres(rig: StereoRig, people_at: Sequence[Sequence[Person]],
                           times_s: Sequence[float]) -> np.ndarray:
    """(N, 3) metres: each person's centre of the visible moving body over the instants (see the module docstring).

    people_at : the people at each of ``times_s`` (the same N people in the same order, e.g.
    ``[source.people(t) for t in times_s]``; a :class:`sim.render.StereoSceneRenderer`'s fixed people repeated).
    """
    if len(people_at) != len(times_s) or not len(times_s):
        raise ValueError(f"need the people at each instant: {len(people_at)} lists for {len(times_s)} instants")
    surfaces = [_surface(rig, people, float(t)) for people, t in zip(people_at, times_s)]
    total, weight = np.zeros((len(people_at[0]), 3)), np.zeros(len(people_at[0]))
    for (i, k) in surfaces[0]:
        uv = np.stack([s[(i, k)][1] for s in surfaces])  # (T, G, 2)
        moves = np.minimum(np.linalg.norm(uv - uv[0], axis=2).max(axis=0) / MOVED_PX, 1.0)  # (G,) in [0, 1]
        for s in surfaces:
            pts, _, seen, cell = s[(i, k)]
            wts = cell * moves * seen
            total[i] += wts @ pts
            weight[i] += wts.sum()
    faces = np.mean([[p.face_centre(float(t)) for p in people] for people, t in zip(people_at, times_s)], axis=0)
    found = weight > 0
    faces[found] = total[found] / weight[found, None]
    return faces.reshape(-1, 3)


def labelled_point_means(points: np.ndarray, people_at: Sequence[Sequence[Person]],
                         times_s: Sequence[float]) -> np.ndarray:
    """(N, 3) metres: the paper's truth for Algorithm 1 (section 7.1, D_ij = ||mu_i - hat mu_j||), each person's
    mean of its ground-truth points, NaN for a person none of the points belongs to.

    points : (M, 3) the HM3D points of one interval, where the method saw them. A point belongs to the person whose
    surface (any part: head, torso, arms, hands) comes nearest to it at some instant of ``times_s``, if that is
    within :data:`LABEL_M` (stereo places a point a few centimetres off at 2-3 m, and a hand moves during the
    interval); farther from everybody it is an outlier of the room and no one's. The generators label their points
    as they draw them; rendered frames have no labels, so the surfaces give them. Unlike
    :func:`visible_moving_centres` this follows the points the detector found: a person seen only by a textured
    collar is at the collar, as the paper's truth would have it.
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    n = len(people_at[0]) if len(people_at) else 0
    if len(people_at) != len(times_s) or not len(times_s):
        raise ValueError(f"need the people at each instant: {len(people_at)} lists for {len(times_s)} instants")
    near = np.full((pts.shape[0], n), np.inf)
    for people, t in zip(people_at, times_s):
        for i, person in enumerate(people):
            for _, corners, _ in person.parts(float(t)):
                near[:, i] = np.minimum(near[:, i], distance_to_quad(pts, corners))
    out = np.full((n, 3), np.nan)
    if not pts.shape[0] or not n:
        return out
    owner = np.argmin(near, axis=1)
    owned = near[np.arange(pts.shape[0]), owner] <= LABEL_M
    for i in range(n):
        mine = owned & (owner == i)
        if mine.any():
            out[i] = pts[mine].mean(axis=0)
    return out
