"""The default layout of the operator console (a Rerun blueprint), and the saved ``layouts/default.rbl``.

Left, the paper's visualisation tool (section 6, figure vtool) in its own arrangement: the left image with the face
boxes and speaking bars (top left), the bird's-eye view (top right), the ITD space with the histogram and the
fitted Gaussians (bottom left; a tab holds the same histogram as a bar chart with numeric axes), and the speaking
probability of each person over time (bottom right). Right, what the paper did not have: the people's legend shared
by every pane, the 3D scene, the counts and the pipeline's diagnostics, and the events (people appearing and
leaving).

The view origins are the entity paths that :mod:`app.console` logs (its module docstring lists them). This module
does not import :mod:`app` (``app`` uses ``layouts``, not the other way round); a test checks that both agree.

``python -m layouts.blueprint [PATH]`` writes the blueprint (default ``layouts/default.rbl``); open it with a
recording: ``rerun recordings/demo.rrd layouts/default.rbl``.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import rerun.blueprint as rrb

__all__ = ["APPLICATION_ID", "DEFAULT_RBL", "HISTORY_S", "default_blueprint", "main", "save_default_blueprint"]

APPLICATION_ID = "avhear"  # a saved blueprint applies to recordings of this application id
DEFAULT_RBL = Path(__file__).resolve().parent / "default.rbl"
LEGEND_ROWS = 6  # people the legend pane shows (app.console.LEGEND_ROWS)
HISTORY_S = 30.0  # seconds of history the time series show behind the time cursor
_HISTORY_FRAMES = 900  # the same at 30 frames per second, on the frame timeline


def _recent() -> list[rrb.VisibleTimeRange]:
    """A scrolling window over the last :data:`HISTORY_S` seconds, on both timelines."""
    return [
        rrb.VisibleTimeRange("capture_time", start=rrb.TimeRangeBoundary.cursor_relative(seconds=-HISTORY_S),
                             end=rrb.TimeRangeBoundary.cursor_relative()),
        rrb.VisibleTimeRange("frame", start=rrb.TimeRangeBoundary.cursor_relative(seq=-_HISTORY_FRAMES),
                             end=rrb.TimeRangeBoundary.cursor_relative()),
    ]


def default_blueprint(several_pairs: bool = False) -> rrb.Blueprint:
    """The console's default layout: the paper's three panes plus the people's legend, the 3D scene, time series
    and diagnostics.

    Rig-independent: the 2D views fit their bounds to the static data the console logs (the camera's resolution,
    the bird's-eye range rings, the ITD axis), so one saved ``.rbl`` serves every rig. The 3D view looks from
    behind and above the robot at the room ahead (people stand 1-4 m in front of it). ``several_pairs``: an array's
    "ITDs per pair" tab opens in front (every pair's evidence, where the ITD space shows the first pair's).
    """
    image = rrb.Spatial2DView(origin="scene/cameras/left", contents=["+ $origin/**", "- $origin/depth"],
                              name="Left image")  # an RGB-D camera's depth is for the 3D view
    birdseye = rrb.Spatial2DView(origin="birdseye", name="Bird's-eye view (x-z, forward up)")
    itd_space = rrb.Spatial2DView(origin="itd", contents=["+ $origin/**", "- $origin/bars"],
                                  name="ITD space (us; fraction of ITDs per bin; grey: outliers)")
    itd_bars = rrb.BarChartView(origin="itd/bars", name="ITD histogram (counts)")
    itd_pairs = rrb.Spatial2DView(origin="itd_pairs", name="ITDs per pair (us; one row per microphone pair)")
    speaking = rrb.TimeSeriesView(origin="people", name="Speaking probability",
                                  axis_y=rrb.ScalarAxis(range=(0.0, 1.0), zoom_lock=True),
                                  plot_legend=rrb.PlotLegend(rrb.Corner2D.LeftTop), time_ranges=_recent())
    lips = rrb.TimeSeriesView(origin="lips", name="Lip activity (--read-lips)",
                              plot_legend=rrb.PlotLegend(rrb.Corner2D.LeftTop), time_ranges=_recent())
    # scene coordinates are x right, y down, z forward (RDF): the eye 1.2 m above and behind the robot, looking
    # between the robot and the people, so that both are in view
    scene = rrb.Spatial3DView(origin="scene", name="Scene 3D",
                              eye_controls=rrb.EyeControls3D(position=(0.0, -1.2, -1.2), look_target=(0.0, 0.0, 1.2),
                                                             eye_up=(0.0, -1.0, 0.0)))
    legend = rrb.Spatial2DView(origin="legend", name="People (id, state, distance, mean ITD)",
                               visual_bounds=rrb.VisualBounds2D(x_range=(-1.0, 1.0),  # a label centred on x=0
                                                                y_range=(-0.6, LEGEND_ROWS - 0.4)))
    counts = rrb.TimeSeriesView(origin="counts", name="People and ITDs", time_ranges=_recent())
    fps = rrb.TimeSeriesView(origin="diagnostics/fps", name="FPS per stage", time_ranges=_recent())
    latency = rrb.TimeSeriesView(origin="diagnostics/latency_ms", name="Latency (ms)", time_ranges=_recent())
    queues = rrb.TimeSeriesView(
        origin="diagnostics",
        contents=["+ $origin/queue_depth/**", "+ $origin/drops/**", "+ $origin/audio_overflows"],
        name="Queues, drops, overflows", time_ranges=_recent(),
    )
    selfcal = rrb.TimeSeriesView(origin="diagnostics/self_calibration",
                                 name="Self-calibration (--self-calibrate: c1, c0 in us, inliers per pair)",
                                 time_ranges=_recent())
    events = rrb.TextLogView(origin="events", name="Events")
    transcript = rrb.TextLogView(origin="transcript", name="Transcript (--transcribe: who said what)")

    paper = rrb.Vertical(
        rrb.Horizontal(image, birdseye, column_shares=[4, 3]),
        rrb.Horizontal(rrb.Tabs(itd_space, itd_bars, itd_pairs, active_tab=2 if several_pairs else 0),
                       rrb.Tabs(speaking, lips, active_tab=0), column_shares=[4, 3]),
        row_shares=[3, 2],
        name="Vision-guided robot hearing",
    )
    extra = rrb.Vertical(
        legend,
        scene,
        rrb.Tabs(counts, fps, latency, queues, selfcal, active_tab=0),
        rrb.Tabs(transcript, events, active_tab=0),
        row_shares=[2, 3, 2, 1],
        name="Scene and diagnostics",
    )
    return rrb.Blueprint(
        rrb.Horizontal(paper, extra, column_shares=[3, 1]),
        rrb.TimePanel(timeline="capture_time", state="collapsed"),
        rrb.SelectionPanel(state="hidden"),
        rrb.BlueprintPanel(state="collapsed"),
        collapse_panels=False,
    )


def save_default_blueprint(path: str | Path = DEFAULT_RBL, several_pairs: bool = False) -> Path:
    """Write :func:`default_blueprint` to ``path`` (a ``.rbl`` file) and return the path."""
    out = Path(path)
    if out.suffix != ".rbl":
        raise ValueError(f"a blueprint file must end in .rbl, got {str(out)!r}")
    out.parent.mkdir(parents=True, exist_ok=True)
    default_blueprint(several_pairs).save(APPLICATION_ID, out)
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m layouts.blueprint [PATH]``: write the default blueprint."""
    parser = argparse.ArgumentParser(prog="python -m layouts.blueprint", description=__doc__.splitlines()[0])
    parser.add_argument("path", nargs="?", default=str(DEFAULT_RBL), help="where to write the .rbl file")
    args = parser.parse_args(argv)
    out = save_default_blueprint(args.path)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
