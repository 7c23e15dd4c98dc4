"""The Rerun operator console (:class:`Console`, a sink): the paper's visualisation tool (section 6, figure vtool) and more, as Rerun data.

Every ``rr.*`` call of the application lives here (docs/architecture.md); what is drawn is computed by the pure helpers
of :mod:`app.console.geometry`. The default layout of these entities is :func:`layouts.blueprint.default_blueprint`.

Entity paths (static entities are logged once, when the console is created). The people of a frame are the
instances of a few batched entities, one instance each, told apart by colour (:func:`~app.console.geometry.
person_colors`, stable per person id) and label (the id; the ``legend`` pane says the rest); such an entity is
cleared when its last person goes. ``<id>`` is a person id.

In full (every part, and why): docs/architecture.md ("The console").
"""
from __future__ import annotations

import logging
from typing import Any

import cv2
import numpy as np
import pyarrow as pa
import rerun as rr

from app.console import geometry as geo
from app.console.entities import (
    BIRDSEYE,
    BIRDSEYE_HEADS,
    BIRDSEYE_VOICES,
    CAMERA_LEFT,
    CAMERA_RIGHT,
    COUNTS,
    COUNT_SERIES,
    DEPTH,
    DEPTH_EVERY,
    DIAGNOSTICS,
    EVENTS,
    FACES,
    HEADS_SILENT,
    HEADS_SPEAKING,
    HM3D_POINTS,
    IMAGE,
    ITD,
    ITD_BARS,
    ITD_CLIP,
    ITD_GAUSSIANS,
    ITD_PAIRS_HIST,
    ITD_PAIRS_LABELS,
    ITD_PAIRS_PEOPLE,
    ITD_TOP,
    LEGEND,
    LIPS,
    MICS_3D,
    PAIR_ROW,
    PEOPLE,
    ROBOT,
    SCENE,
    SCENE_VOICES,
    TIMELINE_CAPTURE,
    TIMELINE_FRAME,
    VOICE_RAY_M,
    VOICE_RGB,
)
from app.console.frame import ConsoleFrame
from app.console.words import WordsDisplay
from avcore.depth import depth_millimetres
from avcore.geometry import MicArray, MicPair
from avcore.stereo import StereoRig

__all__ = ["Console"]

log = logging.getLogger(__name__)



# The two biggest per-frame arrays, the ITD pane's curves and the bar chart's counts, are handed to Rerun as Arrow
# arrays of its own component types (which it takes as they are): its generic converters build them one strip, or
# one tensor, at a time in Python, at ten times the cost.
_STRIPS_2D = rr.components.LineStrip2DBatch._ARROW_DATATYPE


def _strips_2d(strips: list[np.ndarray]) -> pa.Array:
    """Polylines (P_i, 2) as one Arrow LineStrip2D batch (list of fixed-size [x, y] float32 lists)."""
    offsets = np.zeros(len(strips) + 1, np.int32)
    np.cumsum([len(s) for s in strips], out=offsets[1:])
    flat = np.concatenate(strips).astype(np.float32).reshape(-1) if strips else np.zeros(0, np.float32)
    points = pa.FixedSizeListArray.from_arrays(pa.array(flat), type=_STRIPS_2D.value_type)
    return pa.ListArray.from_arrays(pa.array(offsets), points, type=_STRIPS_2D)


class _CountsTensor:
    """Histogram counts (B,) int64 as Rerun's TensorData Arrow array, reusing every part of a first conversion by
    Rerun (shape, names, the tensor buffer's union layout) but the values."""

    def __init__(self, first: np.ndarray) -> None:
        self.first = rr.components.TensorDataBatch(np.asarray(first, np.int64)).as_arrow_array()
        self._size = len(first)
        union = self.first.field("buffer")
        self._union_type = union.type
        self._children = [union.field(i) for i in range(union.type.num_fields)]
        self._slot = [union.type.field(i).name for i in range(union.type.num_fields)].index("I64")
        self._union_buffers = union.buffers()[:3]  # no validity; type ids; value offsets

    def __call__(self, counts: np.ndarray) -> pa.Array:
        if counts.shape != (self._size,):
            raise ValueError(f"counts must have shape ({self._size},), got {counts.shape}")
        children = list(self._children)
        values = pa.array(np.asarray(counts, np.int64))
        children[self._slot] = pa.ListArray.from_arrays(pa.array(np.array([0, self._size], np.int32)), values,
                                                        type=self._union_type.field(self._slot).type)
        union = pa.Array.from_buffers(self._union_type, 1, self._union_buffers, children=children)
        return pa.StructArray.from_arrays([self.first.field("shape"), self.first.field("names"), union],
                                          fields=list(self.first.type))


class Console:
    """Logs the operator console to a Rerun recording.

    Parameters
    ----------
    rig : StereoRig
        The stereo rig (its rectified geometry: camera centres, intrinsics, image size).
    mics : MicPair
        The microphones and the affine AV correction (the ITD axis covers their reachable interval).
    recording : rr.RecordingStream or None
        Where to log; None uses the current (global or thread-local) recording of ``rr.init``.
    jpeg_quality : int in [1, 100], or None
        Images are JPEG-compressed at this quality (bounded .rrd size and viewer memory); None logs raw pixels.
    image_every : int >= 1
        Log one image out of this many frames (the overlays are logged every frame).
    itd_bin_s : float, seconds
        Width of the ITD histogram's bins.
    capture_epoch_s : float or None, seconds
        Unix time of the stamp clock's zero (``time.time() - time.monotonic()`` for live stamps): the
        ``capture_time`` timeline is then a timestamp. None makes it a duration since the clock's zero (replays,
        the simulator).
    head_radius_m : float, metres
        Radius of a drawn head.
    fov_depth_m : float, metres
        How far the bird's-eye view draws the fields of view and range rings.

    Static data (robot, microphones, cameras, bird's-eye furniture, ITD axis) is logged when the console is made.
    :meth:`log` is meant for one thread (the fusion loop): Rerun's time cursor is per thread.
    """

    def __init__(self, rig: StereoRig, mics: MicPair, *, recording: rr.RecordingStream | None = None,
                 jpeg_quality: int | None = 80, image_every: int = 1, itd_bin_s: float = 10e-6,
                 capture_epoch_s: float | None = None, head_radius_m: float = 0.09,
                 fov_depth_m: float = 6.0, array: MicArray | None = None) -> None:
        if not isinstance(rig, StereoRig):
            raise TypeError(f"rig must be a StereoRig, got {type(rig).__name__}")
        if not isinstance(mics, MicPair):
            raise TypeError(f"mics must be a MicPair, got {type(mics).__name__}")
        if jpeg_quality is not None and not (isinstance(jpeg_quality, int) and 1 <= jpeg_quality <= 100):
            raise ValueError(f"jpeg_quality must be an int in [1, 100] or None for raw images, got {jpeg_quality!r}")
        if not (isinstance(image_every, int) and image_every >= 1):
            raise ValueError(f"image_every must be an int >= 1, got {image_every!r}")
        for name, value in (("head_radius_m", head_radius_m), ("fov_depth_m", fov_depth_m)):
            if not (np.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number of metres, got {value!r}")
        if capture_epoch_s is not None and not np.isfinite(capture_epoch_s):
            raise ValueError(f"capture_epoch_s must be a finite Unix time in seconds or None, got {capture_epoch_s!r}")
        self.rig = rig
        self.mics = mics
        self.recording = recording
        self.jpeg_quality = jpeg_quality
        self.image_every = image_every
        self.capture_epoch_s = capture_epoch_s
        self.head_radius_m = float(head_radius_m)
        self.fov_depth_m = float(fov_depth_m)
        self.itd_pane = geo.ItdPane.for_mics(mics, bin_s=itd_bin_s)
        self._edges_s = self.itd_pane.edges_s
        self.array = array if array is not None and array.n_pairs > 1 else None
        self._pair_panes = ([geo.ItdPane.for_mics(array.pair(k), bin_s=itd_bin_s) for k in range(array.n_pairs)]
                            if self.array is not None else [])
        self.frames_logged = 0
        self.words = WordsDisplay()  # with --transcribe: the subtitles and the transcript
        self.new_part()

    def log_words(self, words: list) -> None:
        """Words (:class:`app.speech.transcriber.Words`) to show from the next :meth:`log` on."""
        self.words.take(words)

    def new_part(self) -> None:
        """Start afresh in a new .rrd part (:meth:`app.console.viewer.ViewerSession.next_part`): the static data again,
        and whatever is logged only once or on change (people's styles, the bars' positions, the histogram) at the next
        frame."""
        self._present: set[int] = set()
        self._styled: set[int] = set()
        self._occupied: set[str] = set()  # batched per-person entities holding instances now
        self._had_points = False
        self._had_boxes = False
        self._counts_tensor: _CountsTensor | None = None  # set with the first histogram of the part
        self._last_counts: np.ndarray | None = None  # the histogram logged last, and its ITDs off the axis
        self._last_outside = 0
        self._legend: list[str] | None = None  # the legend's lines logged last
        self.log_static()

    # ------------------------------------------------------------------ helpers
    def _log(self, path: str, *archetypes: Any, static: bool = False) -> None:
        rr.log(path, *archetypes, static=static, recording=self.recording)

    def _set_time(self, frame: ConsoleFrame) -> None:
        rr.set_time(TIMELINE_FRAME, sequence=int(frame.frame), recording=self.recording)
        if self.capture_epoch_s is None:
            rr.set_time(TIMELINE_CAPTURE, duration=float(frame.stamp_s), recording=self.recording)
        else:
            rr.set_time(TIMELINE_CAPTURE, timestamp=float(frame.stamp_s) + self.capture_epoch_s,
                        recording=self.recording)

    # ------------------------------------------------------------------ static data
    def log_static(self) -> None:
        """The rig, the microphones and the fixed parts of the panes (``static=True``: shown at every time)."""
        rig, mics = self.rig, self.mics
        self._log(SCENE, rr.ViewCoordinates.RDF, static=True)
        lo, hi = geo.robot_bounds(mics, rig)
        self._log(ROBOT, rr.Boxes3D(centers=[0.5 * (lo + hi)], half_sizes=[0.5 * (hi - lo)], colors=[(90, 90, 90)],
                                    labels=["robot"]), static=True)
        mic_xyz = np.array([mics.left, mics.right])
        self._log(MICS_3D, rr.Points3D(mic_xyz, radii=0.015, colors=[(220, 40, 40)]), static=True)
        cameras = zip((CAMERA_LEFT, CAMERA_RIGHT), geo.camera_centres(rig), (rig.proj_left, rig.proj_right),
                      strict=True)
        for path, centre, proj in cameras:
            self._log(path, rr.Transform3D(translation=centre), static=True)
            self._log(path, rr.Pinhole(image_from_camera=proj[:, :3], resolution=list(rig.image_size),
                                       camera_xyz=rr.ViewCoordinates.RDF, image_plane_distance=0.15), static=True)

        outline_lo, outline_hi = geo.birdseye(lo), geo.birdseye(hi)
        x0, x1 = sorted((outline_lo[0], outline_hi[0]))
        y0, y1 = sorted((outline_lo[1], outline_hi[1]))
        self._log(f"{BIRDSEYE}/robot", rr.LineStrips2D([[(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]],
                                                       radii=0.01, colors=[(90, 90, 90)], labels=["robot"]),
                  static=True)
        self._log(f"{BIRDSEYE}/mics", rr.Points2D(geo.birdseye(mic_xyz), radii=0.02, colors=[(220, 40, 40)]),
                  static=True)
        self._log(f"{BIRDSEYE}/fov", rr.LineStrips2D(list(geo.fov_strips_birdseye(rig, self.fov_depth_m)),
                                                     radii=0.008, colors=[(30, 90, 200), (30, 150, 220)]),
                  static=True)
        radii_m = np.arange(1.0, np.floor(self.fov_depth_m) + 0.5)
        rings = geo.range_rings_birdseye(radii_m)
        self._log(f"{BIRDSEYE}/rings", rr.LineStrips2D(list(rings), radii=0.004, colors=[(170, 170, 170)],
                                                       labels=[f"{r:g} m" for r in radii_m], show_labels=False),
                  static=True)

        pane = self.itd_pane
        lo_s, hi_s = pane.range_s
        ticks_us = np.arange(np.ceil(lo_s * 1e4), np.floor(hi_s * 1e4) + 1) * 100.0  # every 100 us
        tick_len = 0.02 * pane.height_per_fraction
        strips = [pane.xy(np.array([lo_s, hi_s]), np.zeros(2))]
        strips += [np.array([[t, 0.0], [t, tick_len]]) for t in ticks_us]
        support_s = np.array(mics.itd_interval())
        top = ITD_TOP  # the vertical scale's top, fraction of the ITDs per bin (ItdPane.for_mics)
        strips += [pane.xy(np.full(2, s), np.array([0.0, top])) for s in support_s]  # the reachable interval
        colors = [(60, 60, 60)] * (1 + ticks_us.size) + [(200, 200, 200)] * 2
        self._log(f"{ITD}/axis", rr.LineStrips2D(strips, radii=0.6, colors=colors), static=True)
        named = ticks_us[np.round(ticks_us / 100.0) % 2 == 0]  # a label every 200 us: closer, they overlap
        labels = [f"{t:+.0f} us" if t else "0" for t in named]
        self._log(f"{ITD}/axis/ticks", rr.Points2D(np.stack([named, np.full(named.size, 2.5 * tick_len)], 1),
                                                   radii=0.1, colors=[(60, 60, 60)], labels=labels), static=True)
        fractions = np.linspace(0.05, top, 4)
        self._log(f"{ITD}/axis/fraction", rr.Points2D(pane.xy(np.full(4, lo_s), fractions), radii=1.0,
                                                      colors=[(120, 120, 120)],
                                                      labels=[f"{f:g}" for f in fractions]),
                  static=True)
        self._log(COUNTS, rr.SeriesLines(names=list(COUNT_SERIES), colors=[(40, 40, 40), (214, 39, 40),
                                                                           (31, 119, 180)]), static=True)

    # ------------------------------------------------------------------ per frame
    def log(self, frame: ConsoleFrame) -> None:
        """Log one fused result on the ``frame`` and ``capture_time`` timelines.

        Every person of a frame is one instance of a few batched entities (a box, a circle, a head, a Gaussian),
        told apart by its colour and label, so that a frame replaces the people of the last one (nobody stale
        stays) and takes about a dozen ``rr.log`` calls whatever the number of people: Rerun's cost per call
        (building Arrow arrays, queueing a row) is most of the console's time.
        """
        if not isinstance(frame, ConsoleFrame):
            raise TypeError(f"frame must be a ConsoleFrame, got {type(frame).__name__}")
        if frame.image is not None and frame.image.shape[1::-1] != tuple(self.rig.image_size):
            raise ValueError(f"image must be of the rig's size {self.rig.image_size} (width, height), got "
                             f"{frame.image.shape[1::-1]}")
        if frame.depth_m is not None and frame.depth_m.shape[::-1] != tuple(self.rig.image_size):
            raise ValueError(f"depth_m must be of the rig's size {self.rig.image_size} (width, height), got "
                             f"{frame.depth_m.shape[::-1]}")
        self._set_time(frame)
        ids = [int(i) for i in frame.person_ids]
        colors = geo.pack_rgba(geo.person_colors(frame.person_ids))
        labels = [str(pid) for pid in ids]  # the rest is in the legend and the bars: short labels do not collide
        discs = geo.pack_rgba(geo.speaking_rgba(frame.probability))
        self._log_events(set(ids))
        if frame.image is not None and self.frames_logged % self.image_every == 0:
            self._log_image(frame.image)
        if frame.depth_m is not None and self.frames_logged % DEPTH_EVERY == 0:
            self._log(DEPTH, rr.DepthImage(depth_millimetres(frame.depth_m), meter=1000.0,
                                           depth_range=(300.0, self.fov_depth_m * 1000.0)))
        self._log_faces(frame, colors, labels)
        self._log_heads(frame, colors, labels, discs)
        self._log_itd_space(frame, ids, colors)
        self._log_pairs(frame, colors)
        self._log_series(frame, ids, colors)
        self._log_legend(frame, colors)
        self._log_voices(frame.voices)
        self.words.log(self._log, frame.stamp_s, ids, frame.boxes, colors)
        self._log_points(frame.points_xyz)
        self.frames_logged += 1

    def _log_people(self, path: str, n: int, *archetypes: Any) -> None:
        """A batched entity with one instance per person: logged when someone is there, cleared once when the last
        one goes (an empty frame after an empty frame logs nothing: the entity is already empty)."""
        if n:
            self._log(path, *archetypes)
            self._occupied.add(path)
        elif path in self._occupied:
            self._log(path, rr.Clear(recursive=False))
            self._occupied.discard(path)

    def _log_events(self, now: set[int]) -> None:
        departed = sorted(self._present - now)
        arrived = sorted(now - self._present)
        if departed or arrived:
            parts = [f"person {p} appeared" for p in arrived] + [f"person {p} left" for p in departed]
            self._log(EVENTS, rr.TextLog("; ".join(parts), level=rr.TextLogLevel.INFO))
        self._present = now

    def _log_image(self, image: np.ndarray) -> None:
        if self.jpeg_quality is None:
            self._log(IMAGE, rr.Image(image, color_model="L" if image.ndim == 2 else "BGR"))
            return
        ok, buf = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, self.jpeg_quality])
        if not ok:  # never seen with uint8 images; keep the console alive and say so
            log.warning("JPEG encoding of a %s image failed; image not logged", image.shape)
            return
        self._log(IMAGE, rr.EncodedImage(contents=buf.reshape(-1), media_type="image/jpeg"))

    def _log_faces(self, frame: ConsoleFrame, colors: np.ndarray, labels: list[str]) -> None:
        """Pane 1: a box on each face (a ring around each head when motion-guided), thick when speaking, and above
        it a bar as long as the speaking probability; nothing covers the face (its mouth shows who speaks)."""
        if frame.boxes is not None:
            boxes = frame.boxes
            parts: list[Any] = [rr.Boxes2D(mins=boxes[:, :2], sizes=boxes[:, 2:], colors=colors,
                                           radii=np.where(frame.speaking, 3.0, 1.5), draw_order=15.0)]
        else:
            centres, radii = geo.head_circles_px(self.rig, frame.faces_xyz, self.head_radius_m)
            boxes = np.concatenate([centres - radii[:, None], 2 * np.repeat(radii[:, None], 2, axis=1)], axis=1)
            parts = [rr.Ellipses2D(centers=centres, half_sizes=np.repeat(radii[:, None], 2, axis=1), colors=colors,
                                   line_radii=np.where(frame.speaking, 3.0, 1.5), draw_order=15.0)]
            if self._had_boxes:  # heads without boxes after faces with boxes: no stale box stays
                parts.append(rr.Boxes2D.cleared())
        parts.append(rr.LineStrips2D(geo.speaking_bars_px(boxes, frame.probability), colors=colors,
                                     radii=np.where(frame.speaking, 3.0, 2.0), draw_order=20.0))
        parts.append(rr.Points2D(geo.id_labels_px(boxes), radii=0.1, colors=colors, labels=labels, draw_order=20.0))
        self._had_boxes = frame.boxes is not None
        self._log_people(FACES, frame.n_people, *parts)

    def _log_heads(self, frame: ConsoleFrame, colors: np.ndarray, labels: list[str], discs: np.ndarray) -> None:
        """Pane 2 (bird's-eye view: a circle per head) and the heads of the 3D view (solid when speaking)."""
        r = self.head_radius_m
        n = frame.n_people
        flat = geo.birdseye(frame.faces_xyz)
        self._log_people(BIRDSEYE_HEADS, n,
                         rr.Ellipses2D(centers=flat, half_sizes=np.full((n, 2), r), colors=colors, labels=labels,
                                       line_radii=np.where(frame.speaking, 0.02, 0.01)),
                         rr.Points2D(flat, radii=0.6 * r, colors=discs))
        # the fill mode is one value per entity: speakers and silent heads are two entities
        for path, mask, fill in ((HEADS_SPEAKING, frame.speaking, rr.components.FillMode.Solid),
                                 (HEADS_SILENT, ~frame.speaking, rr.components.FillMode.MajorWireframe)):
            k = int(np.count_nonzero(mask))
            self._log_people(path, k,
                             rr.Ellipsoids3D(centers=frame.faces_xyz[mask], half_sizes=np.full((k, 3), r),
                                             colors=colors[mask], labels=[lb for lb, m in zip(labels, mask) if m],
                                             fill_mode=fill))

    def _log_itd_space(self, frame: ConsoleFrame, ids: list[int], colors: np.ndarray) -> None:
        """Pane 3: the histogram of the interval's ITDs and each mapped face as its fitted Gaussian."""
        pane, edges = self.itd_pane, self._edges_s
        counts, outside = geo.itd_histogram(frame.itds_s, edges)
        k = frame.itds_s.size
        # the same ITDs give the same histogram (silence: none, frame after frame): the logged one still holds
        if self._last_counts is None or outside != self._last_outside or not np.array_equal(counts, self._last_counts):
            fractions = counts / k if k else np.zeros(counts.shape)
            xs, ys = geo.histogram_outline(edges, np.minimum(fractions, ITD_CLIP))
            label = f"{k} ITDs" + (f" ({outside} outside the axis)" if outside else "")
            self._log(f"{ITD}/histogram", rr.LineStrips2D(_strips_2d([pane.xy(xs, ys)]), radii=0.8,
                                                          colors=[(40, 40, 40)]))
            # the count in the pane's top right corner, away from the axis' labels and the people's
            self._log(f"{ITD}/histogram/count", rr.Points2D(pane.xy(np.array([pane.range_s[1]]), np.array([ITD_TOP])),
                                                            radii=0.1, colors=[(40, 40, 40)], labels=[label]))
            self._log_bars(counts)
            self._last_counts, self._last_outside = counts, outside
        if frame.model is None:
            self._log_people(f"{ITD}/outliers", 0)
            self._log_people(ITD_GAUSSIANS, 0)
            return
        level = geo.outlier_level(frame.model, pane.bin_s)
        lo_s, hi_s = frame.model.support
        self._log_people(f"{ITD}/outliers", 1,
                         rr.LineStrips2D(_strips_2d([pane.xy(np.array([lo_s, hi_s]), np.full(2, level))]),
                                         radii=0.5, colors=[(150, 150, 150)]))  # the pane's name explains it
        n = frame.n_people
        curves = geo.gaussian_curves(frame.model, pane.bin_s, clip_s=pane.range_s)
        mapped_s = self.mics.itd(frame.faces_xyz) if n else np.zeros(0)
        peaks = [pane.xy(x[[int(np.argmax(y))]], np.minimum(y[[int(np.argmax(y))]], ITD_CLIP))[0] if y.size
                 else pane.xy(mu, 0.0)[0]
                 for (x, y), mu in zip(curves, frame.model.means, strict=True)]
        self._log_people(ITD_GAUSSIANS, n,
                         rr.LineStrips2D(_strips_2d([pane.xy(x, np.minimum(y, ITD_CLIP)) for x, y in curves]),
                                         radii=np.where(frame.speaking, 1.5, 0.8), colors=colors),
                         rr.Points2D(pane.xy(mapped_s, np.zeros(n)), radii=4.0, colors=colors))
        # each person's label at the top of their Gaussian, clear of the axis' tick labels
        self._log_people(f"{ITD_GAUSSIANS}/labels", n,
                         rr.Points2D(np.array(peaks).reshape(-1, 2), radii=0.1, colors=colors,
                                     labels=[str(pid) for pid in ids]))  # the means are in the legend

    def _log_pairs(self, frame: ConsoleFrame, colors: np.ndarray) -> None:
        """The "ITDs per pair" pane: each pair's histogram, one row per pair (the first at the top), on the ITD
        pane's vertical scale (clipped as there), each person's mapped ITD on it as a dot, and the pair's name and
        count at the row's left end, clear of the histogram's middle."""
        if self.array is None or frame.pair_itds_s is None or frame.pair_itds_s.shape[1] != self.array.n_pairs:
            return
        strips, labels, corners, dots, dot_colors = [], [], [], [], []
        mapped = self.array.itd(frame.faces_xyz).reshape(-1, self.array.n_pairs)
        for k, pane in enumerate(self._pair_panes):
            column = frame.pair_itds_s[:, k]
            values = column[np.isfinite(column)]
            edges = pane.edges_s
            counts, _ = geo.itd_histogram(values, edges)
            xs, ys = geo.histogram_outline(edges, counts / values.size if values.size else np.zeros(counts.shape))
            row = k * PAIR_ROW
            heights = np.minimum(ys, ITD_CLIP) / ITD_TOP * 0.8 * PAIR_ROW
            strips.append(pane.xy(xs, heights / pane.height_per_fraction) + (0.0, row))
            i, j = self.array.pairs[k]  # type: ignore[index]
            labels.append(f"mics {i}-{j}: {values.size} ITDs")
            corners.append((pane.range_s[0] * 1e6, row - 0.5 * PAIR_ROW))
            dots.append(np.stack([mapped[:, k] * 1e6, np.full(mapped.shape[0], row)], axis=1))
            dot_colors.append(colors)
        self._log(ITD_PAIRS_HIST, rr.LineStrips2D(_strips_2d(strips), radii=0.8, colors=[(40, 40, 40)]))
        self._log(ITD_PAIRS_LABELS, rr.Points2D(np.array(corners), radii=0.1, colors=[(40, 40, 40)], labels=labels))
        self._log(ITD_PAIRS_PEOPLE, rr.Points2D(np.concatenate(dots), radii=4.0, colors=np.concatenate(dot_colors)))

    def _log_bars(self, counts: np.ndarray) -> None:
        if self._counts_tensor is not None:
            # the bars' positions never change: sent with the first counts only (static would not do: static
            # values would hide the per-frame ones)
            self._log(ITD_BARS, rr.BarChart.from_fields(values=self._counts_tensor(counts)))
            return
        edges, pane = self._edges_s, self.itd_pane
        centres_us = 0.5 * (edges[1:] + edges[:-1]) * 1e6
        self._counts_tensor = _CountsTensor(counts)
        self._log(ITD_BARS, rr.BarChart(self._counts_tensor.first, abscissa=centres_us, color=(40, 40, 40),
                                        widths=np.full(centres_us.size, pane.bin_s * 1e6, np.float32)))

    def _log_series(self, frame: ConsoleFrame, ids: list[int], colors: np.ndarray) -> None:
        """Speaking probability per person, the counts and the diagnostics, as time series."""
        lips = frame.lip_activity
        for n, (pid, p) in enumerate(zip(ids, frame.probability.tolist(), strict=True)):
            path = f"{PEOPLE}/{pid}/speaking_probability"
            if pid not in self._styled:
                self._log(path, rr.SeriesLines(names=f"person {pid}", colors=colors[n:n + 1]), static=True)
                if lips is not None:
                    self._log(f"{LIPS}/{pid}", rr.SeriesLines(names=f"person {pid}", colors=colors[n:n + 1]),
                              static=True)
                self._styled.add(pid)
            self._log(path, rr.Scalars(p))
            if lips is not None and np.isfinite(lips[n]):  # no opinion: a gap in the line
                self._log(f"{LIPS}/{pid}", rr.Scalars(float(lips[n])))
        self._log(COUNTS, rr.Scalars([frame.n_people, np.count_nonzero(frame.speaking), frame.itds_s.size]))
        for key, value in frame.diagnostics.items():
            self._log(f"{DIAGNOSTICS}/{key}", rr.Scalars(float(value)))

    def _log_legend(self, frame: ConsoleFrame, colors: np.ndarray) -> None:
        """The legend every pane shares: one line a person in the person's colour (:func:`geo.legend_labels`), one
        row each; logged when a line changes, cleared when nobody is there."""
        means = None if frame.model is None else frame.model.means
        lines = geo.legend_labels(frame.person_ids, frame.probability, frame.speaking,
                                  np.linalg.norm(frame.faces_xyz, axis=1), means)
        if lines == self._legend:
            return
        self._legend = lines
        n = len(lines)
        # the labels are written in each person's colour; the points under them are not drawn
        self._log_people(LEGEND, n, rr.Points2D(np.stack([np.zeros(n), np.arange(n, dtype=np.float64)], 1),
                                                radii=0.0, colors=colors, labels=lines))

    def _log_voices(self, voices: tuple) -> None:
        """Each voice out of view as a ray from the robot along its direction (its distance is unknown), in the
        bird's-eye view and the 3D scene, labelled with its id; cleared when none is heard."""
        n = len(voices)
        ends = geo.voice_rays(np.array([a for _, a in voices], dtype=np.float64), VOICE_RAY_M)  # (n, 2, 3)
        labels = [f"voice {i}" for i, _ in voices]
        self._log_people(BIRDSEYE_VOICES, n, rr.LineStrips2D(geo.birdseye(ends), radii=0.02, colors=[VOICE_RGB],
                                                             labels=labels))
        self._log_people(SCENE_VOICES, n, rr.LineStrips3D(ends, radii=0.01, colors=[VOICE_RGB], labels=labels))

    def _log_points(self, points: np.ndarray | None) -> None:
        if points is not None:
            self._log(HM3D_POINTS, rr.Points3D(points, radii=0.01, colors=[(120, 120, 120)]))
            self._had_points = True
        elif self._had_points:
            self._log(HM3D_POINTS, rr.Clear(recursive=False))
            self._had_points = False
