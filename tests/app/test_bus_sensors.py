"""The robot side and the laptop side as real processes over 127.0.0.1: `avhear sensors` publishes a simulated
room's cameras and microphones, `avhear run --source bus` runs the pipeline on them and publishes the results."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from app.bus.messages import decode

ROOT = Path(__file__).resolve().parents[2]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _avhear(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "app", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT)


def _listening_session(port: int):  # noqa: ANN202
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    return zenoh.open(config)


def _wait_for(condition, timeout_s: float, what: str) -> None:  # noqa: ANN001
    """Poll ``condition`` until it holds; the test waits on what happened, not on how long it should take (a loaded
    machine starts a Python process in seconds, not tenths)."""
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, f"timed out after {timeout_s:g} s waiting for {what}"
        time.sleep(0.1)


def test_sensors_to_run_to_a_subscriber_and_the_robot_coming_back() -> None:
    robot, laptop, test = _free_port(), _free_port(), _free_port()
    received: list[bytes] = []
    voices: list[bytes] = []
    lock = threading.Lock()

    def keep(into: list[bytes]):  # noqa: ANN202
        def on_sample(sample) -> None:  # noqa: ANN001
            with lock:
                into.append(sample.payload.to_bytes())
        return on_sample

    def count() -> int:
        with lock:
            return len(received)

    def quiet_for(seconds: float):  # noqa: ANN202
        seen = {"n": -1, "since": time.monotonic()}

        def still() -> bool:
            n, now = count(), time.monotonic()
            if n != seen["n"]:
                seen["n"], seen["since"] = n, now
            return now - seen["since"] >= seconds
        return still

    # each robot session is cut short by SIGTERM once it has served its part (40 s is a cap: the simulated room is
    # rendered for the whole duration before it is published)
    sensors = ("sensors", "--source", "sim:S2", "--duration", "40", "--bus-listen", f"tcp/127.0.0.1:{robot}")
    with _listening_session(test) as session:
        session.declare_subscriber("avhear/results", keep(received))
        session.declare_subscriber("*/humans/voices/tracked/*/*", keep(voices))  # rmw_zenoh's key: domain, type, hash
        first, second = _avhear(*sensors), None
        run = _avhear("run", "--source", "bus", "--publish", "--headless", "--duration", "300",
                      "--bus-listen", f"tcp/127.0.0.1:{laptop}", "--bus-connect", f"tcp/127.0.0.1:{robot}",
                      "--bus-connect", f"tcp/127.0.0.1:{test}")
        try:
            _wait_for(lambda: count() > 30, 120, "30 results from the first robot session")
            first.send_signal(signal.SIGTERM)  # the robot goes away
            assert first.wait(timeout=60) in (0, 130), first.stderr.read()
            _wait_for(quiet_for(2.0), 60, "the results to stop while the robot is away")
            before = count()
            second = _avhear(*sensors)
            _wait_for(lambda: count() > before + 30, 120, "30 results after the robot came back")
            second.send_signal(signal.SIGTERM)
            assert second.wait(timeout=60) in (0, 130), second.stderr.read()
            run.send_signal(signal.SIGTERM)
            out, err = run.communicate(timeout=60)
        finally:
            for proc in (first, second, run):
                if proc is not None and proc.poll() is None:
                    proc.kill()

        def both_arrived() -> bool:  # each result is published with its voices: wait for the last ones in flight
            with lock:
                return len(voices) == len(received)
        _wait_for(both_arrived, 30, "the last results and their voices")
    assert run.returncode == 130, err  # stopped by SIGTERM, after its summary
    assert "Traceback" not in err
    assert "the robot's sensors are back" in err
    assert "0 payloads that did not decode" in out
    gaps = int(out.split("from the bus: ")[1].split(" gaps")[0])
    assert gaps >= 1
    with lock:
        results = [json.loads(p) for p in received]
        tracked = [decode(p, "hri_msgs/msg/IdsList") for p in voices]
    assert len(tracked) == len(results)
    assert any(p["speaking"] for r in results for p in r["people"])
    stamps = np.array([r["stamp_s"] for r in results])
    assert np.all(np.diff(stamps) > 0)


def _compressed_image(image: np.ndarray, stamp_s: float, frame_id: str) -> bytes:
    """A sensor_msgs/CompressedImage built by rosbags and OpenCV alone, as another robot's driver would send it."""
    import cv2
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    t = store.types
    sec = int(stamp_s)
    header = t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=int((stamp_s - sec) * 1e9)),
                                      frame_id=frame_id)
    jpeg = cv2.imencode(".jpg", image)[1].ravel()
    msg = t["sensor_msgs/msg/CompressedImage"](header=header, format="jpeg", data=jpeg)
    return bytes(store.serialize_cdr(msg, "sensor_msgs/msg/CompressedImage"))


def test_an_undecodable_payload_is_counted_and_skipped(tmp_path: Path) -> None:
    """Another ROS 2 robot's cameras under rmw_zenoh's keys (domain 0, the DDS type name, a type hash of another ROS
    release): read, and a payload that is not an image counted and skipped."""
    import zenoh

    from app.bus.source import BusSource
    from app.config import RigConfig
    from avcore.geometry import MicPair
    from avcore.stereo import StereoRig

    port = _free_port()
    rig = RigConfig(StereoRig.ideal(focal_px=100.0, image_size=(64, 48), baseline_m=0.12), MicPair())
    with _listening_session(port) as robot:
        config = zenoh.Config()
        config.insert_json5("mode", '"peer"')
        config.insert_json5("scouting/multicast/enabled", "false")
        config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
        with zenoh.open(config) as laptop:
            source = BusSource(laptop, rig=rig)
            kind = "sensor_msgs::msg::dds_::CompressedImage_/RIHS01_" + "ab" * 32
            left = robot.declare_publisher(f"0/stereo/left/image_rect_color/compressed/{kind}")
            right = robot.declare_publisher(f"0/stereo/right/image_rect_color/compressed/{kind}")
            # the laptop's subscriptions have reached the robot's session: its publishers have a match
            _wait_for(lambda: left.matching_status.matching and right.matching_status.matching, 30,
                      "the laptop's subscriptions")
            image = np.full((48, 64, 3), 90, np.uint8)
            left.put(b"\x00\x01\x00\x00garbage")
            for k in range(3):
                left.put(_compressed_image(image, 1.0 + k / 30, "l"))
                right.put(_compressed_image(image, 1.0 + k / 30, "r"))
            stop = threading.Event()
            frames = []
            threading.Timer(2.0, stop.set).start()
            for frame in source.frames(stop):
                frames.append(frame)
                if len(frames) == 3:
                    stop.set()
            source.close()
    assert source.bad_payloads == 1
    assert [f.index for f in frames] == [0, 1, 2]
    assert frames[0].left.shape == (48, 64, 3) and frames[1].stamp_s == frames[1].right_stamp_s


def test_record_the_bus(tmp_path: Path) -> None:
    robot = _free_port()
    sensors = _avhear("sensors", "--source", "sim:S1", "--duration", "8", "--bus-listen", f"tcp/127.0.0.1:{robot}")
    out = tmp_path / "rec"
    record = subprocess.run([sys.executable, "-m", "app", "record", "--source", "bus", "-o", str(out),
                             "--duration", "3", "--bus-connect", f"tcp/127.0.0.1:{robot}",
                             "--bus-listen", f"tcp/127.0.0.1:{_free_port()}"], capture_output=True, text=True,
                            cwd=ROOT, timeout=60)
    sensors.send_signal(signal.SIGTERM)  # the robot has served its part
    assert sensors.wait(timeout=60) in (0, 130), sensors.stderr.read()
    assert record.returncode == 0, record.stderr
    from app.sources.recording import open_recording

    rec = open_recording(out)
    assert rec.n_frames > 60 and rec.n_samples > 2 * 16000
    assert json.loads((out / "recording.json").read_text())["source"]["kind"] == "bus"


def test_the_robots_microphone_array_reaches_the_laptop() -> None:
    """`avhear sensors --mics nao` serves NAO's four microphones in its rig: the laptop's source uses every pair of
    them (its first pair's channels as the pair), and the audio blocks carry all four channels."""
    import zenoh

    from app.bus.source import BusSource
    from avcore.geometry import MicArray

    robot = _free_port()
    sensors = _avhear("sensors", "--source", "sim:S2", "--mics", "nao", "--duration", "8",
                      "--bus-listen", f"tcp/127.0.0.1:{robot}")
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{robot}"]))
    try:
        with zenoh.open(config) as session:
            source = BusSource(session, rig_timeout_s=30.0)
            try:
                nao = MicArray.preset("nao")
                assert source.array is not None and source.array.n_pairs == nao.n_pairs
                assert np.allclose(source.array.positions, nao.positions)
                first = source.array.pairs[0]
                assert source.channels == (source.array.channels[first[0]], source.array.channels[first[1]])
                assert source.audio_format(timeout_s=30.0)[1] == 4
            finally:
                source.close()
    finally:
        if sensors.poll() is None:
            sensors.send_signal(signal.SIGTERM)  # the robot has served its part
        out, err = sensors.communicate(timeout=60)
    assert sensors.returncode in (0, 130) and "Traceback" not in err, err


def _bus_recipe() -> list[list[str]]:
    """The README's one-machine bus recipe, as written: the `avhear ...` lines of the block after its marker."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = text.split("<!-- the bus recipe", 1)[1].split("```bash", 1)[1].split("```", 1)[0]
    lines = [line.split("#", 1)[0].split() for line in block.splitlines()]
    return [words[1:] for words in lines if words and words[0] == "avhear"]


@pytest.mark.parametrize("order", ["robot first, subscriber last", "subscriber first, robot last, beside a router"])
def test_the_readmes_bus_recipe_on_one_machine(order: str, tmp_path: Path, request: pytest.FixtureRequest) -> None:
    """The README's `avhear sensors`, `avhear run --source bus --publish` and `avhear record --source bus` as typed,
    with a third-party subscriber that connects to the rendezvous, on one machine in two orders, the second beside
    a router-mode session on 7447. AVHEAR_BUS_PORT moves the rendezvous off 7448 so that a developer's own avhear
    cannot interfere; the commands are the README's."""
    import zenoh

    sensors_args, run_args, record_args = _bus_recipe()
    assert sensors_args[0] == "sensors" and run_args[:3] == ["run", "--source", "bus"] and record_args[0] == "record"
    meet = _free_port()
    env = dict(os.environ, AVHEAR_BUS_PORT=str(meet), PYTHONPATH=str(ROOT))
    if "router" in order:
        request.getfixturevalue("router_on_7447")
    received: list[bytes] = []
    lock = threading.Lock()

    def start(args: list[str]) -> subprocess.Popen:
        return subprocess.Popen([sys.executable, "-m", "app", *args], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, cwd=tmp_path, env=env)

    def subscriber():  # noqa: ANN202 - a program of the user's, as the README says to write it
        config = zenoh.Config()
        config.insert_json5("mode", '"peer"')
        config.insert_json5("scouting/multicast/enabled", "false")
        config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{meet}"]))
        session = zenoh.open(config)
        session.declare_subscriber("avhear/results", lambda s: (lock.acquire(), received.append(
            s.payload.to_bytes()), lock.release()))
        return session

    def count() -> int:
        with lock:
            return len(received)

    procs: list[subprocess.Popen] = []
    session = None
    try:
        if order.startswith("subscriber"):
            session = subscriber()
            procs += [start(run_args), start(sensors_args)]
        else:
            procs += [start(sensors_args), start(run_args)]
        sensors, run = (procs[1], procs[0]) if order.startswith("subscriber") else (procs[0], procs[1])
        if session is None:
            session = subscriber()
        _wait_for(lambda: count() > 30, 120, "30 results at the subscriber")
        record = subprocess.run([sys.executable, "-m", "app", *record_args], capture_output=True, text=True,
                                cwd=tmp_path, env=env, timeout=120)
        assert record.returncode == 0, record.stderr
        for proc in (run, sensors):
            proc.send_signal(signal.SIGTERM)
        outs = {name: proc.communicate(timeout=60) for name, proc in (("run", run), ("sensors", sensors))}
    finally:
        for proc in procs:
            if proc.poll() is None:
                proc.kill()
        if session is not None:
            session.close()
    for name, (_, err) in outs.items():
        assert "Traceback" not in err and "in use" not in err, f"{name}: {err}"
    assert run.returncode == 130, outs["run"][1]
    from app.sources.recording import open_recording

    rec = open_recording(tmp_path / record_args[record_args.index("-o") + 1])
    assert rec.n_frames > 60 and rec.n_samples > 2 * 16000
    results = [json.loads(p) for p in received]
    assert any(p["speaking"] for r in results for p in r["people"])


def test_a_run_on_the_bus_with_no_robot_is_an_error(tmp_path: Path, rig_file: Path) -> None:
    """No robot ever publishes: no gap is counted (the robot was never there to go away), and the run exits 2
    with one line naming the keys it listened to, instead of 0 with nothing."""
    env = dict(os.environ, AVHEAR_BUS_PORT=str(_free_port()))
    done = subprocess.run([sys.executable, "-m", "app", "run", "--source", "bus", "--rig", str(rig_file),
                           "--bus-namespace", "lab", "--duration", "2", "--headless"], capture_output=True,
                          text=True, cwd=ROOT, env=env, timeout=120)
    assert done.returncode == 2, done.stderr
    assert "0 gaps" in done.stdout
    assert "no robot published on /lab/stereo/left/image_rect_color/compressed" in done.stderr
    assert "Traceback" not in done.stderr
