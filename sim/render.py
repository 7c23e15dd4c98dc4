"""A stereo scene renderer: a textured room and people carrying real face crops, seen by a rectified rig.

It produces the visual input of the paper's pipeline (section 5.2: F3D faces, HM3D moving points) with ground truth:
the 3D centre of every face at every instant, and the surfaces of the people, so that F3D and HM3D can be scored.

Everything is a textured planar quad (walls, floor, bodies, heads, arms, tables) drawn by a homography per camera, far
to near (painter's algorithm), with sensor noise; a texture with a fourth channel is drawn where its alpha is set
(rounded shoulders, fingers). People with bodies are :mod:`sim.person_body`'s. Faces are crops of real photographs cut
around the hand-labelled boxes of ``../shared/data/faces`` (:func:`load_face_textures`) or, on a clean machine, a drawn
face that OpenCV's frontal Haar cascade finds (:func:`drawn_face_texture`).

Scene frame (docs/architecture.md): the cyclopean frame of the rig, metres, x right, y down, z forward. The cameras are
at y = 0; the floor is ``VisualRoom.floor_y`` below them.
"""
from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np

from avcore.stereo import StereoRig
from sim.person_body import BodyPose, body_quads, body_texture, table_quads
from sim.relief import turned_span, turned_view
from sim.roomsim import resolve_data_dir

__all__ = [
    "FaceTexture",
    "Person",
    "VisualRoom",
    "RenderedFrame",
    "StereoSceneRenderer",
    "distance_to_quad",
    "load_face_textures",
    "drawn_face_texture",
    "mouthless",
    "hand_over_mouth",
    "default_scene",
    "drawing_order",
    "load_textures",
]

FACE_MARGIN = 1.6  # head texture side / labelled face box side: hair, ears and a little background
# where a photographed mouth is in its labelled face box: centre x, y and width as fractions of the box's width and
# height (the face mesh's inner lips and corners on the textures, medians; docs/experiments.md, 2026-11-26)
MOUTH_IN_FACE_BOX = (0.53, 0.73, 0.37)
MOUTH_MAX_GAP = 0.35  # the open mouth's gap over its width at full opening (speech spans about 0.1-0.5)
MOUTH_BGR = (35, 25, 60)  # the mouth's cavity
TEETH_BGR = (150, 160, 172)


@dataclass(frozen=True, eq=False)
class FaceTexture:
    """A head texture and where the face is in it.

    image : (h, w, 3) uint8 BGR; face_box : (x, y, w, h) pixels in ``image``, the labelled face.
    source : where it came from (file name and box index, or "drawn"). mouth_in_box : the mouth's centre and width
    in the face box (fractions), where :meth:`with_mouth` opens it. drawn_mouth : the photographed mouth is
    replaced by drawn lips at every opening, 0 included (the moving mouths); otherwise the photograph is left as
    it is and opened only when asked.
    """

    image: np.ndarray
    face_box: tuple[float, float, float, float]
    source: str = ""
    mouth_in_box: tuple[float, float, float] = MOUTH_IN_FACE_BOX
    drawn_mouth: bool = False

    def with_mouth(self, opening: float) -> np.ndarray:
        """The texture with its mouth open by ``opening`` in [0, 1]; the texture itself at 0 unless ``drawn_mouth``.

        As a jaw drops: the lower lip and the chin below the mouth's line move down by the gap (``opening *
        MOUTH_MAX_GAP`` of the mouth's width), fading to nothing at the chin and beside the mouth, and the dark
        cavity shows between the lips. With ``drawn_mouth`` the photographed mouth is first painted over with the
        skin around it (:func:`mouthless`) and lips are drawn (:func:`_draw_lips`), since the face mesh keeps
        reading a photograph's own lips under whatever is drawn over them (docs/experiments.md)."""
        opening = float(np.clip(opening, 0.0, 1.0))
        if opening <= 0.0 and not self.drawn_mouth:
            return self.image
        bx, by, bw, bh = self.face_box
        fx, fy, fw = self.mouth_in_box
        width, cx, cy = fw * bw, bx + fx * bw, by + fy * bh
        gap = opening * MOUTH_MAX_GAP * width
        image = mouthless(self) if self.drawn_mouth else self.image
        h, w = image.shape[:2]
        ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
        chin = by + bh + 0.1 * bh
        down = np.clip((chin - ys) / max(chin - cy, 1.0), 0.0, 1.0) * (ys >= cy)
        side = np.clip(1.0 - np.abs(xs - cx) / (0.9 * width), 0.0, 1.0)
        shift = (gap * down * np.minimum(1.0, 2.0 * side)).astype(np.float32)
        out = cv2.remap(image, xs, ys - shift, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        if self.drawn_mouth:
            return _draw_lips(out, (cx, cy), width, gap, skin_of(self))
        # the cavity: dark inside, the teeth's edges at its top and bottom (an open mouth shows them)
        cavity = np.zeros((h, w), np.uint8)
        cv2.ellipse(cavity, (round(cx), round(cy + gap / 2)), (max(1, round(0.4 * width)), max(1, round(gap / 2))),
                    0, 0, 360, 255, -1, cv2.LINE_AA)
        teeth = min(0.25 * gap, 0.08 * width)
        colour = np.where(((ys < cy + teeth) | (ys > cy + gap - 0.6 * teeth))[..., None], TEETH_BGR, MOUTH_BGR)
        alpha = 0.85 * cavity[..., None].astype(np.float32) / 255.0
        return (out * (1.0 - alpha) + colour * alpha).astype(np.uint8)


@lru_cache(maxsize=256)
def mouthless(face: FaceTexture) -> np.ndarray:
    """The face's texture with its photographed mouth painted over by the skin around it (OpenCV's inpainting, an
    ellipse 1.5 by 0.9 mouth widths, enough for a laughing mouth), where :meth:`FaceTexture.with_mouth` draws lips."""
    bx, by, bw, bh = face.face_box
    fx, fy, fw = face.mouth_in_box
    width = fw * bw
    mask = np.zeros(face.image.shape[:2], np.uint8)
    cv2.ellipse(mask, (round(bx + fx * bw), round(by + fy * bh)), (round(0.75 * width), round(0.45 * width)),
                0, 0, 360, 255, -1)
    out = cv2.inpaint(face.image, mask, 3, cv2.INPAINT_TELEA)
    out.flags.writeable = False
    return out


LIP_SHADE = (0.62, 0.55, 0.85)  # lips against the skin, B, G, R: darker and redder
_SUB = 8  # sub-pixel steps of the lips' outlines (cv2's ``shift`` of 3 bits)


def _draw_lips(image: np.ndarray, centre: tuple[float, float], width: float, gap: float,
               skin: tuple[float, float, float]) -> np.ndarray:
    """Lips drawn on ``image`` (a copy): an upper lip 0.13 widths thick with a dip at its middle, above the mouth's
    line; the lower lip 0.17 thick, ``gap`` pixels below it; the dark cavity between and the upper teeth's edge.
    The outlines are parabolas from corner to corner, softened by a blur of 0.6 px over the mouth alone."""
    cx, cy = centre
    half = width / 2.0
    x = np.linspace(-half, half, 21)
    bend = 1.0 - (x / half) ** 2
    dip = 1.0 - 0.25 * np.exp(-(x / (0.12 * width)) ** 2)
    upper_outer = np.column_stack([cx + x, cy - 0.13 * width * bend * dip])
    upper_inner = np.column_stack([cx + x, cy - 0.02 * width * bend])[::-1]
    lower_inner = np.column_stack([cx + x, cy + gap * bend ** 0.7])
    lower_outer = np.column_stack([cx + x, cy + gap * bend ** 0.7 + 0.17 * width * bend])[::-1]
    lip = tuple(float(c) * k for c, k in zip(skin, LIP_SHADE))

    def poly(*parts: np.ndarray) -> list[np.ndarray]:
        return [np.round(np.vstack(parts) * _SUB).astype(np.int32)]

    out = image.copy()
    cv2.fillPoly(out, poly(upper_inner, lower_inner), MOUTH_BGR, cv2.LINE_AA, shift=3)
    if gap > 1.0:
        tx = np.linspace(-0.6 * half, 0.6 * half, 11)
        teeth = np.column_stack([cx + tx, cy + min(0.3 * gap, 0.07 * width) * (1.0 - (tx / (0.6 * half)) ** 2)])
        cv2.fillPoly(out, poly(teeth), TEETH_BGR, cv2.LINE_AA, shift=3)  # its ends lie on the mouth's line
    cv2.fillPoly(out, poly(upper_outer, upper_inner), lip, cv2.LINE_AA, shift=3)
    cv2.fillPoly(out, poly(lower_inner, lower_outer), lip, cv2.LINE_AA, shift=3)
    cv2.polylines(out, poly(upper_inner), False, tuple(0.6 * c for c in lip), 1, cv2.LINE_AA, shift=3)
    x0, x1 = max(0, int(cx - width)), min(out.shape[1], int(cx + width) + 1)
    y0, y1 = max(0, int(cy - 0.5 * width)), min(out.shape[0], int(cy + gap + 0.6 * width) + 1)
    if x1 > x0 and y1 > y0:
        out[y0:y1, x0:x1] = cv2.GaussianBlur(out[y0:y1, x0:x1], (0, 0), 0.6)
    return out


def hand_over_mouth(face: FaceTexture, image: np.ndarray) -> np.ndarray:
    """``image`` (the face's texture, its mouth drawn) with a hand held flat over the mouth: a palm of the face's
    skin a little darker (:func:`skin_of`), 1.9 mouth widths across, from below the nose to past the chin, its
    fingers lying across the mouth with the gaps between them drawn as three darker lines."""
    bx, by, bw, bh = face.face_box
    fx, fy, fw = face.mouth_in_box
    width, cx, cy = fw * bw, bx + fx * bw, by + fy * bh
    palm = tuple(0.92 * c for c in skin_of(face))
    out = image.copy()
    cv2.ellipse(out, (round(cx), round(cy + 0.1 * width)), (round(0.95 * width), round(0.6 * width)), 0, 0, 360,
                palm, -1, cv2.LINE_AA)
    for k in (-1, 0, 1):
        y = round(cy + 0.1 * width + 0.3 * k * width)
        cv2.line(out, (round(cx - 0.8 * width), y), (round(cx + 0.8 * width), y), tuple(0.8 * c for c in palm), 1,
                 cv2.LINE_AA)
    return out


def _read_boxes(xml_path: Path) -> list[tuple[str, tuple[int, int, int, int]]]:
    root = ET.parse(xml_path).getroot()
    out = []
    for image in root.iter("image"):
        for box in image.iter("box"):
            xywh = tuple(int(box.get(k)) for k in ("left", "top", "width", "height"))
            out.append((image.get("file"), xywh))
    return out


def _iou(a: Sequence[float], b: Sequence[float]) -> float:
    ix = max(0.0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    inter = ix * iy
    return inter / (a[2] * a[3] + b[2] * b[3] - inter)


# The labelled faces of ../shared/data/faces (60 px or more) that OpenCV 4's frontal Haar cascade does not find in
# their own photograph (tests/sim/test_render.py checks it). The simulated room has left them out since it was
# first drawn (a rendering is no fairer to a detector than its photograph was); named here, the room is the same
# whichever OpenCV draws it (OpenCV 5 has no cascade) and whichever detector the run uses.
UNFOUND_FACES = ("2008_001322.jpg#17", "2008_002506.jpg#8")


def load_face_textures(faces_dir: str | Path, *, files: Sequence[str] = ("training.xml", "testing.xml"),
                       min_face_px: int = 60, size_px: int = 96,
                       detector: object | None = None, exclude: Sequence[str] = ()) -> list[FaceTexture]:
    """Head textures cut from the labelled photographs of ``../shared/data/faces`` (dlib's examples).

    Each labelled box at least ``min_face_px`` wide (small faces are too blurred once enlarged) is cut with a
    margin of :data:`FACE_MARGIN` and resized so that the face box is ``size_px`` wide. With a ``detector``
    (anything with ``detect(image) -> (n, 4)`` boxes, see :mod:`avcore.faces`), only faces that it finds in
    their own photograph (IoU >= 0.5 with the label) are kept: a rendering cannot be fairer to a detector than
    the photograph was. Faces named in ``exclude`` ("file#index", as :attr:`FaceTexture.source`) are left out.
    Raises ``FileNotFoundError`` when the folder or its XML files are absent (callers fall
    back to :func:`drawn_face_texture`).
    """
    root = Path(faces_dir)
    textures = []
    for xml_name in files:
        xml_path = root / xml_name
        if not xml_path.is_file():
            raise FileNotFoundError(f"{xml_path} not found; the face crops need ../shared/data/faces")
        for k, (file, (x, y, w, h)) in enumerate(_read_boxes(xml_path)):
            if w < min_face_px or f"{file}#{k}" in exclude:
                continue
            img = cv2.imread(str(root / file), cv2.IMREAD_COLOR)
            if img is None:
                raise FileNotFoundError(f"{root / file} cannot be read")
            if detector is not None:
                found = detector.detect(img)  # type: ignore[attr-defined]
                if not any(_iou((x, y, w, h), b) >= 0.5 for b in found):
                    continue
            side = FACE_MARGIN * max(w, h)
            cx, cy = x + w / 2.0, y + h / 2.0
            x0, y0 = int(max(0, round(cx - side / 2))), int(max(0, round(cy - side / 2)))
            x1, y1 = int(min(img.shape[1], round(cx + side / 2))), int(min(img.shape[0], round(cy + side / 2)))
            crop = img[y0:y1, x0:x1]
            s = size_px / w
            crop = cv2.resize(crop, (round(crop.shape[1] * s), round(crop.shape[0] * s)),
                              interpolation=cv2.INTER_CUBIC)
            box = ((x - x0) * s, (y - y0) * s, w * s, h * s)
            textures.append(FaceTexture(crop, box, f"{file}#{k}"))
    return textures


def drawn_face_texture(size_px: int = 96, skin_bgr: tuple[int, int, int] = (150, 180, 220),
                       hair_bgr: tuple[int, int, int] = (30, 35, 45)) -> FaceTexture:
    """A drawn face (hair, eyes, brows, nose, mouth) that OpenCV's frontal Haar cascade detects.

    For machines without ``../shared/data``. The face box is the skin oval's width, centred on the eyes-mouth area.
    The cascade's features expect the band of the eyes darker than the cheeks, as the eye sockets' shadow makes it
    in a lit face: each eye sits in a shadow of the skin colour and its white is only a little lighter than the skin
    (pure white eyes in a dark face turned that band bright, and the darkest of the five drawn skins went unfound;
    ``tests/avcore/test_render.py`` checks every skin at 1.3-2.9 m).
    """
    s = size_px
    w, h = round(FACE_MARGIN * s), round(FACE_MARGIN * s * 1.15)
    img = np.full((h, w, 3), 190, np.uint8)
    cx, cy = w // 2, round(h * 0.55)
    cv2.ellipse(img, (cx, round(cy - 0.1 * s)), (round(0.5 * s), round(0.58 * s)), 0, 0, 360, hair_bgr, -1)
    cv2.ellipse(img, (cx, cy), (round(0.42 * s), round(0.53 * s)), 0, 0, 360, skin_bgr, -1)
    ey, ex = round(cy - 0.09 * s), round(0.18 * s)
    socket = tuple(int(c * 0.6) for c in skin_bgr)
    white = tuple(min(235, int(c * 1.25) + 30) for c in skin_bgr)
    for sx in (-1, 1):
        cv2.ellipse(img, (cx + sx * ex, ey - round(0.02 * s)), (round(0.13 * s), round(0.08 * s)), 0, 0, 360,
                    socket, -1)
        cv2.ellipse(img, (cx + sx * ex, ey - round(0.1 * s)), (round(0.11 * s), round(0.028 * s)), 0, 0, 360,
                    (40, 40, 50), -1)
        cv2.ellipse(img, (cx + sx * ex, ey), (round(0.09 * s), round(0.045 * s)), 0, 0, 360, white, -1)
        cv2.circle(img, (cx + sx * ex, ey), round(0.04 * s), (40, 30, 20), -1)
    nose = tuple(int(c * 0.75) for c in skin_bgr)
    cv2.ellipse(img, (cx, round(cy + 0.13 * s)), (round(0.07 * s), round(0.035 * s)), 0, 0, 360, nose, -1)
    cv2.ellipse(img, (cx, round(cy + 0.29 * s)), (round(0.14 * s), round(0.04 * s)), 0, 0, 360, (60, 60, 150), -1)
    img = cv2.GaussianBlur(img, (0, 0), s / 90)
    box = (cx - 0.42 * s, cy - 0.45 * s, 0.84 * s, 0.84 * s)
    return FaceTexture(img, box, "drawn", mouth_in_box=(0.5, (0.45 + 0.29) / 0.84, 0.28 / 0.84))


@lru_cache(maxsize=256)
def skin_of(face: FaceTexture) -> tuple[float, float, float]:
    """BGR, the median colour of the brighter half of the middle of the face box (the cheeks and the forehead, not
    the eyes, the mouth or the shadows): the skin of the person's hands."""
    bx, by, bw, bh = face.face_box
    x0, y0 = int(bx + 0.25 * bw), int(by + 0.25 * bh)
    patch = face.image[y0:y0 + max(int(0.5 * bh), 1), x0:x0 + max(int(0.5 * bw), 1)].reshape(-1, 3)
    if not patch.size:
        return (140.0, 170.0, 210.0)
    grey = patch.astype(np.float64).sum(axis=1)
    b, g, r = np.median(patch[grey >= np.median(grey)], axis=0)
    return (float(b), float(g), float(r))


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


def load_textures(data_dir: str | Path | None = None) -> tuple[list[FaceTexture], str]:
    """Face textures cut from ``data_dir/faces`` (but :data:`UNFOUND_FACES`), or five drawn faces
    when the folder is absent. Returns the textures and "faces" or "drawn"."""
    root = resolve_data_dir(data_dir)
    try:
        textures = load_face_textures(root / "faces", exclude=UNFOUND_FACES)
    except FileNotFoundError:
        textures = []
    if textures:
        return textures, "faces"
    skins = ((150, 180, 220), (110, 140, 190), (90, 120, 160), (130, 160, 205), (70, 95, 130))
    return [drawn_face_texture(skin_bgr=s) for s in skins], "drawn"
