"""A stereo scene renderer: a textured room and people carrying real face crops, seen by a rectified rig.

It produces the visual input of the paper's pipeline (section 5.2: F3D faces, HM3D moving points) with ground truth:
the 3D centre of every face at every instant, and the surfaces of the people, so that F3D and HM3D can be scored.

Everything is a textured planar quad (walls, floor, bodies, heads, arms, tables) drawn by a homography per camera, far
to near (painter's algorithm), with sensor noise; a texture with a fourth channel is drawn where its alpha is set
(rounded shoulders, fingers). People with bodies are :mod:`sim.person_body`'s, their faces :mod:`sim.face_textures`'
(crops of real photographs, or drawn faces on a clean machine).

Scene frame (docs/architecture.md): the cyclopean frame of the rig, metres, x right, y down, z forward. The cameras are
at y = 0; the floor is ``VisualRoom.floor_y`` below them.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from avcore.stereo import StereoRig
from sim.face_textures import (
    UNFOUND_FACES,
    FaceTexture,
    drawn_face_texture,
    hand_over_mouth,
    load_face_textures,
    skin_of,
)
from sim.person_body import BodyPose, body_quads, body_texture, table_quads
from sim.relief import turned_span, turned_view

__all__ = [
    "Person",
    "VisualRoom",
    "RenderedFrame",
    "StereoSceneRenderer",
    "distance_to_quad",
    "default_scene",
    "drawing_order",
]


@dataclass(frozen=True, eq=False)
class Person:
    """A person: a head plane carrying a face texture above a body, optionally swaying and nodding.

    position : (3,) float, metres: the face centre at rest, scene frame.
    face_width_m : physical width of the labelled face box (an adult face is about 0.15-0.17 m).
    sway_m, sway_hz : amplitude (metres) and frequency of a side-to-side sway of the whole person along x.
    nod_rad, nod_hz : amplitude (radians) and frequency of a head nod about the horizontal axis of the face centre.
    phase : radians, added to every oscillation. shirt_bgr : colour of the shirt.
    arms : a body (:mod:`sim.person_body`): a checked shirt on a torso with rounded shoulders, upper arms,
    forearms and hands, and legs unless a table hides them; without it the body is one flat striped plane.
    gesture_m, gesture_hz : how far (metres) and how fast the hands swing (a talker about 0.15 m, a listener a
    little); the shoulders rock with them. table : a table in front of a seated person hides the lower body (drawn by
    :meth:`props`). mouth_open : in [0, 1], how far the mouth is open (:meth:`FaceTexture.with_mouth`).
    hand_over_mouth : a hand covers the mouth (:func:`hand_over_mouth`). yaw_rad : the head turned about the
    vertical axis through the face's centre (a positive turn takes the face's right edge, image right, closer),
    drawn with the head's relief (:mod:`sim.relief`: the far cheek goes behind the nose).
    """

    face: FaceTexture
    position: tuple[float, float, float]
    face_width_m: float = 0.16
    sway_m: float = 0.0
    sway_hz: float = 0.4
    nod_rad: float = 0.0
    nod_hz: float = 1.1
    phase: float = 0.0
    shirt_bgr: tuple[int, int, int] = (140, 70, 40)
    arms: bool = False
    gesture_m: float = 0.0
    gesture_hz: float = 0.8
    table: bool = False
    mouth_open: float = 0.0
    hand_over_mouth: bool = False
    yaw_rad: float = 0.0

    def __post_init__(self) -> None:
        pos = np.asarray(self.position, dtype=np.float64)
        if pos.shape != (3,) or not np.all(np.isfinite(pos)) or pos[2] <= 0.3:
            raise ValueError(f"position must be three finite metres with z > 0.3 (in front of the rig), "
                             f"got {self.position!r}")
        object.__setattr__(self, "position", tuple(float(v) for v in pos))
        if not self.face_width_m > 0:
            raise ValueError(f"face_width_m must be positive metres, got {self.face_width_m!r}")

    def face_centre(self, t: float) -> np.ndarray:
        """(3,) metres: the centre of the labelled face box at time ``t`` seconds."""
        dx = self.sway_m * np.sin(2 * np.pi * self.sway_hz * t + self.phase)
        return np.asarray(self.position) + np.array([dx, 0.0, 0.0])

    def face_span(self) -> tuple[float, float]:
        """Where the labelled face lies across the head, in texture pixels from the face box's middle, the head
        turned by ``yaw_rad`` (:func:`sim.relief.turned_span`): (-w/2, w/2) facing the cameras."""
        bx, _, bw, _ = self.face.face_box
        if not self.yaw_rad:
            return -bw / 2.0, bw / 2.0
        lo, hi = turned_span(self.face, self.yaw_rad)
        return lo - (bx + bw / 2.0), hi - (bx + bw / 2.0)

    def quads(self, t: float) -> list[tuple[np.ndarray, np.ndarray]]:
        """The person's planes at time ``t``: [(corners (4, 3) metres TL, TR, BR, BL, texture), ...], body first."""
        return [(corners, tex) for _, corners, tex in self.parts(t)]

    def parts(self, t: float) -> list[tuple[str, np.ndarray, np.ndarray]]:
        """The person's planes at time ``t`` with their names: [(name, corners, texture), ...], body first. A texture
        of four channels carries a binary alpha."""
        tex = self.face.with_mouth(self.mouth_open)
        if self.hand_over_mouth:
            tex = hand_over_mouth(self.face, tex)
        if self.yaw_rad:
            tex = turned_view(self.face, tex, self.yaw_rad)  # the turn drawn on a head facing the cameras
        bx, by, bw, bh = self.face.face_box
        m_per_px = self.face_width_m / bw
        centre = self.face_centre(t)
        angle = self.nod_rad * np.sin(2 * np.pi * self.nod_hz * t + self.phase)
        right = np.array([1.0, 0.0, 0.0])
        down = np.array([0.0, np.cos(angle), np.sin(angle)])
        # texture pixel (px, py) sits at centre + right * (px - fx) * m + down * (py - fy) * m
        fx, fy = bx + bw / 2.0, by + bh / 2.0
        h, w = tex.shape[:2]
        tex_corners = np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
        head = centre + np.outer((tex_corners[:, 0] - fx) * m_per_px, right) \
            + np.outer((tex_corners[:, 1] - fy) * m_per_px, down)
        # the body hangs from the chin, a little behind the face (shoulders are behind the face)
        top = centre[1] + (h - 0.5 - fy) * m_per_px * 0.9
        if not self.arms:
            z, half = centre[2] + 0.06, 0.23
            body = np.array([[centre[0] - half, top, z], [centre[0] + half, top, z],
                             [centre[0] + half, top + 0.7, z], [centre[0] - half, top + 0.7, z]])
            return [("body", body, self._flat_shirt()), ("head", head, tex)]
        pose = BodyPose(centre, top, self.gesture_m, 2 * np.pi * self.gesture_hz * t + self.phase)
        body_parts = body_quads(pose, legs=not self.table)
        return [(kind, corners, self._texture(kind)) for kind, corners in body_parts[:1]] + [("head", head, tex)] \
            + [(kind, corners, self._texture(kind)) for kind, corners in body_parts[1:]]

    def props(self, t: float) -> list[tuple[np.ndarray, np.ndarray]]:
        """What stands with the person but is not them: a table (``table``), its top and front, that hides the lower
        body."""
        if not self.table:
            return []
        return [(corners, body_texture(kind, (0, 0, 0), (0.0, 0.0, 0.0), 0))  # every table alike
                for kind, corners in table_quads(np.asarray(self.position))]

    def skin_bgr(self) -> tuple[float, float, float]:
        """The hands' skin: the face's (:func:`skin_of`)."""
        return skin_of(self.face)

    def _texture(self, kind: str) -> np.ndarray:
        """A body or table texture of :func:`sim.person_body.body_texture` (made once for all people alike)."""
        return body_texture(kind, tuple(self.shirt_bgr), self.skin_bgr(), abs(hash(tuple(self.shirt_bgr))) % (2**32))

    def _flat_shirt(self) -> np.ndarray:
        cached = self.__dict__.get("_shirt_texture")
        if cached is None:
            rng = np.random.default_rng(abs(hash(self.shirt_bgr)) % (2**32))
            img = np.empty((140, 92, 3), np.uint8)
            img[:] = self.shirt_bgr
            # stripes and folds: texture for the stereo matcher and for Harris corners
            for y in range(0, 140, 14):
                img[y:y + 5] = np.clip(np.array(self.shirt_bgr) * 0.6, 0, 255).astype(np.uint8)
            noise = rng.normal(0, 12, img.shape[:2])[..., None]
            img = np.clip(img + noise, 0, 255).astype(np.uint8)
            cv2.rectangle(img, (30, 20), (60, 50), (230, 230, 230), -1)  # a badge
            object.__setattr__(self, "_shirt_texture", img)
            cached = img
        return cached


@dataclass(frozen=True)
class VisualRoom:
    """A box room, scene frame, metres: walls at x = +-half_width and z = depth, floor at y = floor_y, ceiling at
    y = ceiling_y (negative: above the cameras)."""

    half_width: float = 3.0
    depth: float = 6.0
    floor_y: float = 1.2
    ceiling_y: float = -1.5
    near_z: float = 0.4


def _texture(kind: str, rng: np.random.Generator, size: tuple[int, int]) -> np.ndarray:
    h, w = size
    if kind == "floor":
        yy, xx = np.mgrid[0:h, 0:w]
        checker = ((yy // 64 + xx // 64) % 2).astype(np.float64)
        base = 90 + 60 * checker
        col = np.stack([base * 0.8, base * 0.9, base], axis=-1)
    else:
        tone = {"back": (170, 180, 190), "side": (150, 170, 160), "ceiling": (210, 210, 210)}[kind]
        col = np.empty((h, w, 3))
        col[:] = tone
        for _ in range(14 if kind != "ceiling" else 3):  # posters, shelves, frames: static corners
            x0, y0 = rng.integers(0, w - 60), rng.integers(0, h - 60)
            x1, y1 = x0 + rng.integers(30, 160), y0 + rng.integers(30, 160)
            cv2.rectangle(col, (int(x0), int(y0)), (int(x1), int(y1)), rng.integers(20, 240, 3).tolist(), -1)
    smooth = cv2.GaussianBlur(rng.normal(0, 18, (h, w)), (0, 0), 3)[..., None]
    return np.clip(col + smooth, 0, 255).astype(np.uint8)


@dataclass(frozen=True, eq=False)
class RenderedFrame:
    """One rendered stereo frame and its ground truth.

    left, right : (h, w, 3) uint8 BGR rectified images; time_s : seconds;
    faces : (n, 3) float, metres: the face centres in the scene frame;
    face_boxes_left : (n, 4) float, pixels: each labelled face box projected into the left image (x, y, w, h).
    """

    left: np.ndarray
    right: np.ndarray
    time_s: float
    faces: np.ndarray
    face_boxes_left: np.ndarray


@dataclass(eq=False)
class StereoSceneRenderer:
    """Renders a room with people into both rectified cameras of ``rig`` (its rectified geometry is used).

    noise_std : grey levels of Gaussian sensor noise added to every pixel of every frame (seeded by ``seed`` and
    the frame time, so a frame is reproducible).
    """

    rig: StereoRig
    people: list[Person]
    room: VisualRoom = field(default_factory=VisualRoom)
    noise_std: float = 1.5
    seed: int = 0
    _background: dict[str, np.ndarray] = field(init=False, default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.rig, StereoRig):
            raise TypeError(f"rig must be a StereoRig, got {type(self.rig).__name__}")
        if self.noise_std < 0:
            raise ValueError(f"noise_std must be >= 0 grey levels, got {self.noise_std!r}")

    # ------------------------------------------------------------------ drawing
    def _project(self, corners: np.ndarray, side: str) -> np.ndarray:
        ul, ur = self.rig.project(corners)
        return ul if side == "left" else ur

    def _draw(self, canvas: np.ndarray, corners: np.ndarray, texture: np.ndarray, side: str) -> None:
        h, w = texture.shape[:2]
        src = np.float32([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])
        dst = self._project(corners, side).astype(np.float32)
        # warp into the quad's bounding box only: warpPerspective visits every destination pixel, and a face
        # covers a few percent of the frame
        x0, y0 = np.floor(dst.min(axis=0)).astype(int) - 1
        x1, y1 = np.ceil(dst.max(axis=0)).astype(int) + 2
        x0, y0 = max(x0, 0), max(y0, 0)
        x1, y1 = min(x1, canvas.shape[1]), min(y1, canvas.shape[0])
        if x1 <= x0 or y1 <= y0:
            return
        homography = cv2.getPerspectiveTransform(src, dst - np.float32([x0, y0]))
        roi = canvas[y0:y1, x0:x1]
        if texture.shape[2] == 4:  # a binary alpha: draw where it is set
            patch = cv2.warpPerspective(texture, homography, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
                                        borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0, 0))
            cv2.copyTo(patch[..., :3], (patch[..., 3] >= 128).view(np.uint8), roi)
            return
        warped = cv2.warpPerspective(texture, homography, (x1 - x0, y1 - y0), dst=roi, flags=cv2.INTER_LINEAR,
                                     borderMode=cv2.BORDER_TRANSPARENT)
        if warped is not roi and not np.shares_memory(warped, canvas):  # OpenCV could not write in place
            roi[...] = warped

    def room_quads(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """The room's walls, floor and ceiling: [(corners (4, 3) metres, texture), ...] (textures drawn anew)."""
        r = self.room
        rng = np.random.default_rng(self.seed)
        xw, zn, zf, yf, yc = r.half_width, r.near_z, r.depth, r.floor_y, r.ceiling_y
        return [
            (np.array([[-xw, yc, zf], [xw, yc, zf], [xw, yf, zf], [-xw, yf, zf]]), _texture("back", rng, (512, 1024))),
            (np.array([[-xw, yf, zf], [xw, yf, zf], [xw, yf, zn], [-xw, yf, zn]]), _texture("floor", rng, (512, 512))),
            (np.array([[-xw, yc, zn], [xw, yc, zn], [xw, yc, zf], [-xw, yc, zf]]),
             _texture("ceiling", rng, (512, 512))),
            (np.array([[-xw, yc, zn], [-xw, yc, zf], [-xw, yf, zf], [-xw, yf, zn]]),
             _texture("side", rng, (512, 1024))),
            (np.array([[xw, yc, zf], [xw, yc, zn], [xw, yf, zn], [xw, yf, zf]]), _texture("side", rng, (512, 1024))),
        ]

    def _room(self, side: str) -> np.ndarray:
        if side not in self._background:
            w, h = self.rig.image_size
            canvas = np.zeros((h, w, 3), np.uint8)
            for corners, tex in self.room_quads():
                self._draw(canvas, corners, tex, side)
            self._background[side] = canvas
        return self._background[side]

    def render(self, t: float = 0.0) -> RenderedFrame:
        """The two rectified images at time ``t`` seconds, with the ground truth of that instant."""
        quads = [(corners, tex) for _, _, corners, tex in drawing_order(self.people, t)]
        images = []
        rng = np.random.default_rng([self.seed, int(round(t * 1e6)) % (2**32)])
        for side in ("left", "right"):
            canvas = self._room(side).copy()
            for corners, tex in quads:
                self._draw(canvas, corners, tex, side)
            if self.noise_std > 0:
                noisy = canvas.astype(np.float32) + rng.normal(0, self.noise_std, canvas.shape).astype(np.float32)
                canvas = np.clip(np.rint(noisy), 0, 255).astype(np.uint8)
            images.append(canvas)
        faces = np.array([p.face_centre(t) for p in self.people]).reshape(-1, 3)
        return RenderedFrame(images[0], images[1], float(t), faces, self._face_boxes(t))

    def _face_boxes(self, t: float) -> np.ndarray:
        boxes = []
        for p in self.people:
            bx, by, bw, bh = p.face.face_box
            m = p.face_width_m / bw
            c = p.face_centre(t)
            lo, hi = p.face_span()
            corners = c + np.outer([lo, hi, hi, lo], [m, 0.0, 0.0]) \
                + np.outer([-bh / 2, -bh / 2, bh / 2, bh / 2], [0.0, m, 0.0])
            uv = self._project(corners, "left")
            lo, hi = uv.min(axis=0), uv.max(axis=0)
            boxes.append([lo[0] + 0.5, lo[1] + 0.5, hi[0] - lo[0], hi[1] - lo[1]])  # OpenCV Rect convention
        return np.array(boxes, dtype=np.float64).reshape(-1, 4)

    def to_raw(self, frame: RenderedFrame) -> tuple[np.ndarray, np.ndarray]:
        """The frame as the rig's real (distorted, unrectified) cameras would see it.

        Rendering happens in the rectified cameras; each raw pixel is looked up at its rectified position
        (:meth:`StereoRig.rectify_points`). Raw pixels that fall outside the rectified view are black. For an
        ideal rig the images come back unchanged. Returns (left, right) (h, w, 3) uint8.
        """
        if self.rig.is_rectified:
            return frame.left, frame.right
        out = []
        for side, img in (("left", frame.left), ("right", frame.right)):
            key = f"raw_map_{side}"
            if key not in self._background:
                w, h = self.rig.image_size
                grid = np.stack(np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h, dtype=np.float64)),
                                axis=-1).reshape(-1, 2)
                rect = self.rig.rectify_points(grid, side).reshape(h, w, 2).astype(np.float32)
                self._background[key] = rect
            rect = self._background[key]
            out.append(cv2.remap(img, rect[..., 0], rect[..., 1], cv2.INTER_LINEAR,
                                 borderMode=cv2.BORDER_CONSTANT, borderValue=0))
        return out[0], out[1]

    # ------------------------------------------------------------------ ground truth for HM3D
    def distance_to_people(self, points: np.ndarray, t: float) -> np.ndarray:
        """Distance of each point to the nearest person surface (head, body, arm, hand) at time ``t``.

        points : (m, 3) float, metres  ->  (m,) float, metres (inf when there is nobody).
        """
        return self.nearest_parts(points, t)[0]

    def nearest_parts(self, points: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Distance of each point to the nearest person surface at time ``t``, and that surface's name
        (:meth:`Person.parts`: "head", "shirt", "hand", ...; "" when there is nobody). The distance is to the whole
        quad, its transparent corners included. points : (m, 3) metres -> (m,) metres, (m,) str."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        best = np.full(pts.shape[0], np.inf)
        names = np.full(pts.shape[0], "", dtype=object)
        for p in self.people:
            for name, corners, _ in p.parts(t):
                d = distance_to_quad(pts, corners)
                names[d < best] = name
                best = np.minimum(best, d)
        return best, names


def drawing_order(people: Sequence[Person], t: float) -> list[tuple[int, str, np.ndarray, np.ndarray]]:
    """Everything the people bring at time ``t``, in the order it is drawn (far to near by mean depth, the painter's
    algorithm): [(person index, part name, corners (4, 3), texture), ...]; a table's part is named "prop"."""
    quads = [(i, name, corners, tex) for i, p in enumerate(people) for name, corners, tex in p.parts(t)]
    quads += [(i, "prop", corners, tex) for i, p in enumerate(people) for corners, tex in p.props(t)]
    quads.sort(key=lambda q: -float(q[2][:, 2].mean()))  # stable: equal depths keep the people's order
    return quads


def distance_to_quad(points: np.ndarray, corners: np.ndarray) -> np.ndarray:
    """Distance from points (m, 3) to a planar parallelogram given by its corners TL, TR, BR, BL (4, 3)."""
    origin = corners[0]
    a, b = corners[1] - origin, corners[3] - origin
    rel = points - origin
    s = np.clip(rel @ a / (a @ a), 0.0, 1.0)
    r = np.clip(rel @ b / (b @ b), 0.0, 1.0)
    nearest = origin + s[:, None] * a + r[:, None] * b
    return np.linalg.norm(points - nearest, axis=1)


def default_scene(faces_dir: str | Path | None = None, *, moving: bool = False, seed: int = 0,
                  rig: StereoRig | None = None, n_people: int = 3, bodies: bool = False) -> StereoSceneRenderer:
    """People in a 6 m room, seen by a 640x480 rig (focal 554 px, i.e. a 60 degree horizontal field of view,
    baseline 0.12 m). The first three stand at 1.3, 2.1 and 2.9 m; up to two more (``n_people`` <= 5) at 2.6 and
    1.8 m make a busier scene.

    faces_dir : ``../shared/data/faces`` for real face crops; None (or absent) for drawn faces.
    moving : people sway (5-8 cm) and nod (about 10 degrees), so that HM3D finds motion.
    bodies : people with bodies (:mod:`sim.person_body`: a checked shirt, arms and hands that gesture when
    ``moving``) behind a table.
    """
    if not 0 <= n_people <= 5:
        raise ValueError(f"n_people must be between 0 and 5, got {n_people!r}")
    rig = rig or StereoRig.ideal(focal_px=554.0, image_size=(640, 480), baseline_m=0.12)
    textures: list[FaceTexture] = []
    if faces_dir is not None:
        try:
            textures = load_face_textures(faces_dir, exclude=UNFOUND_FACES)
        except FileNotFoundError:
            textures = []
    if textures:
        rng = np.random.default_rng(seed)
        chosen = [textures[i] for i in rng.choice(len(textures), size=n_people, replace=len(textures) < n_people)]
    else:
        skins = ((150, 180, 220), (110, 140, 190), (90, 120, 160), (130, 160, 205), (70, 95, 130))
        chosen = [drawn_face_texture(skin_bgr=s) for s in skins[:n_people]]
    positions = [(-0.55, -0.05, 1.3), (0.1, 0.05, 2.1), (0.75, -0.1, 2.9), (-0.3, 0.0, 2.6), (0.95, 0.05, 1.8)]
    shirts = [(140, 70, 40), (40, 120, 160), (60, 60, 170), (60, 140, 60), (120, 120, 120)]
    people = [
        Person(face=tex, position=pos, shirt_bgr=shirt,
               sway_m=(0.05 + 0.015 * i) if moving else 0.0, nod_rad=0.17 if moving else 0.0,
               phase=1.3 * i, arms=bodies, gesture_m=0.15 if bodies and moving else 0.0, table=bodies)
        for i, (tex, pos, shirt) in enumerate(zip(chosen, positions, shirts))
    ]
    return StereoSceneRenderer(rig, people, seed=seed)
