"""`--source ros`: a ROS 2 robot's RGB-D camera and microphone topics, as realsense2_camera and audio_common publish
them, read over real Zenoh sessions. The robot's messages are built here by rosbags alone (with audio_common's
message definitions as its package declares them), under rmw_zenoh's keys written out by hand."""
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

ROOT = Path(__file__).resolve().parents[2]
K = [[600.0, 0.0, 322.0], [0.0, 601.0, 239.0], [0.0, 0.0, 1.0]]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _session(listen: int | None = None, connect: int | None = None):  # noqa: ANN202
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    if listen is not None:
        config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{listen}"]))
    if connect is not None:
        config.insert_json5("connect/endpoints", json.dumps([f"tcp/127.0.0.1:{connect}"]))
    return zenoh.open(config)


class _Driver:
    """A RealSense and an audio_capture node, as rosbags serialises their messages (ROS 2 Jazzy)."""

    def __init__(self, session, tokens: bool = False) -> None:  # noqa: ANN001
        from rosbags.typesys import Stores, get_types_from_msg, get_typestore

        self.tokens = tokens  # each publisher's liveliness token, as rmw_zenoh declares it (node "camera", id 0)
        self._live: list = []

        self.store = get_typestore(Stores.ROS2_JAZZY)
        # audio_common (ros-drivers/audio_common, branch ros2), audio_common_msgs/msg/*.msg
        for name, text in (("AudioData", "uint8[] data"),
                           ("AudioDataStamped", "std_msgs/Header header\naudio_common_msgs/AudioData audio"),
                           ("AudioInfo", "uint8 channels\nuint32 sample_rate\nstring sample_format\nuint32 bitrate\n"
                                         "string coding_format")):
            self.store.register(get_types_from_msg(text, f"audio_common_msgs/msg/{name}"))
        self.t = self.store.types
        self.session = session
        self._pubs = {}

    def put(self, topic: str, typename: str, message: object) -> None:
        package, _, name = typename.split("/")
        key = f"0/{topic}/{package}::msg::dds_::{name}_/{self.store.hash_rihs01(typename)}"
        if key not in self._pubs:
            self._pubs[key] = self.session.declare_publisher(key)
            if self.tokens:  # ros2/rmw_zenoh docs/design.md: @ros2_lv/<domain>/<zid>/<node>/<id>/MP/<enclave>/...
                token = (f"@ros2_lv/0/{self.session.info.zid()}/0/{len(self._pubs)}/MP/%/%/camera/"
                         f"%{topic.replace('/', '%')}/{package}::msg::dds_::{name}_/{self.store.hash_rihs01(typename)}/"
                         "::,10:,:,:,,")
                self._live.append(self.session.liveliness().declare_token(token))
        self._pubs[key].put(bytes(self.store.serialize_cdr(message, typename)))

    def announce(self, topic: str, typename: str) -> None:
        """A publisher's liveliness token alone, as a driver that has started and sent nothing yet."""
        package, _, name = typename.split("/")
        self._live.append(self.session.liveliness().declare_token(
            f"@ros2_lv/0/{self.session.info.zid()}/0/{100 + len(self._live)}/MP/%/%/camera/%{topic.replace('/', '%')}/"
            f"{package}::msg::dds_::{name}_/{self.store.hash_rihs01(typename)}/::,10:,:,:,,"))

    def header(self, stamp: float, frame: str):  # noqa: ANN201
        sec = int(stamp)
        return self.t["std_msgs/msg/Header"](stamp=self.t["builtin_interfaces/msg/Time"](
            sec=sec, nanosec=int(round((stamp - sec) * 1e9))), frame_id=frame)

    def camera(self, stamp: float, colour_rgb: np.ndarray, depth_mm: np.ndarray) -> None:
        h, w = depth_mm.shape
        image = self.t["sensor_msgs/msg/Image"]
        self.put("camera/camera/color/image_raw", "sensor_msgs/msg/Image", image(
            header=self.header(stamp, "camera_color_optical_frame"), height=h, width=w, encoding="rgb8",
            is_bigendian=0, step=3 * w, data=colour_rgb.reshape(-1)))
        self.put("camera/camera/aligned_depth_to_color/image_raw", "sensor_msgs/msg/Image", image(
            header=self.header(stamp, "camera_color_optical_frame"), height=h, width=w, encoding="16UC1",
            is_bigendian=0, step=2 * w, data=depth_mm.astype("<u2").view(np.uint8).reshape(-1)))

    def camera_info(self, stamp: float, w: int, h: int) -> None:
        t = self.t
        self.put("camera/camera/color/camera_info", "sensor_msgs/msg/CameraInfo", t["sensor_msgs/msg/CameraInfo"](
            header=self.header(stamp, "camera_color_optical_frame"), height=h, width=w, distortion_model="plumb_bob",
            d=np.zeros(5), k=np.array(K).ravel(), r=np.eye(3).ravel(),
            p=np.hstack([np.array(K), np.zeros((3, 1))]).ravel(), binning_x=0, binning_y=0,
            roi=t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0, do_rectify=False)))

    def audio(self, stamp: float, pcm: np.ndarray) -> None:
        t = self.t
        self.put("audio/audio_stamped", "audio_common_msgs/msg/AudioDataStamped", t[
            "audio_common_msgs/msg/AudioDataStamped"](header=self.header(stamp, "mic"), audio=t[
                "audio_common_msgs/msg/AudioData"](data=pcm.astype("<i2").view(np.uint8).reshape(-1))))

    def audio_info(self, channels: int) -> None:
        self.put("audio/audio_info", "audio_common_msgs/msg/AudioInfo", self.t["audio_common_msgs/msg/AudioInfo"](
            channels=channels, sample_rate=16000, sample_format="S16LE", bitrate=16 * 16000 * channels,
            coding_format="wave"))


def test_a_realsense_and_audio_capture_as_a_source(tmp_path: Path) -> None:
    """The camera's intrinsics come from its CameraInfo, colour (rgb8) and aligned depth (16UC1) are paired into
    frames with their depth in metres, and the audio (S16LE, stamped on GStreamer's monotonic clock, far from ROS
    time) is numbered and moved onto ROS time; a lost audio message skips its samples."""
    from app.bus.ros_source import RosSource
    from app.config import RigConfig
    from avcore.geometry import MicPair

    port = _free_port()
    w, h = 64, 48
    rig = RigConfig(None, MicPair(left=(-0.05, 0.0, 0.0), right=(0.05, 0.0, 0.0)))
    with _session(listen=port) as robot, _session(connect=port) as laptop:
        driver = _Driver(robot)
        stop_info = threading.Event()

        def infos() -> None:  # the drivers publish their info messages over and over (audio_capture every 5 s)
            while not stop_info.is_set():
                driver.camera_info(time.time(), w, h)
                driver.audio_info(2)
                stop_info.wait(0.1)

        threading.Thread(target=infos, daemon=True).start()
        try:
            source = RosSource(laptop, rig, info_timeout_s=30.0)
        finally:
            stop_info.set()
        assert source.rig.image_size == (w, h) and source.samplerate_hz == 16000.0
        assert source.camera_frame == "camera_color_optical_frame"  # CameraInfo's: where the rig hangs in TF
        np.testing.assert_allclose(source.rig.back_project([[322.0, 239.0]], [2.0], rectified=False),
                                   [[-0.0005, 0.0, 2.0]], atol=1e-9)  # the principal point, 2 m ahead
        rng = np.random.default_rng(0)
        now = time.time()
        colour = rng.integers(0, 255, (h, w, 3), np.uint8)
        depth = np.full((h, w), 1500, np.uint16)
        depth[0, 0] = 0  # no depth here
        uptime = 5000.0  # GStreamer's clock: seconds since boot
        pcm = (np.arange(4 * 160 * 2) % 2000 - 1000).reshape(4, 160, 2).astype(np.int16)
        deadline = time.monotonic() + 30
        frames: list = []
        blocks: list = []
        stop = threading.Event()
        for k in range(8):  # at a camera's pace, not in one burst (the pairing keeps 4 of each stream)
            driver.camera(now + k / 30, colour, depth)
            time.sleep(0.01)
        for k in (0, 1, 3):  # message 2 is lost
            driver.audio(uptime + k * 0.01, pcm[k])
        for frame in source.frames(stop):
            frames.append(frame)
            if len(frames) == 4 or time.monotonic() > deadline:
                break
        for block in source.audio(stop):
            blocks.append(block)
            if len(blocks) == 3 or time.monotonic() > deadline:
                break
        source.close()
    assert len(frames) == 4 and all(f.right is None for f in frames)
    f = frames[0]
    np.testing.assert_array_equal(f.left, colour[..., ::-1])  # rgb8 -> BGR
    assert np.isnan(f.depth_m[0, 0]) and f.depth_m[1, 1] == pytest.approx(1.5)
    k = round((f.stamp_s - now) * 30)  # the colour image's own stamp, paired with its depth
    assert 0 <= k < 8 and f.stamp_s == pytest.approx(now + k / 30, abs=1e-6)
    assert [b.first_sample for b in blocks] == [0, 160, 480] and source.audio_gaps == 1
    np.testing.assert_allclose(blocks[2].samples, pcm[3] / 32768.0)
    assert abs(blocks[0].stamp_s - time.time()) < 10  # moved onto ROS time
    assert blocks[2].stamp_s - blocks[0].stamp_s == pytest.approx(0.03)


def test_mp3_audio_is_one_line() -> None:
    from app.bus.convert import audio_format
    from app.bus.messages import AUDIO_INFO, typestore

    info = typestore().types[AUDIO_INFO](channels=1, sample_rate=16000, sample_format="S16LE", bitrate=192,
                                         coding_format="mp3")
    with pytest.raises(ValueError, match="format:=wave"):
        audio_format(info)


def _ros_recipe() -> tuple[list[str], str]:
    """The README's ROS recipe: its `avhear ...` line's arguments and the mics.yaml that follows it."""
    text = (ROOT / "README.md").read_text(encoding="utf-8").split("<!-- the ROS recipe", 1)[1]
    block = text.split("```bash", 1)[1].split("```", 1)[0]
    lines = [line.split("#", 1)[0].split() for line in block.splitlines()]
    (avhear,) = [words[1:] for words in lines if words and words[0] == "avhear"]
    return avhear, text.split("```yaml", 1)[1].split("```", 1)[0]


def test_the_readmes_ros_recipe_on_a_ros_robot_made_of_the_simulator(tmp_path: Path, rmw_router: str) -> None:
    """The README's ROS recipe as written (its `avhear run` line and its mics.yaml) on a robot made of the simulated
    room (`avhear sensors --ros --mics respeaker4`: realsense2_camera and audio_capture topics), all joined to an
    rmw_zenoh router; then `avhear record --source ros`. The people are found where they are (in the colour
    camera's frame), someone speaks, the rig hangs under the camera's frame on tf_static, and the recording holds
    the colour and the depth and replays. The topics the README says it reads are the defaults."""
    from app.bus.messages import RosTopics

    args, mics = _ros_recipe()
    assert args[:3] == ["run", "--source", "ros"] and "--publish" in args
    section = (ROOT / "README.md").read_text(encoding="utf-8").split("## A ROS 2 robot", 1)[1].split("\n## ", 1)[0]
    assert all(f"`{topic}`" in section for topic in (RosTopics.colour, RosTopics.depth, RosTopics.camera_info,
                                                      RosTopics.audio, RosTopics.audio_info))
    (tmp_path / args[args.index("--rig") + 1]).write_text(mics)
    import zenoh

    from app.bus.messages import decode

    env = dict(os.environ, AVHEAR_BUS_PORT=str(_free_port()), PYTHONPATH=str(ROOT))
    env.pop("ROS_DOMAIN_ID", None)
    results = tmp_path / "results.jsonl"
    ns = ("--bus-namespace", "e2e")  # this test's robot only, whatever other tests left running
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps([rmw_router]))
    statics: list[bytes] = []
    graph = zenoh.open(config)
    graph.declare_subscriber("0/e2e/tf_static/tf2_msgs::msg::dds_::TFMessage_/*",
                             lambda sample: statics.append(sample.payload.to_bytes()))
    robot = subprocess.Popen([sys.executable, "-m", "app", "sensors", "--source", "sim:S1", "--ros", "--mics",
                              "respeaker4", "--duration", "60", *ns], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, cwd=tmp_path, env=env)
    try:
        for line in robot.stderr:  # a robot up and running, as the recipe starts from
            if "avhear: publishing" in line:
                break
        run = subprocess.run([sys.executable, "-m", "app", *args, "--duration", "4", "--headless",
                              "--results-jsonl", str(results), "--vote-frames", "1", *ns],
                             capture_output=True, text=True, cwd=tmp_path, env=env, timeout=180)
        record = subprocess.run([sys.executable, "-m", "app", "record", "--source", "ros", "-o", "rec", "--duration",
                                 "2", *ns], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=180)
    finally:
        robot.send_signal(signal.SIGTERM)
        robot.communicate(timeout=60)
        graph.close()
    assert run.returncode == 0, run.stderr
    assert "Check the rig file's microphones" not in run.stderr  # the recipe's mics.yaml is the robot's array
    # the rig hangs under the camera's optical frame in the robot's TF tree (REP-103, REP-155); how often it is sent
    # again goes by the wall clock (tests/app/test_bus.py), which a loaded machine stretches: here, not per result
    links = [decode(payload, "tf2_msgs/msg/TFMessage").transforms[0] for payload in statics]
    assert 1 <= len(links) <= 8, len(links)
    assert {(t.header.frame_id, t.child_frame_id) for t in links} == {("camera_color_optical_frame", "avhear_rig")}
    assert links[0].transform.rotation.w == 1.0 and 0 <= links[0].transform.translation.x < 0.01
    lines = [json.loads(line) for line in results.read_text().splitlines()]
    assert len(lines) > 30
    from app.sources.sim import load_clip_bank
    from sim.scenario import make_scenario

    scenario = make_scenario("S1", clip_durations_s=load_clip_bank(16000, None, seed=0).durations_s, seed=0)
    # the results are stamped on ROS time, the truth on the scenario's: compare with the people's whole paths
    path = np.concatenate([scenario.positions(t) for t in np.arange(0.0, scenario.duration_s, 0.05)])
    truth = path + np.array([0.5 * scenario.rig.baseline_m, 0.0, 0.0])  # in the colour frame
    found = np.array([p["position_m"] for r in lines for p in r["people"]])
    nearest = np.linalg.norm(found[:, None] - truth[None], axis=2).min(axis=1)
    assert np.median(nearest) < 0.05, (np.median(found, axis=0), truth[0])
    assert any(p["speaking"] for r in lines for p in r["people"])
    assert record.returncode == 0, record.stderr
    from app.events import StereoFrame
    from app.sources.recording import open_recording

    rec = open_recording(tmp_path / "rec")
    assert rec.depth_files is not None and rec.n_frames > 30 and rec.n_samples > 16000
    frame = next(x for x in rec.stream() if isinstance(x, StereoFrame))
    assert frame.right is None and np.nanmedian(frame.depth_m) > 1.0


@pytest.mark.parametrize("wrong, flag, right", [
    ({"colour": "/camera/color/image_raw"}, "--colour-topic", "/camera/camera/color/image_raw"),
    ({"audio": "/audio/audio"}, "--audio-topic", "/audio/audio_stamped"),
])
def test_a_topic_nobody_publishes_is_named_with_those_that_exist(wrong: dict, flag: str, right: str) -> None:
    """A wrong topic name is never a silent success: within the info timeout the stream says which topic has no
    publisher and lists the topics of its type the robot's graph announces (its liveliness tokens), naming the
    flag; the run then ends with that one line (a UserError)."""
    from app.bus.messages import RosTopics
    from app.bus.ros_source import RosSource
    from app.config import RigConfig
    from app.errors import UserError
    from avcore.geometry import MicPair

    port = _free_port()
    rig = RigConfig(None, MicPair(left=(-0.05, 0.0, 0.0), right=(0.05, 0.0, 0.0)))
    with _session(listen=port) as robot, _session(connect=port) as laptop:
        driver = _Driver(robot, tokens=True)
        stop_robot = threading.Event()

        def drivers() -> None:  # the robot's drivers, publishing as they do
            k = 0
            while not stop_robot.is_set():
                now = time.time()
                driver.camera_info(now, 64, 48)
                driver.audio_info(2)
                driver.camera(now, np.zeros((48, 64, 3), np.uint8), np.full((48, 64), 1500, np.uint16))
                driver.audio(now, np.zeros((160, 2), np.int16))
                k += 1
                stop_robot.wait(0.03)

        threading.Thread(target=drivers, daemon=True).start()
        try:
            source = RosSource(laptop, rig, topics=RosTopics(**wrong), info_timeout_s=3.0)
            stop = threading.Event()
            started = time.monotonic()
            with pytest.raises(UserError) as caught:
                stream = source.frames(stop) if "colour" in wrong else source.audio(stop)
                for _ in stream:
                    assert time.monotonic() - started < 20, "no word about the silent topic"
            source.close()
        finally:
            stop_robot.set()
    message = str(caught.value)
    bad = next(iter(wrong.values()))
    assert f"on {bad} within" in message and "no node publishes it" in message, message
    assert right in message and flag in message and "\n" not in message, message


def test_no_router_is_said_to_be_no_router(tmp_path: Path) -> None:
    """`run --source ros` with nothing at the rmw_zenoh router's endpoint: one line that says so and how to start
    one (not a missing camera driver), exit 2."""
    env = dict(os.environ, AVHEAR_BUS_PORT=str(_free_port()), AVHEAR_ROS_ROUTER=f"tcp/127.0.0.1:{_free_port()}")
    env.pop("ROS_DOMAIN_ID", None)
    done = subprocess.run([sys.executable, "-m", "app", "run", "--source", "ros", "--duration", "3", "--headless",
                           "--bus-wait", "2"],
                          capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    errors = [line for line in done.stderr.splitlines() if "error" in line]
    assert len(errors) == 1 and f"nothing answers at {env['AVHEAR_ROS_ROUTER']}" in errors[0], done.stderr
    assert "rmw_zenohd" in errors[0] and "CameraInfo" not in errors[0]


def test_sensors_never_publish_onto_a_robots_own_topics_unless_forced(tmp_path: Path, rmw_router: str) -> None:
    """`avhear sensors --ros` beside a robot whose camera driver already publishes (its liveliness tokens say so):
    refused in one line that names the topic and the way out, exit 2; with --force it publishes, and says which
    simulated room it publishes on which topics."""
    env = dict(os.environ, AVHEAR_BUS_PORT=str(_free_port()), PYTHONPATH=str(ROOT))
    env.pop("ROS_DOMAIN_ID", None)
    with _session(connect=int(rmw_router.rsplit(":", 1)[1])) as robot:
        driver = _Driver(robot, tokens=True)
        driver.camera(time.time(), np.zeros((48, 64, 3), np.uint8), np.zeros((48, 64), np.uint16))
        argv = [sys.executable, "-m", "app", "sensors", "--source", "sim:S1", "--ros", "--duration", "1"]
        refused = subprocess.run(argv, capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)
        forced = subprocess.run([*argv, "--force"], capture_output=True, text=True, cwd=tmp_path, env=env,
                                timeout=120)
    assert refused.returncode == 2 and "Traceback" not in refused.stderr, refused.stderr
    error = [line for line in refused.stderr.splitlines() if "error" in line]
    assert len(error) == 1 and "/camera/camera/color/image_raw" in error[0] and "--force" in error[0], error
    assert forced.returncode == 0, forced.stderr
    assert "publishing the simulated room sim:S1 (seed 0) as an RGB-D camera" in forced.stderr
    assert "/camera/camera/color/image_raw" in forced.stderr and "/audio/audio_stamped" in forced.stderr


def test_a_ros_robot_without_a_rig_is_asked_for_its_microphones(tmp_path: Path, rmw_router: str) -> None:
    """`run --source ros` with a router and no --rig: one line that asks for the microphones' rig file (it
    suggested `avhear sensors`, which a ROS robot does not run), exit 2."""
    env = dict(os.environ, AVHEAR_BUS_PORT=str(_free_port()))
    env.pop("ROS_DOMAIN_ID", None)
    done = subprocess.run([sys.executable, "-m", "app", "run", "--source", "ros", "--duration", "2", "--headless",
                           "--bus-wait", "2"],
                          capture_output=True, text=True, cwd=tmp_path, env=env, timeout=120)
    assert done.returncode == 2 and "Traceback" not in done.stderr, done.stderr
    errors = [line for line in done.stderr.splitlines() if "error" in line]
    assert len(errors) == 1 and "--rig mics.yaml" in errors[0] and "start `avhear sensors`" not in errors[0]


def test_a_published_topic_that_is_slow_to_start_is_waited_for(caplog: pytest.LogCaptureFixture) -> None:
    """Image topics whose driver is up (their tokens are there) but has sent nothing yet by the info timeout: said as
    a warning and waited for, not an error (a driver's slow start is no wrong name)."""
    import logging

    from app.bus.ros_source import RosSource
    from app.config import RigConfig
    from avcore.geometry import MicPair

    port = _free_port()
    rig = RigConfig(None, MicPair(left=(-0.05, 0.0, 0.0), right=(0.05, 0.0, 0.0)))
    with _session(listen=port) as robot, _session(connect=port) as laptop:
        driver = _Driver(robot, tokens=True)
        driver.announce("camera/camera/color/image_raw", "sensor_msgs/msg/Image")
        driver.announce("camera/camera/aligned_depth_to_color/image_raw", "sensor_msgs/msg/Image")
        stop_robot = threading.Event()

        def drivers() -> None:  # everything but the images
            while not stop_robot.is_set():
                driver.camera_info(time.time(), 64, 48)
                driver.audio_info(2)
                driver.audio(time.time(), np.zeros((160, 2), np.int16))
                stop_robot.wait(0.03)

        threading.Thread(target=drivers, daemon=True).start()
        try:
            source = RosSource(laptop, rig, info_timeout_s=2.0)
            stop = threading.Event()
            threading.Timer(4.0, stop.set).start()
            with caplog.at_level(logging.WARNING):
                assert list(source.frames(stop)) == []  # waited until stopped: no error
            source.close()
        finally:
            stop_robot.set()
    assert any("/camera/camera/color/image_raw" in r.getMessage() and "though a node publishes it" in r.getMessage()
               for r in caplog.records)
