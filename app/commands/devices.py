"""`avhear devices`: the cameras and audio inputs of this computer, with what --cameras and --audio-device take."""
from __future__ import annotations

import argparse
import glob
import re
import sys

from app.commands.options import count
from app.sound import DeviceError, load_sounddevice


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("devices", help="list the cameras and audio inputs (for --cameras and --audio-device)",
                       description="Lists the cameras OpenCV can open, with the size of their images, and the audio "
                       "inputs PortAudio sees, with their channels and default sample rate; the default input is "
                       "marked. `avhear run --source webcam` uses camera 0 and the default input unless --cameras "
                       "and --audio-device say otherwise.")
    p.add_argument("--max-cameras", type=count(1, 64), default=10,
                   help="camera indices to try where the system does not list them (default 10)")
    p.set_defaults(func=run)


def camera_indices(max_cameras: int) -> list[int]:
    """The indices to try: Linux's /dev/video* (each capture device has one or more nodes), else 0..max-1."""
    nodes = sorted(int(m.group(1)) for path in glob.glob("/dev/video*") if (m := re.fullmatch(r"/dev/video(\d+)",
                                                                                               path)))
    return nodes if sys.platform.startswith("linux") else list(range(max_cameras))


def list_cameras(max_cameras: int) -> list[tuple[int, int, int, float]]:
    """(index, width, height, fps) of every camera that delivers a frame."""
    import cv2  # here, so that `avhear --help` imports no OpenCV

    found = []
    for index in camera_indices(max_cameras):
        cap = cv2.VideoCapture(index)
        try:
            ok, img = cap.read() if cap.isOpened() else (False, None)
            if ok and img is not None:
                found.append((index, int(img.shape[1]), int(img.shape[0]), float(cap.get(cv2.CAP_PROP_FPS) or 0.0)))
        finally:
            cap.release()
    return found


def list_inputs() -> list[tuple[int, str, int, float, bool]]:
    """(index, name, input channels, default sample rate, is the default input) of every audio input; DeviceError
    when PortAudio is missing."""
    sd = load_sounddevice()
    default = sd.default.device[0] if isinstance(sd.default.device, (list, tuple)) else sd.default.device
    return [(i, str(d["name"]), int(d["max_input_channels"]), float(d["default_samplerate"]), i == default)
            for i, d in enumerate(sd.query_devices()) if int(d["max_input_channels"]) > 0]


def run(args: argparse.Namespace) -> int:
    cameras = list_cameras(args.max_cameras)
    print("cameras (--cameras INDEX):")
    for index, w, h, fps in cameras:
        print(f"  {index}: {w}x{h}" + (f" at {fps:g} FPS" if fps > 0 else ""))
    if not cameras:
        print("  none found (plugged in? used by another program?)")
    print("audio inputs (--audio-device INDEX, --audio-channels N):")
    try:
        inputs = list_inputs()
    except DeviceError as exc:
        print(f"  none listed: {exc}")
        return 0
    for index, name, channels, rate, default in inputs:
        print(f"  {index}: {name}: {channels} channel{'s' if channels != 1 else ''}, {rate:g} Hz"
              + ("  (default)" if default else ""))
    if not inputs:
        print("  none found")
    return 0
