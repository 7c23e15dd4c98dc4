"""The scenarios of section 7.3 (S1-S5) over several seeds: the spread of the speaking-state figures (issue 5, §4).

``avhear eval scenarios`` sums the counts over its seeds; this script prints one row per seed as well, so that the
variation between seeds (different faces, timelines and voices) is visible next to the totals. Each scenario takes
15-35 s per seed on two cores.

    python benchmarks/scenarios.py                          # S1-S5, seeds 0 1 2, face-guided
    python benchmarks/scenarios.py --seeds 0 1 --motion     # the motion-guided variant
    python benchmarks/scenarios.py --scenario S2 S4 --no-calibrate   # with the nominal microphone pair
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from app.commands.options import add_method_arguments, pipeline_config
from app.eval.scenarios import PAPER_PERCENT, SCENARIOS, SCENARIO_CHOICES, calibrate_on_preset, evaluate_scenario
from app.eval.scoring import ScenarioScore


def _pct(x: float) -> str:
    return "   -  " if math.isnan(x) else f"{100 * x:5.1f}%"


def _num(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:+.1f}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", nargs="+", choices=SCENARIO_CHOICES, default=list(SCENARIOS))
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    parser.add_argument("--duration", type=float, default=None, help="seconds per scenario (default the preset's)")
    add_method_arguments(parser)
    parser.add_argument("--calibrate", action=argparse.BooleanOptionalAction, default=True,
                        help="fit c1, c0 on the calibration preset first (default), as avhear eval scenarios")
    parser.add_argument("--json", type=Path, default=None, help="also write every row to this file")
    args = parser.parse_args()
    config = pipeline_config(args)
    mics = None
    if args.calibrate:
        fit = calibrate_on_preset(seed=args.seeds[0], config=config)
        mics = fit.mics
        print(f"calibration: {fit.as_dict()}", flush=True)
    print(f"{config.inference}-guided, ITD {config.itd_method}; one count = one visible person during 0.4 s")
    print(f"{'scen.':6s} {'seed':>5s} {'TP':>4s} {'FN':>4s} {'FP':>4s} {'TN':>4s} {'TP %':>7s} {'paper':>7s} "
          f"{'FN face':>8s} {'FN ovl':>7s} {'faces':>7s} {'F3D m':>6s} {'ITD40':>7s} {'pull us':>8s} {'time':>6s}")
    rows = []
    for name in args.scenario:
        total: ScenarioScore | None = None
        for seed in args.seeds:
            t0 = time.perf_counter()
            s = evaluate_scenario(name, seed, duration_s=args.duration, config=config, mics=mics)
            elapsed = time.perf_counter() - t0
            _row(name, str(seed), s, elapsed)
            rows.append(s.as_dict())
            if total is None:
                total = s
            else:
                total.merge(s)
        assert total is not None
        _row(name, "all", total, float("nan"))
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=2))
    return 0


def _row(name: str, seed: str, s: ScenarioScore, elapsed: float) -> None:
    c = s.counts
    print(f"{name:6s} {seed:>5s} {c.tp:4d} {c.fn:4d} {c.fp:4d} {c.tn:4d} {_pct(c.tp_rate):>7s} "
          f"{PAPER_PERCENT.get(name, (math.nan, math.nan))[1]:6.1f}% {c.fn_missed_face:8d} {c.fn_overlap:7d} "
          f"{_pct(s.all_found_share):>7s} "
          f"{s.f3d_median_m:6.3f} {_pct(s.itd_accuracy):>7s} {_num(s.itd_pull_s * 1e6):>8s} "
          f"{'' if math.isnan(elapsed) else f'{elapsed:5.0f}s':>6s}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
