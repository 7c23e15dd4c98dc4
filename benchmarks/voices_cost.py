"""CPU of each person's voice (issue 59): the separator alone, per second of audio, with and without its parts.

Three people, one talking all along, one half the time, one silent; people updates at 30 a second and audio in
blocks of 1/30 s, as the pipeline's voices thread takes them. Every configuration runs the same 10 s of noise, best
of three (the process's CPU time, BLAS on one thread: other work on a shared machine slows the caches, so the best
is the figure to compare, as in itd_speed.py).

    python benchmarks/voices_cost.py            # the pair and four microphones, 16 and 48 kHz
    python benchmarks/voices_cost.py --quick    # 3 s, one repeat

Columns: the default stream (the room's filter with three microphones or more, the choice of three beams), without
the room's filter, without the choice; and the room's filter alone (avcore.dereverb.Dereverberator on the same
frames).
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

from avcore.dereverb import Dereverberator  # noqa: E402
from avcore.separation import VoiceSeparator  # noqa: E402

PEOPLE = np.array([[-1.0, 0.0, 2.0], [0.0, 0.0, 2.5], [1.0, 0.0, 2.0]])


def _mics(q: int) -> np.ndarray:
    """``q`` microphones on a 64 mm circle (the pair: 64 mm apart)."""
    a = 2 * np.pi * np.arange(q) / q
    return np.stack([0.032 * np.cos(a), np.zeros(q), 0.032 * np.sin(a)], axis=1)


def _separator_cpu(q: int, fs: int, seconds: float, repeats: int, **options: bool) -> float:
    rng = np.random.default_rng(0)
    x = rng.standard_normal((int(fs * seconds), q)) * 0.1
    ids, block, best = np.arange(3), fs // 30, float("inf")
    for _ in range(repeats):
        separator = VoiceSeparator(_mics(q), fs, **options)
        t0 = time.process_time()
        for k, start in enumerate(range(0, x.shape[0], block)):
            separator.push_people(start / fs, ids, PEOPLE, np.array([True, k % 30 < 15, False]))
            separator.push_audio(start / fs, x[start:start + block])
            separator.pop()
        separator.flush()
        best = min(best, (time.process_time() - t0) / seconds)
    return best


def _filter_cpu(q: int, seconds: float, repeats: int) -> float:
    rng = np.random.default_rng(1)
    frames = int(seconds * 62.5)  # 16-ms hops
    spectra = rng.standard_normal((frames, 257, q)) + 1j * rng.standard_normal((frames, 257, q))
    best = float("inf")
    for _ in range(repeats):
        wpe = Dereverberator(257, q, 62.5)
        t0 = time.process_time()
        for frame in spectra:
            wpe(frame)
        best = min(best, (time.process_time() - t0) / seconds)
    return best


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="3 s of audio, one repeat")
    args = parser.parse_args(argv)
    seconds, repeats = (3.0, 1) if args.quick else (10.0, 3)
    print("CPU seconds per second of audio, three people, best of", repeats)
    print("| microphones | rate | default | no room filter | no choice of beams | the room filter alone |")
    print("|---|---|---|---|---|---|")
    for q in (2, 4):
        for fs in (16000, 48000):
            default = _separator_cpu(q, fs, seconds, repeats)
            plain = _separator_cpu(q, fs, seconds, repeats, dereverb=False)
            one = _separator_cpu(q, fs, seconds, repeats, quiet_beams=False)
            wpe = _filter_cpu(q, seconds, repeats)
            print(f"| {q} | {fs // 1000} kHz | {default:.3f} | {plain:.3f} | {one:.3f} | {wpe:.3f} |", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
