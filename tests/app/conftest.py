"""Devices for the app's tests: video files as cameras, and a stand-in for sounddevice's PortAudio stream."""
from __future__ import annotations

import json
import os
import socket
import threading
import time
import types
from collections.abc import Callable, Iterator
from pathlib import Path

import cv2
import numpy as np
import pytest

import app.sources.live
from app.config import RigConfig, save_rig
from avcore.geometry import MicPair
from avcore.stereo import StereoRig

SMALL_RIG = StereoRig.ideal(focal_px=100.0, image_size=(64, 48), baseline_m=0.12)  # the video-file cameras' size


def _router(endpoint: str):  # noqa: ANN202
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"router"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps([endpoint]))
    return zenoh.open(config)


@pytest.fixture
def router_on_7447() -> Iterator[object]:
    """A router-mode Zenoh session on tcp/127.0.0.1:7447, as rmw_zenoh's `ros2 run rmw_zenoh_cpp rmw_zenohd`;
    None when something listens there already (a router of the developer's: what is under test holds then too)."""
    with socket.socket() as probe:
        if probe.connect_ex(("127.0.0.1", 7447)) == 0:
            yield None
            return
    with _router("tcp/127.0.0.1:7447") as router:
        yield router


@pytest.fixture
def rmw_router() -> Iterator[str]:
    """The rmw_zenoh router avhear's processes join (``AVHEAR_ROS_ROUTER``, the suite's own port: tests/conftest.py),
    as a router-mode session; yields its endpoint."""
    endpoint = os.environ["AVHEAR_ROS_ROUTER"]
    with _router(endpoint):
        yield endpoint


@pytest.fixture
def rig_file(tmp_path: Path) -> Path:
    """A rig YAML for the 64x48 video-file cameras, with the nominal microphone pair."""
    path = tmp_path / "rig.yaml"
    save_rig(path, RigConfig(SMALL_RIG, MicPair()))
    return path


def write_video(path: Path, n: int, width: int, shade: int, height: int = 48) -> Path:
    """An MJPG video of ``n`` frames (a flat ``shade`` with the frame number written on it)."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (width, height))
    assert writer.isOpened()
    for i in range(n):
        img = np.full((height, width, 3), shade, np.uint8)
        cv2.putText(img, str(i), (5, 30), cv2.FONT_HERSHEY_SIMPLEX, 0.8, (255, 255, 255), 2)
        writer.write(img)
    writer.release()
    return path


@pytest.fixture
def make_video() -> Callable[..., Path]:
    return write_video


@pytest.fixture
def paced_cameras(monkeypatch: pytest.MonkeyPatch) -> None:
    """Video files delivered as cameras deliver, 30 frames a second, rather than as fast as they decode: the
    vision thread then sees the frames a camera would give it, whatever the face detector costs."""

    capture = cv2.VideoCapture

    class PacedCapture:  # wraps OpenCV's capture rather than subclassing it (a subclass crashed at exit)
        def __init__(self, *args: object) -> None:
            self._cap, self._due = capture(*args), 0.0

        def __getattr__(self, name: str) -> object:
            return getattr(self._cap, name)

        def grab(self) -> bool:
            now = time.monotonic()
            if self._due > now:
                time.sleep(self._due - now)
            self._due = max(self._due, now) + 1 / 30
            return self._cap.grab()

    monkeypatch.setattr(app.sources.live.cv2, "VideoCapture", PacedCapture)


class FakeInputStream:
    """Stands in for sounddevice.InputStream: calls the callback from its own thread, like PortAudio, with block
    k filled with the value k / 1000 (distinct after 16-bit PCM); block 5 reports an input overflow. After its
    ``n_blocks`` the stream stops, as a device unplugged, unless ``stays_open`` (a device open but silent)."""

    n_blocks = 20
    stays_open = False

    def __init__(self, *, callback, channels, samplerate, blocksize, **kwargs) -> None:  # noqa: ANN001
        self.callback, self.channels, self.blocksize, self.samplerate = callback, channels, blocksize, samplerate
        self.active = False
        self._stop = threading.Event()

    def __enter__(self) -> FakeInputStream:
        self.active = True
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join(1)
        self.active = False

    def _run(self) -> None:
        t = 0.0
        for k in range(self.n_blocks):
            if self._stop.is_set():
                return
            data = np.full((self.blocksize, self.channels), k / 1000, np.float32)
            info = types.SimpleNamespace(currentTime=t, inputBufferAdcTime=t)
            status = types.SimpleNamespace(input_overflow=(k == 5))
            self.callback(data, self.blocksize, info, status)
            t += self.blocksize / self.samplerate
            self._stop.wait(0.001)
        self.active = self.stays_open


@pytest.fixture
def fake_sounddevice(monkeypatch: pytest.MonkeyPatch) -> types.SimpleNamespace:
    # a class of the test's own: a test that sets n_blocks or stays_open changes no other test's device
    fake = types.SimpleNamespace(InputStream=type("FakeInputStream", (FakeInputStream,), {}))
    monkeypatch.setattr(app.sources.live, "load_sounddevice", lambda: fake)
    return fake


@pytest.fixture
def people_result() -> Callable[..., object]:
    """Makes a face-guided :class:`app.result.Result` that holds only people: a stamp, positions (N, 3) and
    speaking states (N,), as the evaluation's scoring reads them."""
    from app.result import Result

    def make(stamp_s: float, positions: np.ndarray, speaking: np.ndarray) -> Result:
        xyz = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
        n = xyz.shape[0]
        output = types.SimpleNamespace(speaking=np.asarray(speaking, dtype=bool).reshape(-1),
                                       probability=np.asarray(speaking, dtype=float).reshape(-1),
                                       itd_means=np.full(n, np.nan))
        return Result(float(stamp_s), 0, np.zeros((0, 0), np.uint8), np.zeros((n, 4)), xyz, np.empty(0),
                            output, float("nan"), np.arange(n))
    return make
