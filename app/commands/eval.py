"""`avhear eval ...`: accuracy evaluations that print the paper's tables beside ours."""
from __future__ import annotations

import argparse
import json
import sys
import time

from app.errors import UserError
from avcore.synthetic import SEQUENCES
from avcore.synthetic_eval import (
    FACE_VARIANTS,
    PAPER_AUDIO,
    PAPER_VISUAL,
    VARIANTS,
    SequenceScore,
    evaluate_face_guided,
    evaluate_sequence,
)

VARIANT_LABELS = {"paper": "paper's method", "avhear": "avhear"}


def add_parser(sub: argparse._SubParsersAction) -> None:
    parser = sub.add_parser("eval", help="accuracy evaluations (the paper's section 7)")
    kinds = parser.add_subparsers(dest="kind", metavar="KIND")
    kinds.required = True
    syn = kinds.add_parser(
        "synthetic",
        help="Algorithm 1 on the synthetic sequences of section 7.1 (tables 1 and 2)",
        description="Run Motion-Guided Robot Hearing (Algorithm 1) on the four synthetic sequence types of the "
        "paper's section 7.1 and print its tables 1 (visual) and 2 (auditory state) with the paper's published "
        "numbers, the paper's method as implemented here, and avhear's method.",
    )
    syn.add_argument("--sequence", nargs="+", choices=SEQUENCES, default=list(SEQUENCES), metavar="NAME",
                     help=f"sequence types to run (default: all of {', '.join(SEQUENCES)})")
    syn.add_argument("--seed", nargs="+", type=int, default=None, metavar="N",
                     help="seeds of the generated sequences (default: 0 1 2)")
    syn.add_argument("--variant", nargs="+", choices=sorted(VARIANTS), default=["paper", "avhear"],
                     help="which variants of the method to run (default: both)")
    syn.add_argument("--face-guided", action="store_true",
                     help="also run Algorithm 2 (faces given) with its variants on the same sequences (table 3)")
    syn.add_argument("--json", action="store_true", help="print the results as JSON instead of tables")
    syn.set_defaults(func=run_synthetic)


def _progress(message: str) -> None:
    print(f"  {message}", file=sys.stderr, flush=True)


def run_synthetic(args: argparse.Namespace) -> int:
    seeds = args.seed if args.seed is not None else [0, 1, 2]
    if any(s < 0 for s in seeds):
        raise UserError(f"--seed takes non-negative integers, got {seeds}")
    scores: list[SequenceScore] = []
    start = time.perf_counter()
    if not args.json:
        print(f"Running {len(args.sequence)} sequence type(s) x {len(seeds)} seed(s) x {len(args.variant)} "
              "variant(s) (136 intervals of 0.4 s each)...", file=sys.stderr, flush=True)
    for name in args.sequence:
        for variant in args.variant:
            scores.append(evaluate_sequence(name, seeds, VARIANTS[variant](), variant=variant,
                                            progress=None if args.json else _progress))
    face: list[SequenceScore] = []
    if args.face_guided:
        for name in args.sequence:
            for variant, params in FACE_VARIANTS.items():
                face.append(evaluate_face_guided(name, seeds, params(), variant=variant))
    if args.json:
        out = _as_json(scores, seeds)
        out["face_guided"] = [s.as_dict() for s in face]
        print(json.dumps(out, indent=2))
    else:
        print(format_tables(scores, seeds))
        if face:
            print()
            print(format_face_table(face, seeds))
        print(f"\n({time.perf_counter() - start:.1f} s)")
    return 0


def _as_json(scores: list[SequenceScore], seeds: list[int]) -> dict[str, object]:
    return {
        "seeds": seeds,
        "results": [s.as_dict() for s in scores],
        "paper": {"visual": {k: PAPER_VISUAL[k] for k in {s.sequence for s in scores}},
                  "audio": {k: PAPER_AUDIO[k] for k in {s.sequence for s in scores}}},
    }


def _pct(count: float, total: float) -> str:
    return f"({100.0 * count / total:4.1f}%)" if total else "(  - )"


def format_tables(scores: list[SequenceScore], seeds: list[int]) -> str:
    """Tables 1 and 2 of section 7.1; our counts are per sequence (averaged over the seeds)."""
    n = len(seeds)
    lines = [
        f"Table 1 - visual evaluation (section 7.1). Counts per 136-interval sequence, averaged over seeds "
        f"{', '.join(map(str, seeds))}; TP % = TP / (TP + FN).",
        f"{'Seq.':8s} {'method':22s} {'FP':>7s} {'FN':>16s} {'TP':>16s} {'ALE [m]':>8s}",
    ]
    for name in dict.fromkeys(s.sequence for s in scores):
        p = PAPER_VISUAL[name]
        lines.append(f"{name:8s} {'paper (published)':22s} {p['fp']:7.0f} {p['fn']:6.0f} "
                     f"{_pct(p['fn'], p['fn'] + p['tp']):>9s} {p['tp']:6.0f} {_pct(p['tp'], p['fn'] + p['tp']):>9s} "
                     f"{p['ale_m']:8.2f}")
        for s in scores:
            if s.sequence != name:
                continue
            t = s.totals
            lines.append(f"{'':8s} {VARIANT_LABELS.get(s.variant, s.variant):22s} {t.fp / n:7.1f} {t.fn / n:6.1f} "
                         f"{_pct(t.fn, t.n_truth):>9s} {t.tp / n:6.1f} {_pct(t.tp, t.n_truth):>9s} {t.ale_m:8.3f}")
    lines += [
        "",
        "Table 2 - auditory state (section 7.1), over the true-positive clusters. TP % = TP / (TP + FN).",
        f"{'Seq.':8s} {'method':22s} {'FP':>7s} {'FN':>16s} {'TP':>16s}",
    ]
    for name in dict.fromkeys(s.sequence for s in scores):
        p = PAPER_AUDIO[name]
        lines.append(f"{name:8s} {'paper (published)':22s} {p['fp']:7.0f} {p['fn']:6.0f} "
                     f"{_pct(p['fn'], p['fn'] + p['tp']):>9s} {p['tp']:6.0f} {_pct(p['tp'], p['fn'] + p['tp']):>9s}")
        for s in scores:
            if s.sequence != name:
                continue
            t = s.totals
            speak = t.audio_tp + t.audio_fn
            lines.append(f"{'':8s} {VARIANT_LABELS.get(s.variant, s.variant):22s} {t.audio_fp / n:7.1f} "
                         f"{t.audio_fn / n:6.1f} {_pct(t.audio_fn, speak):>9s} {t.audio_tp / n:6.1f} "
                         f"{_pct(t.audio_tp, speak):>9s}")
    return "\n".join(lines)


def format_face_table(scores: list[SequenceScore], seeds: list[int]) -> str:
    """Table 3 (avhear's): Algorithm 2's speaking states with the faces given, per variant."""
    n = len(seeds)
    lines = [
        "Table 3 - Face-Guided Robot Hearing (Algorithm 2), faces = visible people + 1 cm noise; speaking states.",
        "paper = means free, tau_A = K/(N+2); anchored = means kept at the faces; avhear = anchored + outlier-aware.",
        f"{'Seq.':8s} {'variant':22s} {'FP':>7s} {'FN':>16s} {'TP':>16s}",
    ]
    for name in dict.fromkeys(s.sequence for s in scores):
        for s in scores:
            if s.sequence != name:
                continue
            t = s.totals
            speak = t.audio_tp + t.audio_fn
            lines.append(f"{name if s is scores[0] or s.variant == 'paper' else '':8s} {s.variant:22s} "
                         f"{t.audio_fp / n:7.1f} {t.audio_fn / n:6.1f} {_pct(t.audio_fn, speak):>9s} "
                         f"{t.audio_tp / n:6.1f} {_pct(t.audio_tp, speak):>9s}")
    return "\n".join(lines)
