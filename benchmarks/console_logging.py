"""Cost of the Rerun operator console: bytes per frame in the .rrd and time per ``Console.log`` call.

Issue 6 asks to compress images, bound what is kept and measure it: Rerun users report growing latency and memory
when raw images stream at a high rate. This logs the default simulated scene (640x480, three people; one person
speaking, 18 ITDs per interval, the face-guided model of each interval) to a ``.rrd`` file in a temporary folder,
for raw images, JPEG at several qualities and no image at all (the overlays and time series alone).

Figures per mode: bytes per frame in the file (static data excluded), the data rate at 30 FPS, the ``rr.log`` calls
per frame, the time of one ``Console.log`` call (median and p95 of the wall time; the median of the calling
thread's CPU time too, which other processes on a busy machine disturb less; Rerun encodes and writes chunks in its
own thread, so the wall time per frame including the final flush is also given) and the mean absolute error of the
decoded image in grey levels.

    python benchmarks/console_logging.py                # 150 frames per mode
    python benchmarks/console_logging.py --frames 60    # quicker
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
import rerun as rr

from app.console import Console, ConsoleFrame
from avcore.geometry import MicPair
from avcore.inference import FaceGuidedHearing
from sim.render import default_scene
from layouts.blueprint import APPLICATION_ID

FPS = 30.0


def make_frames(n_unique: int, seed: int = 0) -> tuple[object, MicPair, list[ConsoleFrame]]:
    """Rendered frames of the moving default scene with ground-truth faces and a face-guided fit per frame."""
    scene = default_scene(moving=True, seed=seed)
    mics = MicPair()
    fg = FaceGuidedHearing(mics)
    rng = np.random.default_rng(seed)
    frames = []
    for i in range(n_unique):
        r = scene.render(i / FPS)
        itds = np.concatenate([mics.itd(r.faces[1]) + rng.normal(0, 2e-5, 15), rng.uniform(-3e-4, 3e-4, 3)])
        out = fg.step(r.faces, itds)
        frames.append(ConsoleFrame.from_face_guided(
            i / FPS, i, r.left, r.face_boxes_left, r.faces, itds, out,
            diagnostics={"fps/vision": FPS, "latency_ms/capture_to_log": 20.0, "queue_depth/itd": 1, "drops/stereo": 0},
        ))
    return scene.rig, mics, frames


def run_mode(rig: object, mics: MicPair, frames: list[ConsoleFrame], n_frames: int, quality: int | None,
             with_image: bool, folder: Path) -> dict[str, float]:
    """Log ``n_frames`` frames (cycling through ``frames``) to a fresh .rrd; return the figures."""
    static_path, path = folder / "static.rrd", folder / "run.rrd"
    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(static_path)
    Console(rig, mics, recording=rec, jpeg_quality=quality)  # type: ignore[arg-type]
    rec.disconnect()
    static_bytes = static_path.stat().st_size

    rec = rr.RecordingStream(APPLICATION_ID)
    rec.save(path)
    console = Console(rig, mics, recording=rec, jpeg_quality=quality)  # type: ignore[arg-type]
    calls = 0
    log_call = console._log

    def counting_log(*args: object, **kwargs: object) -> None:
        nonlocal calls
        calls += 1
        log_call(*args, **kwargs)  # type: ignore[arg-type]

    console._log = counting_log  # type: ignore[method-assign]
    times = np.empty(n_frames)
    cpu = np.empty(n_frames)
    start = time.perf_counter()
    for i in range(n_frames):
        src = frames[i % len(frames)]
        frame = ConsoleFrame(i / FPS, i, src.image if with_image else None, src.boxes, src.faces_xyz, src.speaking,
                             src.probability, src.itds_s, src.model, src.person_ids, None, src.diagnostics)
        t0, c0 = time.perf_counter(), time.thread_time()
        console.log(frame)
        times[i], cpu[i] = time.perf_counter() - t0, time.thread_time() - c0
    rec.disconnect()  # flushes: encoding and writing included in the wall time
    wall = time.perf_counter() - start
    per_frame = (path.stat().st_size - static_bytes) / n_frames

    error = 0.0
    if with_image and quality is not None:
        img = frames[0].image
        _ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, quality])
        error = float(np.mean(np.abs(cv2.imdecode(buf, cv2.IMREAD_COLOR).astype(float) - img)))
    return {
        "bytes": per_frame,
        "mb_per_min": per_frame * FPS * 60 / 1e6,
        "calls": calls / n_frames,
        "cpu_ms": float(np.median(cpu) * 1e3),
        "median_ms": float(np.median(times) * 1e3),
        "p95_ms": float(np.percentile(times, 95) * 1e3),
        "wall_ms": wall / n_frames * 1e3,
        "error": error,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=150, help="frames logged per mode (default 150, 5 s at 30 FPS)")
    parser.add_argument("--unique", type=int, default=6, help="distinct rendered frames cycled through (default 6)")
    args = parser.parse_args(argv)
    print(f"rendering {args.unique} frames of the default scene ...", file=sys.stderr, flush=True)
    rig, mics, frames = make_frames(args.unique)
    img = frames[0].image
    assert img is not None
    modes: list[tuple[str, int | None, bool]] = [
        ("raw", None, True), ("jpeg q95", 95, True), ("jpeg q80 (default)", 80, True), ("jpeg q60", 60, True),
        ("no image", 80, False),
    ]
    print(f"\nConsole.log on {img.shape[1]}x{img.shape[0]} BGR frames (raw {img.nbytes / 1e3:.0f} kB), 3 people, "
          f"{frames[0].itds_s.size} ITDs per interval, {args.frames} frames per mode, file sink, rerun "
          f"{rr.__version__}")
    print(f"{'mode':<20} {'kB/frame':>9} {'MB/min @30':>10} {'rr.log/fr':>9} {'log ms med':>10} {'log ms p95':>10} "
          f"{'cpu ms med':>10} {'wall ms/fr':>10} {'img err':>7}")
    with tempfile.TemporaryDirectory() as tmp:
        for name, quality, with_image in modes:
            print(f"  {name} ...", file=sys.stderr, flush=True)
            r = run_mode(rig, mics, frames, args.frames, quality, with_image, Path(tmp))
            print(f"{name:<20} {r['bytes'] / 1e3:9.1f} {r['mb_per_min']:10.1f} {r['calls']:9.1f} "
                  f"{r['median_ms']:10.2f} {r['p95_ms']:10.2f} {r['cpu_ms']:10.2f} {r['wall_ms']:10.2f} "
                  f"{r['error']:7.2f}")
    print("\nkB/frame: growth of the .rrd per frame (static data excluded); MB/min @30: at 30 FPS; rr.log/fr: "
          "rr.log calls per frame; log ms: one Console.log call, wall time; cpu ms: its CPU time in the calling "
          "thread; wall ms/fr: total time per frame including Rerun's final flush; img err: mean absolute JPEG "
          "error, grey levels.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
