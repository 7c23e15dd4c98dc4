"""The paper's figure "calibration" (section 5.3) of an audio-visual calibration, drawn with OpenCV: no plotting
library at run time."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from app.av_calibration import CalibrationResult
from app.errors import UserError
from app.plotting import BLACK, BLUE, FONT, GREEN, GREY, PALE_RED, RED, nice_ticks

__all__ = ["draw_calibration_figure", "save_calibration_figure"]


def draw_calibration_figure(result: CalibrationResult, *, size: tuple[int, int] = (1400, 640)) -> np.ndarray:
    """The paper's figure "calibration" as a BGR image: ITD (microseconds) against time (seconds).

    Red circles: the extracted ITDs of the paired windows (pale red: the ones the robust fit left out as outliers;
    grey: ITDs of windows with no single face to pair with);
    blue: the single faces projected with the input mapping (eq. itd with the hand-measured microphones); green: the
    same faces projected with the fitted mapping (eq. final_av_mapping).
    """
    width, height = size
    left_m, right_m, top_m, bottom_m = 90, 30, 60, 60
    img = np.full((height, width, 3), 255, np.uint8)
    faces = result.faces
    single = faces.single
    t_face = faces.stamps_s[single]
    before = result.measured.itd(faces.points_xyz[single]) * 1e6
    after = result.report.mics.itd(faces.points_xyz[single]) * 1e6
    t_itd = result.pairs.times_s
    itd = result.pairs.itds_s * 1e6
    inl = result.report.inliers

    t_all = np.concatenate([t_face, result.itds.times_s])
    t_lo, t_hi = (float(t_all.min()), float(t_all.max())) if t_all.size else (0.0, 1.0)
    if t_hi <= t_lo:
        t_hi = t_lo + 1.0
    extent = [np.abs(a).max() for a in (before, after, itd) if a.size]
    limit = 1.15 * max(extent) if extent and max(extent) > 0 else result.measured.max_itd_s * 1e6
    y_lo, y_hi = -limit, limit
    pw, ph = width - left_m - right_m, height - top_m - bottom_m

    def px(t: np.ndarray, y: np.ndarray) -> np.ndarray:
        u = left_m + (np.asarray(t) - t_lo) / (t_hi - t_lo) * pw
        v = top_m + (y_hi - np.clip(np.asarray(y), y_lo, y_hi)) / (y_hi - y_lo) * ph
        return np.stack([u, v], axis=-1).round().astype(np.int32)

    for tick in nice_ticks(y_lo, y_hi):
        (u0, v), (u1, _) = px(np.array([t_lo, t_hi]), np.array([tick, tick]))
        cv2.line(img, (int(u0), int(v)), (int(u1), int(v)), (235, 235, 235) if tick else (190, 190, 190), 1)
        cv2.putText(img, f"{tick:g}", (8, int(v) + 5), FONT, 0.45, BLACK, 1, cv2.LINE_AA)
    for tick in nice_ticks(t_lo, t_hi, 12):
        (u, v0), (_, v1) = px(np.array([tick, tick]), np.array([y_lo, y_hi]))
        cv2.line(img, (int(u), int(v0)), (int(u), int(v1)), (235, 235, 235), 1)
        cv2.putText(img, f"{tick:g}", (int(u) - 10, height - bottom_m + 20), FONT, 0.45, BLACK, 1, cv2.LINE_AA)
    cv2.rectangle(img, (left_m, top_m), (left_m + pw, top_m + ph), BLACK, 1)
    cv2.putText(img, "time (s)", (left_m + pw // 2 - 30, height - 12), FONT, 0.55, BLACK, 1, cv2.LINE_AA)
    cv2.putText(img, "ITD (us)", (8, top_m - 12), FONT, 0.55, BLACK, 1, cv2.LINE_AA)

    unpaired = ~np.isin(result.itds.times_s, t_itd)
    for u, v in px(result.itds.times_s[unpaired], result.itds.itds_s[unpaired] * 1e6):
        cv2.circle(img, (int(u), int(v)), 3, GREY, 1, cv2.LINE_AA)
    for (u, v), good in zip(px(t_itd, itd), inl):
        cv2.circle(img, (int(u), int(v)), 4, RED if good else PALE_RED, 1, cv2.LINE_AA)
    for series, colour in ((before, BLUE), (after, GREEN)):
        pts = px(t_face, series)
        # a line through consecutive single-face frames; a gap of more than 0.2 s breaks it
        breaks = np.flatnonzero(np.diff(t_face) > 0.2) + 1
        for piece in np.split(pts, breaks):
            if len(piece) > 1:
                cv2.polylines(img, [piece.reshape(-1, 1, 2)], False, colour, 2, cv2.LINE_AA)
            elif len(piece) == 1:
                cv2.circle(img, tuple(int(c) for c in piece[0]), 2, colour, -1)

    rep = result.report
    title = (f"audio-visual calibration (section 5.3): c1 = {rep.c1:.4f}, c0 = {rep.c0 * 1e6:+.1f} us, "
             f"median |ITD residual| {rep.median_abs_before_s * 1e6:.1f} -> {rep.median_abs_after_s * 1e6:.1f} us")
    cv2.putText(img, title, (left_m, 24), FONT, 0.6, BLACK, 1, cv2.LINE_AA)
    legend = (("extracted ITDs", RED), ("outliers (robust fit)", PALE_RED), ("not paired", GREY),
              ("faces, eq. itd (before)", BLUE),
              ("faces, eq. final_av_mapping (after)", GREEN))
    x = left_m
    for text, colour in legend:
        if colour is PALE_RED and rep.method != "robust":
            continue
        if colour in (RED, PALE_RED, GREY):
            cv2.circle(img, (x + 8, 44), 4, colour, 1, cv2.LINE_AA)
        else:
            cv2.line(img, (x, 44), (x + 18, 44), colour, 2, cv2.LINE_AA)
        cv2.putText(img, text, (x + 24, 49), FONT, 0.5, BLACK, 1, cv2.LINE_AA)
        x += 34 + cv2.getTextSize(text, FONT, 0.5, 1)[0][0]
    return img


def save_calibration_figure(result: CalibrationResult, path: Path) -> None:
    """Write :func:`draw_calibration_figure` as a PNG."""
    if not cv2.imwrite(str(path), draw_calibration_figure(result)):
        raise UserError(f"{path}: cannot write the calibration figure; choose another --figure")


