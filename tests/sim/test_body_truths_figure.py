"""benchmarks/body_truths_figure.py: the picture of a skeletons interval with its truth points (issue 18)."""
from __future__ import annotations

import numpy as np

from app.plotting import BLUE, GREEN, RED

def _has(img: np.ndarray, colour: tuple[int, int, int]) -> bool:
    return bool(np.any(np.all(img == np.array(colour, np.uint8), axis=2)))


def test_one_panel_per_visible_person_with_every_mark(load_benchmark) -> None:  # noqa: ANN001
    fig = load_benchmark("body_truths_figure")
    img = fig.draw("seated", 0, 3)
    assert img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8
    # three seated people, each panel at least 300 px wide, with both truths and avhear's estimate drawn
    assert img.shape[1] >= 3 * 300
    for colour in (BLUE, GREEN, RED):
        assert _has(img, colour), colour
    # all three are found at that interval: each person's panel shows avhear's estimate
    panel_w = img.shape[1] // 3
    for k in range(3):
        assert _has(img[:, k * panel_w:(k + 1) * panel_w], RED), k
