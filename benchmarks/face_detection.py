"""Face detection recall and precision on real photographs with labelled faces (issue 4, paper section 5.2).

Data: ../shared/data/faces (dlib's examples: PASCAL VOC photographs, faces labelled in training.xml and
testing.xml). A detection counts when it overlaps a labelled box with IoU >= 0.5 (one-to-one, greedy by IoU).
Small background faces (posters, crowds) are not labelled, so precision is a lower bound.

    python benchmarks/face_detection.py                       # Haar at several scales, BlazeFace when installed
    python benchmarks/face_detection.py --yunet-model face_detection_yunet_2023mar.onnx

Each backend's recall by the labelled face's width follows (the faces of these photographs are 24-100 px wide),
then by yaw: each photograph turned about the vertical axis through each labelled face (a homography, the photograph
a plane 4 face widths in front of a pinhole), the face found when a detection's centre lies inside the turned
label's bounding box. A turned photograph is narrower and foreshortened, not a turned head (whose far side
disappears and whose nose leaves the outline): a lower bound on the difficulty, said as such.
"""
from __future__ import annotations

import argparse
import sys
import time
import xml.etree.ElementTree as ET
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np

from avcore.blazeface import BlazeFaceDetector
from avcore.faces import HaarFaceDetector, YuNetFaceDetector, detect_faces

DEFAULT_DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "faces"


def iou_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of every box of a (n, 4) with every box of b (m, 4), boxes x, y, w, h."""
    ax0, ay0, ax1, ay1 = a[:, 0, None], a[:, 1, None], (a[:, 0] + a[:, 2])[:, None], (a[:, 1] + a[:, 3])[:, None]
    bx0, by0, bx1, by1 = b[None, :, 0], b[None, :, 1], (b[:, 0] + b[:, 2])[None], (b[:, 1] + b[:, 3])[None]
    iw = np.clip(np.minimum(ax1, bx1) - np.maximum(ax0, bx0), 0, None)
    ih = np.clip(np.minimum(ay1, by1) - np.maximum(ay0, by0), 0, None)
    inter = iw * ih
    return inter / (a[:, 2, None] * a[:, 3, None] + (b[:, 2] * b[:, 3])[None] - inter)


def matched_truth(truth: np.ndarray, found: np.ndarray, threshold: float = 0.5) -> np.ndarray:
    """(n,) bool: which labelled faces a detection matches (one-to-one, greedy by IoU, IoU >= threshold)."""
    hit = np.zeros(len(truth), dtype=bool)
    if len(truth) == 0 or len(found) == 0:
        return hit
    iou = iou_matrix(truth, found)
    while iou.size and iou.max() >= threshold:
        i, j = np.unravel_index(int(np.argmax(iou)), iou.shape)
        hit[i] = True
        iou[i, :] = -1
        iou[:, j] = -1
    return hit


def count_matches(truth: np.ndarray, found: np.ndarray, threshold: float = 0.5) -> int:
    return int(matched_truth(truth, found, threshold).sum())


def load(data: Path, xml_name: str) -> list[tuple[np.ndarray, np.ndarray]]:
    out = []
    for image in ET.parse(data / xml_name).getroot().iter("image"):
        img = cv2.imread(str(data / image.get("file")), cv2.IMREAD_COLOR)
        if img is None:
            raise SystemExit(f"cannot read {data / image.get('file')}")
        boxes = np.array([[int(b.get(k)) for k in ("left", "top", "width", "height")] for b in image.iter("box")],
                         dtype=np.float64).reshape(-1, 4)
        out.append((img, boxes))
    return out


def turned(img: np.ndarray, truth: np.ndarray, face: int, yaw_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """``img`` seen as a plane turned by ``yaw_deg`` about the vertical axis through labelled face ``face``'s
    centre, 4 face widths from a pinhole whose focal length keeps that face's scale at 0 degrees; the labels'
    bounding boxes after the turn."""
    x, y, w, h = truth[face]
    cx, cy, depth = x + w / 2, y + h / 2, 4.0 * w
    c, s_ = np.cos(np.radians(yaw_deg)), np.sin(np.radians(yaw_deg))

    def project(pts: np.ndarray) -> np.ndarray:
        dx, dy = pts[:, 0] - cx, pts[:, 1] - cy
        z = depth + dx * s_
        return np.stack([cx + depth * dx * c / z, cy + depth * dy / z], axis=1)

    hh, ww = img.shape[:2]
    corners = np.array([[0, 0], [ww, 0], [ww, hh], [0, hh]], dtype=np.float64)
    m = cv2.getPerspectiveTransform(corners.astype(np.float32), project(corners).astype(np.float32))
    out = cv2.warpPerspective(img, m, (ww, hh), borderMode=cv2.BORDER_REPLICATE)
    boxes = []
    for bx, by, bw, bh in truth:
        q = project(np.array([[bx, by], [bx + bw, by], [bx + bw, by + bh], [bx, by + bh]]))
        boxes.append([q[:, 0].min(), q[:, 1].min(), np.ptp(q[:, 0]), np.ptp(q[:, 1])])
    return out, np.array(boxes)


def yaw_table(sets: dict, backends: list, yaws: list[float]) -> None:
    """Recall of the turned face, and the detections that are no labelled face, by yaw."""
    items = [(img, truth) for group in sets.values() for img, truth in group]
    print("\nturned photographs: the turned face found (a detection's centre in its box) / detections of no "
          "labelled face")
    print(f"{'backend':<12} " + " ".join(f"{f'{y:g} deg':>14}" for y in yaws))
    for name, det in backends:
        cells = []
        for yaw in yaws:
            found = total = stray = 0
            for img, truth in items:
                for face in range(len(truth)):
                    view, boxes = turned(img, truth, face, yaw)
                    dets = detect_faces(view, det)
                    centres = dets[:, :2] + dets[:, 2:] / 2 if len(dets) else np.zeros((0, 2))
                    inside = [(centres[:, 0] >= b[0]) & (centres[:, 0] <= b[0] + b[2]) & (centres[:, 1] >= b[1])
                              & (centres[:, 1] <= b[1] + b[3]) for b in boxes]
                    found += int(inside[face].any())
                    stray += int((~np.any(inside, axis=0)).sum()) if len(dets) else 0
                    total += 1
            cells.append(f"{found:>3d}/{total:<3d} {found / total:4.2f} {stray:2d}")
        print(f"{name:<12} " + " ".join(f"{c:>14}" for c in cells), flush=True)


def turning_row(sets: dict, model: Path, yaws: list[float], step_deg: float = 5.0) -> None:
    """The tracked BlazeFace (as the pipeline runs it) on each face turning from 0 degrees in ``step_deg`` steps,
    two frames a step: the turned face found at each of ``yaws``."""
    from avcore.blazeface import TrackingBlazeFace

    items = [(img, truth) for group in sets.values() for img, truth in group]
    found = {yaw: 0 for yaw in yaws}
    total = 0
    for img, truth in items:
        for face in range(len(truth)):
            tracker, total = TrackingBlazeFace.from_model(model), total + 1
            for yaw in np.arange(0.0, max(yaws) + step_deg / 2, step_deg):
                view, boxes = turned(img, truth, face, float(yaw))
                for _ in range(2):
                    dets = tracker.detect(view)
                b = boxes[face]
                c = dets[:, :2] + dets[:, 2:] / 2 if len(dets) else np.zeros((0, 2))
                hit = bool(((c[:, 0] >= b[0]) & (c[:, 0] <= b[0] + b[2]) & (c[:, 1] >= b[1])
                            & (c[:, 1] <= b[1] + b[3])).any())
                for y in yaws:
                    found[y] += int(hit and abs(y - yaw) < 1e-9)
    cells = [f"{found[y]:>3d}/{total:<3d} {found[y] / total:4.2f}   " for y in yaws]
    print(f"{'tracked':<12} " + " ".join(f"{c:>14}" for c in cells) + "  (turning, 5 degrees a step)", flush=True)


def head_views(data: Path, yaw_deg: float, distance_m: float) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each simulated face (``sim.face_textures.load_textures``) on a head turned by ``yaw_deg`` (with its relief,
    :mod:`sim.relief`) ``distance_m`` in front of the simulated rig's left camera: (left image, the face's box)."""
    from sim.face_textures import load_textures
    from sim.render import Person

    textures, _ = load_textures(data.parent)
    scene = _scene()
    out = []
    for face in textures:
        scene.people = [Person(face, (-0.06, -0.05, distance_m), yaw_rad=float(np.radians(yaw_deg)))]
        frame = scene.render(0.0)
        out.append((frame.left, frame.face_boxes_left[0]))
    return out


@lru_cache(maxsize=1)
def _scene():  # noqa: ANN202 - the simulated room, drawn once
    from avcore.stereo import StereoRig
    from sim.render import StereoSceneRenderer

    return StereoSceneRenderer(StereoRig.ideal(focal_px=554.0, image_size=(640, 480), baseline_m=0.12), [])


def centre_inside(dets: np.ndarray, box: np.ndarray) -> bool:
    """Whether a detection's centre lies inside ``box`` (x, y, w, h)."""
    if not len(dets):
        return False
    c = dets[:, :2] + dets[:, 2:] / 2
    return bool(((c[:, 0] >= box[0]) & (c[:, 0] <= box[0] + box[2]) & (c[:, 1] >= box[1])
                 & (c[:, 1] <= box[1] + box[3])).any())


def head_table(data: Path, backends: list, model: Path | None, yaws: list[float], distances: list[float],
               step_deg: float = 5.0) -> None:
    """Turned heads in the simulated room: each face at each distance turned both ways by each of ``yaws``, found
    by each backend on the single image and, for BlazeFace, by the tracker following the head as it turns from 0
    in ``step_deg`` steps, two frames a step (the simulator turns heads over 0.3 s: about 5 degrees a frame)."""
    from avcore.blazeface import TrackingBlazeFace

    print(f"\nturned heads in the simulated room (faces at {', '.join(f'{d:g}' for d in distances)} m, turned both "
          "ways): the face found (a detection's centre in the turned face's box)")
    print(f"{'backend':<12} " + " ".join(f"{f'{y:g} deg':>14}" for y in yaws))
    views = {(y, d, sign): head_views(data, sign * y, d) for y in yaws for d in distances for sign in (1, -1)}
    rows = [(name, lambda img, det=det: detect_faces(img, det)) for name, det in backends]
    for name, find in rows:
        cells = []
        for yaw in yaws:
            hits = [centre_inside(find(img), box) for d in distances for sign in (1, -1)
                    for img, box in views[(yaw, d, sign)]]
            cells.append(f"{sum(hits):>3d}/{len(hits):<3d} {np.mean(hits):4.2f}   ")
        print(f"{name:<12} " + " ".join(f"{c:>14}" for c in cells), flush=True)
    if model is None:
        return
    found = {y: 0 for y in yaws}
    total = 0
    steps = np.arange(0.0, max(yaws) + step_deg / 2, step_deg)
    for d in distances:
        for sign in (1, -1):
            sweep = {float(a): head_views(data, sign * a, d) for a in steps}
            for k in range(len(sweep[0.0])):
                tracker, total = TrackingBlazeFace.from_model(model), total + 1
                for a in steps:
                    img, box = sweep[float(a)][k]
                    for _ in range(2):
                        dets = tracker.detect(img)
                    for y in yaws:
                        found[y] += int(abs(y - a) < 1e-9 and centre_inside(dets, box))
    cells = [f"{found[y]:>3d}/{total:<3d} {found[y] / total:4.2f}   " for y in yaws]
    print(f"{'tracked':<12} " + " ".join(f"{c:>14}" for c in cells) + "  (turning, 5 degrees a step)", flush=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder with training.xml and testing.xml")
    parser.add_argument("--scales", type=float, nargs="+", default=[1.0, 0.8, 0.6, 0.5])
    parser.add_argument("--yunet-model", type=Path, default=None, help="YuNet ONNX file to benchmark too")
    parser.add_argument("--threads", type=int, default=1, help="OpenCV threads (default 1: one core)")
    parser.add_argument("--yaws", type=float, nargs="*", default=[0, 30, 45, 60],
                        help="degrees of the turned-photograph and turned-head tables (none: no tables)")
    parser.add_argument("--distances", type=float, nargs="+", default=[1.3, 2.1, 2.9],
                        help="metres from the camera of the turned-head table's faces")
    args = parser.parse_args()
    if not (args.data / "testing.xml").is_file():
        print(f"no labelled faces at {args.data}; give --data", file=sys.stderr)
        return 2
    cv2.setNumThreads(args.threads)
    sets = {name: load(args.data, f"{name}.xml") for name in ("training", "testing")}
    backends = [(f"haar x{s:g}", HaarFaceDetector(scale=s)) for s in args.scales] if hasattr(
        cv2, "CascadeClassifier") else []
    if not backends:
        print(f"Haar left out: OpenCV {cv2.__version__} has no Haar cascades", file=sys.stderr)
    if args.yunet_model is not None:
        backends += [(f"yunet x{s:g}", YuNetFaceDetector(args.yunet_model, scale=s)) for s in args.scales]
    model = None
    try:
        from app.models import blazeface_model

        model = blazeface_model()
        backends += [("blazeface", BlazeFaceDetector(model, tiles=1)),
                     ("blaze 2x2", BlazeFaceDetector(model, tiles=2))]
    except Exception as exc:  # noqa: BLE001 - the benchmark runs without it and says why
        print(f"BlazeFace left out: {exc}", file=sys.stderr)
    widths = np.concatenate([t[:, 2] for items in sets.values() for _, t in items])
    bins = [(0, 40), (40, 60), (60, 1e9)]
    by_size: dict[str, list[int]] = {}
    print(f"face detection on {args.data} (IoU >= 0.5), OpenCV {cv2.__version__}, {args.threads} thread(s)")
    print(f"{'backend':<12} {'set':<9} {'faces':>5} {'found':>5} {'dets':>5} {'recall':>7} {'precision':>9} "
          f"{'ms/img':>7}")
    for k, (name, det) in enumerate(backends, 1):
        print(f"[{k}/{len(backends)}] {name} ...", file=sys.stderr)
        for set_name, items in sets.items():
            n_true = n_found = n_det = 0
            times = []
            for img, truth in items:
                t0 = time.perf_counter()
                boxes = detect_faces(img, det)
                times.append(time.perf_counter() - t0)
                n_true += len(truth)
                n_det += len(boxes)
                hit = matched_truth(truth, boxes)
                n_found += int(hit.sum())
                counts = by_size.setdefault(name, [0] * len(bins))
                for b, (lo, hi) in enumerate(bins):
                    counts[b] += int(hit[(truth[:, 2] >= lo) & (truth[:, 2] < hi)].sum())
            recall = n_found / n_true if n_true else float("nan")
            precision = n_found / n_det if n_det else float("nan")
            print(f"{name:<12} {set_name:<9} {n_true:5d} {n_found:5d} {n_det:5d} {recall:7.2f} {precision:9.2f} "
                  f"{1000 * np.median(times):7.1f}", flush=True)
    print("\nrecall by the labelled face's width (both sets):")
    totals = [int(((widths >= lo) & (widths < hi)).sum()) for lo, hi in bins]
    print(f"{'backend':<12} " + " ".join(f"{f'{lo:g}-{hi:g} px' if hi < 1e9 else f'>= {lo:g} px':>14}"
                                         for lo, hi in bins))
    for name, counts in by_size.items():
        print(f"{name:<12} " + " ".join(f"{c:>5d}/{t:<3d} {c / t if t else float('nan'):4.2f}"
                                        for c, t in zip(counts, totals)))
    if args.yaws:
        blaze = model if any(name.startswith("blaze") for name, _ in backends) else None
        yaw_table(sets, backends, args.yaws)
        if blaze is not None:
            turning_row(sets, blaze, args.yaws)
        head_table(args.data, backends, blaze, args.yaws, args.distances)
    print("paper: WaldBoost detector (no figures on these photographs); images are about 500x375 px")
    return 0


if __name__ == "__main__":
    sys.exit(main())
