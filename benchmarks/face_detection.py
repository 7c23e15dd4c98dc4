"""Face detection recall and precision on real photographs with labelled faces (issue 4, paper section 5.2).

Data: ../shared/data/faces (dlib's examples: PASCAL VOC photographs, faces labelled in training.xml and
testing.xml). A detection counts when it overlaps a labelled box with IoU >= 0.5 (one-to-one, greedy by IoU).
Small background faces (posters, crowds) are not labelled, so precision is a lower bound.

    python benchmarks/face_detection.py                       # Haar at several scales, BlazeFace when installed
    python benchmarks/face_detection.py --yunet-model face_detection_yunet_2023mar.onnx

Each backend's recall by the labelled face's width follows (the faces of these photographs are 24-100 px wide).
"""
from __future__ import annotations

import argparse
import sys
import time
import xml.etree.ElementTree as ET
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


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT_DATA, help="folder with training.xml and testing.xml")
    parser.add_argument("--scales", type=float, nargs="+", default=[1.0, 0.8, 0.6, 0.5])
    parser.add_argument("--yunet-model", type=Path, default=None, help="YuNet ONNX file to benchmark too")
    parser.add_argument("--threads", type=int, default=1, help="OpenCV threads (default 1: one core)")
    args = parser.parse_args()
    if not (args.data / "testing.xml").is_file():
        print(f"no labelled faces at {args.data}; give --data", file=sys.stderr)
        return 2
    cv2.setNumThreads(args.threads)
    sets = {name: load(args.data, f"{name}.xml") for name in ("training", "testing")}
    backends = [(f"haar x{s:g}", HaarFaceDetector(scale=s)) for s in args.scales]
    if args.yunet_model is not None:
        backends += [(f"yunet x{s:g}", YuNetFaceDetector(args.yunet_model, scale=s)) for s in args.scales]
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
    print("paper: WaldBoost detector (no figures on these photographs); images are about 500x375 px")
    return 0


if __name__ == "__main__":
    sys.exit(main())
