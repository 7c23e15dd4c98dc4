"""The speaking-state timeline of one scenario run (``avhear eval scenarios --timeline DIR``), drawn with OpenCV.

One pair of lanes per person, against time:

- **truth**: the person's spoken numbers (blue; red when the number was counted a miss, FN) and the other sounds
  they make (hand claps, orange ticks); grey where the person is outside the field of view;
- **avhear**: each result's state, green where judged speaking, light grey where judged silent, white where the
  face was not found; red bars above the lane mark the stretches counted as false positives per spoken number.

Thin vertical lines mark the 0.4 s intervals of the per-interval view. The title gives the per-number counts.
"""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from app.errors import UserError
from app.plotting import BLACK, BLUE, FONT, GREEN, GREY, LIGHT, RED, nice_ticks
from app.eval.counts import Timeline
from app.eval.scoring import INTERVAL_S

__all__ = ["draw_timeline", "save_timeline"]

ORANGE = (0, 140, 255)
OUTSIDE = (200, 200, 200)
INTERVAL_LINE = (242, 242, 242)
LANE_H = 20
GROUP_GAP = 26


def draw_timeline(timeline: Timeline, title: str, *, width: int = 1600) -> np.ndarray:
    """The timeline figure as a BGR image (see the module docstring)."""
    sc = timeline.scenario
    n = len(sc.actors)
    left_m, right_m, top_m, bottom_m = 150, 20, 76, 44
    height = top_m + n * (2 * LANE_H + GROUP_GAP) + bottom_m
    img = np.full((height, width, 3), 255, np.uint8)
    t_hi = float(sc.duration_s)
    pw = width - left_m - right_m

    def u(t: float | np.ndarray) -> np.ndarray:
        return np.round(left_m + np.clip(np.asarray(t, dtype=np.float64), 0.0, t_hi) / t_hi * pw).astype(int)

    def bar(t0: float, t1: float, y0: int, y1: int, colour: tuple[int, int, int], fill: bool = True) -> None:
        a, b = int(u(t0)), max(int(u(t1)), int(u(t0)) + 1)
        cv2.rectangle(img, (a, y0), (b, y1), colour, -1 if fill else 1)

    for k in range(int(np.ceil(t_hi / INTERVAL_S)) + 1):
        x = int(u(k * INTERVAL_S))
        cv2.line(img, (x, top_m - 6), (x, height - bottom_m), INTERVAL_LINE, 1)

    # visibility, sampled at the results (or every 0.1 s when there are none)
    stamps = timeline.stamps_s if timeline.stamps_s.size else np.arange(0.0, t_hi, 0.1)
    step = float(np.median(np.diff(stamps))) if stamps.size > 1 else 0.1
    visible = np.array([sc.visible(float(t)) for t in stamps]).reshape(-1, n)
    missed = {(i, round(a, 6)) for i, a, _ in timeline.missed}
    for i in range(n):
        y = top_m + i * (2 * LANE_H + GROUP_GAP)
        truth_y, ours_y = (y, y + LANE_H - 2), (y + LANE_H + 2, y + 2 * LANE_H)
        cv2.putText(img, f"person {i}", (8, y + LANE_H), FONT, 0.5, BLACK, 1, cv2.LINE_AA)
        cv2.putText(img, "truth", (left_m - 44, truth_y[1] - 4), FONT, 0.35, GREY, 1, cv2.LINE_AA)
        cv2.putText(img, "avhear", (left_m - 50, ours_y[1] - 4), FONT, 0.35, GREY, 1, cv2.LINE_AA)
        for j, t in enumerate(stamps):
            if not visible[j, i]:
                bar(t - step / 2, t + step / 2, truth_y[0], truth_y[1], OUTSIDE)
        for e in sc.events:
            if e.actor != i:
                continue
            if e.kind == "speech":
                colour = RED if (i, round(e.start_s, 6)) in missed else BLUE
                bar(e.start_s, e.end_s, truth_y[0] + 3, truth_y[1] - 3, colour)
            else:
                bar(e.start_s, e.end_s, truth_y[0], truth_y[1], ORANGE)
        h = timeline.half_span_s
        for t, state in zip(timeline.stamps_s, timeline.states[:, i] if timeline.states.size else []):
            if state >= 0:
                bar(t - h, t + h, ours_y[0], ours_y[1], GREEN if state == 1 else LIGHT)
        for person, a, b in timeline.false_stretches:
            if person == i:
                bar(a, b, ours_y[0] - 3, ours_y[0], RED)
        cv2.rectangle(img, (left_m, truth_y[0]), (left_m + pw, ours_y[1]), GREY, 1)

    for tick in nice_ticks(0.0, t_hi, 20):
        x = int(u(tick))
        cv2.line(img, (x, height - bottom_m), (x, height - bottom_m + 5), BLACK, 1)
        cv2.putText(img, f"{tick:g}", (x - 8, height - bottom_m + 20), FONT, 0.45, BLACK, 1, cv2.LINE_AA)
    cv2.putText(img, "time (s)", (left_m + pw // 2 - 30, height - 8), FONT, 0.5, BLACK, 1, cv2.LINE_AA)

    cv2.putText(img, title, (left_m, 24), FONT, 0.6, BLACK, 1, cv2.LINE_AA)
    legend = (("spoken number", BLUE), ("missed number (FN)", RED), ("other sound", ORANGE),
              ("outside the view", OUTSIDE), ("judged speaking", GREEN), ("judged silent", LIGHT),
              ("false stretch (FP)", RED))
    x = left_m
    for text, colour in legend:
        cv2.rectangle(img, (x, 42), (x + 16, 54), colour, -1)
        cv2.rectangle(img, (x, 42), (x + 16, 54), GREY, 1)
        cv2.putText(img, text, (x + 22, 53), FONT, 0.45, BLACK, 1, cv2.LINE_AA)
        x += 36 + cv2.getTextSize(text, FONT, 0.45, 1)[0][0]
    cv2.putText(img, f"thin lines: the {INTERVAL_S} s intervals; white: face not found", (x, 53), FONT, 0.4, GREY, 1,
                cv2.LINE_AA)
    return img


def save_timeline(timeline: Timeline, path: Path, title: str) -> None:
    """Write :func:`draw_timeline` as a PNG at ``path`` (its folder is created)."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UserError(f"{path.parent}: cannot create the folder for the timeline figures ({exc})") from None
    if not cv2.imwrite(str(path), draw_timeline(timeline, title)):
        raise UserError(f"{path}: cannot write the timeline figure; choose another --timeline folder")
