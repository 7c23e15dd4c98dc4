"""The whole face-guided pipeline on the simulated room, with the Rerun console logging to a file (issue 6 targets).

    python benchmarks/pipeline.py                       # scenario S2, 60 s in real time, then as fast as possible
    python benchmarks/pipeline.py --duration 600 --skip-fast    # the 10-minute memory run (about 12 minutes)
    python benchmarks/pipeline.py --duration 120 --part-s 0     # one .rrd file: Rerun's writer keeps growing
    python benchmarks/pipeline.py --duration 90 --sink none     # the same without Rerun: whose memory grows?
    python benchmarks/pipeline.py --duration 90 --tracemalloc   # where Python allocations grow (slower)
    python benchmarks/pipeline.py --scenario S5 --read-lips     # three faces, the face mesh on each, moving mouths

Prints, for a real-time run: results per second, latency from capture stamp to logged result (p50, p95) and the part
of it beyond the wait that the method itself imposes (a frame's ITDs are complete only once the audio has passed its
stamp + frame_window_s, and an ITD window's centre lies window_s / 2 before its end), late frames skipped by the
source, queue drops, audio blocks, and the resident memory (RSS) of the process and its children (the ITDs', the
voices', the words' and the console's processes) sampled every ``--sample-s`` seconds: the growth from the first to the last
quarter of the run (mean RSS of each quarter, the issue's measure), the slope of a straight line fitted to the
second half (MB per minute: what keeps growing once the caches are warm) and the peak. Progress goes to stderr every
``--progress-s`` seconds. Then the same scenario as fast as possible: throughput.

Targets (issue 6): >= 30 FPS sustained (the paper: 17 FPS on NAO); latency <= 50 ms at p95 beyond the ITD window;
memory flat over a 10-minute replay (<= 50 MB growth); no dropped audio.
"""
from __future__ import annotations

import argparse
import os
import resource
import sys
import tempfile
import threading
import time
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np

from app.console import ConsoleFrame
from app.console.process import ConsoleProcess
from app.pipeline import Pipeline, PipelineConfig
from app.result import Result
from app.sources.open import open_source
from app.console.viewer import ViewerTarget


def _rss_mb() -> float:
    """The resident memory of this process and of its children (the ITDs', the voices', the words' and the console's
    processes, app/child_process.py)."""
    try:
        pids = ["self"]
        for task in Path("/proc/self/task").iterdir():
            pids += (task / "children").read_text().split()
        total = 0
        for pid in pids:
            try:
                total += int(Path(f"/proc/{pid}/statm").read_text().split()[1])
            except (OSError, IndexError, ValueError):  # a child that has just ended
                pass
        return total * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:  # not Linux
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def _say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


class MemoryMonitor:
    """Samples the resident memory every ``every_s`` seconds in a thread; reports progress every ``progress_s``.

    With ``trace``, Python allocations are traced (tracemalloc) and snapshots taken at the end of the first quarter
    of ``duration_s`` and at :meth:`stop`, to show which lines of code hold the memory that grew.
    """

    def __init__(self, duration_s: float, pipeline: Pipeline, *, every_s: float = 2.0, progress_s: float = 30.0,
                 trace: bool = False) -> None:
        self.duration_s = duration_s
        self.pipeline = pipeline
        self.every_s = every_s
        self.progress_s = progress_s
        self.trace = trace
        self.samples: list[tuple[float, float]] = []  # (seconds since start, RSS MB)
        self.snapshots: list[tracemalloc.Snapshot] = []
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._run, name="memory-monitor", daemon=True)

    def start(self) -> None:
        if self.trace:
            tracemalloc.start(8)
        self._thread.start()

    def stop(self) -> None:
        self._done.set()
        self._thread.join(5.0)
        if self.trace:
            self.snapshots.append(tracemalloc.take_snapshot())
            tracemalloc.stop()

    def _run(self) -> None:
        t0 = time.perf_counter()
        next_progress = self.progress_s
        while not self._done.wait(self.every_s):
            t = time.perf_counter() - t0
            self.samples.append((t, _rss_mb()))
            if self.trace and not self.snapshots and t >= self.duration_s / 4:
                self.snapshots.append(tracemalloc.take_snapshot())
            if t >= next_progress:
                next_progress += self.progress_s
                s = self.pipeline.stats
                _say(f"  {t:5.0f} s: {s.results} results ({s.results / t:.1f}/s), {s.itds} ITDs, RSS "
                     f"{self.samples[-1][1]:.0f} MB")

    def figures(self) -> dict[str, float]:
        """Growth first quarter -> last quarter (mean RSS of each), second-half slope (MB/min), peak."""
        if not self.samples:
            rss = _rss_mb()
            return {"rss_start_mb": rss, "rss_end_mb": rss, "growth_mb": 0.0, "slope_mb_per_min": float("nan"),
                    "peak_mb": rss, "n_samples": 0}
        t = np.array([s[0] for s in self.samples])
        mem = np.array([s[1] for s in self.samples])
        q = max(1, len(mem) // 4)
        half = len(mem) // 2
        slope = float(np.polyfit(t[half:], mem[half:], 1)[0] * 60.0) if len(mem) - half >= 3 else float("nan")
        return {"rss_start_mb": float(mem[:q].mean()), "rss_end_mb": float(mem[-q:].mean()),
                "growth_mb": float(mem[-q:].mean() - mem[:q].mean()), "slope_mb_per_min": slope,
                "peak_mb": float(mem.max()), "n_samples": len(mem)}

    def trajectory(self, points: int = 9) -> str:
        """RSS at evenly spaced moments of the run, as 't s: MB' pairs."""
        if not self.samples:
            return "no samples"
        idx = np.unique(np.linspace(0, len(self.samples) - 1, points).round().astype(int))
        return ", ".join(f"{self.samples[i][0]:.0f} s: {self.samples[i][1]:.0f}" for i in idx)

    def top_growth(self, n: int = 12) -> list[str]:
        """The lines whose Python allocations grew most between the two snapshots."""
        if len(self.snapshots) < 2:
            return []
        stats = self.snapshots[1].compare_to(self.snapshots[0], "lineno")
        return [f"{s.size_diff / 2**20:+8.2f} MB {s.count_diff:+8d} blocks  {s.traceback}" for s in stats[:n]]


def run(scenario: str, duration_s: float, realtime: bool, rrd: Path | None, *, sample_s: float = 2.0,
        progress_s: float = 30.0, trace: bool = False, part_s: float | None = 60.0,
        frame_itds: bool = True, vote_frames: int = 9, mics: str = "pair", read_lips: bool = False,
        voices: bool = False, transcribe: bool = False) -> dict[str, Any]:
    """One run of ``scenario``: the pipeline with the console logging to ``rrd`` (None: no Rerun at all), in parts
    of ``part_s`` seconds as ``avhear run`` writes them (None: one file); ``read_lips``: the simulated mouths move
    and the face mesh reads every face (``avhear run --lips --read-lips``)."""
    source = open_source(f"sim:{scenario}", realtime=realtime, duration_s=duration_s, mics=mics, lips=read_lips,
                         progress=lambda m: _say(f"  {m}"))
    voices = voices or transcribe
    config = PipelineConfig(frame_itds=frame_itds, vote_frames=vote_frames, lips=read_lips, voices=voices)
    transcriber = None
    if transcribe:
        from app.speech.transcriber import Transcriber
        from sim.audio import DIGIT_WORDS

        transcriber = Transcriber(list(DIGIT_WORDS) if scenario != "room" else None)
        transcriber.wait_ready()
    final_lags: list[float] = []  # each utterance's final words out minus its end, on the source's clock
    # the console as `avhear run` has it: in a process of its own
    console = (ConsoleProcess(ViewerTarget(save=rrd, part_s=part_s), source.rig, source.mics, source.array,
                              backpressure=not realtime) if rrd is not None else None)

    def on_result(r: Result) -> None:
        if transcriber is not None:
            transcriber.result(r.stamp_s, [(p.id, p.speaking) for p in r.people])
            final_lags.extend(source.clock() - w.end_s for w in transcriber.events() if w.final)
        if console is not None:
            console.log(ConsoleFrame.from_result(r))

    voice_s = [0.0]

    def on_voice(chunk: Any) -> None:  # what --voices-dir would write, counted
        voice_s[0] += chunk.samples.size / chunk.samplerate_hz
        if transcriber is not None:
            transcriber.voice(chunk)

    pipeline = Pipeline(source, config, on_result, on_voice=on_voice if voices else None)
    monitor = MemoryMonitor(duration_s, pipeline, every_s=sample_s, progress_s=progress_s, trace=trace)
    monitor.start()
    try:
        stats = pipeline.run()
    finally:
        monitor.stop()
        if transcriber is not None:
            transcriber.close()
        if console is not None:
            console.close()
    d = stats.as_dict()
    # a frame waits for the ITDs of its time frame, then for the later frames its vote needs
    vote_wait_s = (config.vote_frames // 2) / float(getattr(source, "fps", 30.0))
    imposed_ms = (config.frame_window_s + config.window_s / 2 + config.hop_s + vote_wait_s) * 1e3
    lat = np.asarray(stats.latencies_s) * 1e3
    return {
        "fps": d["fps"], "results": d["results"], "late_frames": d["late_frames"], "drops": d["drops"],
        "audio_blocks": d["audio_blocks"], "audio_gaps": d["audio_gaps"], "duration_s": d["duration_s"],
        "latency_p50_ms": float(np.percentile(lat, 50)) if lat.size else float("nan"),
        "latency_p95_ms": float(np.percentile(lat, 95)) if lat.size else float("nan"),
        "beyond_window_p95_ms": float(np.percentile(lat, 95) - imposed_ms) if lat.size else float("nan"),
        "imposed_ms": imposed_ms, **monitor.figures(), "trajectory": monitor.trajectory(),
        "top_growth": monitor.top_growth(),
        "rrd_mb": sum(p.stat().st_size for p in console.parts) / 2**20 if console is not None else 0.0,
        "rrd_parts": len(console.parts) if console is not None else 0,
        "console_dropped": console.dropped + console.lost if console is not None else 0,
        "stage_ms": d["stage_ms_per_item"],
        "voice_s": voice_s[0], "voice_latency_p50_ms": _pct(stats.voice_latencies_s, 50),
        "voice_latency_p95_ms": _pct(stats.voice_latencies_s, 95),
        "voice_latency_max_ms": _pct(stats.voice_latencies_s, 100),
        "finals": len(final_lags), "final_lag_p50_s": _pct(final_lags, 50) / 1e3,
        "final_lag_max_s": _pct(final_lags, 100) / 1e3,
    }


def _pct(values_s: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(values_s) * 1e3, q)) if values_s else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scenario", default="S2")
    parser.add_argument("--duration", type=float, default=60.0, help="seconds of scenario")
    parser.add_argument("--skip-fast", action="store_true", help="only the real-time run")
    parser.add_argument("--no-frame-itds", dest="frame_itds", action="store_false",
                        help="without the single frames' ITDs for the speaking test (PipelineConfig.frame_itds)")
    parser.add_argument("--vote-frames", type=int, default=9,
                        help="results each speaking state is voted over (PipelineConfig.vote_frames; 1: no vote)")
    parser.add_argument("--sink", choices=("file", "none"), default="file",
                        help="the console logs to an .rrd file (default), or no Rerun at all")
    parser.add_argument("--part-s", type=float, default=60.0,
                        help="seconds per .rrd part, as avhear run writes them (default 60; 0: one file)")
    parser.add_argument("--sample-s", type=float, default=2.0, help="seconds between RSS samples (default 2)")
    parser.add_argument("--progress-s", type=float, default=30.0, help="seconds between progress lines on stderr")
    parser.add_argument("--mics", default="pair", help="the simulated microphones (an array preset, e.g. nao, uma8)")
    parser.add_argument("--read-lips", action="store_true",
                        help="moving mouths and the face mesh on every face (avhear run --lips --read-lips)")
    parser.add_argument("--voices", action="store_true",
                        help="each person's voice too (avhear run --voices-dir): its latency from capture to out")
    parser.add_argument("--transcribe", action="store_true",
                        help="each person's words too (avhear run --transcribe, the digits' grammar): how soon after "
                             "an utterance ends its final words come")
    parser.add_argument("--tracemalloc", action="store_true",
                        help="trace Python allocations: lines that grew from the first quarter to the end")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        sink = "console to an .rrd file" if args.sink == "file" else "no Rerun"
        lips = ((", the lips read" if args.read_lips else "") + (", each person's voice" if args.voices else "")
                + (", their words" if args.transcribe else ""))
        print(f"{args.scenario}, {args.duration:.0f} s in real time, {sink}, microphones {args.mics}{lips} ...",
              flush=True)
        rrd = Path(tmp) / "rt.rrd" if args.sink == "file" else None
        part_s = args.part_s or None
        r = run(args.scenario, args.duration, True, rrd, sample_s=args.sample_s, progress_s=args.progress_s,
                trace=args.tracemalloc, part_s=part_s, frame_itds=args.frame_itds,
                vote_frames=args.vote_frames, mics=args.mics, read_lips=args.read_lips, voices=args.voices,
                transcribe=args.transcribe)
        print(f"  results per second {r['fps']:.1f} (target >= 30; the paper 17), {r['results']} results in "
              f"{r['duration_s']:.0f} s, {r['late_frames']} late frames skipped by the source, drops {r['drops']}, "
              f"audio blocks {r['audio_blocks']} (gaps {r['audio_gaps']})")
        print(f"  latency p50 {r['latency_p50_ms']:.1f} ms, p95 {r['latency_p95_ms']:.1f} ms; the method waits "
              f"{r['imposed_ms']:.0f} ms for a frame's ITDs; beyond that p95 {r['beyond_window_p95_ms']:.1f} ms "
              "(target <= 50)")
        print(f"  resident memory {r['rss_start_mb']:.0f} MB (first quarter) -> {r['rss_end_mb']:.0f} MB (last "
              f"quarter), growth {r['growth_mb']:+.0f} MB (target <= 50 over 10 min); second half "
              f"{r['slope_mb_per_min']:+.2f} MB/min; peak {r['peak_mb']:.0f} MB; {r['n_samples']} samples; .rrd "
              f"{r['rrd_mb']:.0f} MB in {r['rrd_parts']} part(s), {r['console_dropped']} results not logged by the "
              "console")
        if args.voices:
            print(f"  voices: {r['voice_s']:.0f} s of people's voices; each chunk out after its first sample's "
                  f"capture: p50 {r['voice_latency_p50_ms']:.1f} ms, p95 {r['voice_latency_p95_ms']:.1f} ms, max "
                  f"{r['voice_latency_max_ms']:.1f} ms (target <= 100)")
        if args.transcribe:
            print(f"  words: {r['finals']} utterances final, each after its end: p50 {r['final_lag_p50_s']:.2f} s, "
                  f"max {r['final_lag_max_s']:.2f} s (target <= 1.5 s)")
        print(f"  RSS (MB) along the run: {r['trajectory']}")
        print(f"  per item: {r['stage_ms']} ms")
        if r["top_growth"]:
            print("  Python allocations grown from the first quarter to the end (tracemalloc):")
            for line in r["top_growth"]:
                print(f"    {line}")
        if not args.skip_fast:
            rrd = Path(tmp) / "fast.rrd" if args.sink == "file" else None
            f = run(args.scenario, args.duration, False, rrd, sample_s=args.sample_s, progress_s=args.progress_s,
                    part_s=part_s, frame_itds=args.frame_itds, vote_frames=args.vote_frames, mics=args.mics,
                    read_lips=args.read_lips)
            print(f"as fast as possible: {f['fps']:.1f} results per second, {f['results']} results, drops "
                  f"{f['drops']}")


if __name__ == "__main__":
    main()
