"""The body of a rendered person: torso, arms, hands and legs as textured planar quads, and a table.

:class:`sim.render.Person` draws these when it has a body (``arms``). The aim is what HM3D sees on a real person:
Harris corners lie where clothing has texture (the checks and folds of a shirt, the collar, the buttons, the cuffs,
the outline of the arms, the fingers), and the motion that keeps them comes from the head nodding, the arms gesturing
and the shoulders rocking a little. So every part here carries a texture with corners, and every part moves with
the gesture: a talker's hands swing ``gesture_m`` (about 15 cm), a listener's a little.

Geometry, scene frame (x right, y down, z forward, metres), relative to the face centre ``c``: the shoulders 0.40 m
wide a little below the chin, the torso a plane 6 cm behind the face down to the hips (0.74 m below the face), upper
arms hanging from the shoulders to elbows that rest 0.39 m below the face a little in front of the body, forearms
from the elbows to the wrists in front of the chest, hands continuing the forearms. A standing person (no table)
also has two legs down to 1.6 m below the face. A seated person's table (:func:`table_quads`) has its top 0.42 m
below the face (0.73 m above the floor for the scenarios' seated heads) and its front 0.30 m in front of the face:
it hides the lower half of the body.

The shirt's and the hands' textures have a fourth channel, a binary alpha (the renderer draws only where alpha >= 128):
rounded shoulders, a hand's fingers. Textures are made once per person and cached by the caller.
"""
from __future__ import annotations

from functools import lru_cache

import cv2
import numpy as np

__all__ = ["BodyPose", "body_quads", "table_quads", "body_texture"]

SHOULDER_HALF_M = 0.20
TORSO_DEPTH_M = 0.06      # the torso plane behind the face
TORSO_HEIGHT_M = 0.62     # from the chin to the hips
LEG_LENGTH_M = 0.85
TABLE_TOP_BELOW_FACE_M = 0.42
TABLE_FRONT_M = 0.30      # the table's front edge in front of the face
TABLE_HALF_M = 0.45
TABLE_DEPTH_M = 0.35


class BodyPose:
    """Where the joints of a body are at one instant, from the face centre, the chin and the gesture.

    centre : (3,) the face centre; chin_y : where the torso starts (y, metres); gesture_m : how far the hands swing;
    w : the gesture's phase (radians) at this instant.
    """

    def __init__(self, centre: np.ndarray, chin_y: float, gesture_m: float, w: float) -> None:
        self.c, self.top, self.g, self.w = centre, chin_y, gesture_m, w
        self.rock = 0.2 * gesture_m * np.sin(0.5 * w)  # the shoulders rock with the gesture, the hips stay

    def shoulder(self, s: float) -> np.ndarray:
        return np.array([self.c[0] + s * 0.175 + self.rock, self.top + 0.05, self.c[2] + 0.04])

    def elbow(self, s: float) -> np.ndarray:
        ws = self.w + (0.0 if s < 0 else 1.7)
        return np.array([self.c[0] + s * (0.22 + 0.3 * self.g * np.sin(ws)) + 0.5 * self.rock,
                         self.top + 0.27 - 0.25 * self.g * np.sin(1.3 * ws), self.c[2] - 0.06])

    def wrist(self, s: float) -> np.ndarray:
        ws = self.w + (0.0 if s < 0 else 1.7)
        return np.array([self.c[0] + s * 0.12 + self.g * np.sin(ws), self.top + 0.20 - 0.5 * self.g * np.sin(1.7 * ws),
                         self.c[2] - 0.18])


def _strip(a: np.ndarray, b: np.ndarray, width: float) -> np.ndarray:
    """A quad of ``width`` from a to b (TL, TR at a; BR, BL at b), its width across the segment in the x-y plane."""
    d = b - a
    across = np.array([-d[1], d[0], 0.0])
    across = across / max(np.linalg.norm(across), 1e-9) * width / 2
    return np.array([a - across, a + across, b + across, b - across])


def body_quads(pose: BodyPose, legs: bool) -> list[tuple[str, np.ndarray]]:
    """The body's parts at one pose, as (texture kind, corners (4, 3) TL, TR, BR, BL), torso first.

    A texture kind names a texture of :func:`body_texture`. The torso is a parallelogram: its top moves with the
    shoulders' rock, its bottom stays.
    """
    c, top, z = pose.c, pose.top, pose.c[2] + TORSO_DEPTH_M
    half, bottom = SHOULDER_HALF_M, pose.top + TORSO_HEIGHT_M
    torso = np.array([[c[0] - half + pose.rock, top, z], [c[0] + half + pose.rock, top, z],
                      [c[0] + half, bottom, z], [c[0] - half, bottom, z]])
    out = [("shirt", torso)]
    if legs:
        for s in (-1.0, 1.0):
            hip = np.array([c[0] + s * 0.09, bottom - 0.04, z + 0.01])
            out.append(("trousers", _strip(hip, hip + np.array([s * 0.03, LEG_LENGTH_M, 0.0]), 0.15)))
    for s in (-1.0, 1.0):
        shoulder, elbow, wrist = pose.shoulder(s), pose.elbow(s), pose.wrist(s)
        out.append(("upper_sleeve", _strip(shoulder, elbow, 0.11)))
        out.append(("sleeve", _strip(elbow, wrist, 0.09)))
        d = wrist - elbow
        out.append(("hand", _strip(wrist - 0.01 * d, wrist + 0.4 * d, 0.095)))
    return out


def table_quads(c: np.ndarray) -> list[tuple[str, np.ndarray]]:
    """A seated person's table, in front of the face centre ``c`` (position at rest): its top and its front."""
    y, zf = c[1] + TABLE_TOP_BELOW_FACE_M, c[2] - TABLE_FRONT_M
    x0, x1, zb = c[0] - TABLE_HALF_M, c[0] + TABLE_HALF_M, zf + TABLE_DEPTH_M
    top = np.array([[x0, y, zb], [x1, y, zb], [x1, y, zf], [x0, y, zf]])
    lip = y - 0.01  # the front overlaps the top's edge: no row of pixels between them
    front = np.array([[x0, lip, zf], [x1, lip, zf], [x1, y + 1.0, zf], [x0, y + 1.0, zf]])
    return [("table_top", top), ("table_front", front)]


# ---------------------------------------------------------------------------------------------------------------
# textures


def _checks(h: int, w: int, colour: np.ndarray, period: int, rng: np.random.Generator) -> np.ndarray:
    """A checked cloth: dark bands both ways, thin light lines between them, woven noise. (h, w, 3) float."""
    img = np.empty((h, w, 3))
    img[:] = colour
    yy, xx = np.mgrid[0:h, 0:w]
    dark = ((yy % period) < period // 5) | ((xx % period) < period // 5)
    img[dark] *= 0.6
    img[((yy + period // 2) % period == 0) | ((xx + period // 2) % period == 0)] *= 1.45
    return img + rng.normal(0, 7, (h, w))[..., None]


def _shirt(colour: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Checked shirt of the torso: collar, buttons, folds; rounded shoulders and a narrower waist in alpha."""
    h, w = 200, 128
    img = _checks(h, w, colour, 26, rng)
    cv2.line(img, (w // 2, 18), (w // 2, h), (colour * 0.45).tolist(), 2)  # the placket
    for y in range(30, h, 28):
        cv2.circle(img, (w // 2 + 4, y), 3, (225, 225, 225), -1)
    collar = np.array([[w // 2 - 26, 0], [w // 2, 26], [w // 2 + 26, 0]], np.int32)
    cv2.fillConvexPoly(img, collar, (235, 235, 235))
    cv2.polylines(img, [collar], False, (90, 90, 90), 2)
    folds = np.zeros((h, w))
    for _ in range(6):  # creases: soft dark diagonals, mostly near the armpits and the waist
        x0, y0 = int(rng.integers(0, w)), int(rng.integers(h // 3, h))
        cv2.line(folds, (x0, y0), (x0 + int(rng.integers(-40, 40)), y0 + int(rng.integers(10, 40))), 1.0, 3)
    img *= 1.0 - 0.35 * cv2.GaussianBlur(folds, (0, 0), 2)[..., None]
    alpha = np.full((h, w), 255.0)
    r = 30  # rounded shoulders
    yy, xx = np.mgrid[0:h, 0:w]
    outside = (yy < r) & ((xx - r) ** 2 + (yy - r) ** 2 > r * r) & (xx < r)
    alpha[outside | outside[:, ::-1]] = 0
    taper = 0.08 * w * np.clip((yy - 0.45 * h) / (0.55 * h), 0, 1)  # the waist a little narrower
    alpha[(xx < taper) | (xx > w - 1 - taper)] = 0
    return _rgba(img, alpha)


def _sleeve(colour: np.ndarray, rng: np.random.Generator, cuff: bool) -> np.ndarray:
    h, w = 90, 32
    img = _checks(h, w, colour, 18, rng)
    for y in rng.integers(10, h - 14, 3):  # folds across the sleeve
        img[int(y):int(y) + 2] *= 0.7
    if cuff:
        img[h - 12:] = colour * 0.8 + rng.normal(0, 6, (12, w))[..., None]
        img[h - 12:h - 10] *= 0.5
    return _opaque(img)


def _hand(skin: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A hand, wrist at the top, fingers down: palm, four fingers and a thumb in alpha; creases and nails."""
    h, w = 64, 48
    alpha = np.zeros((h, w))
    cv2.ellipse(alpha, (w // 2, 20), (17, 17), 0, 0, 360, 255, -1)
    for k, x in enumerate((11, 20, 29, 38)):
        cv2.rectangle(alpha, (x - 3, 24), (x + 3, 52 + (4 if k in (1, 2) else 0)), 255, -1)
    cv2.line(alpha, (8, 16), (1, 34), 255, 7)  # the thumb
    img = np.empty((h, w, 3))
    img[:] = skin
    img *= 1.0 - 0.08 * rng.random((h, w))[..., None]
    for x in (15, 24, 33):
        cv2.line(img, (x, 26), (x, 60), (skin * 0.55).tolist(), 1)
    for y in (36, 46):
        cv2.line(img, (8, y), (42, y), (skin * 0.7).tolist(), 1)
    img[:6] *= 0.85  # the wrist's shadow under the cuff
    return _rgba(img, alpha)


def _trousers(rng: np.random.Generator) -> np.ndarray:
    h, w = 170, 30
    img = np.empty((h, w, 3))
    img[:] = (95, 60, 40)
    img[:, w // 2 - 1:w // 2 + 1] *= 0.6  # the seam
    for y in rng.integers(20, h - 10, 5):
        img[int(y):int(y) + 2] *= 0.75
    return _opaque(img + rng.normal(0, 8, (h, w))[..., None])


def _wood(h: int, w: int, tone: tuple[float, float, float], rng: np.random.Generator) -> np.ndarray:
    img = np.empty((h, w, 3))
    img[:] = tone
    grain = cv2.GaussianBlur(rng.normal(0, 1, (h, w // 8)), (0, 0), 1.5)
    img *= 1.0 + 0.12 * cv2.resize(grain, (w, h))[..., None]
    img[::7] *= 0.85
    return _opaque(img + rng.normal(0, 5, (h, w))[..., None])


def _rgba(img: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    return np.dstack([np.clip(img, 0, 255), alpha]).astype(np.uint8)


def _opaque(img: np.ndarray) -> np.ndarray:
    """No alpha: the renderer's faster path."""
    return np.clip(img, 0, 255).astype(np.uint8)


@lru_cache(maxsize=512)
def body_texture(kind: str, shirt_bgr: tuple[int, int, int], skin_bgr: tuple[float, float, float],
                 seed: int) -> np.ndarray:
    """The texture of a body part or table kind (see :func:`body_quads`, :func:`table_quads`): (h, w, 4) BGRA
    where the outline is not the quad's (the shirt's shoulders, the hand), else (h, w, 3) BGR.

    Made once per set of arguments (a simulated source makes new people every frame) and read-only."""
    texture = _make_texture(kind, shirt_bgr, skin_bgr, seed)
    texture.flags.writeable = False
    return texture


def _make_texture(kind: str, shirt_bgr: tuple[int, int, int], skin_bgr: tuple[float, float, float],
                  seed: int) -> np.ndarray:
    rng = np.random.default_rng([seed, len(kind), ord(kind[0])])
    colour = np.asarray(shirt_bgr, dtype=np.float64)
    if kind == "shirt":
        return _shirt(colour, rng)
    if kind in ("sleeve", "upper_sleeve"):
        return _sleeve(colour, rng, cuff=kind == "sleeve")
    if kind == "hand":
        return _hand(np.asarray(skin_bgr, dtype=np.float64), rng)
    if kind == "trousers":
        return _trousers(rng)
    if kind == "table_top":
        return _wood(90, 240, (80, 125, 170), rng)
    if kind == "table_front":
        return _wood(120, 240, (55, 88, 128), rng)
    raise ValueError(f"unknown body part {kind!r}")
