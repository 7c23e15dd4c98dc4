"""`avhear record`: live cameras and microphones to a raw recording folder."""
from __future__ import annotations

import argparse
import functools
from contextlib import ExitStack
import shutil
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING

from app.bus.session import open_session
from app.errors import UserError
from app.commands.options import (add_bus_arguments, add_device_arguments, add_ros_topic_arguments, bus_options,
                                  bus_source, count, duration, live_config, positive, ros_source)
from app.commands.paths import output_dir
from app.signals import stop_on_signals

if TYPE_CHECKING:
    from app.sources.recorder import RecordStats


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("record", help="record live cameras and microphones to a raw recording folder",
                       description="Capture two cameras (or one side-by-side camera) and a multichannel "
                       "microphone into the raw recording format (recordings/FORMAT.md), replayable with "
                       "avhear run --source replay:FOLDER. Ctrl-C stops and keeps everything captured.")
    p.add_argument("-o", "--output", type=Path, required=True, help="the recording folder to write")
    p.add_argument("--source", choices=("live", "bus", "ros"), default="live",
                   help="live devices (default), a robot's `avhear sensors` on the bus, or a ROS 2 robot's RGB-D "
                        "camera and microphone topics (run --help lists the topic flags)")
    p.add_argument("--rig", default=None, help="rig YAML (stereo + microphones), from avhear calibrate stereo; "
                   "with --source bus, the robot's unless given")
    p.add_argument("--fps", type=functools.partial(positive, maximum=240.0), default=30.0,
                   help="frames per second asked of the cameras (default 30)")
    p.add_argument("--samplerate", type=count(8000, 192000), default=16000, metavar="HZ",
                   help="audio sample rate asked of the microphone, Hz (default 16000, the method's)")
    p.add_argument("--duration", type=duration(), default=None, metavar="SECONDS", help="stop after this long")
    p.add_argument("--video", choices=("avi", "png"), default="avi", help="MJPG video or PNG image sequences")
    p.add_argument("--force", action="store_true", help="replace a recording already in the folder")
    add_device_arguments(p, recording=True)
    add_bus_arguments(p)
    add_ros_topic_arguments(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from app.config import require_live_rig
    from app.sources.live import LiveSource
    from app.sources.recorder import record
    from app.sources.recording import RecordingWriter

    if args.source in ("bus", "ros"):
        return _record_bus(args)
    if args.rig is None:
        raise UserError("a live recording needs the rig calibration: --rig rig.yaml (avhear calibrate stereo "
                        "makes one)")
    rig = require_live_rig(args.rig)
    config = live_config(args, fps=args.fps, samplerate_hz=args.samplerate)
    if (args.output / "frames.csv").exists() and not args.force:
        raise UserError(f"{args.output} already holds a recording; choose another folder or add --force")
    fresh = not args.output.exists()
    output_dir(args.output, "-o")
    source = LiveSource(config, rig.stereo, rig.microphones, rig.array)
    writer = RecordingWriter(args.output, rig=rig, fps=args.fps, samplerate_hz=args.samplerate,
                             n_channels=args.audio_channels, video=args.video, overwrite=args.force,
                             channels={"left": source.channels[0], "right": source.channels[1]},
                             meta={"kind": "live", "cameras": list(args.cameras)})
    print(f"avhear: recording to {args.output} ... Ctrl-C stops", file=sys.stderr, flush=True)
    with stop_on_signals(threading.Event()) as stop:
        stats = record(source, writer, duration_s=args.duration, stop=stop)
    if not stats.frames and stats.errors:
        if fresh:  # the devices failed before anything was captured: leave no empty recording behind
            shutil.rmtree(args.output, ignore_errors=True)
        raise UserError(f"nothing recorded: {stats.errors[0]}")
    print(f"avhear: {stats.frames} frames and {stats.audio_blocks} audio blocks in {stats.duration_s:.1f} s "
          f"written to {args.output} (audio overflows {source.overflows})")
    for error in stats.errors:
        print(f"avhear: the recording ended early: {error}; kept {stats.frames} frames in {args.output}",
              file=sys.stderr)
    return _status(stats, stop, args.output)


def _status(stats: RecordStats, stop: threading.Event, folder: Path) -> int:
    """130 when interrupted; else a recording without frames or without audio is an error (exit 2), with what was
    kept left in place."""
    if getattr(stop, "signal", None) is not None:
        print(f"avhear: interrupted; kept {stats.frames} frames in {folder}", file=sys.stderr)
        return 130
    missing = [what for what, n in (("no camera frames", stats.frames), ("no audio", stats.audio_blocks)) if not n]
    if missing:
        why = f": {stats.errors[0]}" if stats.errors else ""
        raise UserError(f"the recording in {folder} has {' and '.join(missing)}{why}; check the devices and record "
                        "again")
    return 0


def _record_bus(args: argparse.Namespace) -> int:
    """The robot's sensors from the bus (``avhear sensors``, or a ROS 2 robot's topics) into the same raw recording
    format, as received (stamps included; an RGB-D camera's depth in depth/)."""
    from app.config import RigConfig
    from app.sources.recorder import record
    from app.sources.recording import RecordingWriter

    if (args.output / "frames.csv").exists() and not args.force:
        raise UserError(f"{args.output} already holds a recording; choose another folder or add --force")
    options = bus_options(args)
    fresh = not args.output.exists()
    output_dir(args.output, "-o")  # an unwritable path is said at once, not after the wait for the robot
    with ExitStack() as stack:
        try:
            session = open_session(options)
            stack.callback(session.close)
            source = (ros_source if args.source == "ros" else bus_source)(session, options, args)
        except BaseException:
            if fresh:  # no robot: leave no empty folder behind
                shutil.rmtree(args.output, ignore_errors=True)
            raise
        stack.callback(source.close)
        samplerate, n_channels = source.audio_format(args.bus_wait)
        rig = RigConfig(source.rig, source.mics, getattr(source, "array", None))
        writer = RecordingWriter(args.output, rig=rig, fps=args.fps,
                                 samplerate_hz=int(samplerate), n_channels=n_channels, video=args.video,
                                 overwrite=args.force, channels={"left": source.channels[0],
                                                                 "right": source.channels[1]},
                                 meta={"kind": args.source, "keys": list(source.keys)})
        print(f"avhear: recording the bus to {args.output} ... Ctrl-C stops", file=sys.stderr, flush=True)
        with stop_on_signals(threading.Event()) as stop:
            stats = record(source, writer, duration_s=args.duration, stop=stop)
    print(f"avhear: {stats.frames} frames and {stats.audio_blocks} audio blocks in {stats.duration_s:.1f} s "
          f"written to {args.output} ({source.gaps} gaps, {source.bad_payloads} payloads that did not decode)")
    return _status(stats, stop, args.output)
