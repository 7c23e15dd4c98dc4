"""Soak: a long recording replayed as fast as possible gives the same results as in real time, with flat memory.

    python benchmarks/soak.py                    # S2, 600 s: simulated once, replayed --fast, then in real time
    python benchmarks/soak.py --duration 120     # a shorter check
    python benchmarks/soak.py --folder DIR       # replay an existing recording instead of simulating one

Both replays run the real pipeline (no console) with every result kept. Printed: results, ITDs per result (min,
median), every drop counter, resident memory over each run (mean of its first and last quarter, peak), and how many
results differ between the two replays in their speaking states. A real-time replay on a busy machine may skip
late frames (counted as "late frames"): results are compared on the stamps both runs have.
"""
from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pipeline import MemoryMonitor  # noqa: E402  (benchmarks/pipeline.py)

from app.cli import main as avhear  # noqa: E402
from app.pipeline import Pipeline, PipelineConfig
from app.result import Result  # noqa: E402
from app.sources.open import open_source  # noqa: E402


def replay(folder: Path, realtime: bool) -> tuple[dict[float, tuple], dict[str, object]]:
    source = open_source(f"replay:{folder}", realtime=realtime)
    states: dict[float, tuple] = {}
    n_itds: list[int] = []
    first: list[float] = []

    def on_result(r: Result) -> None:
        if not first:
            first.append(r.stamp_s)
        n_itds.append(r.itds_s.size)
        states[round(r.stamp_s - first[0], 4)] = tuple(zip(r.person_ids.tolist(), r.output.speaking.tolist()))

    pipe = Pipeline(source, PipelineConfig(), on_result)
    monitor = MemoryMonitor(0.0, pipe, every_s=1.0, progress_s=60.0)
    monitor.start()
    stats = pipe.run()
    monitor.stop()
    mem = monitor.figures()
    d = stats.as_dict()
    itds = np.asarray(n_itds)
    return states, {"results": d["results"], "seconds": d["duration_s"], "results with < 15 ITDs": int((itds < 15).sum()),
                    "itds_median": float(np.median(itds)), "drops (all counters)": sum(d["drops"].values()),
                    "late frames": d["late_frames"],
                    "rss first quarter MB": round(mem["rss_start_mb"]), "rss last quarter MB": round(mem["rss_end_mb"]),
                    "rss peak MB": round(mem["peak_mb"])}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--duration", type=float, default=600.0, help="seconds of recording (default 600)")
    p.add_argument("--scenario", default="S2")
    p.add_argument("--folder", type=Path, default=None, help="an existing recording to replay")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = args.folder
        if folder is None:
            folder = Path(tmp) / "soak"
            if avhear(["simulate", args.scenario, "-o", str(folder), "--duration", str(args.duration)]) != 0:
                return 1
        fast, fast_fig = replay(folder, realtime=False)
        real, real_fig = replay(folder, realtime=True)
    common = sorted(set(fast) & set(real))
    differ = sum(fast[t] != real[t] for t in common)
    print(f"\n{folder}: {args.duration:g} s of {args.scenario}")
    print(f"{'':24s} {'as fast as possible':>22s} {'real time':>22s}")
    for key in fast_fig:
        print(f"{key:24s} {str(fast_fig[key]):>22s} {str(real_fig[key]):>22s}")
    print(f"results compared on common stamps: {len(common)}; speaking states differing: {differ}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
