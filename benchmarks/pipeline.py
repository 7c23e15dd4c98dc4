"""The whole face-guided pipeline on the simulated room, with the Rerun console logging to a file (issue 6 targets).

    python benchmarks/pipeline.py                       # scenario S2, 60 s in real time, then as fast as possible
    python benchmarks/pipeline.py --duration 600        # the 10-minute memory run

Prints, for a real-time run: results per second, latency from capture stamp to logged result (p50, p95) and the
part of it beyond the wait that the method itself imposes (a frame's ITDs are complete only once the audio has
passed its stamp + frame_window_s, and an ITD window's centre lies window_s / 2 before its end), late frames
skipped by the source, queue drops, audio blocks, and the process's resident memory sampled every few seconds
(growth from the first to the last quarter of the run). Then the same scenario as fast as possible: throughput.

Targets (issue 6): >= 30 FPS sustained (the paper: 17 FPS on NAO); latency <= 50 ms at p95 beyond the ITD window;
memory flat over a 10-minute replay (<= 50 MB growth); no dropped audio.
"""
from __future__ import annotations

import argparse
import os
import resource
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from app.console import Console, ConsoleFrame
from app.pipeline import FusionResult, Pipeline, PipelineConfig
from app.sources import open_source
from app.viewer import ViewerSession, ViewerTarget


def _rss_mb() -> float:
    try:
        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:  # not Linux
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run(scenario: str, duration_s: float, realtime: bool, rrd: Path) -> dict:
    source = open_source(f"sim:{scenario}", realtime=realtime, duration_s=duration_s)
    config = PipelineConfig()
    session = ViewerSession(ViewerTarget(save=rrd))
    console = Console(source.rig, source.mics, recording=session.recording)

    def on_result(r: FusionResult) -> None:
        console.log(ConsoleFrame.from_face_guided(r.stamp_s, r.index, r.image, r.boxes, r.xyz, r.itds_s, r.output,
                                                  person_ids=r.person_ids))

    pipeline = Pipeline(source, config, on_result)
    rss: list[tuple[float, float]] = []
    done = threading.Event()

    def sample() -> None:
        t0 = time.perf_counter()
        while not done.wait(2.0):
            rss.append((time.perf_counter() - t0, _rss_mb()))

    sampler = threading.Thread(target=sample, daemon=True)
    sampler.start()
    stats = pipeline.run()
    done.set()
    session.close(keep_serving=False)
    d = stats.as_dict()
    imposed_ms = (config.frame_window_s + config.window_s / 2 + config.hop_s) * 1e3
    lat = np.asarray(stats.latencies_s) * 1e3
    mem = np.array([m for _, m in rss]) if rss else np.array([_rss_mb()])
    q = max(1, len(mem) // 4)
    return {
        "fps": d["fps"], "results": d["results"], "late_frames": d["late_frames"], "drops": d["drops"],
        "audio_blocks": d["audio_blocks"], "audio_gaps": d["audio_gaps"],
        "latency_p50_ms": float(np.percentile(lat, 50)) if lat.size else None,
        "latency_p95_ms": float(np.percentile(lat, 95)) if lat.size else None,
        "beyond_window_p95_ms": float(np.percentile(lat, 95) - imposed_ms) if lat.size else None,
        "imposed_ms": imposed_ms,
        "rss_start_mb": float(mem[:q].mean()), "rss_end_mb": float(mem[-q:].mean()),
        "rrd_mb": rrd.stat().st_size / 2**20, "stage_ms": d["stage_ms_per_item"],
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenario", default="S2")
    parser.add_argument("--duration", type=float, default=60.0, help="seconds of scenario")
    parser.add_argument("--skip-fast", action="store_true")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        print(f"{args.scenario}, {args.duration:.0f} s in real time, console to an .rrd file ...", flush=True)
        r = run(args.scenario, args.duration, True, Path(tmp) / "rt.rrd")
        print(f"  results per second {r['fps']:.1f} (target >= 30; the paper 17), {r['results']} results, "
              f"{r['late_frames']} late frames skipped by the source, drops {r['drops']}, audio blocks "
              f"{r['audio_blocks']} (gaps {r['audio_gaps']})")
        print(f"  latency p50 {r['latency_p50_ms']:.1f} ms, p95 {r['latency_p95_ms']:.1f} ms; the method waits "
              f"{r['imposed_ms']:.0f} ms for a frame's ITDs; beyond that p95 {r['beyond_window_p95_ms']:.1f} ms "
              "(target <= 50)")
        print(f"  resident memory {r['rss_start_mb']:.0f} MB (first quarter) -> {r['rss_end_mb']:.0f} MB (last "
              f"quarter), growth {r['rss_end_mb'] - r['rss_start_mb']:+.0f} MB (target <= 50 over 10 min); .rrd "
              f"{r['rrd_mb']:.0f} MB")
        print(f"  per item: {r['stage_ms']} ms")
        if not args.skip_fast:
            f = run(args.scenario, args.duration, False, Path(tmp) / "fast.rrd")
            print(f"as fast as possible: {f['fps']:.1f} results per second, {f['results']} results, drops "
                  f"{f['drops']}")


if __name__ == "__main__":
    main()
