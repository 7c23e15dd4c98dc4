"""The faces the simulated people carry: crops of real photographs cut around their hand-labelled boxes
(``../shared/data/faces``, :func:`load_face_textures`) or, on a clean machine, drawn faces (:func:`drawn_face_texture`),
and their mouths opened, drawn or covered (:meth:`FaceTexture.with_mouth`, :func:`hand_over_mouth`).

A floor below the renderer (:mod:`sim.render`) and the turned views (:mod:`sim.relief`), which both take a
:class:`FaceTexture`."""
from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np

from sim.roomsim import resolve_data_dir

__all__ = ["FACE_MARGIN", "FaceTexture", "MOUTH_MAX_GAP", "UNFOUND_FACES", "drawn_face_texture", "hand_over_mouth",
           "load_face_textures", "load_textures", "mouthless", "skin_of"]

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
