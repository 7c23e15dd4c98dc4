"""One interval of a skeletons family drawn person by person, with the truth points a position can be scored
against (issue 18): where the motion points lie, and where each truth and avhear's estimate put the person.

    python benchmarks/body_truths_figure.py                         # skeletons:seated, seed 0, interval 10
    python benchmarks/body_truths_figure.py --family close --seed 1 --interval 30 --out /tmp/close.png

One panel per visible person, seen from the cameras (x right, y up in the picture; metres around the person's
default truth). Dots: the motion points the generator drew for that person (dark) and every other point nearby
(outliers, neighbours; light); the person's labels are the generator's, shown here only to look at. Marks:

- blue cross: the default truth, the centre of the visible moving body (:mod:`sim.skeletons`, ``"moving"``);
- green cross: the paper's truth, the mean of the person's feature distribution (``"points"``);
- black plus: the head's centre (``"head"``);
- red circle: avhear's estimate (``MotionGuidedHearing`` run over the sequence up to that interval).

The caption under each panel gives the estimate's distance to each truth.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from app.plotting import BLACK, BLUE, FONT, GREEN, GREY, LIGHT, RED  # noqa: E402
from avcore.evaluation import match_clusters  # noqa: E402
from avcore.geometry import MicPair  # noqa: E402
from avcore.inference import MotionGuidedHearing, MotionGuidedParams  # noqa: E402
from sim import skeletons  # noqa: E402

TRUTHS = (("moving", BLUE, "x"), ("points", GREEN, "x"), ("head", BLACK, "+"))
PX_PER_M = 420


def _mark(img: np.ndarray, p: tuple[int, int], colour: tuple[int, int, int], kind: str) -> None:
    x, y = p
    if kind == "x":
        cv2.line(img, (x - 7, y - 7), (x + 7, y + 7), colour, 2, cv2.LINE_AA)
        cv2.line(img, (x - 7, y + 7), (x + 7, y - 7), colour, 2, cv2.LINE_AA)
    elif kind == "+":
        cv2.line(img, (x - 8, y), (x + 8, y), colour, 2, cv2.LINE_AA)
        cv2.line(img, (x, y - 8), (x, y + 8), colour, 2, cv2.LINE_AA)
    else:
        cv2.circle(img, p, 8, colour, 2, cv2.LINE_AA)


def draw(family: str, seed: int, interval: int) -> np.ndarray:
    """The figure as a BGR image (see the module docstring)."""
    seqs = {name: skeletons.generate_family(family, seed=seed,
                                            config=skeletons.BodyConfig(n_intervals=interval + 1, truth_point=name))
            for name, _, _ in TRUTHS}
    hearing = MotionGuidedHearing(MicPair(), MotionGuidedParams())
    for iv in seqs["moving"][: interval + 1]:
        out = hearing.step(iv.points, iv.itds)
    iv = seqs["moving"][interval]
    match = dict(match_clusters(out.positions, iv.truth_xyz).pairs)
    # one extent for every panel, around each person's default truth: what holds 98 % of their points
    offsets = [iv.points[iv.point_ids == pid] - iv.truth_xyz[g] for g, pid in enumerate(iv.truth_ids)]
    offsets = [o for o in offsets if o.shape[0]] or [np.zeros((1, 3))]
    half_w = max(float(np.quantile(np.abs(o[:, 0]), 0.98)) for o in offsets) + 0.1
    up = max(float(-np.quantile(o[:, 1], 0.01)) for o in offsets) + 0.1
    down = max(float(np.quantile(o[:, 1], 0.99)) for o in offsets) + 0.1
    half_w = max(half_w, 150 / PX_PER_M)  # room for the caption
    pw, ph, caption_h, title_h = int(2 * half_w * PX_PER_M), int((up + down) * PX_PER_M), 90, 56
    panels = []
    for g, pid in enumerate(iv.truth_ids):
        img = np.full((ph + caption_h, pw, 3), 255, np.uint8)
        centre = iv.truth_xyz[g]

        def px(p: np.ndarray, c: np.ndarray = centre) -> tuple[int, int]:
            return int(round((p[0] - c[0] + half_w) * PX_PER_M)), int(round((p[1] - c[1] + up) * PX_PER_M))

        near = np.abs(iv.points[:, 2] - centre[2]) < 0.5
        for own in (False, True):
            sel = near & ((iv.point_ids == pid) == own)
            for p in iv.points[sel]:
                cv2.circle(img, px(p), 2, GREY if own else LIGHT, -1)
        for name, colour, kind in TRUTHS:
            _mark(img, px(seqs[name][interval].truth_xyz[g]), colour, kind)
        lines = [f"person {pid}: {int((iv.point_ids == pid).sum())} points"]
        if g in match:
            est = out.positions[match[g]]
            _mark(img, px(est), RED, "o")
            d = {name: 100 * np.linalg.norm(est - seqs[name][interval].truth_xyz[g]) for name, _, _ in TRUTHS}
            lines += [f"avhear to moving {d['moving']:.1f} cm,", f"to points {d['points']:.1f}, to head {d['head']:.1f}"]
        else:
            lines.append("not found")
        for k, text in enumerate(lines):
            cv2.putText(img, text, (8, ph + 22 + 24 * k), FONT, 0.5, BLACK, 1, cv2.LINE_AA)
        cv2.rectangle(img, (0, 0), (pw - 1, ph - 1), GREY, 1)
        bar = int(0.1 * PX_PER_M)  # a 10 cm scale bar
        cv2.line(img, (10, ph - 12), (10 + bar, ph - 12), BLACK, 2)
        cv2.putText(img, "10 cm", (14 + bar, ph - 7), FONT, 0.45, BLACK, 1, cv2.LINE_AA)
        panels.append(img)
    body = np.concatenate(panels, axis=1) if panels else np.full((ph + caption_h, pw, 3), 255, np.uint8)
    head = np.full((title_h, body.shape[1], 3), 255, np.uint8)
    titles = (f"skeletons:{family}, seed {seed}, interval {interval}; red o avhear, black + head,",
              "blue x moving-body truth (default), green x points' mean (paper)")
    for k, text in enumerate(titles):
        cv2.putText(head, text, (8, 22 + 24 * k), FONT, 0.5, BLACK, 1, cv2.LINE_AA)
    return np.concatenate([head, body], axis=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--family", default="seated", choices=skeletons.FAMILIES)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--interval", type=int, default=10)
    parser.add_argument("--out", type=Path, default=Path("body_truths.png"))
    args = parser.parse_args()
    if args.seed < 0 or args.interval < 0:
        parser.error("--seed and --interval must be >= 0")
    if args.out.suffix.lower() not in (".png", ".jpg", ".jpeg"):
        parser.error(f"--out {args.out}: give a .png or .jpg file")
    if not args.out.parent.is_dir():  # checked before the drawing, which takes a few seconds
        parser.error(f"--out {args.out}: no such directory {args.out.parent}; create it first")
    img = draw(args.family, args.seed, args.interval)
    if not cv2.imwrite(str(args.out), img):
        parser.error(f"cannot write {args.out}: check the directory is writable")
    print(f"wrote {args.out} ({img.shape[1]} x {img.shape[0]} px)")


if __name__ == "__main__":
    main()
