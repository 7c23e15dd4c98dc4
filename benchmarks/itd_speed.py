"""Real-time factor of each ITD method (issue 3, section 4): processing time / audio duration, on one core.

Every window passes the energy gate (the worst case: someone speaks all the time). Both the batch form
(``extract_itds``) and the streaming form (``ItdStream`` fed 10 ms blocks, as the audio callback does) are timed.

    python benchmarks/itd_speed.py           # 16 and 48 kHz, 20 s of audio, best of 3
    python benchmarks/itd_speed.py --quick   # 5 s of audio, best of 2

Targets (issue 3): real-time factor <= 0.05 for the correlogram and <= 0.01 for GCC-PHAT at 16 kHz.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):  # one core, before numpy loads
    os.environ.setdefault(_var, "1")

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from avcore.itd import ItdStream, extract_itds

METHODS = ["correlogram", "gcc-phat", "correlogram-robust", "gcc-phat-robust"]
TARGETS = {"correlogram": 0.05, "gcc-phat": 0.01}


def test_signal(seconds: float, fs: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    n = int(seconds * fs)
    right = 0.1 * rng.standard_normal(n)
    left = np.concatenate([np.zeros(3), right[:-3]])
    return left, right


def best_time(fn, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="5 s of audio, best of 2")
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--rates", type=int, nargs="+", default=[16000, 48000])
    parser.add_argument("--methods", nargs="+", default=METHODS)
    args = parser.parse_args()
    if args.quick:
        args.seconds, args.repeats = 5.0, 2
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core

    print(f"ITD real-time factor: {args.seconds:.0f} s of two-channel audio, every window active, window 150 ms, "
          f"hop 20 ms, lags +-1 ms, one core, best of {args.repeats}.")
    header = f"{'method':<20} {'rate Hz':>8} {'batch RTF':>10} {'stream RTF':>11} {'target':>8}"
    print(header)
    print("-" * len(header))
    for fs in args.rates:
        left, right = test_signal(args.seconds, fs)
        block = int(0.01 * fs)
        for method in args.methods:
            print(f"  timing {method} at {fs} Hz ...", file=sys.stderr, flush=True)

            def batch(left=left, right=right, fs=fs, method=method) -> None:
                extract_itds(left, right, fs, method=method)

            def stream(left=left, right=right, fs=fs, method=method, block=block) -> None:
                s = ItdStream(fs, method=method)
                for i in range(0, len(left), block):
                    s.push(left[i:i + block], right[i:i + block])

            rtf_batch = best_time(batch, args.repeats) / args.seconds
            rtf_stream = best_time(stream, args.repeats) / args.seconds
            target = TARGETS.get(method) if fs == 16000 else None
            mark = "" if target is None else f"<= {target:g}" + (" ok" if max(rtf_batch, rtf_stream) <= target
                                                                 else " MISSED")
            print(f"{method:<20} {fs:>8d} {rtf_batch:>10.4f} {rtf_stream:>11.4f} {mark:>8}", flush=True)


if __name__ == "__main__":
    main()
