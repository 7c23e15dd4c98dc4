"""Speed and accuracy of the visual front-end on rendered 640x480 stereo scenes (issue 4, paper section 5.2).

Scenes: sim.render.default_scene (three people at 1.3, 2.1 and 2.9 m, rig of focal 554 px and baseline 0.12 m),
with real face crops from ../shared/data/faces when present, drawn faces otherwise. Timings are per stereo pair,
on one core by default (cv2.setNumThreads(1)); with one thread they are the CPU time of the calling thread (where
OpenCV then runs), so that other work on the machine does not inflate them (on an idle core it equals wall time).

    python benchmarks/vision_speed.py                 # 4 scenes: F3D stills and videos, the face mesh, HM3D
    python benchmarks/vision_speed.py --scenes 2      # quicker
"""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import cv2
import numpy as np

from avcore.faces import (
    HAAR_FRONTAL,
    HaarFaceDetector,
    TrackingFaceDetector,
    detect_faces,
    locate_faces,
)
from avcore.motion import harris_motion_points
from avcore.depth import motion_points_depth
from sim.render import default_scene

DEFAULT_FACES = Path(__file__).resolve().parents[2] / "shared" / "data" / "faces"


def _clock(threads: int):
    return time.thread_time if threads == 1 else time.perf_counter


def _score(points: np.ndarray, faces: np.ndarray, errors: list[float]) -> tuple[int, int, int]:
    """Faces found within 10 cm (their errors appended to ``errors``), faces in all, and false detections."""
    found = 0
    for g in faces:
        d = np.linalg.norm(points - g, axis=1).min() if len(points) else np.inf
        if d < 0.1:
            found += 1
            errors.append(d)
    false = sum(np.linalg.norm(faces - p, axis=1).min() >= 0.1 for p in points)
    return found, len(faces), int(false)


def _error_columns(errors: list[float]) -> tuple[str, str]:
    err = np.array(errors) * 100
    if not err.size:
        return f"{'-':>9}", f"{'-':>7}"
    return f"{np.median(err):9.2f}", f"{np.percentile(err, 90):7.2f}"


class OneCallHaar:
    """The baseline that HaarFaceDetector's octaves replace: one ``detectMultiScale`` call on the whole resized image
    (whose window steps by 1 px instead of 2 once it is scaled by two or more)."""

    def __init__(self, scale: float, scale_factor: float) -> None:
        self.scale, self.scale_factor = scale, scale_factor
        self.cascade = cv2.CascadeClassifier(str(Path(cv2.data.haarcascades) / HAAR_FRONTAL))

    def detect(self, image: np.ndarray) -> np.ndarray:
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        small = cv2.resize(grey, None, fx=self.scale, fy=self.scale, interpolation=cv2.INTER_AREA)
        boxes = self.cascade.detectMultiScale(small, scaleFactor=self.scale_factor, minNeighbors=3, minSize=(24, 24))
        return np.asarray(boxes, dtype=np.float64).reshape(-1, 4) / self.scale


def f3d_table(args: argparse.Namespace, faces_dir: Path | None) -> None:
    haar = hasattr(cv2, "CascadeClassifier")  # OpenCV 5 has none: its rows are left out, and the table says so
    configs = [(s, sf, octaves) for s in args.scales for sf in (1.2, 1.1) for octaves in (True, False)] if haar else []
    frames = []
    for seed in range(args.scenes):
        scene = default_scene(faces_dir, moving=True, seed=seed)
        for t in (0.0, 0.37):
            frames.append((scene.rig, scene.render(t)))
    print(f"\nF3D: {len(frames)} stereo pairs, {3 * len(frames)} faces at 1.3-2.9 m "
          f"({'real crops' if faces_dir else 'drawn faces'})")
    print(f"{'detector':<20} {'found':>7} {'false':>5} {'median cm':>9} {'p90 cm':>7} {'detect ms':>9} {'F3D ms':>7}")
    if not haar:
        print(f"(Haar's rows left out: OpenCV {cv2.__version__} has no Haar cascades)")
    for k, (scale, sf, octaves) in enumerate(configs, 1):
        name = f"{'haar' if octaves else 'one call'} x{scale:g} sf {sf:g}"
        print(f"  [{k}/{len(configs)}] {name} ...", file=sys.stderr, flush=True)
        det = HaarFaceDetector(scale=scale, scale_factor=sf) if octaves else OneCallHaar(scale, sf)
        found = total = false = 0
        errors, t_det, t_f3d = [], [], []
        clock = _clock(args.threads)
        for rig, frame in frames:
            grey = cv2.cvtColor(frame.left, cv2.COLOR_BGR2GRAY)
            t0 = clock()
            detect_faces(grey, det)
            t_det.append(clock() - t0)
            t0 = clock()
            loc = locate_faces(frame.left, frame.right, rig, detector=det)
            t_f3d.append(clock() - t0)
            n_found, n_total, n_false = _score(loc.points, frame.faces, errors)
            found, total, false = found + n_found, total + n_total, false + n_false
        med, p90 = _error_columns(errors)
        print(f"{name:<20} {found:3d}/{total:<3d} {false:5d} {med} {p90} "
              f"{1000 * np.median(t_det):9.1f} {1000 * np.median(t_f3d):7.1f}", flush=True)
    print(f"\nF3D on video: {args.scenes} sequences of {args.track_frames} frames at {args.fps:g} fps, "
          "TrackingFaceDetector (a search around the previous faces and a slice of a full scan each frame; "
          "the first frame gets a whole scan)")
    print(f"{'detector':<16} {'found':>7} {'false':>5} {'median cm':>9} {'p90 cm':>7} {'first ms':>8} "
          f"{'mean ms':>7} {'p95 ms':>6} {'max ms':>6} {'scan/frames':>11}")
    trackers = [(f"track x{s:g}", lambda s=s: TrackingFaceDetector(HaarFaceDetector(scale=s))) for s in args.scales
                if haar]
    try:  # MediaPipe's BlazeFace, tracked as the pipeline runs it (--face-detector blazeface), when installed
        from app.models import blazeface_model
        from avcore.blazeface import TrackingBlazeFace

        model = blazeface_model()
        trackers.append(("blazeface", lambda: TrackingBlazeFace.from_model(model)))
        from avcore.tflite import litert_available

        if litert_available():  # the optional runtime (--tflite-runtime litert)
            trackers.append(("blazeface litert", lambda: TrackingBlazeFace.from_model(model, runtime="litert")))
    except Exception as exc:  # noqa: BLE001 - the table is printed without it, and says why
        print(f"BlazeFace left out: {exc}", file=sys.stderr)
    for name, make in trackers:
        found = total = false = 0
        errors, t_first, t_f3d = [], [], []
        clock = _clock(args.threads)
        for seed in range(args.scenes):
            scene = default_scene(faces_dir, moving=True, seed=seed)
            tracker = make()
            for i in range(args.track_frames):
                frame = scene.render(i / args.fps)
                t0 = clock()
                loc = locate_faces(frame.left, frame.right, scene.rig, detector=tracker)
                (t_f3d if i else t_first).append(clock() - t0)
                n_found, n_total, n_false = _score(loc.points, frame.faces, errors)
                found, total, false = found + n_found, total + n_total, false + n_false
        med, p90 = _error_columns(errors)
        ms = 1000 * np.array(t_f3d)
        per_scan = getattr(tracker, "frames_per_scan", None)
        print(f"{name:<16} {found:3d}/{total:<3d} {false:5d} {med} {p90} "
              f"{1000 * np.median(t_first):8.1f} {ms.mean():7.1f} {np.percentile(ms, 95):6.1f} {ms.max():6.1f} "
              f"{per_scan if per_scan is not None else '-':>11}", flush=True)
    print("targets: every face found, median error <= 2 cm, detection + F3D <= 15 ms per pair "
          "(after the first frame of a video)")


def hm3d_table(args: argparse.Namespace, faces_dir: Path | None) -> None:
    times = [0.2 + i / args.fps for i in range(args.frames)]
    print(f"\nHM3D: intervals of {args.frames} frames at {args.fps:g} fps ({args.frames / args.fps:.2f} s), "
          "people swaying and nodding")
    print(f"{'people':>6} {'scene':>5} {'points':>6} {'within 10 cm':>12} {'off the head':>12} {'median cm':>9} "
          f"{'ms/pair':>8} {'render ms':>9}")
    shares, body_shares, per_pair, counts, render_ms = [], [], [], [], []
    runs_total = len(args.people) * args.scenes
    for n_people in args.people:
        for seed in range(args.scenes):
            print(f"  [{len(shares) + 1}/{runs_total}] rendering ...", file=sys.stderr, flush=True)
            scene = default_scene(faces_dir, moving=True, seed=seed, n_people=n_people, bodies=args.bodies)
            clock = _clock(args.threads)
            scene.render(times[0])  # the room and the textures are drawn once per scene
            frames, spent = [], []
            for t in times:
                t0 = clock()
                frames.append(scene.render(t))
                spent.append(clock() - t0)
            render_ms.append(1000 * float(np.median(spent)))
            left = np.stack([cv2.cvtColor(f.left, cv2.COLOR_BGR2GRAY) for f in frames])
            right = np.stack([cv2.cvtColor(f.right, cv2.COLOR_BGR2GRAY) for f in frames])
            runs = []
            if args.camera == "rgbd":  # the simulated D435's depth aligned to the left (colour) camera
                from sim.depth import DepthRenderer

                depth_renderer = DepthRenderer(scene, lambda _t, s=scene: s.people, seed=seed)
                depths = [depth_renderer.render(t, f.left) for t, f in zip(times, frames)]
            clock = _clock(args.threads)
            for _ in range(args.repeat):
                t0 = clock()
                if args.camera == "rgbd":
                    result = motion_points_depth(left, depths, scene.rig)
                else:
                    result = harris_motion_points(left, right, scene.rig)
                runs.append((clock() - t0) / len(times))
            nearest = [scene.nearest_parts(result.points[result.frame_index == k], t) for k, t in enumerate(times)]
            d = np.concatenate([n[0] for n in nearest])
            part = np.concatenate([n[1] for n in nearest])
            share = float(np.mean(d < 0.1)) if d.size else float("nan")
            on = d < 0.1
            body = float(np.mean(part[on] != "head")) if on.any() else float("nan")
            shares.append(share)
            body_shares.append(body)
            per_pair.append(min(runs))
            counts.append(len(result))
            print(f"{n_people:6d} {seed:5d} {len(result):6d} {100 * share:11.1f}% {100 * body:11.1f}% "
                  f"{100 * np.median(d):9.2f} {1000 * min(runs):8.1f} {render_ms[-1]:9.1f}", flush=True)
    print(f"{'all':>6} {'':>5} {np.mean(counts):6.0f} {100 * np.mean(shares):11.1f}% {100 * np.mean(body_shares):11.1f}% "
          f"{'':>9} {1000 * np.median(per_pair):8.1f} {np.median(render_ms):9.1f}")
    print("off the head: of the points within 10 cm of a person, those nearest a part other than the head (shirt, "
          "arms, hands); render ms: one stereo pair drawn by sim.render")
    print("targets: >= 90 % of points within 10 cm of a person, <= 25 ms per pair; paper: about 2,000 points per "
          "interval of 6 frames (0.4 s)")


def mesh_table(args: argparse.Namespace, faces_dir: Path | None) -> None:
    """The face mesh (--read-lips) on the faces the tracked BlazeFace finds: ms per frame of three faces, per
    runtime (all of a frame's faces in one batch)."""
    try:
        from app.models import blazeface_model, facemesh_model
        from avcore.blazeface import TrackingBlazeFace
        from avcore.facemesh import FaceMesh
        from avcore.tflite import litert_available
    except ImportError as exc:
        print(f"face mesh left out: {exc}", file=sys.stderr)
        return
    try:
        detector_model, mesh_model = blazeface_model(), facemesh_model()
    except Exception as exc:  # noqa: BLE001 - the table is left out, and says why
        print(f"face mesh left out: {exc}", file=sys.stderr)
        return
    print("\nface mesh (--read-lips) on the tracked faces, a batch per frame")
    print(f"{'runtime':<8} {'faces':>5} {'mean ms':>7} {'p95 ms':>6} {'ms/face':>7}")
    for runtime in ("opencv", "litert") if litert_available() else ("opencv",):
        mesh = FaceMesh(mesh_model, runtime=runtime)
        clock, spent, faces = _clock(args.threads), [], 0
        for seed in range(args.scenes):
            scene = default_scene(faces_dir, moving=True, seed=seed)
            tracker = TrackingBlazeFace.from_model(detector_model)
            for i in range(args.track_frames):
                image = scene.render(i / args.fps).left
                found = tracker.detect_faces(image)
                t0 = clock()
                mesh.run(image, found.boxes, found.keypoints[:, :2])
                spent.append(clock() - t0)
                faces += len(found)
        ms = 1000 * np.array(spent)
        print(f"{runtime:<8} {faces:5d} {ms.mean():7.1f} {np.percentile(ms, 95):6.1f} {ms.sum() / faces:7.2f}",
              flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--faces", type=Path, default=DEFAULT_FACES, help="labelled faces folder (drawn if absent)")
    parser.add_argument("--drawn", action="store_true", help="use drawn faces even if real crops are there")
    parser.add_argument("--scenes", type=int, default=4, help="scenes (random seeds) per table")
    parser.add_argument("--scales", type=float, nargs="+", default=[1.0, 0.8, 0.6])
    parser.add_argument("--frames", type=int, default=6, help="frames per HM3D interval (paper: 6)")
    parser.add_argument("--people", type=int, nargs="+", default=[3, 5], help="people per HM3D scene")
    parser.add_argument("--fps", type=float, default=15.0)
    parser.add_argument("--track-frames", type=int, default=20, help="frames per F3D video sequence")
    parser.add_argument("--repeat", type=int, default=2, help="HM3D timing repeats (best kept)")
    parser.add_argument("--threads", type=int, default=1, help="OpenCV threads (default 1: one core)")
    parser.add_argument("--skip", choices=("f3d", "mesh", "hm3d"), action="append", default=[])
    parser.add_argument("--camera", choices=("stereo", "rgbd"), default="stereo",
                        help="HM3D from the stereo pair (default) or from an RGB-D camera's depth (sim.depth)")
    parser.add_argument("--bodies", action="store_true",
                        help="HM3D on people with bodies (checked shirts, gesturing arms and hands, a table)")
    args = parser.parse_args()
    cv2.setNumThreads(args.threads)
    faces_dir = None if args.drawn or not args.faces.is_dir() else args.faces
    print(f"visual front-end on rendered 640x480 pairs, OpenCV {cv2.__version__}, {args.threads} thread(s)")
    if "f3d" not in args.skip:
        f3d_table(args, faces_dir)
    if "mesh" not in args.skip:
        mesh_table(args, faces_dir)
    if "hm3d" not in args.skip:
        hm3d_table(args, faces_dir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
