"""The Rerun recording of an audio-visual calibration (section 5.3): its figure's time series, for `rerun FILE.rrd`."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from app.av_calibration import CalibrationResult
from app.plotting import BLUE, GREEN, PALE_RED, RED

__all__ = ["log_calibration_rrd"]


def log_calibration_rrd(result: CalibrationResult, path: Path, *, figure_png: Path | None = None) -> None:
    """The figure's three series as Rerun time series (timeline ``time``, seconds) in an ``.rrd`` file.

    Entities: ``calibration/itd/extracted`` (red points), ``calibration/itd/outliers`` (pale red points, robust fit
    only), ``calibration/itd/faces_before`` (blue) and ``calibration/itd/faces_after`` (green), in microseconds;
    the PNG (if given) as ``calibration/figure``.
    """
    import rerun as rr
    import rerun.blueprint as rrb

    rec = rr.RecordingStream("avhear_av_calibration")
    blueprint = rrb.Blueprint(rrb.Vertical(
        rrb.TimeSeriesView(origin="calibration/itd", name="ITD (us) over time"),
        rrb.Spatial2DView(origin="calibration/figure", name="figure"),
    ))
    rec.save(str(path), default_blueprint=blueprint)
    faces = result.faces
    single = faces.single
    rep = result.report

    def points(entity: str, name: str, colour: tuple[int, int, int], t: np.ndarray, y_us: np.ndarray,
               lines: bool = False) -> None:
        style = (rr.SeriesLines(names=name, colors=[colour]) if lines
                 else rr.SeriesPoints(names=name, colors=[colour], markers="circle", marker_sizes=3.0))
        rec.log(entity, style, static=True)
        if t.size:
            rec.send_columns(entity, indexes=[rr.TimeColumn("time", duration=np.asarray(t, dtype=np.float64))],
                             columns=rr.Scalars.columns(scalars=np.asarray(y_us, dtype=np.float64)))

    rgb = lambda bgr: (bgr[2], bgr[1], bgr[0])  # noqa: E731
    t_itd, itd = result.pairs.times_s, result.pairs.itds_s * 1e6
    points("calibration/itd/extracted", "extracted ITDs", rgb(RED), t_itd[rep.inliers], itd[rep.inliers])
    if rep.method == "robust":
        points("calibration/itd/outliers", "outlier ITDs", rgb(PALE_RED), t_itd[~rep.inliers], itd[~rep.inliers])
    t_face = faces.stamps_s[single]
    points("calibration/itd/faces_before", "faces, eq. itd (before)", rgb(BLUE), t_face,
           result.measured.itd(faces.points_xyz[single]) * 1e6, lines=True)
    points("calibration/itd/faces_after", "faces, eq. final_av_mapping (after)", rgb(GREEN), t_face,
           rep.mics.itd(faces.points_xyz[single]) * 1e6, lines=True)
    if figure_png is not None:
        rec.log("calibration/figure", rr.EncodedImage(path=figure_png), static=True)
    rec.flush()
    rec.disconnect()
