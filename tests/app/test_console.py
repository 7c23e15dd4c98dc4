"""The Rerun operator console: pure drawing helpers with numbers, and recordings written then read back.

The recordings are written with ``RecordingStream.save`` into ``tmp_path`` and read with rerun's own reader for
0.41 (``rerun.chunk.RrdReader``); no viewer, no network.
"""
from __future__ import annotations

import subprocess
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from app.console import geometry as geo
from app.console import Console, ConsoleFrame
from app.console.viewer import ViewerSession, ViewerTarget, rerun_executable
from avcore.faces import locate_faces
from avcore.geometry import MicArray, MicPair
from avcore.inference import FaceGuidedHearing
from avcore.mixture import Mixture1D
from sim.render import default_scene
from avcore.stereo import StereoRig
from layouts.blueprint import (
    APPLICATION_ID,
    DEFAULT_RBL,
    default_blueprint,
    save_default_blueprint,
)

# A warning from rerun means something was not logged (a bad component value...): make it a failure.
pytestmark = pytest.mark.filterwarnings("error::rerun.error_utils.RerunWarning")

MICS = MicPair()
RIG = StereoRig.ideal(focal_px=554.0, image_size=(640, 480), baseline_m=0.12)


# ---------------------------------------------------------------------------------------------- reading .rrd back
class Rrd:
    """The rows of one recording, by entity path: ``rows[path]`` is a list of (frame or None, {column: value})."""

    def __init__(self, path: Path) -> None:
        self.rows: dict[str, list[tuple[int | None, dict]]] = defaultdict(list)
        for chunk in RrdReader(path).stream().to_chunks():
            batch = chunk.to_record_batch()
            cols = {n: batch.column(n).to_pylist() for n in batch.schema.names
                    if n not in ("rerun.controls.RowId", "log_time", "capture_time")}
            if "capture_time" in batch.schema.names:
                cols["capture_time_ns"] = batch.column("capture_time").cast("int64").to_pylist()
            for i in range(batch.num_rows):
                row = {n: v[i] for n, v in cols.items()}
                self.rows[chunk.entity_path].append((row.pop("frame", None), row))
        for rows in self.rows.values():
            rows.sort(key=lambda r: -1 if r[0] is None else r[0])

    def values(self, path: str, column: str) -> list:
        """The column's value on every row that has it, in frame order (static rows first)."""
        return [row[column] for _, row in self.rows[path] if row.get(column) is not None]

    def frames(self, path: str, column: str) -> list[int | None]:
        return [f for f, row in self.rows[path] if row.get(column) is not None]


def _tensor(value: list) -> np.ndarray:
    """A logged tensor (BarChart values, abscissa): one row holding {shape, names, buffer}."""
    (tensor,) = value
    buffer = tensor["buffer"]
    data = buffer[1] if isinstance(buffer, tuple) else buffer  # a dense union reads as (type name, values)
    return np.asarray(data).reshape(tensor["shape"])


# ---------------------------------------------------------------------------------------------- pure helpers
def test_speaking_circle_is_darker_when_more_likely() -> None:
    rgba = geo.speaking_rgba(np.array([0.0, 0.5, 1.0]))
    assert rgba.dtype == np.uint8 and rgba.shape == (3, 4)
    assert rgba[:, 0].tolist() == [255, 128, 0]
    assert np.all(rgba[:, 0] == rgba[:, 1]) and np.all(rgba[:, 1] == rgba[:, 2])  # grey
    assert np.all(np.diff(rgba[:, 3].astype(int)) > 0)  # more opaque as well


def test_colours_pack_as_rrggbbaa() -> None:
    packed = geo.pack_rgba(np.array([[1, 2, 3], [255, 0, 16]], np.uint8))
    assert packed.dtype == np.uint32 and packed.tolist() == [0x010203FF, 0xFF0010FF]
    assert geo.pack_rgba(np.array([[1, 2, 3, 4]], np.uint8)).tolist() == [0x01020304]
    with pytest.raises(ValueError, match="colors"):
        geo.pack_rgba(np.zeros((2, 5), np.uint8))


def test_the_speaking_bar_sits_above_the_face() -> None:
    """A bar 5 px above each box, from its left edge, as long as the probability of its width: the face uncovered."""
    bars = geo.speaking_bars_px(np.array([[10.0, 20.0, 40.0, 60.0], [100.0, 50.0, 20.0, 20.0]]), np.array([0.25, 1.0]))
    np.testing.assert_allclose(bars, [[[10.0, 15.0], [20.0, 15.0]], [[100.0, 45.0], [120.0, 45.0]]])
    assert geo.speaking_bars_px(np.zeros((0, 4)), np.zeros(0)).shape == (0, 2, 2)


def test_head_circles_project_onto_the_left_image() -> None:
    centres, radii = geo.head_circles_px(RIG, np.array([[0.06, 0.0, 2.0]]), 0.1)
    # (0.06, 0, 2) is straight ahead of the left camera centre (-0.06) offset by 0.12 m: u = cx + f 0.12 / 2
    np.testing.assert_allclose(centres, [[319.5 + 554.0 * 0.12 / 2.0, 239.5]])
    np.testing.assert_allclose(radii, [554.0 * 0.1 / 2.0])


def test_birdseye_puts_forward_up() -> None:
    np.testing.assert_allclose(geo.birdseye(np.array([[1.0, 5.0, 2.0], [-0.5, 0.0, 0.3]])),
                               [[1.0, -2.0], [-0.5, -0.3]])


def test_fields_of_view_open_symmetrically_from_each_camera() -> None:
    strips = geo.fov_strips_birdseye(RIG, depth_m=6.0)
    assert strips.shape == (2, 3, 2)
    np.testing.assert_allclose(strips[:, 1], [[-0.06, 0.0], [0.06, 0.0]])  # the camera centres
    np.testing.assert_allclose(strips[:, [0, 2], 1], -6.0)  # edges at 6 m depth, drawn upwards
    half_width = 6.0 * 320.0 / 554.0  # edges of the outer pixels, u = -0.5 and 639.5
    np.testing.assert_allclose(strips[0, 0, 0], -0.06 - half_width)
    np.testing.assert_allclose(strips[0, 2, 0], -0.06 + half_width)
    angle = np.degrees(2 * np.arctan(320.0 / 554.0))
    assert 59.0 < angle < 61.0  # the default scene's 60 degree field of view


def test_range_rings_are_half_circles_in_front() -> None:
    rings = geo.range_rings_birdseye(np.array([1.0, 2.5]), n_points=31)
    assert rings.shape == (2, 31, 2)
    np.testing.assert_allclose(np.linalg.norm(rings, axis=-1), [[1.0] * 31, [2.5] * 31])
    assert np.all(rings[..., 1] <= 1e-12)  # in front of the robot, i.e. up in the view
    np.testing.assert_allclose(rings[:, [0, -1], 0], [[-1.0, 1.0], [-2.5, 2.5]], atol=1e-12)


def test_robot_box_holds_every_sensor() -> None:
    mics = MicPair(left=(-0.1, 0.02, 0.03), right=(0.1, 0.02, 0.03))
    lo, hi = geo.robot_bounds(mics, RIG, margin_m=0.04)
    np.testing.assert_allclose(lo, [-0.14, -0.04, -0.04])
    np.testing.assert_allclose(hi, [0.14, 0.06, 0.07])


def test_itd_pane_covers_the_reachable_interval_with_whole_bins() -> None:
    pane = geo.ItdPane.for_mics(MICS, bin_s=10e-6)
    lo, hi = MICS.itd_interval()
    assert pane.range_s[0] < lo and pane.range_s[1] > hi
    np.testing.assert_allclose(pane.range_s[1] - pane.range_s[0], 1.5 * (hi - lo))
    edges = pane.edges_s
    np.testing.assert_allclose(np.diff(edges), 10e-6)
    assert edges[0] <= pane.range_s[0] and edges[-1] >= pane.range_s[1]
    assert edges[-1] - edges[0] < pane.range_s[1] - pane.range_s[0] + 10e-6
    np.testing.assert_allclose(0.5 * (edges[0] + edges[-1]), 0.0, atol=1e-15)  # symmetric around c0 = 0
    np.testing.assert_allclose(pane.xy(np.array([1e-4]), np.array([0.5])), [[100.0, -0.5 * pane.height_per_fraction]])


def test_itd_pane_rejects_a_bad_range() -> None:
    with pytest.raises(ValueError, match="range_s"):
        geo.ItdPane((1e-4, -1e-4), 1e-5, 100.0)
    with pytest.raises(ValueError, match="bin_s"):
        geo.ItdPane((-1e-4, 1e-4), 0.0, 100.0)


def test_histogram_counts_inside_and_reports_the_rest() -> None:
    edges = np.array([-2e-4, -1e-4, 0.0, 1e-4, 2e-4])
    counts, outside = geo.itd_histogram(np.array([-1.5e-4, 0.5e-4, 0.6e-4, 1.5e-4, 3e-4, np.nan, -9e-4]), edges)
    assert counts.tolist() == [1, 0, 2, 1]
    assert outside == 3


def test_histogram_outline_steps_along_the_bar_tops() -> None:
    xs, ys = geo.histogram_outline(np.array([0.0, 1.0, 2.0]), np.array([3.0, 5.0]))
    assert xs.tolist() == [0.0, 0.0, 1.0, 1.0, 2.0, 2.0]
    assert ys.tolist() == [0.0, 3.0, 3.0, 5.0, 5.0, 0.0]
    assert np.trapezoid(ys, xs) == pytest.approx(8.0)  # the area of the bars


def test_gaussian_curve_predicts_the_fraction_of_itds_per_bin() -> None:
    model = Mixture1D(np.array([0.6, 0.3, 0.1]), np.array([-1e-4, 1.2e-4]), np.array([1e-9, 4e-10]),
                      MICS.itd_interval())
    bin_s = 10e-6
    curves = geo.gaussian_curves(model, bin_s, n_points=401)
    assert len(curves) == 2
    for n, (x, y) in enumerate(curves):
        sigma = np.sqrt(model.variances[n])
        np.testing.assert_allclose([x[0], x[-1]], model.means[n] + np.array([-4, 4]) * sigma)
        peak = model.weights[n] * bin_s / np.sqrt(2 * np.pi * model.variances[n])
        assert y.max() == pytest.approx(peak, rel=1e-6)
        # integrated over ITD space, y / bin_s gives the component's weight (within 4 sigma: 99.994%)
        assert np.trapezoid(y, x) / bin_s == pytest.approx(model.weights[n], rel=1e-3)
    clipped = geo.gaussian_curves(model, bin_s, clip_s=(2e-4, 1e-3))  # mu_0 + 4 sigma_0 = 26 us
    assert clipped[0][0].size == 0  # entirely left of the shown range
    assert geo.outlier_level(model, bin_s) == pytest.approx(0.1 * bin_s / (MICS.itd_interval()[1] * 2))


def test_gaussian_curve_lies_on_the_histogram_of_its_samples() -> None:
    rng = np.random.default_rng(3)
    mu, sigma = 5e-5, 3.2e-5
    itds = rng.normal(mu, sigma, 20000)
    pane = geo.ItdPane.for_mics(MICS, bin_s=10e-6)
    counts, outside = geo.itd_histogram(itds, pane.edges_s)
    assert outside == 0
    model = Mixture1D(np.array([1.0 - 1e-12, 1e-12]), np.array([mu]), np.array([sigma**2]), MICS.itd_interval())
    centres = 0.5 * (pane.edges_s[1:] + pane.edges_s[:-1])
    predicted = model.component_densities(centres)[:, 0] * pane.bin_s
    near = np.abs(centres - mu) < sigma
    np.testing.assert_allclose(counts[near] / itds.size, predicted[near], rtol=0.1)


def test_person_colours_are_stable_per_id() -> None:
    c = geo.person_colors(np.array([0, 3, 10, 13]))
    assert c.shape == (4, 3) and c.dtype == np.uint8
    assert np.array_equal(c[0], c[2]) and np.array_equal(c[1], c[3]) and not np.array_equal(c[0], c[1])


def test_arrow_fast_paths_equal_rerun_conversions() -> None:
    """The console hands strips and bar counts to Rerun as ready Arrow arrays: the same arrays Rerun would build."""
    from app.console.console import _CountsTensor, _strips_2d

    rng = np.random.default_rng(5)
    strips = [rng.normal(size=(64, 2)), np.zeros((0, 2)), rng.normal(size=(3, 2))]
    assert _strips_2d(strips).equals(rr.components.LineStrip2DBatch(strips).as_arrow_array())
    first, later = rng.integers(0, 9, 105), rng.integers(0, 9, 105)
    tensor = _CountsTensor(first)
    assert tensor.first.equals(rr.components.TensorDataBatch(first).as_arrow_array())
    assert tensor(later).equals(rr.components.TensorDataBatch(later).as_arrow_array())
    with pytest.raises(ValueError, match="counts must have shape"):
        tensor(later[:5])


# ---------------------------------------------------------------------------------------------- ConsoleFrame
def _console_to_file(path: Path) -> tuple[rr.RecordingStream, Console]:
    """A console logging to a fresh .rrd at ``path``."""
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    return rec, Console(RIG, MICS, recording=rec)


def _frame(**kw: object) -> ConsoleFrame:
    base: dict[str, object] = {
        "stamp_s": 0.0, "frame": 0, "image": None, "boxes": np.array([[10.0, 10.0, 50.0, 50.0]]),
        "faces_xyz": np.array([[0.0, 0.0, 2.0]]), "speaking": np.array([True]), "probability": np.array([0.9]),
        "itds_s": np.array([1e-5, -2e-5]),
    }
    base.update(kw)
    return ConsoleFrame(**base)  # type: ignore[arg-type]


def test_console_frame_defaults_and_empty_scene() -> None:
    f = _frame()
    assert f.person_ids.tolist() == [0] and f.n_people == 1 and f.diagnostics == {}
    empty = _frame(boxes=np.zeros((0, 4)), faces_xyz=np.zeros((0, 3)), speaking=[], probability=[], itds_s=[])
    assert empty.n_people == 0 and empty.speaking.dtype == bool


@pytest.mark.parametrize(("kw", "match"), [
    ({"boxes": np.zeros((2, 4))}, "boxes must have one row per face"),
    ({"probability": np.array([1.5])}, r"probability must lie in \[0, 1\]"),
    ({"image": np.zeros((4, 4), np.float32)}, "uint8"),
    ({"itds_s": np.zeros((2, 2, 2))}, r"itds_s must be a \(K,\) or \(K, P\) array"),
    ({"probability": np.array([[0.5]])}, "probability must be a 1-D array"),
    ({"faces_xyz": np.array([[np.nan, 0.0, 1.0]])}, "finite"),
    ({"person_ids": np.array([4, 4]), "faces_xyz": np.ones((2, 3)), "boxes": np.ones((2, 4)), "speaking": [True, False],
      "probability": [0.5, 0.5]}, "distinct"),
    ({"model": Mixture1D.outliers_only((-1e-4, 1e-4))}, "model has 0 Gaussian components but there are 1"),
    ({"diagnostics": {"fps vision": 3.0}}, "diagnostics key"),
    ({"stamp_s": float("nan")}, "stamp_s"),
])
def test_console_frame_rejects_inconsistent_input(kw: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        _frame(**kw)


def test_console_frame_rejects_wrong_types() -> None:
    with pytest.raises(TypeError, match="speaking must be an array of bool"):
        _frame(speaking=np.array([0.7]))
    with pytest.raises(TypeError, match="person_ids must be integers"):
        _frame(person_ids=np.array([1.0]))
    with pytest.raises(TypeError, match="frame must be an int"):
        _frame(frame=1.0)
    with pytest.raises(TypeError, match="diagnostics"):
        _frame(diagnostics={"fps/vision": "fast"})


def test_console_rejects_bad_settings() -> None:
    with pytest.raises(ValueError, match="jpeg_quality"):
        Console(RIG, MICS, recording=rr.RecordingStream(APPLICATION_ID), jpeg_quality=0)
    with pytest.raises(TypeError, match="rig must be a StereoRig"):
        Console(object(), MICS)  # type: ignore[arg-type]


# ---------------------------------------------------------------------------------------------- recordings
@pytest.fixture(scope="module")
def scene(face_finder) -> dict:  # noqa: ANN001
    """One rendered 640x480 frame of the default scene (three drawn faces) and its F3D faces."""
    renderer = default_scene()
    frame = renderer.render(0.0)
    faces = locate_faces(frame.left, frame.right, renderer.rig, detector=face_finder)
    assert len(faces) == 3
    return {"rig": renderer.rig, "image": frame.left, "boxes": faces.boxes, "xyz": faces.points}


def _itds_of_speaker(xyz: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """ITDs of an interval in which person 1 speaks: 14 around its mapped ITD, 3 outliers, 1 far off the axis."""
    return np.concatenate([MICS.itd(xyz[1]) + rng.normal(0.0, 2e-5, 14), rng.uniform(-3e-4, 3e-4, 3), [2e-3]])


@pytest.fixture(scope="module")
def recorded(scene: dict, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Five frames logged to a .rrd: three people for four frames, then person 2 leaves."""
    path = tmp_path_factory.mktemp("console") / "run.rrd"
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    console = Console(scene["rig"], MICS, recording=rec)
    fg = FaceGuidedHearing(MICS)
    rng = np.random.default_rng(0)
    logged = []
    for i in range(5):
        n = 3 if i < 4 else 2
        itds = _itds_of_speaker(scene["xyz"], rng)
        out = fg.step(scene["xyz"][:n], itds)
        frame = ConsoleFrame.from_face_guided(
            10.0 + i / 30.0, i, scene["image"], scene["boxes"][:n], scene["xyz"][:n], itds, out,
            person_ids=np.array([7, 8, 9])[:n],
            diagnostics={"fps/vision": 30.0 - i, "latency_ms/capture_to_log": 12.5, "audio_overflows": 0},
        )
        console.log(frame)
        logged.append((frame, out))
    rec.disconnect()
    return {"rrd": Rrd(path), "logged": logged, "path": path}


def test_static_rig_microphones_and_cameras(recorded: dict, scene: dict) -> None:
    rrd = recorded["rrd"]
    assert rrd.frames("/scene/robot/mics", "Points3D:positions") == [None]  # static
    np.testing.assert_allclose(rrd.values("/scene/robot/mics", "Points3D:positions")[0], [MICS.left, MICS.right])
    assert rrd.values("/scene/cameras/left", "Pinhole:resolution")[0] == [[640.0, 480.0]]
    k = np.array(rrd.values("/scene/cameras/left", "Pinhole:image_from_camera")[0]).reshape(3, 3).T
    np.testing.assert_allclose(k, scene["rig"].proj_left[:, :3])
    np.testing.assert_allclose(rrd.values("/scene/cameras/right", "Transform3D:translation")[0], [[0.06, 0.0, 0.0]])
    assert len(rrd.values("/birdseye/fov", "LineStrips2D:strips")[0]) == 2
    assert rrd.values("/scene", "ViewCoordinates:xyz")  # right-down-forward


def test_timelines_follow_frame_numbers_and_capture_stamps(recorded: dict) -> None:
    rows = recorded["rrd"].rows["/counts"]
    timed = [(f, row["capture_time_ns"]) for f, row in rows if f is not None]
    assert [f for f, _ in timed] == [0, 1, 2, 3, 4]
    np.testing.assert_allclose([t * 1e-9 for _, t in timed], 10.0 + np.arange(5) / 30.0, atol=1e-9)


def test_left_image_is_logged_as_jpeg_close_to_the_original(recorded: dict, scene: dict) -> None:
    rrd = recorded["rrd"]
    assert rrd.values("/scene/cameras/left/image", "EncodedImage:media_type")[0] == ["image/jpeg"]
    blobs = rrd.values("/scene/cameras/left/image", "EncodedImage:blob")
    assert len(blobs) == 5
    jpeg = np.frombuffer(bytes(blobs[0][0]), np.uint8)
    decoded = cv2.imdecode(jpeg, cv2.IMREAD_COLOR)
    assert decoded.shape == scene["image"].shape
    assert np.mean(np.abs(decoded.astype(float) - scene["image"])) < 6.0
    assert jpeg.size < scene["image"].nbytes / 5


def test_face_boxes_and_speaking_bars(recorded: dict, scene: dict) -> None:
    rrd = recorded["rrd"]
    _, out = recorded["logged"][0]
    assert out.speaking.tolist() == [False, True, False]
    path = "/scene/cameras/left/faces"  # one instance per person, in the frame's order
    x, y, w, h = scene["boxes"].T
    centres = np.stack([x + w / 2, y + h / 2], 1)
    np.testing.assert_allclose(rrd.values(path, "Boxes2D:centers")[0], centres, rtol=1e-6)
    np.testing.assert_allclose(rrd.values(path, "Boxes2D:half_sizes")[0], np.stack([w / 2, h / 2], 1), rtol=1e-6)
    # nothing is drawn over the faces: the ids are written above each bar, at the box's left edge
    assert "Boxes2D:labels" not in rrd.rows[path][0][1]
    assert rrd.values(path, "Points2D:labels")[0] == ["7", "8", "9"]
    ids_at = np.array(rrd.values(path, "Points2D:positions")[0])
    np.testing.assert_allclose(ids_at[:, 0], x, rtol=1e-6)
    assert (ids_at[:, 1] < y - 10).all()
    assert rrd.values(path, "Boxes2D:radii")[0] == [1.5, 3.0, 1.5]  # the speaker's box is the thick one
    colours = rrd.values(path, "Boxes2D:colors")[0]
    assert colours == geo.pack_rgba(geo.person_colors(np.array([7, 8, 9]))).tolist()
    bars = np.array(rrd.values(path, "LineStrips2D:strips")[0])  # above each box, as long as its probability
    np.testing.assert_allclose(bars, geo.speaking_bars_px(scene["boxes"], out.probability), rtol=1e-6)
    lengths = bars[:, 1, 0] - bars[:, 0, 0]
    assert lengths[1] > 0.5 * w[1] > max(lengths[0], lengths[2])  # the speaker's bar is the long one
    assert (bars[:, 0, 1] < y).all()
    assert len(rrd.values(path, "Boxes2D:centers")[-1]) == 2  # person 9 gone at the last frame: two boxes left


def test_birdseye_heads_and_3d_heads(recorded: dict, scene: dict) -> None:
    rrd = recorded["rrd"]
    _, out = recorded["logged"][0]
    xyz = scene["xyz"]
    circles = "/birdseye/heads/circles"
    np.testing.assert_allclose(rrd.values(circles, "Ellipses2D:centers")[0], np.stack([xyz[:, 0], -xyz[:, 2]], 1),
                               rtol=1e-6)
    np.testing.assert_allclose(rrd.values(circles, "Ellipses2D:half_sizes")[0], [[0.09, 0.09]] * 3, rtol=1e-6)
    assert rrd.values(circles, "Ellipses2D:labels")[0] == ["7", "8", "9"]  # the legend says the rest
    # person 8 speaks: a solid head; 7 and 9 are wireframes
    np.testing.assert_allclose(rrd.values("/scene/heads/speaking", "Ellipsoids3D:centers")[0], xyz[[1]], rtol=1e-6)
    np.testing.assert_allclose(rrd.values("/scene/heads/silent", "Ellipsoids3D:centers")[0], xyz[[0, 2]], rtol=1e-6)
    assert rrd.values("/scene/heads/speaking", "Ellipsoids3D:labels")[0] == ["8"]
    solid, wire = (rrd.values(f"/scene/heads/{s}", "Ellipsoids3D:fill_mode")[0] for s in ("speaking", "silent"))
    assert solid == [rr.components.FillMode.Solid.value] and wire == [rr.components.FillMode.MajorWireframe.value]


def test_itd_histogram_and_fitted_gaussians(recorded: dict, scene: dict) -> None:
    rrd = recorded["rrd"]
    frame, out = recorded["logged"][0]
    counts = _tensor(rrd.values("/itd/bars", "BarChart:values")[0])
    abscissa = _tensor(rrd.values("/itd/bars", "BarChart:abscissa")[0])
    assert counts.shape == abscissa.shape == (105,)  # 1050 us in 10 us bins
    assert len(rrd.values("/itd/bars", "BarChart:values")) == 5
    assert rrd.frames("/itd/bars", "BarChart:abscissa") == [0]  # the bars' positions are sent once
    assert counts.sum() == frame.itds_s.size - 1  # the 2 ms ITD lies off the axis
    # microseconds: +-350 us reachable, widened by a quarter of its 700 us on each side
    np.testing.assert_allclose(abscissa[[0, -1]], [-520.0, 520.0])
    mapped_us = MICS.itd(scene["xyz"][1]) * 1e6
    assert abs(abscissa[np.argmax(counts)] - mapped_us) < 60.0  # the histogram peaks at the speaker
    # the count in the pane's top right corner: clear of the axis' labels
    assert rrd.values("/itd/histogram/count", "Points2D:labels")[0] == ["18 ITDs (1 outside the axis)"]
    corner = np.array(rrd.values("/itd/histogram/count", "Points2D:positions")[0][0])
    pane = geo.ItdPane.for_mics(MICS)
    np.testing.assert_allclose(corner, [pane.range_s[1] * 1e6, -0.2 * pane.height_per_fraction], rtol=1e-6)
    strip = np.array(rrd.values("/itd/histogram", "LineStrips2D:strips")[0][0])
    assert strip.shape == (2 * counts.size + 2, 2) and np.all(strip[:, 1] <= 0)  # bars drawn upwards
    gaussians = "/itd/faces/gaussians"  # one strip per face, in the frame's order: person 8 is the second
    curve = np.array(rrd.values(gaussians, "LineStrips2D:strips")[0][1])
    peak_x_us = curve[np.argmin(curve[:, 1]), 0]
    step_us = 8 * np.sqrt(out.model.variances[1]) * 1e6 / 63  # 64 points over mu +- 4 sigma
    assert peak_x_us == pytest.approx(out.model.means[1] * 1e6, abs=0.5 * step_us + 1e-3)
    np.testing.assert_allclose(rrd.values(gaussians, "Points2D:positions")[0][1], [mapped_us, 0.0], atol=1e-3)
    # each person's label sits at the top of their Gaussian, clear of the axis' tick labels
    label_at = np.array(rrd.values(f"{gaussians}/labels", "Points2D:positions")[0][1])
    np.testing.assert_allclose(label_at, curve[np.argmin(curve[:, 1])], atol=1e-6)
    assert rrd.values(f"{gaussians}/labels", "Points2D:labels")[0][1] == "8"  # its mean is in the legend
    # the vertical scale: 0.2 of the ITDs per bin rises half the pane's width (a 2:1 pane), so the speaker's
    # Gaussian (about 0.12 per bin) fills most of its height
    lo_s, hi_s = geo.ItdPane.for_mics(MICS).range_s
    assert geo.ItdPane.for_mics(MICS).height_per_fraction * 0.2 == pytest.approx((hi_s - lo_s) * 1e6 / 2)
    # the speaker's curve is the tall one
    tallest = [-np.array(strip)[:, 1].min() for strip in rrd.values(gaussians, "LineStrips2D:strips")[0]]
    assert tallest[1] > 5 * max(tallest[0], tallest[2])


def test_time_series_per_person_counts_and_diagnostics(recorded: dict) -> None:
    rrd = recorded["rrd"]
    logged = recorded["logged"]
    series = rrd.values("/people/8/speaking_probability", "Scalars:scalars")
    np.testing.assert_allclose([s[0] for s in series], [out.probability[1] for _, out in logged])
    assert rrd.values("/people/8/speaking_probability", "SeriesLines:names") == [["person 8"]]
    assert len(rrd.values("/people/9/speaking_probability", "Scalars:scalars")) == 4
    counts = rrd.values("/counts", "Scalars:scalars")  # people, speakers, ITDs
    assert rrd.values("/counts", "SeriesLines:names") == [["people", "speakers", "ITDs in the interval"]]
    assert [v[0] for v in counts] == [3, 3, 3, 3, 2]
    assert [v[1] for v in counts] == [int(np.count_nonzero(out.speaking)) for _, out in logged]
    assert [v[2] for v in counts] == [18] * 5
    assert [v[0] for v in rrd.values("/diagnostics/fps/vision", "Scalars:scalars")] == [30, 29, 28, 27, 26]
    assert rrd.values("/diagnostics/latency_ms/capture_to_log", "Scalars:scalars")[0] == [12.5]


def test_departed_person_is_gone_everywhere(recorded: dict) -> None:
    rrd = recorded["rrd"]
    # a frame replaces the people of the last one: person 9 (third) is in none of the last frame's instances
    last = {"/scene/cameras/left/faces": "Points2D:labels", "/birdseye/heads/circles": "Ellipses2D:labels",
            "/itd/faces/gaussians/labels": "Points2D:labels", "/legend": "Points2D:labels"}
    for path, column in last.items():
        ids = [[next(w for w in lb.split() if w.isdigit()) for lb in labels] for labels in rrd.values(path, column)]
        assert ids[-1] == ["7", "8"] and all(row == ["7", "8", "9"] for row in ids[:-1]), path
    heads = rrd.values("/scene/heads/speaking", "Ellipsoids3D:labels") + rrd.values("/scene/heads/silent",
                                                                                    "Ellipsoids3D:labels")
    assert sum(lb == "9" for frame in heads for lb in frame) == 4  # in frames 0..3 only
    texts = rrd.values("/events", "TextLog:text")
    assert texts == [["person 7 appeared; person 8 appeared; person 9 appeared"], ["person 9 left"]]


def test_motion_guided_frame_without_boxes_with_points(scene: dict, tmp_path: Path) -> None:
    @dataclass
    class Output:  # the fields of MotionGuidedOutput the console reads
        positions: np.ndarray
        speaking: np.ndarray
        probability: np.ndarray
        model: Mixture1D | None

    points = np.random.default_rng(1).normal([0.1, 0.0, 2.1], 0.05, (50, 3))
    out = Output(scene["xyz"][1:2], np.array([True]), np.array([0.8]), None)
    path = tmp_path / "motion.rrd"
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    console = Console(scene["rig"], MICS, recording=rec, jpeg_quality=None, capture_epoch_s=1.7e9)
    console.log(ConsoleFrame.from_motion_guided(0.5, 0, scene["image"], points, np.array([1e-5]), out))
    console.log(ConsoleFrame.from_motion_guided(0.6, 1, None, None, np.array([1e-5]), out))  # type: ignore[arg-type]
    rec.disconnect()
    rrd = Rrd(path)
    buffer = rrd.values("/scene/cameras/left/image", "Image:buffer")
    assert len(buffer) == 1 and bytes(buffer[0][0]) == scene["image"].tobytes()  # raw, exact
    assert "Boxes2D:centers" not in rrd.rows["/scene/cameras/left/faces"][0][1]
    centre, radius = geo.head_circles_px(scene["rig"], scene["xyz"][1:2], 0.09)
    np.testing.assert_allclose(rrd.values("/scene/cameras/left/faces", "Ellipses2D:centers")[0], centre, rtol=1e-6)
    np.testing.assert_allclose(rrd.values("/scene/cameras/left/faces", "Ellipses2D:half_sizes")[0],
                               [[radius[0], radius[0]]], rtol=1e-6)  # a ring around the head, not a disc on it
    np.testing.assert_allclose(rrd.values("/scene/hm3d_points", "Points3D:positions")[0], points, rtol=1e-6)
    assert rrd.frames("/scene/hm3d_points", "Clear:is_recursive") == [1]
    stamps = [row["capture_time_ns"] for f, row in rrd.rows["/counts"] if f is not None]
    np.testing.assert_allclose(np.array(stamps) * 1e-9, [1.7e9 + 0.5, 1.7e9 + 0.6])  # a timestamp timeline


def test_image_every_thins_the_images_not_the_overlays(scene: dict, tmp_path: Path) -> None:
    path = tmp_path / "thin.rrd"
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    console = Console(scene["rig"], MICS, recording=rec, image_every=2)
    for i in range(5):
        console.log(_frame(frame=i, image=scene["image"]))
    rec.disconnect()
    rrd = Rrd(path)
    assert rrd.frames("/scene/cameras/left/image", "EncodedImage:blob") == [0, 2, 4]
    assert rrd.frames("/scene/cameras/left/faces", "Boxes2D:centers") == [0, 1, 2, 3, 4]


def test_empty_scene_and_silence_are_logged(tmp_path: Path) -> None:
    path = tmp_path / "empty.rrd"
    rec, console = _console_to_file(path)
    nobody = {"boxes": np.zeros((0, 4)), "faces_xyz": np.zeros((0, 3)), "speaking": np.zeros(0, bool),
              "probability": np.zeros(0)}
    console.log(_frame(frame=0, itds_s=np.zeros(0), **nobody))
    console.log(_frame(frame=1, model=Mixture1D.outliers_only(MICS.itd_interval()), **nobody))
    rec.disconnect()
    rrd = Rrd(path)
    assert rrd.values("/counts", "Scalars:scalars") == [[0, 0, 0], [0, 0, 2]]
    assert _tensor(rrd.values("/itd/bars", "BarChart:values")[1]).sum() == 2
    assert rrd.frames("/itd/outliers", "LineStrips2D:strips") == [1]  # no model at frame 0, outliers only at 1


def test_people_leaving_and_repeated_silence(tmp_path: Path) -> None:
    """The last person going clears the batched entities once; the same empty histogram is not sent again."""
    path = tmp_path / "leaving.rrd"
    rec, console = _console_to_file(path)
    nobody = {"boxes": np.zeros((0, 4)), "faces_xyz": np.zeros((0, 3)), "speaking": np.zeros(0, bool),
              "probability": np.zeros(0), "itds_s": np.zeros(0)}
    model = Mixture1D(np.array([0.9, 0.1]), np.array([1e-5]), np.array([1e-9]), MICS.itd_interval())
    console.log(_frame(frame=0, model=model))
    for i in (1, 2, 3):
        console.log(_frame(frame=i, **nobody))
    rec.disconnect()
    rrd = Rrd(path)
    for entity in ("/scene/cameras/left/faces", "/birdseye/heads/circles", "/scene/heads/speaking",
                   "/itd/faces/gaussians", "/itd/outliers"):
        assert rrd.frames(entity, "Clear:is_recursive") == [1], entity
    assert rrd.frames("/scene/heads/silent", "Ellipsoids3D:centers") == []  # nobody silent: never logged
    assert rrd.frames("/itd/histogram", "LineStrips2D:strips") == [0, 1]  # frames 2 and 3: the same, not resent
    assert rrd.frames("/itd/bars", "BarChart:values") == [0, 1]
    assert rrd.values("/itd/histogram/count", "Points2D:labels")[-1] == ["0 ITDs"]
    assert [v[0] for v in rrd.values("/counts", "Scalars:scalars")] == [1, 0, 0, 0]  # the series go on


def test_image_of_the_wrong_size_is_refused(scene: dict) -> None:
    console = Console(scene["rig"], MICS, recording=rr.RecordingStream(APPLICATION_ID))
    with pytest.raises(ValueError, match="rig's size"):
        console.log(_frame(image=np.zeros((240, 320, 3), np.uint8)))


def test_jpeg_keeps_a_frame_several_times_smaller_than_raw(scene: dict) -> None:
    sizes = {}
    for quality in (None, 80):
        rec = rr.RecordingStream(APPLICATION_ID)
        stream = rec.memory_recording()
        console = Console(scene["rig"], MICS, recording=rec, jpeg_quality=quality)
        stream.drain_as_bytes()  # the static data
        for i in range(3):
            console.log(_frame(frame=i, image=scene["image"]))
        rec.flush()
        sizes[quality] = len(stream.drain_as_bytes()) / 3
    assert sizes[None] > 0.5 * scene["image"].nbytes  # the file sink's LZ4 does not shrink a noisy image much
    assert sizes[80] < sizes[None] / 5


# ---------------------------------------------------------------------------------------------- blueprint
def _origins(path: Path) -> set[str]:
    reader = RrdReader(path)
    (store,) = reader.blueprints()
    assert store.application_id == APPLICATION_ID
    out = set()
    for chunk in reader.stream(store=store).to_chunks():
        batch = chunk.to_record_batch()
        if "ViewBlueprint:space_origin" in batch.schema.names:
            out.update(o for v in batch.column("ViewBlueprint:space_origin").to_pylist() for o in v)
    return out


@pytest.fixture(scope="module")
def recorded_pairs(scene: dict, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """Three frames of a console with NAO's four microphones (six pairs): (K, P) ITD vectors of person 0."""
    array = MicArray.preset("nao")
    path = tmp_path_factory.mktemp("console") / "pairs.rrd"
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    console = Console(scene["rig"], array.pair(0), recording=rec, array=array)
    fg = FaceGuidedHearing(array)
    rng = np.random.default_rng(1)
    xyz = scene["xyz"]
    for i in range(3):
        itds = array.itd(xyz[0]) + rng.normal(0.0, 15e-6, (20, array.n_pairs))
        itds[::4, 3] = np.nan  # a pair's energy gate rejected some windows
        out = fg.step(xyz, itds)
        console.log(ConsoleFrame.from_face_guided(10.0 + i / 30.0, i, scene["image"], scene["boxes"], xyz, itds,
                                                  out))
    rec.disconnect()
    return {"rrd": Rrd(path), "array": array, "xyz": xyz}


def test_every_pair_gets_its_histogram_and_the_people_on_it(recorded_pairs: dict) -> None:
    rrd, array = recorded_pairs["rrd"], recorded_pairs["array"]
    strips = rrd.values("/itd_pairs/histograms", "LineStrips2D:strips")
    assert len(strips) == 3 and len(strips[-1]) == array.n_pairs
    labels = rrd.values("/itd_pairs/labels", "Points2D:labels")[-1]
    assert labels[0] == f"mics {array.pairs[0][0]}-{array.pairs[0][1]}: 20 ITDs" and labels[3].endswith(": 15 ITDs")
    # each row on the ITD pane's scale: its bars rise from the row's line, at most a row high (clipped as there),
    # and the talker's peak fills most of it; the labels sit at the rows' left ends, half a row up
    from app.console.entities import PAIR_ROW

    for k, strip in enumerate(strips[-1]):
        ys = np.array(strip)[:, 1]
        assert ys.max() == pytest.approx(k * PAIR_ROW) and ys.min() >= k * PAIR_ROW - PAIR_ROW - 1e-6
    assert np.array(strips[-1][0])[:, 1].min() < -0.5 * PAIR_ROW
    corners = np.array(rrd.values("/itd_pairs/labels", "Points2D:positions")[-1])
    np.testing.assert_allclose(corners[:, 1], np.arange(array.n_pairs) * PAIR_ROW - 0.5 * PAIR_ROW)
    dots = np.array(rrd.values("/itd_pairs/people", "Points2D:positions")[-1])
    mapped = array.itd(recorded_pairs["xyz"]) * 1e6  # (N, P): one dot per person and pair, at its ITD
    np.testing.assert_allclose(np.sort(dots[:, 0]), np.sort(mapped.T.reshape(-1)), atol=1e-6)
    # the ITD-space pane shows the first pair's ITDs
    assert rrd.values("/itd/histogram/count", "Points2D:labels")[-1] == ["20 ITDs"]


@pytest.fixture(scope="module")
def recorded_lips(tmp_path_factory: pytest.TempPathFactory) -> Rrd:
    """Four frames of two people with the lips' cue (person 5 has no opinion at first, then moving lips), a
    self-calibration's state among the diagnostics, and person 5's words (partial at frame 1, final at frame 2)."""
    from app.speech.transcriber import Words

    path = tmp_path_factory.mktemp("console") / "lips.rrd"
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    console = Console(RIG, MICS, recording=rec)
    words = {1: [Words(5, 0, 0.0, None, "one two", None, False)],
             2: [Words(5, 0, 0.0, 0.1, "one two three", 0.8, True)]}
    for i, lips in enumerate(([np.nan, 0.003], [np.nan, 0.004], [0.04, 0.002], [0.05, 0.003])):
        console.log_words(words.get(i, []))
        console.log(_frame(frame=i, stamp_s=i / 30, boxes=np.array([[10.0, 10, 50, 50], [200.0, 10, 50, 50]]),
                           faces_xyz=np.array([[-0.5, 0.0, 2.0], [0.5, 0.0, 2.0]]), speaking=np.array([True, False]),
                           probability=np.array([0.9, 0.1]), person_ids=np.array([5, 6]), lip_activity=lips,
                           diagnostics={"self_calibration/pair0/c1": 0.9 + 0.01 * i}))
    rec.disconnect()
    return Rrd(path)


def test_each_persons_words_are_a_subtitle_under_the_face_and_a_line_of_the_transcript(recorded_lips: Rrd) -> None:
    """--transcribe: the partial words under person 5's face (box 10, 10, 50, 50), then the final ones, held; one
    transcript line per final utterance, in the person's colour."""
    labels = recorded_lips.values("/scene/cameras/left/words", "Points2D:labels")
    assert labels[:2] == [["one two"], ["one two three"]]
    at = recorded_lips.values("/scene/cameras/left/words", "Points2D:positions")[0]
    assert at[0] == pytest.approx([35.0, 74.0])
    lines = recorded_lips.values("/transcript", "TextLog:text")
    assert lines == [["person 5 (0.0-0.1 s): one two three"]]


def test_each_persons_lip_activity_is_a_series_with_gaps_for_no_opinion(recorded_lips: Rrd) -> None:
    assert [v[0] for v in recorded_lips.values("/lips/5", "Scalars:scalars")] == pytest.approx([0.04, 0.05])
    assert recorded_lips.frames("/lips/5", "Scalars:scalars") == [2, 3]
    assert len(recorded_lips.values("/lips/6", "Scalars:scalars")) == 4
    assert recorded_lips.values("/lips/5", "SeriesLines:names") == [["person 5"]]
    with pytest.raises(ValueError, match="lip_activity must have one value per face"):
        _frame(lip_activity=[0.1, 0.2])


def test_blueprint_views_look_at_what_the_console_logs(recorded: dict, recorded_pairs: dict, recorded_lips: Rrd,
                                                       tmp_path: Path) -> None:
    path = save_default_blueprint(tmp_path / "console.rbl")
    origins = _origins(path)
    assert {"scene/cameras/left", "birdseye", "itd", "itd/bars", "itd_pairs", "people", "scene", "counts",
            "diagnostics/fps", "diagnostics/latency_ms", "events", "lips", "legend"} <= origins
    logged = set(recorded["rrd"].rows) | set(recorded_pairs["rrd"].rows) | set(recorded_lips.rows)
    for origin in origins:
        assert any(p == f"/{origin}" or p.startswith(f"/{origin}/") for p in logged), origin


def test_saved_default_blueprint_is_current(tmp_path: Path) -> None:
    assert DEFAULT_RBL.name == "default.rbl" and DEFAULT_RBL.is_file()
    assert _origins(DEFAULT_RBL) == _origins(save_default_blueprint(tmp_path / "fresh.rbl"))


def test_blueprint_file_needs_the_rbl_suffix(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match=r"\.rbl"):
        save_default_blueprint(tmp_path / "layout.rrd")


def test_a_long_recording_goes_into_parts_that_each_open_alone(tmp_path: Path) -> None:
    """Rerun's file writer holds memory until its file is closed, so a long run is saved in parts; each part has the
    static data and the people's styles again, and together they hold every frame once."""
    path = tmp_path / "long.rrd"
    session = ViewerSession(ViewerTarget(save=path, part_s=3600.0))
    console = Console(RIG, MICS, recording=session.recording)
    for i in range(6):
        if i in (2, 4):
            session._part_started -= 3600.0  # the part has run its time
        if session.part_due():
            assert session.next_part().name == f"long.part{len(session.parts)}.rrd"
            console.new_part()
        console.log(_frame(frame=i))
    session.close(keep_serving=False)
    assert session.parts == [path, tmp_path / "long.part2.rrd", tmp_path / "long.part3.rrd"]
    seen = []
    for k, part in enumerate(session.parts):
        rrd = Rrd(part)
        assert rrd.frames("/scene", "ViewCoordinates:xyz") == [None]  # the static data, in every part
        assert rrd.frames("/scene/cameras/left/faces", "Boxes2D:centers") == [2 * k, 2 * k + 1]
        assert rrd.frames("/itd/bars", "BarChart:abscissa") == [2 * k]  # the bars' positions, in every part
        series = {p: rows for p, rows in rrd.rows.items() if p.endswith("/speaking_probability")}
        assert series and all(any(f is None and "SeriesLines:names" in row for f, row in rows)
                              for rows in series.values())  # each person's series named and coloured again
        seen += rrd.frames("/counts", "Scalars:scalars")
    assert seen == list(range(6))
    # Rerun's own tool joins the parts into one recording
    merged = tmp_path / "merged.rrd"
    with merged.open("wb") as out:
        subprocess.run([rerun_executable() or "rerun", "rrd", "merge", *map(str, session.parts)], stdout=out,
                       stderr=subprocess.DEVNULL, check=True, timeout=60)
    assert Rrd(merged).frames("/counts", "Scalars:scalars") == list(range(6))
    with pytest.raises(ValueError, match="part_s"):
        ViewerSession(ViewerTarget(save=path, part_s=0.0))


def test_labels_that_collided_are_gone(recorded: dict) -> None:
    """The cameras' and microphones' labels sat on top of each other at the robot (bird's-eye and 3D): they are
    drawn without labels; the robot keeps its own."""
    rrd = recorded["rrd"]
    for path, labels in (("/birdseye/fov", "LineStrips2D:labels"), ("/birdseye/mics", "Points2D:labels"),
                         ("/scene/robot/mics", "Points3D:labels")):
        assert path in rrd.rows, path
        assert all(labels not in row for _, row in rrd.rows[path]), path
    assert rrd.values("/birdseye/robot", "LineStrips2D:labels")[0] == ["robot"]


def test_the_cameras_image_planes_hide_nobody(recorded: dict) -> None:
    """In the 3D view the cameras' image planes stay 0.15 m in front of them (0.5 m hid the people behind)."""
    rrd = recorded["rrd"]
    for camera in ("/scene/cameras/left", "/scene/cameras/right"):
        assert rrd.values(camera, "Pinhole:image_plane_distance")[0] == pytest.approx([0.15])


def test_the_itd_pane_keeps_its_scale(recorded: dict, scene: dict, tmp_path: Path) -> None:
    """A bin holding a fifth of the ITDs reaches the top of the scale; what rises higher (one ITD in the interval:
    a whole bin) is drawn at 1.25 times the top, so one full bin cannot squash the pane; the axis is labelled every
    200 us so that its labels do not overlap."""
    from app.console.entities import ITD_CLIP, ITD_TOP

    path = tmp_path / "one_itd.rrd"
    rec = rr.RecordingStream("avhear-test")
    rec.save(path)
    console = Console(scene["rig"], MICS, recording=rec, jpeg_quality=None)
    console.log(ConsoleFrame(0.5, 0, None, None, np.zeros((0, 3)), np.zeros(0, bool), np.zeros(0), np.array([1e-5])))
    rec.disconnect()
    pane = geo.ItdPane.for_mics(MICS)
    (strip,) = Rrd(path).values("/itd/histogram", "LineStrips2D:strips")[-1]
    assert -np.array(strip)[:, 1].min() / pane.height_per_fraction == pytest.approx(ITD_CLIP)  # not 1.0
    assert ITD_CLIP == pytest.approx(1.25 * ITD_TOP)
    labels = recorded["rrd"].values("/itd/axis/ticks", "Points2D:labels")[0]
    values = [0.0 if lb == "0" else float(lb.split()[0]) for lb in labels]
    assert values and all(v % 200 == 0 for v in values) and 0.0 in values


def test_an_rgbd_cameras_depth_goes_to_the_3d_view(scene: dict, tmp_path: Path) -> None:
    """An RGB-D frame's depth is logged (millimetres, meter = 1000) under the left camera every DEPTH_EVERY frames,
    where the 3D view draws it as a point cloud; the left image's 2D view leaves it out."""
    from app.console.entities import DEPTH, DEPTH_EVERY

    path = tmp_path / "rgbd.rrd"
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    console = Console(scene["rig"], MICS, recording=rec)
    depth = np.full((480, 640), 2.5, np.float32)
    depth[0, 0] = np.nan
    out = FaceGuidedHearing(MICS).step(scene["xyz"], np.zeros(0))
    for i in range(DEPTH_EVERY + 1):
        console.log(ConsoleFrame(10.0 + i / 30, i, scene["image"], scene["boxes"], scene["xyz"], out.speaking,
                                 out.probability, np.zeros(0), depth_m=depth))
    with pytest.raises(ValueError, match="depth_m must be of the rig's size"):
        console.log(ConsoleFrame(11.0, 99, scene["image"], scene["boxes"], scene["xyz"], out.speaking,
                                 out.probability, np.zeros(0), depth_m=depth[:240]))
    rec.disconnect()
    rrd = Rrd(path)
    assert rrd.frames(f"/{DEPTH}", "DepthImage:buffer") == [0, DEPTH_EVERY]
    assert rrd.values(f"/{DEPTH}", "DepthImage:meter")[0] == [1000.0]
    left = [v for v in _views(default_blueprint().root_container) if str(v.origin) == "scene/cameras/left"]
    assert len(left) == 1 and "- $origin/depth" in left[0].contents


def _views(container):  # noqa: ANN001, ANN202
    """Every view of a blueprint container, depth first."""
    for item in container.contents:
        yield from (_views(item) if hasattr(item, "contents") and not hasattr(item, "origin") else [item])


def test_one_legend_for_every_pane(recorded: dict) -> None:
    """The legend: one line a person in the person's colour (the colour of their box, circle, head, Gaussian and
    series), the speakers marked with a filled disc and the word, the distance and the Gaussian's mean; logged only
    when a line changes, and person 9's line gone when they leave."""
    rrd = recorded["rrd"]
    frame, out = recorded["logged"][0]
    lines = rrd.values("/legend", "Points2D:labels")
    first = lines[0]
    assert [next(w for w in line.split() if w.isdigit()) for line in first] == ["7", "8", "9"]
    assert first[1].startswith("\u25cf") and "speaking" in first[1]  # person 8 speaks
    assert all(line.startswith("\u25cb") and "silent" in line for line in (first[0], first[2]))
    distance = np.linalg.norm(frame.faces_xyz[1])
    assert f"{distance:.1f} m" in first[1] and f"mu {out.model.means[1] * 1e6:+5.0f} us" in first[1]
    assert len({len(line) for line in first}) == 1  # centred labels line up when they are equally long
    assert rrd.values("/legend", "Points2D:colors")[0] == rrd.values("/scene/cameras/left/faces",
                                                                      "Boxes2D:colors")[0]
    assert len(lines[-1]) == 2


def test_an_unchanged_legend_is_not_logged_again(tmp_path: Path) -> None:
    """The same people in the same states frame after frame: the legend is logged once; a line that changes (a
    probability in its first decimal) logs it again."""
    path = tmp_path / "legend.rrd"
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    console = Console(RIG, MICS, recording=rec)
    for i, p in enumerate((0.91, 0.93, 0.92, 0.71)):
        console.log(_frame(frame=i, probability=np.array([p])))
    rec.disconnect()
    assert Rrd(path).frames("/legend", "Points2D:labels") == [0, 3]


def test_legend_lines_change_only_when_what_they_say_changes() -> None:
    speaking, silent = (geo.legend_labels(np.array([3]), np.array([p]), np.array([s]), np.array([2.04]),
                                          np.array([1.2e-4])) for p, s in ((0.93, True), (0.12, False)))
    assert speaking == ["\u25cf   3  speaking 0.9    2.0 m   mu  +120 us"]
    assert silent == ["\u25cb   3  silent   0.1    2.0 m   mu  +120 us"]
    # a probability that moves in its second decimal writes the same line
    assert geo.legend_labels(np.array([3]), np.array([0.94]), np.array([True]), np.array([2.04]),
                             np.array([1.2e-4])) == speaking
    assert len(geo.legend_labels(np.array([3]), np.array([0.94]), np.array([True]), np.array([2.04]), None)[0]) == \
        len(speaking[0])  # no model: the line keeps its length


def test_the_layout_opens_on_people_the_robot_and_every_pair() -> None:
    """The 3D view looks from behind and above the robot at the room ahead (the people stand 1-4 m in front: +z in
    the scene's RDF frame, "up" is -y); the blueprint panel starts collapsed; with several pairs the "ITDs per pair"
    tab opens in front, with one pair the ITD space."""
    for several, active in ((False, 0), (True, 2)):
        blueprint = default_blueprint(several)
        tabs = [v for v in _containers(blueprint.root_container) if type(v).__name__ == "Tabs"]
        itd_tabs = next(t for t in tabs if any(getattr(v, "origin", None) == "itd_pairs" for v in t.contents))
        assert itd_tabs.active_tab == active
        assert itd_tabs.contents[active].origin == ("itd_pairs" if several else "itd")
    scene = next(v for v in _views(default_blueprint().root_container) if str(v.origin) == "scene")
    eye = scene.properties["EyeControls3D"]
    position = np.array(eye.position.as_arrow_array().to_pylist()[0])
    target = np.array(eye.look_target.as_arrow_array().to_pylist()[0])
    assert position[2] < 0 < target[2] and position[1] < 0  # behind the robot, above it, looking ahead
    assert vars(default_blueprint().blueprint_panel)["state"] == "collapsed"


def _containers(container):  # noqa: ANN001, ANN202
    """Every container of a blueprint, depth first."""
    for item in container.contents:
        if hasattr(item, "contents") and not hasattr(item, "origin"):
            yield item
            yield from _containers(item)


def test_a_voice_out_of_view_is_a_ray_from_the_robot(tmp_path: Path) -> None:
    """A voice 53 degrees to the left: a ray from the robot 4 m along it in the bird's-eye view (x, -z: forward
    up) and in 3D, labelled with its id; cleared when no voice is heard."""
    path = tmp_path / "voices.rrd"
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    console = Console(RIG, MICS, recording=rec)
    az = np.radians(-53.0)
    console.log(_frame(frame=0, voices=((3, az),)))
    console.log(_frame(frame=1))
    rec.disconnect()
    rrd = Rrd(path)
    ray = np.array(rrd.values("/birdseye/voices", "LineStrips2D:strips")[0][0])
    np.testing.assert_allclose(ray, [[0.0, 0.0], [4 * np.sin(az), -4 * np.cos(az)]], atol=1e-6)
    assert ray[1, 0] < 0 and ray[1, 1] < 0  # to the left, and ahead (up in the view)
    assert rrd.values("/birdseye/voices", "LineStrips2D:labels")[0] == ["voice 3"]
    np.testing.assert_allclose(np.array(rrd.values("/scene/voices", "LineStrips3D:strips")[0][0])[1],
                               [4 * np.sin(az), 0.0, 4 * np.cos(az)], atol=1e-6)
    assert rrd.frames("/birdseye/voices", "Clear:is_recursive") == [1]
