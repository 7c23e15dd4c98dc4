"""Real-time factor of each ITD method (issue 3, section 4): processing time / audio duration, on one core.

Every window passes the energy gate (the worst case: someone speaks all the time). Both the batch form
(``extract_itds``) and the streaming form (``PairStream`` fed 10 ms blocks, as the audio callback does) are timed.

    python benchmarks/itd_speed.py           # 16 and 48 kHz, 20 s of audio, best and median of 5
    python benchmarks/itd_speed.py --quick   # 5 s of audio, best and median of 3
    python benchmarks/itd_speed.py --quick --rates 16000 --methods gcc-phat-robust \
        'gcc-phat-robust[dereverb_taps=0,frame_corr_power=0]'   # a method with options (as itd_accuracy.py)

Times are the process's CPU time (one thread: the BLAS and FFT libraries are limited to one), so that other work on
a shared machine does not count; still, it slows the caches and the core down, so the best of the repeats is the
figure to compare with the targets, and the median shows how much the others disturbed it.

Targets (issue 3): real-time factor <= 0.05 for the correlogram and <= 0.01 for GCC-PHAT at 16 kHz.

``--arrays nao uma8`` also times the streaming extraction on every pair of those microphone arrays (one
``PairStream`` per pair, ``avcore.itd.PairsItdStream``) and prints the cost per pair: it grows linearly.
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

from avcore.itd import extract_itds
from avcore.itd._extract import PairStream
from benchmarks.itd_accuracy import parse_spec

METHODS = ["correlogram", "gcc-phat", "correlogram-robust", "gcc-phat-robust"]
TARGETS = {"correlogram": 0.05, "gcc-phat": 0.01}


def test_signal(seconds: float, fs: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    n = int(seconds * fs)
    right = 0.1 * rng.standard_normal(n)
    left = np.concatenate([np.zeros(3), right[:-3]])
    return left, right


def timings(fn, repeats: int) -> tuple[float, float]:
    """Best and median CPU time of ``repeats`` calls, seconds."""
    times = []
    for _ in range(repeats):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times), float(np.median(times))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--quick", action="store_true", help="5 s of audio, 3 repeats")
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--rates", type=int, nargs="+", default=[16000, 48000])
    parser.add_argument("--methods", nargs="+", default=METHODS)
    parser.add_argument("--arrays", nargs="*", default=[], help="array presets to time on every pair (16 kHz)")
    args = parser.parse_args()
    if args.quick:
        args.seconds, args.repeats = 5.0, 3
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core

    print(f"ITD real-time factor: {args.seconds:.0f} s of two-channel audio, every window active, window 150 ms, "
          f"hop 20 ms, lags +-1 ms, one core, best (median) of {args.repeats}.")
    width = max(20, *(len(m) + 1 for m in args.methods))
    header = (f"{'method':<{width}} {'rate Hz':>8} {'batch RTF':>17} {'stream RTF':>17} {'target':>8}")
    print(header)
    print("-" * len(header))
    for fs in args.rates:
        left, right = test_signal(args.seconds, fs)
        block = int(0.01 * fs)
        for spec in args.methods:
            print(f"  timing {spec} at {fs} Hz ...", file=sys.stderr, flush=True)
            method, options = parse_spec(spec)

            def batch(left=left, right=right, fs=fs, method=method, options=options) -> None:
                extract_itds(left, right, fs, method=method, **options)

            def stream(left=left, right=right, fs=fs, method=method, options=options, block=block) -> None:
                s = PairStream(fs, method=method, **options)
                for i in range(0, len(left), block):
                    s.push(left[i:i + block], right[i:i + block])

            rtf_batch, med_batch = (t / args.seconds for t in timings(batch, args.repeats))
            rtf_stream, med_stream = (t / args.seconds for t in timings(stream, args.repeats))
            target = TARGETS.get(spec) if fs == 16000 else None
            mark = "" if target is None else f"<= {target:g}" + (" ok" if max(rtf_batch, rtf_stream) <= target
                                                                 else " MISSED")
            print(f"{spec:<{width}} {fs:>8d} {rtf_batch:>8.4f} ({med_batch:.4f}) {rtf_stream:>8.4f} ({med_stream:.4f}) "
                  f"{mark:>8}", flush=True)
    for name in args.arrays:
        time_array(name, args)


def time_array(name: str, args: argparse.Namespace) -> None:
    """Streaming extraction on every pair of an array preset: the real-time factor in all and per pair."""
    from avcore.geometry import MicArray
    from avcore.itd import PairsItdStream

    array = MicArray.preset(name)
    fs = 16000
    rng = np.random.default_rng(0)
    n = int(args.seconds * fs)
    channels = 0.1 * rng.standard_normal((n, max(array.channels) + 1))
    block = int(0.01 * fs)
    print(f"\n{name}: {len(array.positions)} microphones, {array.n_pairs} pairs, 16 kHz, streaming")
    for spec in args.methods:
        method, options = parse_spec(spec)
        frame_itds = method == "gcc-phat-robust"

        def stream(method=method, options=options, frame_itds=frame_itds) -> None:
            s = PairsItdStream(array, fs, method=method, frame_itds=frame_itds, **options)
            for i in range(0, n, block):
                s.push(channels[i:i + block])
                if frame_itds:
                    s.pop_frame_itds(), s.pop_band_itds()

        best, med = (t / args.seconds for t in timings(stream, args.repeats))
        print(f"  {spec:<{22}} RTF {best:.4f} ({med:.4f}) for {array.n_pairs} pairs, {best / array.n_pairs:.4f} per "
              f"pair", flush=True)


if __name__ == "__main__":
    main()
