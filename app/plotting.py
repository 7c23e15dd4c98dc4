"""What the figures that avhear draws with OpenCV share: the colours (BGR), the font and the axis ticks."""
from __future__ import annotations

import cv2
import numpy as np

__all__ = ["BLACK", "BLUE", "FONT", "GREEN", "GREY", "LIGHT", "PALE_RED", "RED", "nice_ticks"]

RED = (40, 40, 214)
PALE_RED = (170, 170, 235)
BLUE = (180, 119, 31)
GREEN = (44, 160, 44)
GREY = (110, 110, 110)
LIGHT = (225, 225, 225)
BLACK = (0, 0, 0)
FONT = cv2.FONT_HERSHEY_SIMPLEX


def nice_ticks(lo: float, hi: float, target: int = 8) -> np.ndarray:
    """About ``target`` round tick values (1, 2 or 5 times a power of ten apart) covering ``[lo, hi]``."""
    span = max(hi - lo, 1e-12)
    raw = span / target
    mag = 10 ** np.floor(np.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw)
    return np.arange(np.ceil(lo / step) * step, hi + 0.5 * step, step)
