"""`avhear simulate`: write a simulated-room scenario as a raw recording folder.

``avhear simulate S2 -o recordings/s2/`` renders the preset (the paper's section 7.3 scenarios S1-S5, or the
section 5.3 ``calibration``) with real faces and spoken digits from ``../shared/data`` when present, drawn faces and
synthetic voiced clips otherwise, and writes the folder documented in ``recordings/FORMAT.md`` (videos, WAV, frame
stamps, rig YAML, ground truth, sound events).
"""
from __future__ import annotations

import argparse
import json
import sys
import threading
import time
from pathlib import Path

from app.errors import UserError
from app.commands.options import (MAX_SIMULATED_S, add_bodies_argument, add_camera_argument, add_lips_argument,
                                  add_mics_argument, count, duration, positive, wants_bodies, wants_lips)
from app.commands.paths import output_dir
from app.signals import stop_on_signals
from sim.presets import DEFAULT_DURATION_S, PRESETS


def add_parser(subparsers: argparse._SubParsersAction) -> None:
    p = subparsers.add_parser(
        "simulate", help="write a simulated-room scenario (S1-S6, calibration) as a raw recording",
        description=("Simulate one of the paper's scenarios (section 7.3: S1 one person counting; S2 three seated "
                     "people counting in turns; S3 one of them standing; S4 one outside the field of view; S5 "
                     "independent speakers, one walking, hand claps; and the section 5.3 calibration: a loudspeaker "
                     "playing white-noise bursts carried in a zig-zag) and write it as a raw recording folder "
                     "(recordings/FORMAT.md)."),
    )
    p.add_argument("scenario", choices=PRESETS, metavar="SCENARIO", help=f"one of {', '.join(PRESETS)}")
    p.add_argument("-o", "--output", required=True, type=Path, help="recording folder to write")
    p.add_argument("--duration", type=duration(MAX_SIMULATED_S), default=None, metavar="S",
                   help="seconds of scenario (default: " +
                        ", ".join(f"{k} {v:g}" for k, v in DEFAULT_DURATION_S.items()) + ")")
    p.add_argument("--seed", type=count(0), default=0, help="random seed: the same seed gives the same recording")
    p.add_argument("--fps", type=positive, default=30.0, help="camera frames per second (default 30)")
    p.add_argument("--rt60", type=positive, default=0.4, metavar="S", help="reverberation time, seconds (0.4)")
    p.add_argument("--video", choices=("avi", "png"), default="avi",
                   help="avi: MJPG video per camera (compact); png: lossless image sequences (large)")
    p.add_argument("--data", type=Path, default=None, metavar="DIR",
                   help="real faces and speech (default ../shared/data; without it drawn faces and the speech avhear "
                        "ships; a folder given here is read alone)")
    p.add_argument("--force", action="store_true", help="replace a recording already in the output folder")
    add_mics_argument(p)
    add_bodies_argument(p)
    add_lips_argument(p)
    add_camera_argument(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from app.sources.recording import write_recording
    from app.sources.sim import SimSource

    out = sys.stdout
    if (args.output / "frames.csv").exists() and not args.force:
        raise UserError(f"{args.output} already holds a recording; choose another folder or add --force")
    fresh = not args.output.exists()
    output_dir(args.output, "-o")
    if fresh:  # checked writable; created again by the writer, so an interrupted preparation leaves nothing
        args.output.rmdir()
    t0 = time.perf_counter()
    print(f"simulating {args.scenario} ...", file=out, flush=True)
    try:
        source = SimSource.from_preset(args.scenario, duration_s=args.duration, seed=args.seed, fps=args.fps,
                                       data_dir=args.data, rt60_s=args.rt60, mics=args.mics,
                                       bodies=wants_bodies(args), camera=args.camera, lips=wants_lips(args),
                                       progress=lambda msg: print(f"  {msg}", file=out, flush=True))
    except ValueError as exc:
        raise UserError(f"cannot simulate {args.scenario}: {exc}") from None
    m = source.meta
    t_audio = time.perf_counter() - t0
    n = len(source.scenario.actors)
    print(f"  {args.scenario}: {m['description']}; {source.scenario.duration_s:g} s, seed {args.seed}, "
          f"{n} {'person' if n == 1 else 'people'}, speech: {m['speech']}, faces: {m['faces']}, "
          f"RT60 {m['measured_rt60_s']:.2f} s; audio ready in {t_audio:.1f} s", file=out, flush=True)
    last = [time.perf_counter()]

    def progress(done: int, total: int) -> None:
        now = time.perf_counter()
        if now - last[0] >= 1.0 or done == total:
            last[0] = now
            print(f"  frames {done}/{total} ({100 * done / total:.0f} %)", file=out, flush=True)

    t1 = time.perf_counter()
    with stop_on_signals(threading.Event()) as stop:
        write_recording(args.output, source, video=args.video, overwrite=args.force, progress=progress, stop=stop)
    if stop.is_set():
        kept = json.loads((args.output / "recording.json").read_text())["n_frames"]
        print(f"avhear: interrupted; kept {kept} of {source.n_frames} frames in {args.output} (it replays: avhear "
              f"run --source replay:{args.output})", file=sys.stderr, flush=True)
        return 130
    elapsed = time.perf_counter() - t0
    fps = source.n_frames / max(time.perf_counter() - t1, 1e-9)
    kind = {"rgbd": "colour and depth", "mono": "one camera"}.get(args.camera, "stereo")
    print(f"wrote {args.output}: {source.n_frames} {kind} frames at {source.fps:g} FPS, "
          f"{source.n_samples / source.samplerate_hz:g} s of {source.n_channels}-channel audio at "
          f"{source.samplerate_hz} Hz, ground truth; {elapsed:.1f} s "
          f"({source.scenario.duration_s / elapsed:.2f} s of scenario per second; frames at {fps:.0f} FPS)",
          file=out, flush=True)
    return 0
