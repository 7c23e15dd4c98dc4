"""`avhear sensors`: the robot side of the bus. Publishes a source's cameras and microphones and serves its rig
(app.bus.sensors), so that `avhear run --source bus` can run the method on another machine, as the paper's system
ran on a laptop beside NAO."""
from __future__ import annotations

import argparse
import sys
import threading
import time
from typing import Any

from app.bus.session import BusOptions, open_session
from app.errors import UserError
from app.commands.options import (add_bus_arguments, add_device_arguments, add_lips_argument, add_mics_argument,
                                  bus_options, count, duration, live_config, wants_lips)
from app.signals import stop_on_signals


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("sensors", help="publish cameras and microphones on the bus (the robot side)",
                       description="Publishes both cameras (sensor_msgs/CompressedImage, JPEG) and the audio "
                       "(avhear_msgs/AudioBlock) of a source on Zenoh in real time, and answers the laptop's query "
                       "for the rig. On the same machine: avhear run --source bus; on a laptop: avhear run --source bus "
                       "--bus-connect tcp/ROBOT:7448 (with --bus-listen tcp/ROBOT:7448 here).")
    p.add_argument("--source", default="sim:S2", help="live (a stereo pair, with --rig), sim:S1..S6|calibration or "
                   "replay:FOLDER (a webcam's one camera goes with avhear run --source webcam)")
    p.add_argument("--seed", type=count(0), default=0, help="seed of a simulated source")
    p.add_argument("--rig", default=None, help="live: rig YAML (stereo + microphones)")
    p.add_argument("--duration", type=duration(), default=None, metavar="SECONDS",
                   help="stop after this many seconds (default: the end of the source, or Ctrl-C)")
    p.add_argument("--jpeg-quality", type=count(10, 100), default=90, help="JPEG quality of the images (90)")
    p.add_argument("--ros", action="store_true",
                   help="publish as a ROS 2 robot's drivers do: the simulated room's RGB-D camera as "
                        "realsense2_camera's colour, aligned depth and camera_info topics, the microphones as "
                        "audio_common's audio_stamped and audio_info (read them with avhear run --source ros)")
    p.add_argument("--force", action="store_true",
                   help="publish even onto topics another node already publishes (a robot's own camera driver: "
                        "its images and the simulated ones would mix); by default avhear sensors refuses")
    add_mics_argument(p)
    add_lips_argument(p)
    add_device_arguments(p)
    add_bus_arguments(p, receiver=False)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from app.bus.sensors import RosDriverPublisher, SensorPublisher
    from app.sources.open import open_source

    if args.source == "bus":
        raise UserError("avhear sensors publishes a source on the bus: give live, sim:S2 or replay:FOLDER")
    if args.source == "webcam":
        raise UserError("avhear sensors publishes a stereo pair (or with --ros an RGB-D camera); a webcam's one "
                        "camera goes with avhear run --source webcam on this computer")
    if args.mics != "pair" and not args.source.startswith("sim:"):
        raise UserError(f"--mics {args.mics} chooses the simulated room's microphones; {args.source} brings its own "
                        "(the rig file's array or pair, or the recording's)")
    if args.lips is not None and not args.source.startswith("sim:"):
        flag = "--lips" if args.lips else "--no-lips"
        raise UserError(f"{flag} chooses how the simulated room's people are drawn; {args.source} has real ones")
    if args.ros and not args.source.startswith("sim:"):
        raise UserError(f"--ros publishes the simulated room's RGB-D camera as a driver does; {args.source} has "
                        "none (a real robot's drivers publish their own topics)")
    live = live_config(args) if args.source == "live" else None
    options = bus_options(args)
    session = open_session(options)
    try:
        source = open_source(args.source, realtime=True, duration_s=args.duration if live is None else None,
                             seed=args.seed, rig_path=args.rig, live=live, mics=args.mics,
                             camera="rgbd" if args.ros else "stereo", lips=wants_lips(args),
                             progress=lambda m: print(f"  {m}", file=sys.stderr, flush=True))
        if getattr(getattr(source, "stream", None), "camera", "stereo") == "mono":
            raise UserError(f"{args.source} has one camera; avhear sensors publishes a stereo pair: replay it with "
                            f"avhear run --source {args.source}")
        kind = RosDriverPublisher if args.ros else SensorPublisher
        publisher = kind(session, source, convention=options.convention, jpeg_quality=args.jpeg_quality)
        if not args.force:
            if args.ros:  # the robot's drivers are met through its router
                _wait_for_router(session, options)
            taken = publisher.taken()
            if taken:
                publisher.close()
                raise UserError(f"another node already publishes {', '.join(taken)} (a robot's own drivers?): "
                                f"{args.source}'s frames would mix with its own. Publish beside it with "
                                "--bus-namespace NAME (and read them with the same), or give --force")
        topics = ", ".join(options.convention.topic(t) for t, _ in publisher.topics().values())
        print(f"avhear: publishing {_what(args)} on {topics} ... Ctrl-C stops", file=sys.stderr, flush=True)
        start = time.monotonic()
        with stop_on_signals(threading.Event()) as stop:
            publisher.run(stop, duration_s=args.duration)
        elapsed = max(time.monotonic() - start, 1e-9)
        publisher.close()
    finally:
        session.close()
    print(f"avhear: published {publisher.frames} {'colour and depth' if args.ros else 'stereo'} frames and {publisher.audio_blocks} audio blocks in "
          f"{elapsed:.1f} s ({publisher.bytes / elapsed / 1e6:.2f} MB/s)")
    if publisher.errors:
        raise UserError(f"the sensors stopped: {publisher.errors[0]}")
    return 130 if getattr(stop, "signal", None) is not None else 0


def _what(args: argparse.Namespace) -> str:
    """What the robot is made of, in words: a simulated room says it is one (and which)."""
    if args.source.startswith("sim:"):
        kind = "an RGB-D camera" if args.ros else "a stereo pair"
        return f"the simulated room {args.source} (seed {args.seed}) as {kind} and microphones ({args.mics})"
    return args.source


def _wait_for_router(session: Any, options: BusOptions, timeout_s: float = 3.0) -> None:
    """Give the session up to ``timeout_s`` to join the rmw_zenoh router it is to join, so that the graph it then
    reads is the robot's (a session just opened has not met the router yet)."""
    from app.bus.session import ros_router

    if ros_router(options) is None:
        return
    deadline = time.monotonic() + timeout_s
    while not list(session.info.routers_zid()) and time.monotonic() < deadline:
        time.sleep(0.05)
