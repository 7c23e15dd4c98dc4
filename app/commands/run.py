"""`avhear demo` (the simulated room in the operator console) and `avhear run` (any source)."""
from __future__ import annotations

import argparse
import json
import math
from contextlib import ExitStack
from dataclasses import replace
from functools import partial
import signal
import sys
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app.errors import UserError
from app.commands.options import (MAX_DURATION_S, MAX_SIMULATED_S, add_bodies_argument, add_camera_argument,
                                  add_lips_argument, wants_lips,
                                  add_ros_topic_arguments, ros_name, ros_source,
                                  add_bus_arguments, add_device_arguments, add_method_arguments, add_mics_argument,
                                  bus_options, bus_source, count, duration, live_config, pipeline_config, port,
                                  face_detector_name, positive, wants_bodies)
from app.commands.paths import distinct_outputs, output_dir, output_file
from app.sources.limits import DEFAULT_FOV_DEG
from sim.presets import PRESETS

if TYPE_CHECKING:  # the run's parts are imported when it runs: `avhear --help` imports none of them
    from app.console.viewer import ViewerTarget
    from app.pipeline import PipelineStats
    from app.pipeline_config import PipelineConfig
    from app.sinks import Sinks
    from app.sinks.bus import ResultPublisher
    from app.sinks.results_file import ResultsWriter
    from app.sinks.voices_dir import VoicesWriter
    from app.sources.live import LiveConfig
    from app.speech.transcriber import Transcriber

DEMO_RRD = Path("recordings/demo.rrd")


def _common(p: argparse.ArgumentParser, *, duration_help: str, max_duration_s: float = MAX_DURATION_S,
            webcam: bool = False) -> None:
    p.add_argument("--duration", type=duration(max_duration_s), default=None, metavar="SECONDS", help=duration_help)
    add_method_arguments(p)
    add_mics_argument(p, webcam=webcam)
    add_bodies_argument(p)
    add_lips_argument(p)
    add_camera_argument(p)
    where = p.add_mutually_exclusive_group()  # one place for the console's data (ViewerTarget holds one)
    where.add_argument("--save", type=Path, default=None, metavar="FILE.rrd",
                       help="save the console's data to this file")
    where.add_argument("--connect", nargs="?", const="", default=None, metavar="URL",
                       help="send to a running Rerun viewer (default the local one, rerun+http://127.0.0.1:9876/proxy)")
    where.add_argument("--serve", action="store_true",
                       help="host the web viewer (bound to 127.0.0.1 unless --bind says otherwise)")
    where.add_argument("--headless", action="store_true", help="no viewer and no file: only the summary")
    p.add_argument("--bind", default="127.0.0.1", help="address the web viewer's servers listen on")
    p.add_argument("--grpc-port", type=port, default=9876, help="port of the data server of --serve")
    p.add_argument("--web-port", type=port, default=9090, help="port of the web page of --serve")
    p.add_argument("--stats-json", type=Path, default=None, metavar="FILE",
                   help="write the run's figures (fps, latency_ms_p95, drops, overflows) to this file at exit")
    p.add_argument("--save-rig", type=Path, default=None, metavar="FILE.yaml",
                   help="with --self-calibrate: at the end (or on Ctrl-C) write the rig with the correction learned, "
                        "for the next run's --rig")
    p.add_argument("--fast", action="store_true", help="as fast as possible instead of in real time")
    p.add_argument("--results-jsonl", type=Path, default=None, metavar="FILE",
                   help="write every fused result to FILE as one JSON line, as it is produced (schema: README)")
    p.add_argument("--voices-dir", type=Path, default=None, metavar="DIR",
                   help="write each person's voice (steered at them by all the microphones) to DIR/person_<id>.wav, "
                        "16 kHz mono, with DIR/voices.json giving each file's start on the results' clock")
    p.add_argument("--transcribe", action="store_true",
                   help="who said what: each person's words (pocketsphinx, US English) as subtitles in the console, "
                        "in the results file (utterances) and on the bus (humans/voices/<id>/speech)")
    p.add_argument("--words", type=Path, default=None, metavar="FILE",
                   help="with --transcribe: recognise only the words of FILE (whitespace or commas between them, "
                        "e.g. the ten digits for the scenarios' counting); default the general language model")
    p.add_argument("--publish", action="store_true",
                   help="publish every result on the bus (Zenoh) as ROS4HRI messages and JSON, and each person's "
                        "voice on humans/voices/<id>/audio (README: the bus)")
    add_bus_arguments(p)


def add_parser(sub: argparse._SubParsersAction) -> None:
    demo = sub.add_parser("demo", help="the whole system on the built-in simulated room, in the Rerun console",
                          description="Runs the simulated room (three people counting in turns, scenario S2 by "
                          "default) through the real pipeline and shows it in the Rerun viewer; without a display "
                          f"it saves {DEMO_RRD} and says how to open it.")
    demo.add_argument("--scenario", default="S2", choices=PRESETS, help="S1..S6 or calibration (default S2)")
    demo.add_argument("--seed", type=count(0), default=0, help="seed of the simulated room")
    _common(demo, duration_help=f"seconds of the simulated room to run (default 20, at most {MAX_SIMULATED_S:g})",
            max_duration_s=MAX_SIMULATED_S)
    demo.set_defaults(func=run_demo, duration=20.0)
    run = sub.add_parser("run", help="run the pipeline on a source: sim:PRESET, replay:FOLDER, live, webcam, bus or "
                         "ros",
                         description="Runs the pipeline (who is there, where, who speaks) on a source: the simulated "
                         "room (sim:S1..S6), a recording folder (replay:FOLDER), cameras and a microphone (live, "
                         "with --rig), a robot's `avhear sensors` on the bus (bus), or a ROS 2 robot's RGB-D camera "
                         "and microphone topics (ros). Results go to the Rerun console, a results file "
                         "(--results-jsonl) and the bus (--publish). Ctrl-C stops and keeps everything.")
    run.add_argument("--source", default="sim:S2",
                     help="sim:S1..S6|calibration, replay:FOLDER, live, webcam (one camera and the computer's "
                          "microphones, no calibration), bus (a robot's `avhear sensors`) or ros (a ROS 2 robot's "
                          "camera and microphone topics)")
    run.add_argument("--fov", type=_fov, default=None, metavar="DEGREES",
                     help=f"webcam: the camera's horizontal field of view (default {DEFAULT_FOV_DEG:g}; a laptop's is "
                          "typically 65-80), for its intrinsics without a calibration (--rig with a stereo section "
                          "gives them instead)")
    run.add_argument("--mic-spacing", type=partial(positive, maximum=1.0, what="a distance in metres"), default=None,
                     metavar="METRES",
                     help="webcam with --mics laptop: the distance between the two microphones (default 0.10)")
    run.add_argument("--left-key", type=ros_name, default=None, metavar="TOPIC",
                     help="bus: ROS topic of the left camera (sensor_msgs/CompressedImage, rectified; relative to "
                          "--bus-namespace unless it starts with /; default: avhear sensors')")
    run.add_argument("--right-key", type=ros_name, default=None, metavar="TOPIC",
                     help="bus: ROS topic of the right camera")
    run.add_argument("--audio-key", type=ros_name, default=None, metavar="TOPIC",
                     help="bus: ROS topic of the audio (avhear_msgs/AudioBlock)")
    run.add_argument("--seed", type=count(0), default=0, help="seed of a simulated source")
    run.add_argument("--rig", default=None,
                     help="rig YAML of a live source (stereo + microphones); with --source bus it overrides the "
                          "robot's; with --source ros, the microphones in the colour camera's optical frame")
    add_device_arguments(run)
    add_ros_topic_arguments(run)
    _common(run, duration_help="stop after this many seconds of stream (default: the whole source; a live source "
                               "until Ctrl-C)", webcam=True)
    run.set_defaults(func=run_source)


def _fov(text: str) -> float:
    """A horizontal field of view, degrees (10 to 170)."""
    value = positive(text, maximum=170.0, what="a field of view in degrees")
    if value < 10.0:
        raise argparse.ArgumentTypeError(f"{text} is less than the 10 degrees allowed")
    return value


def run_demo(args: argparse.Namespace) -> int:
    target = _target(args, demo=True)
    return _run(f"sim:{args.scenario}", args, target)


def run_source(args: argparse.Namespace) -> int:
    live = live_config(args, one_camera=args.source == "webcam") if args.source in ("live", "webcam") else None
    return _run(args.source, args, _target(args, demo=False), live=live)


def _target(args: argparse.Namespace, *, demo: bool) -> ViewerTarget:
    from app.console.viewer import ViewerTarget, display_available

    if args.headless:
        return ViewerTarget()
    if args.save is not None:
        return ViewerTarget(save=args.save)
    if args.connect is not None:
        return ViewerTarget(connect=args.connect)
    if args.serve:
        return ViewerTarget(serve=True, bind=args.bind, grpc_port=args.grpc_port, web_port=args.web_port)
    if display_available():
        return ViewerTarget(spawn=True)
    return ViewerTarget(save=DEMO_RRD if demo else Path("recordings/run.rrd"))


def _check_outputs(spec: str, args: argparse.Namespace, target: ViewerTarget) -> None:
    """Everything the run will write or reach, checked before the (possibly long) preparation and run."""
    from app.console.viewer import check_viewer

    if spec.startswith("sim:"):
        from app.sources.sim import check_simulated_duration

        check_simulated_duration(args.duration)
    for name in ("bodies", "lips"):
        if getattr(args, name, None) is not None and not spec.startswith("sim:"):
            flag = f"--{name}" if getattr(args, name) else f"--no-{name}"
            raise UserError(f"{flag} chooses how the simulated room's people are drawn; {spec} has real ones")
    webcam = spec == "webcam"
    if spec.startswith(("replay:", "sim:")) and getattr(args, "rig", None):
        what = "a recording replays with the rig it was recorded with (its rig.yaml: edit or replace that file)" \
            if spec.startswith("replay:") else "the simulated room has its own rig"
        raise UserError(f"--rig {args.rig} is not used with --source {spec}: {what}")
    if args.mics not in (None, "pair") and not (spec.startswith("sim:") or webcam):
        if spec in ("ros", "bus", "live"):
            raise UserError(f"--mics {args.mics} chooses the simulated room's (or a webcam's) microphones; the "
                            f"robot's are in the rig file (--rig): array: {{preset: {args.mics}, translation_m: "
                            "[x, y, z]}, or array: {positions_m: [[x, y, z], ...]} in the colour camera's frame")
        raise UserError(f"--mics {args.mics} chooses the simulated room's (or a webcam's) microphones; {spec} brings "
                        "its own (one pair from the rig file or the recording)")
    for flag, value in (("--fov", getattr(args, "fov", None)), ("--mic-spacing", getattr(args, "mic_spacing", None))):
        if value is not None and not webcam:
            raise UserError(f"{flag} describes a webcam without calibration; it goes with --source webcam")
    if getattr(args, "mic_spacing", None) is not None and (args.mics or "laptop") != "laptop":
        raise UserError(f"--mic-spacing sets the laptop's two microphones apart; --mics {args.mics} has its own shape")
    if args.camera != "stereo" and not spec.startswith("sim:"):
        raise UserError(f"--camera {args.camera} chooses the simulated room's camera; {spec} brings its own")
    if args.save_rig is not None:
        if not args.self_calibrate:
            raise UserError("--save-rig keeps what --self-calibrate learns: give both")
        output_file(args.save_rig, "--save-rig")
    distinct_outputs(("--save", target.save), ("--results-jsonl", args.results_jsonl),
                     ("--stats-json", args.stats_json), ("--save-rig", args.save_rig))
    if target.save is not None:
        output_file(target.save, "--save")
    if args.voices_dir is not None:
        output_dir(args.voices_dir, "--voices-dir")
    if args.words is not None and not args.transcribe:
        raise UserError("--words chooses the words --transcribe recognises: give both")
    if args.stats_json is not None:
        output_file(args.stats_json, "--stats-json")
    if target.connect is not None:
        check_viewer(target.connect)


def _run(spec: str, args: argparse.Namespace, target: ViewerTarget, live: LiveConfig | None = None) -> int:
    from app.bus.session import open_session
    from app.sinks.bus import ResultPublisher
    from app.sinks.results_file import ResultsWriter
    from app.sinks.voices_dir import VoicesWriter
    from app.sources.open import open_source
    from app.speech.open import open_transcriber

    config = pipeline_config(args)
    _check_outputs(spec, args, target)
    with ExitStack() as stack:
        results = stack.enter_context(ResultsWriter(args.results_jsonl)) if args.results_jsonl is not None else None
        voices = stack.enter_context(VoicesWriter(args.voices_dir)) if args.voices_dir is not None else None
        transcriber = None
        if args.transcribe:
            transcriber = open_transcriber(args.words)
            stack.callback(transcriber.close, 2.0)
        publisher = session = None
        options = bus_options(args)
        if args.publish or spec in ("bus", "ros"):
            session = open_session(options)
            stack.callback(session.close)
        if args.publish:
            publisher = ResultPublisher(session, convention=options.convention)
            stack.callback(publisher.close)
        print(f"avhear: preparing {spec} ...", file=sys.stderr, flush=True)
        if spec == "bus":
            source = bus_source(session, options, args)
        elif spec == "ros":
            source = ros_source(session, options, args)
        else:
            fov = getattr(args, "fov", None)
            source = open_source(spec, realtime=not args.fast, duration_s=args.duration,
                                 seed=getattr(args, "seed", 0), rig_path=getattr(args, "rig", None), live=live,
                                 mics=args.mics or ("laptop" if spec == "webcam" else "pair"),
                                 bodies=wants_bodies(args), camera=args.camera, lips=wants_lips(args),
                                 fov_deg=DEFAULT_FOV_DEG if fov is None else fov,
                                 mic_spacing_m=getattr(args, "mic_spacing", None),
                                 progress=lambda m: print(f"  {m}", file=sys.stderr, flush=True))
        stack.enter_context(source)
        if publisher is not None and hasattr(source, "camera_frame"):  # a ROS robot's camera: link the rig to it
            publisher.link_rig(lambda: source.camera_frame, (0.5 * source.rig.baseline_m, 0.0, 0.0))
        return _run_checked(spec, args, target, config, source, results, publisher, voices, transcriber,
                            wall_time=live is not None or spec in ("bus", "ros"))


def _report(spec: str, args: argparse.Namespace, target: ViewerTarget, stats: PipelineStats, source: Any,
            sinks: Sinks) -> None:
    """The run's summary and where its outputs are."""
    print(f"avhear: {stats.summary()}")
    if spec in ("bus", "ros"):
        print(f"avhear: from the bus: {source.gaps} gaps while the robot was away, {source.bad_payloads} payloads "
              "that did not decode (skipped)")
    if args.stats_json is not None:
        args.stats_json.write_text(json.dumps(stats.as_dict(), indent=2))
    if sinks.results is not None:
        print(f"avhear: {sinks.results.written} results in {sinks.results.path}")
    if sinks.voices is not None:
        sinks.voices.close()
        print(f"avhear: each person's voice in {sinks.voices.folder} ({sinks.voices.written_s:.1f} s of voices; "
              f"voices.json says when each starts)")
    if sinks.publisher is not None:
        sinks.publisher.close()
        print(f"avhear: {sinks.publisher.published} results published on the bus ({sinks.publisher.dropped} dropped "
              "by a slow bus)")
    console = sinks.console
    parts = console.parts if console is not None else []
    if console is not None and console.dropped + console.lost:
        why = [f"{console.dropped} while its process fell behind"] if console.dropped else []
        why += [f"{console.lost} after it ended"] if console.lost else []
        print(f"avhear: the console skipped {console.dropped + console.lost} of {stats.results} results "
              f"({', '.join(why)})", file=sys.stderr)
    if len(parts) > 1:
        pattern = target.save.with_name(f"{target.save.stem}*{target.save.suffix}")  # type: ignore[union-attr]
        print(f"avhear: the console's data is in {len(parts)} parts, {parts[0]} to {parts[-1]}; open them together "
              f"with: {_rerun_command()} {pattern}")
    elif target.save is not None:
        print(f"avhear: the console's data is in {target.save}; open it with: {_rerun_command()} {target.save}")


def _rerun_command() -> str:
    """How to call Rerun's viewer from here: ``rerun`` when it is on PATH, else its path in the venv (relative to the
    current folder when it lies below it: ``.venv/bin/rerun``)."""
    import os
    import shutil

    from app.console.viewer import rerun_executable

    if shutil.which("rerun"):
        return "rerun"
    found = rerun_executable()  # the venv's, beside this Python
    if found is None:
        return "rerun"
    relative = os.path.relpath(found)
    return relative if not relative.startswith("..") else found


def _save_learned_rig(path: Path, source: Any, state: list[dict[str, Any]]) -> None:
    """The source's cameras and microphones with each pair's self-calibrated c1, c0 (and an array's learned turn
    about the vertical, in its positions), as a rig file."""
    from app.config import RigConfig, save_rig
    from avcore.geometry import MicArray

    array = getattr(source, "array", None)
    array = array if array is not None else MicArray.from_pair(source.mics, tuple(source.channels))
    yaw = state[0].get("array_yaw_deg")
    if yaw is not None:
        array = array.turned(math.radians(yaw))
    learned = MicArray(array.positions, array.pairs, array.speed_of_sound, tuple(s["c1"] for s in state),
                       tuple(s["c0_s"] for s in state), array.channels)
    rig = RigConfig(source.rig, learned.pair(0), None) if learned.n_pairs == 1 else RigConfig(source.rig, None, learned)
    fitted = ", ".join(f"c1 {s['c1']:.4f} c0 {s['c0_s'] * 1e6:+.1f} us ({s['inliers']} of {s['observations']} "
                       "one-source time frames)" for s in state)
    if yaw is not None:
        fitted += f"; the array turned {yaw:+.1f} degrees about the vertical"
    save_rig(path, rig, header=f"written by avhear run --self-calibrate: {fitted}")
    print(f"avhear: the self-calibrated rig is in {path} ({fitted}); use it with --rig {path}")


def _run_checked(spec: str, args: argparse.Namespace, target: ViewerTarget, config: PipelineConfig, source: Any,
                 results: ResultsWriter | None, publisher: ResultPublisher | None, voices: VoicesWriter | None,
                 transcriber: Transcriber | None, *, wall_time: bool) -> int:
    from app.pipeline import Pipeline
    from app.sinks import Sinks

    stream = getattr(source, "stream", None)
    if getattr(stream, "camera", "stereo") == "mono":  # a recording of one camera: known once it is open
        if config.inference == "motion":
            raise UserError(f"--motion (Algorithm 1) needs depth for its moving points and {spec} has one camera: "
                            "leave --motion out (faces are located by their size)")
        config = replace(config, face_detector=face_detector_name(args, one_camera=True))
    meta = getattr(stream, "meta", None)
    if spec.startswith("sim:") and isinstance(meta, dict) and (meta.get("faces") == "drawn"
                                                               or meta.get("speech") == "synthetic"):
        print(f"  no ../shared/data here: the simulated room uses {meta.get('faces')} faces and "
              f"{meta.get('speech')} speech", file=sys.stderr, flush=True)
    console = None
    if target.logs:  # the console (and Rerun) only for a viewer or a file, in a process of its own
        from app.console.process import ConsoleProcess

        console = ConsoleProcess(target, source.rig, source.mics, getattr(source, "array", None),
                                 backpressure=not source.realtime)  # a replay as fast as it goes logs every result
    sinks = Sinks(console, results, publisher, voices, transcriber)
    pipeline = sinks.pipeline = Pipeline(source, config, sinks, on_voice=sinks.voice if config.voices else None)
    terminated = threading.Event()

    def on_sigterm(*_: object) -> None:
        terminated.set()
        pipeline.stop()

    previous = signal.getsignal(signal.SIGTERM)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, on_sigterm)
    print(f"avhear: running {spec} ({config.inference}-guided) ... Ctrl-C stops", file=sys.stderr, flush=True)
    try:
        # a simulated source is as long as asked; a live or bus one runs for --duration of wall time
        stats = pipeline.run(duration_s=args.duration if wall_time else None)
    except BaseException:
        if console is not None:
            console.close()
        if results is not None:
            print(f"avhear: {results.written} results kept in {results.path}", file=sys.stderr, flush=True)
        raise
    finally:
        if threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, previous)
    stats.interrupted = stats.interrupted or terminated.is_set()
    sinks.finish()
    if console is not None:
        console.finish()  # its files are whole, and named, before the report
    _report(spec, args, target, stats, source, sinks)
    if args.save_rig is not None and stats.self_calibration:
        _save_learned_rig(args.save_rig, source, stats.self_calibration)
    if spec in ("bus", "ros") and not source.images_received and not stats.interrupted:
        if console is not None:
            console.close()
        hint = ("start `avhear sensors` there (the same --bus-namespace and --ros-keys), or name its camera topics "
                "with --left-key/--right-key") if spec == "bus" else ("is the camera driver running (the same "
                "--ros-domain and --ros-keys)? Name its topics with --colour-topic/--depth-topic")
        raise UserError(f"no robot published on {', '.join(source.keys[:2])} during the run: {hint}")
    if stats.interrupted:
        print("avhear: interrupted", file=sys.stderr)
        if console is not None:
            console.close()
        return 130
    # an interactive user keeps the web viewer until Ctrl-C; a script or CI run ends here
    if console is not None:
        console.close(keep_serving=sys.stdin is not None and sys.stdin.isatty())
    return 0
