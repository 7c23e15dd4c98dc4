"""The bus: ROS4HRI messages in CDR through rosbags' own deserialiser, and `--publish` between real processes over
127.0.0.1 (a Zenoh subscriber in the test, avhear in a subprocess)."""
from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from app.bus.messages import FACE, VOICE, Topics, decode

ROOT = Path(__file__).resolve().parents[2]
RECORD = {"stamp_s": 12.25, "index": 367, "mode": "face", "n_itds": 9, "latency_s": None, "people": [
    {"id": 0, "position_m": [-0.8, 0.05, 1.9], "speaking": False, "probability": 0.1, "itd_mean_s": -2e-4,
     "box_px": [80, 120, 40, 44]},
    {"id": 3, "position_m": [0.7, -0.1, 2.9], "speaking": True, "probability": 0.97, "itd_mean_s": 1.3e-4,
     "box_px": [410, 100, 30, 33]},
]}


def test_every_message_round_trips_through_rosbags() -> None:
    messages = Topics().messages(RECORD)
    got = {topic: payload for topic, _, payload in messages}
    types = {topic: typename for topic, typename, _ in messages}
    assert types["tf"] == "tf2_msgs/msg/TFMessage" and types["avhear/results"] is None
    voices = decode(got["humans/voices/tracked"], "hri_msgs/msg/IdsList")
    assert voices.ids == ["v0", "v3"] and voices.header.frame_id == "avhear_rig"
    assert (voices.header.stamp.sec, voices.header.stamp.nanosec) == (12, 250_000_000)
    assert decode(got["humans/voices/v0/is_speaking"], "std_msgs/msg/Bool").data is False
    assert decode(got["humans/voices/v3/is_speaking"], "std_msgs/msg/Bool").data is True
    assert decode(got["humans/faces/tracked"], "hri_msgs/msg/IdsList").ids == ["f0", "f3"]
    roi = decode(got["humans/faces/f3/roi"], "sensor_msgs/msg/RegionOfInterest")
    assert (roi.x_offset, roi.y_offset, roi.width, roi.height) == (410, 100, 30, 33)
    assert not [topic for topic in got if topic.endswith("lip_activity")]  # the lips were not read
    matches = [decode(p, "hri_msgs/msg/IdsMatch") for topic, _, p in messages if topic == "humans/candidate_matches"]
    assert {(m.id1, m.id1_type, m.id2, m.id2_type) for m in matches} == {
        ("f0", FACE, "v0", VOICE), ("f3", FACE, "v3", VOICE), ("p0", 1, "v0", 4), ("p0", 1, "f0", 2),
        ("p3", 1, "v3", 4), ("p3", 1, "f3", 2)}  # PERSON = 1, FACE = 2, VOICE = 4 (hri_msgs/IdsMatch)
    tf = decode(got["tf"], "tf2_msgs/msg/TFMessage")
    frames = {t.child_frame_id: t for t in tf.transforms}
    assert set(frames) == {"voice_v0", "voice_v3", "face_f0", "face_f3", "person_p0", "person_p3"}
    v = frames["voice_v3"].transform.translation
    assert (v.x, v.y, v.z) == (0.7, -0.1, 2.9) and frames["voice_v3"].header.frame_id == "avhear_rig"
    assert json.loads(got["avhear/results"]) == RECORD
    # CDR as ROS 2 sends it: the 4-byte encapsulation header, little-endian (CDR_LE = 0x0001)
    assert all(payload[:4] == b"\x00\x01\x00\x00" for key, payload in got.items() if not key.endswith("results"))


def test_each_face_s_lip_activity_goes_out_when_the_lips_are_read() -> None:
    people = [dict(RECORD["people"][0], lip_activity=0.0123), dict(RECORD["people"][1], lip_activity=None)]
    got = {topic: payload for topic, _, payload in Topics().messages(dict(RECORD, people=people))}
    assert decode(got["humans/faces/f0/lip_activity"], "std_msgs/msg/Float32").data == pytest.approx(0.0123)
    assert "humans/faces/f3/lip_activity" not in got  # no opinion (just arrived, turned away): nothing said


def test_persons_are_followed_and_fade_when_no_longer_seen() -> None:
    """ROS4HRI persons: the person seen has location confidence 1; one no longer seen is still known, at its last
    place, its confidence falling linearly to 0 over 10 s, then forgotten (REP-155, "Person frame")."""
    topics = Topics()
    moved = dict(RECORD["people"][0], position_m=[-0.7, 0.05, 1.9])

    def at(stamp_s: float, people: list) -> dict[str, list[bytes]]:
        out: dict[str, list[bytes]] = {}
        for topic, _, payload in topics.messages(dict(RECORD, stamp_s=stamp_s, people=people)):
            out.setdefault(topic, []).append(payload)
        return out

    at(12.25, RECORD["people"])
    later = at(17.25, [moved])  # person 3 unseen for 5 s
    ids = lambda topic, got: decode(got[topic][0], "hri_msgs/msg/IdsList").ids  # noqa: E731
    assert ids("humans/persons/tracked", later) == ["p0"] and ids("humans/persons/known", later) == ["p0", "p3"]
    conf = {p: decode(later[f"humans/persons/{p}/location_confidence"][0], "std_msgs/msg/Float32").data
            for p in ("p0", "p3")}
    assert conf["p0"] == 1.0 and conf["p3"] == pytest.approx(0.5)
    assert decode(later["humans/persons/p3/anonymous"][0], "std_msgs/msg/Bool").data is True
    assert decode(later["humans/persons/p3/face_id"][0], "std_msgs/msg/String").data == "f3"
    assert decode(later["humans/persons/p3/voice_id"][0], "std_msgs/msg/String").data == "v3"
    frames = {t.child_frame_id: t.transform.translation for t in
              decode(later["tf"][0], "tf2_msgs/msg/TFMessage").transforms}
    assert (frames["person_p3"].x, frames["person_p3"].z) == (0.7, 2.9)  # where person 3 was last seen
    assert (frames["person_p0"].x, frames["person_p0"].z) == (-0.7, 1.9)  # with the face
    gone = at(22.3, [moved])  # 10.05 s after person 3 was last seen
    assert ids("humans/persons/known", gone) == ["p0"] and "humans/persons/p3/location_confidence" not in gone


def test_motion_guided_results_have_voices_only() -> None:
    record = dict(RECORD, mode="motion", people=[{k: v for k, v in p.items() if k != "box_px"}
                                                 for p in RECORD["people"]])
    messages = Topics().messages(record)
    keys = [k for k, _, _ in messages]
    assert "humans/voices/tracked" in keys and "tf" in keys and "humans/persons/p3/voice_id" in keys
    assert not [k for k in keys if k.startswith("humans/faces") or k.endswith("/face_id")]
    matches = [decode(p, "hri_msgs/msg/IdsMatch") for k, _, p in messages if k == "humans/candidate_matches"]
    assert {(m.id1, m.id2) for m in matches} == {("p0", "v0"), ("p3", "v3")}  # a person and its voice, no face


def test_an_undecodable_payload_is_a_value_error() -> None:
    with pytest.raises(ValueError, match="does not decode"):
        decode(b"\x00\x01\x00\x00\xff", "hri_msgs/msg/IdsList")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _demo_on_the_bus(*flags: str) -> tuple[subprocess.CompletedProcess[str], dict[str, list[tuple[bytes, bytes]]],
                                             list[tuple[str, str]]]:
    """`avhear demo --publish` for 2 s, connected to a session of the test's that listens on a loopback port:
    (the process, every sample's payload and attachment by key, every liveliness token's (kind, key))."""
    import zenoh

    port = _free_port()
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    received: dict[str, list[tuple[bytes, bytes]]] = {}
    tokens: list[tuple[str, str]] = []
    lock = threading.Lock()

    def on_sample(sample: zenoh.Sample) -> None:
        attachment = sample.attachment.to_bytes() if sample.attachment is not None else b""
        with lock:
            received.setdefault(str(sample.key_expr), []).append((sample.payload.to_bytes(), attachment))

    def on_token(sample: zenoh.Sample) -> None:
        with lock:
            tokens.append((str(sample.kind), str(sample.key_expr)))

    def arrived(suffix: str) -> int:
        with lock:
            return sum(len(v) for k, v in received.items() if k.endswith(suffix) or f"/{suffix}/" in k)

    with zenoh.open(config) as session:
        session.declare_subscriber("**", on_sample)
        session.liveliness().declare_subscriber("@ros2_lv/**", on_token)
        done = subprocess.run(
            [sys.executable, "-m", "app", "demo", "--headless", "--duration", "2", "--fast", "--publish",
             "--bus-namespace", "lab", "--bus-connect", f"tcp/127.0.0.1:{port}",
             "--bus-listen", f"tcp/127.0.0.1:{_free_port()}", *flags],
            capture_output=True, text=True, cwd=ROOT, timeout=120)
        # the last samples may still be in flight when the process ends: wait for them, not for a set time
        deadline = time.monotonic() + 30.0
        while min(arrived(k) for k in ("avhear/results", "humans/voices/tracked", "tf")) < 60:
            assert time.monotonic() < deadline, {k: len(v) for k, v in received.items()}
            time.sleep(0.02)
    with lock:
        return done, dict(received), list(tokens)


def test_publish_between_two_processes_with_the_bridges_keys() -> None:
    """Under zenoh-bridge-ros2dds's convention the keys are the ROS topics without their leading slash."""
    done, received, tokens = _demo_on_the_bus("--ros-keys", "bridge")
    assert done.returncode == 0, done.stderr
    assert "60 results published on the bus (0 dropped" in done.stdout
    assert tokens == []  # the bridge announces DDS entities itself
    results = [json.loads(p) for p, _ in received["lab/avhear/results"]]
    tracked = [decode(p, "hri_msgs/msg/IdsList") for p, _ in received["lab/humans/voices/tracked"]]
    speaking = {k: [decode(p, "std_msgs/msg/Bool").data for p, _ in v] for k, v in received.items()
                if k.endswith("/is_speaking")}
    tf = [decode(p, "tf2_msgs/msg/TFMessage") for p, _ in received["lab/tf"]]
    assert len(results) == 60 and len(tracked) == 60 and len(tf) == 60
    assert [r["index"] for r in results] == sorted(r["index"] for r in results)
    ids = {p["id"] for r in results for p in r["people"]}
    assert {f"lab/humans/voices/v{i}/is_speaking" for i in ids} == set(speaking)
    assert any(any(v) for v in speaking.values())  # somebody speaks in S2's first two seconds
    assert all(len(t.transforms) >= 3 * len(r["people"]) for t, r in zip(tf, results))  # voice, face, person
    # each voice's audio (REP-155's required topic): 16 kHz S16LE bytes in audio_common_msgs/AudioData, from the
    # voices' delay (0.6 s) on: most of the 1.4 s left of the run (the last chunks may be in flight at the end)
    audio = {k: b"".join(bytes(decode(p, "audio_common_msgs/msg/AudioData").data) for p, _ in v)
             for k, v in received.items() if k.endswith("/audio")}
    assert set(audio) == {f"lab/humans/voices/v{i}/audio" for i in ids}
    assert all(1.0 * 16000 * 2 <= len(b) <= 1.45 * 16000 * 2 and len(b) % 2 == 0 for b in audio.values())
    assert all(np.abs(np.frombuffer(b, dtype="<i2")).max() > 100 for b in audio.values())


# REP-2011 hashes as ROS 2 Jazzy computes them (ros-z's regression table, checked there against rmw_zenoh_cpp:
# ZettaScaleLabs/ros-z crates/ros-z-codegen/tests/hash_regression.rs)
PUBLISHED_HASHES = {
    "std_msgs/msg/String": "RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18",
    "std_msgs/msg/Header": "RIHS01_f49fb3ae2cf070f793645ff749683ac6b06203e41c891e17701b1cb597ce6a01",
    "geometry_msgs/msg/TwistStamped": "RIHS01_5f0fcd4f81d5d06ad9b4c4c63e3ea51b82d6ae4d0558f1d475229b1121db6f64",
    "geometry_msgs/msg/PoseStamped": "RIHS01_10f3786d7d40fd2b54367835614bff85d4ad3b5dab62bf8bca0cc232d73b4cd8",
    "sensor_msgs/msg/Imu": "RIHS01_7d9a00ff131080897a5ec7e26e315954b8eae3353c3f995c55faf71574000b5b",
    "nav_msgs/msg/Odometry": "RIHS01_3cc97dc7fb7502f8714462c526d369e35b603cfc34d946e3f2eda2766dfec6e0",
}


def test_rmw_zenohs_router_is_joined_where_ros_2_has_it(monkeypatch: pytest.MonkeyPatch) -> None:
    from app.bus.ros2 import ROUTER, router

    assert ROUTER == "tcp/127.0.0.1:7447"  # rmw_zenoh's router, rmw_zenohd's default port
    monkeypatch.delenv("AVHEAR_ROS_ROUTER", raising=False)
    assert router() == ROUTER
    monkeypatch.setenv("AVHEAR_ROS_ROUTER", "")
    assert router() is None


@pytest.mark.parametrize("typename", sorted(PUBLISHED_HASHES))
def test_type_hashes_are_the_ones_ros_publishes(typename: str) -> None:
    from app.bus.messages import typestore

    assert typestore().hash_rihs01(typename) == PUBLISHED_HASHES[typename]


def test_publish_between_two_processes_as_a_native_ros2_node() -> None:
    """Under rmw_zenoh's convention (the default): the data keys are <domain>/<topic>/<DDS type>/<RIHS01 hash>, each
    sample carries rmw_zenoh's 33-byte attachment, and the node and each publisher hold liveliness tokens in
    rmw_zenoh's format, read here as ros2/rmw_zenoh's docs/design.md and liveliness_utils.cpp describe them."""
    import struct

    from app.bus.messages import typestore

    done, received, tokens = _demo_on_the_bus("--ros-domain", "7")
    assert done.returncode == 0, done.stderr
    topics = {}
    for key, samples in received.items():
        if key == "lab/avhear/results":  # the JSON is not a ROS message: the same key in both conventions
            continue
        domain, *topic, dds_type, type_hash = key.split("/")
        package, msg, dds, name = dds_type.split("::")
        typename = f"{package}/msg/{name[:-1]}"
        assert (domain, topic[0], msg, dds, name[-1]) == ("7", "lab", "msg", "dds_", "_"), key
        assert type_hash == typestore().hash_rihs01(typename), key
        topics["/" + "/".join(topic)] = typename
        sequence = []
        for payload, attachment in samples:
            decode(payload, typename)
            assert len(attachment) == 33 and attachment[16] == 16  # int64, int64, LEB128 length 16, 16 bytes
            number, source_ns = struct.unpack("<qq", attachment[:16])
            assert abs(source_ns / 1e9 - time.time()) < 120
            sequence.append(number)
        assert sequence == list(range(1, len(samples) + 1)), key  # every sample, numbered from 1
    assert topics["/lab/humans/voices/tracked"] == "hri_msgs/msg/IdsList" and topics["/lab/tf"] == "tf2_msgs/msg/TFMessage"
    assert len(received["lab/avhear/results"]) == 60
    alive = [key.split("/") for kind, key in tokens if kind == "SampleKind.PUT"]
    gone = {key for kind, key in tokens if kind == "SampleKind.DELETE"}
    assert {"/".join(parts) for parts in alive} == gone  # the process took its tokens back when it ended
    nodes = [p for p in alive if p[5] == "NN"]
    assert len(nodes) == 1
    admin, domain, zid, node_id, entity_id, kind, enclave, namespace, node_name = nodes[0]
    assert (admin, domain, node_id == entity_id, enclave, namespace, node_name) == ("@ros2_lv", "7", True, "%",
                                                                                   "%lab", "avhear")
    publishers = {}
    for parts in (p for p in alive if p[5] == "MP"):
        assert parts[1:4] == [domain, zid, node_id] and parts[6:9] == ["%", "%lab", "avhear"]
        topic, dds_type, type_hash, qos = parts[9:]
        publishers[topic.replace("%", "/")] = (dds_type, type_hash, qos)
    assert set(publishers) == set(topics)
    assert len({p[4] for p in alive}) == len(alive)  # one id per entity
    from app.bus.ros2 import entity_gid

    token_of = {p[9].replace("%", "/"): "/".join(p) for p in alive if p[5] == "MP"}
    for key, samples in received.items():  # each sample carries its publisher's GID, rmw_zenoh's hash of its token
        if key != "lab/avhear/results":
            topic = "/" + "/".join(key.split("/")[1:-2])
            assert {a[17:] for _, a in samples} == {entity_gid(token_of[topic])}, key
    for topic, typename in topics.items():
        package, _, name = typename.split("/")
        assert publishers[topic] == (f"{package}::msg::dds_::{name}_", typestore().hash_rihs01(typename),
                                     "::,10:,:,:,,")  # reliable, volatile, keep last 10


@pytest.mark.parametrize("argv, message", [
    (["--bus-listen", "tcp/nohost"], "is not a Zenoh endpoint"),
    (["--bus-config", "{cfg}"], "does not parse as a Zenoh configuration"),
    (["--bus-config", "{missing}"], "no such file"),
])
def test_bus_mistakes_are_one_line(tmp_path: Path, argv: list[str], message: str) -> None:
    cfg = tmp_path / "bad.json5"
    cfg.write_text("{bad")
    argv = [a.format(cfg=cfg, missing=tmp_path / "nope.json5") for a in argv]
    done = subprocess.run([sys.executable, "-m", "app", "demo", "--headless", "--duration", "1", "--fast",
                           "--publish", *argv], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert done.returncode == 2
    assert message in done.stderr and "Traceback" not in done.stderr
    assert len([line for line in done.stderr.splitlines() if "error" in line]) == 1


def test_a_slow_bus_never_stalls_the_pipeline(people_result: Callable[..., object]) -> None:
    """The publisher's session takes 50 ms per message: publish() hands over without waiting, so the oldest
    results are dropped and counted, and what is published is whole."""
    from app.bus.ros2 import Convention
    from app.sinks.bus import ResultPublisher

    class SlowPublisher:
        def __init__(self, sent: list[str], key: str) -> None:
            self.sent, self.key = sent, key

        def put(self, payload: bytes) -> None:
            time.sleep(0.05)
            self.sent.append(self.key)

        def undeclare(self) -> None:
            pass

    class SlowSession:
        def __init__(self) -> None:
            self.sent: list[str] = []

        def declare_publisher(self, key: str) -> SlowPublisher:
            return SlowPublisher(self.sent, key)

    session = SlowSession()
    publisher = ResultPublisher(session, convention=Convention("bridge"), queue_size=4)
    for k in range(40):
        publisher.publish(people_result(k / 30, [[0.1, 0.0, 2.0]], [True]))
    publisher.close(timeout_s=10)
    # a publish() that waited for the slow session would have lost nothing: dropping is the proof it did not wait
    assert publisher.dropped > 0 and publisher.published + publisher.dropped == 40
    assert session.sent.count("avhear/results") == publisher.published


def test_the_rigs_link_goes_out_once_a_second_of_the_clock(people_result: Callable[..., object],
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    """The rig's tf_static link is repeated every RIG_LINK_EVERY_S of the wall clock (there is no latched topic for
    a late subscriber), whatever the rate of the results: 3.5 s of results at 30 a second send it 4 times, stamped
    with the result that carried it, and not before the camera's frame is known."""
    import app.sinks.bus as bus
    from app.bus.ros2 import Convention

    class Clock:
        now = 0.0

        def monotonic(self) -> float:
            return self.now

    class Recorder:
        def __init__(self, sent: list[tuple[str, bytes]], key: str) -> None:
            self.sent, self.key = sent, key

        def put(self, payload: bytes) -> None:
            self.sent.append((self.key, payload))

        def undeclare(self) -> None:
            pass

    class Session:
        def __init__(self) -> None:
            self.sent: list[tuple[str, bytes]] = []

        def declare_publisher(self, key: str) -> Recorder:
            return Recorder(self.sent, key)

    clock, session, frame = Clock(), Session(), [None]
    monkeypatch.setattr(bus, "time", clock)
    publisher = bus.ResultPublisher(session, convention=Convention("bridge"))
    publisher.link_rig(lambda: frame[0], (0.06, 0.0, 0.0))
    for k in range(-15, 105):  # half a second before the camera's frame is known, then 3.5 s
        frame[0] = "camera_color_optical_frame" if k >= 0 else None
        clock.now = k / 30
        publisher.publish(people_result(k / 30, [[0.1, 0.0, 2.0]], [True]))
        deadline = time.monotonic() + 10
        while publisher.published < k + 16 and time.monotonic() < deadline:
            time.sleep(0.001)
    publisher.close()
    links = [decode(payload, "tf2_msgs/msg/TFMessage").transforms[0] for key, payload in session.sent
             if key.startswith("tf_static")]
    assert [round(t.header.stamp.sec + t.header.stamp.nanosec * 1e-9, 3) for t in links] == [0.0, 1.0, 2.0, 3.0]
    assert {(t.header.frame_id, t.child_frame_id) for t in links} == {("camera_color_optical_frame", "avhear_rig")}
    assert links[0].transform.translation.x == pytest.approx(0.06)


def test_a_ros2_graph_behind_rmw_zenohs_router_sees_avhear(rmw_router: str) -> None:
    """With no endpoint given, avhear joins rmw_zenoh's router (on 7447 by default; here the suite's own port,
    AVHEAR_ROS_ROUTER) as every rmw_zenoh node does, without listening there: a session that only knows the router,
    as `ros2 node list` and `ros2 topic echo` on an rmw_zenoh machine, finds the node `avhear`, its publisher of
    /humans/voices/tracked, and its messages."""
    import zenoh

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("connect/endpoints", json.dumps([rmw_router]))
    tokens: list[str] = []
    tracked: list[bytes] = []
    lock = threading.Lock()

    def on_token(sample: zenoh.Sample) -> None:
        if sample.kind == zenoh.SampleKind.PUT:  # a DELETE comes when the process takes its token back
            with lock:
                tokens.append(str(sample.key_expr))

    def on_tracked(sample: zenoh.Sample) -> None:
        with lock:
            tracked.append(sample.payload.to_bytes())

    with zenoh.open(config) as graph:
        graph.liveliness().declare_subscriber("@ros2_lv/0/**", on_token)
        graph.declare_subscriber("0/humans/voices/tracked/hri_msgs::msg::dds_::IdsList_/*", on_tracked)
        env = dict(os.environ, AVHEAR_BUS_PORT=str(_free_port()))
        env.pop("ROS_DOMAIN_ID", None)
        demo = subprocess.Popen([sys.executable, "-m", "app", "demo", "--headless", "--duration", "60",
                                 "--publish"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                cwd=ROOT, env=env)
        try:
            deadline = time.monotonic() + 90.0
            while True:
                with lock:
                    if len(tracked) >= 10:
                        break
                assert demo.poll() is None and time.monotonic() < deadline, demo.stderr.read()
                time.sleep(0.05)
        finally:
            demo.send_signal(signal.SIGTERM)
            demo.communicate(timeout=60)
    with lock:
        parts = [t.split("/") for t in tokens]
        messages = [decode(p, "hri_msgs/msg/IdsList") for p in tracked]
    assert [p[8] for p in parts if p[5] == "NN"] == ["avhear"]
    assert any(p[5] == "MP" and p[9] == "%humans%voices%tracked" for p in parts)
    assert all(m.header.frame_id == "avhear_rig" for m in messages) and any(m.ids for m in messages)


def test_a_voice_out_of_view_is_a_person_with_a_voice_only_on_its_ray() -> None:
    """A voice out of view (a person of the results without a position) is a voice tracked and speaking, and a
    person with that voice, no face and its location unknown (confidence 0, no person frame); the voice's frame lies
    1 m along its direction (x = sin azimuth, z = cos azimuth: 53 degrees to the left)."""
    heard = {"id": 2, "position_m": None, "speaking": True, "probability": None, "itd_mean_s": None,
             "azimuth_deg": -53.0, "elevation_deg": None}
    topics = Topics()
    topics.messages(RECORD)  # p0 and p3 seen a second before
    messages = topics.messages(dict(RECORD, stamp_s=13.25, people=RECORD["people"][:1] + [heard]))
    got: dict[str, list[bytes]] = {}
    for topic, _, payload in messages:
        got.setdefault(topic, []).append(payload)
    assert decode(got["humans/voices/tracked"][0], "hri_msgs/msg/IdsList").ids == ["v0", "v2"]
    assert decode(got["humans/voices/v2/is_speaking"][0], "std_msgs/msg/Bool").data is True
    assert decode(got["humans/persons/tracked"][0], "hri_msgs/msg/IdsList").ids == ["p0", "p2"]
    assert decode(got["humans/persons/known"][0], "hri_msgs/msg/IdsList").ids == ["p0", "p3", "p2"]
    assert decode(got["humans/persons/p2/voice_id"][0], "std_msgs/msg/String").data == "v2"
    assert decode(got["humans/persons/p2/location_confidence"][0], "std_msgs/msg/Float32").data == 0.0
    assert decode(got["humans/persons/p3/location_confidence"][0], "std_msgs/msg/Float32").data == pytest.approx(0.9)
    assert "humans/persons/p2/face_id" not in got and "humans/faces/f2/roi" not in got
    matches = [decode(p, "hri_msgs/msg/IdsMatch") for p in got["humans/candidate_matches"]]
    assert {(m.id1, m.id2) for m in matches if "2" in m.id1 + m.id2} == {("p2", "v2")}
    frames = {t.child_frame_id: t for t in decode(got["tf"][0], "tf2_msgs/msg/TFMessage").transforms}
    assert "person_p2" not in frames and "face_f2" not in frames
    v = frames["voice_v2"].transform.translation
    assert (v.x, v.y, v.z) == pytest.approx((-0.7986, 0.0, 0.6018), abs=1e-4)


def test_nodes_of_one_session_share_rmw_zenohs_counter_and_declare_each_node_once() -> None:
    """rmw_zenoh numbers a context's entities with one counter from 0, nodes and endpoints alike, and a node's token
    carries its id twice; avhear's parts that share a session and a node name are one node with one token
    (ros2/rmw_zenoh rmw_context_impl_s.cpp ``get_next_entity_id``, liveliness_utils.cpp ``Entity::Entity``)."""
    import zenoh

    from app.bus.ros2 import Convention, RosNode

    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{_free_port()}"]))
    convention = Convention(domain=3, namespace="twice")
    with zenoh.open(config) as session:
        first, second = RosNode(session, convention), RosNode(session, convention)  # e.g. the source and the sink
        sensors = RosNode(session, convention, name="avhear_sensors")
        endpoints = [first.publisher("humans/voices/tracked", "hri_msgs/msg/IdsList"),
                     second.publisher("humans/faces/tracked", "hri_msgs/msg/IdsList"),
                     second.subscriber("audio/audio_info", "audio_common_msgs/msg/AudioInfo", lambda s: None),
                     sensors.publisher("camera/camera/color/image_raw", "sensor_msgs/msg/Image")]
        tokens = [str(r.ok.key_expr) for r in session.liveliness().get("@ros2_lv/3/**", timeout=5.0) if r.ok]
        parts = [t.split("/") for t in tokens]
        nodes = {p[8]: p for p in parts if p[5] == "NN"}
        assert sorted(p[8] for p in parts if p[5] == "NN") == ["avhear", "avhear_sensors"]  # one token a node
        assert all(p[3] == p[4] for p in nodes.values())  # a node's token: its id twice
        assert len({int(p[4]) for p in parts}) == len(parts) == 6  # one counter: no id used twice
        assert sorted(int(p[4]) for p in parts) == list(range(6))  # from 0, nodes and endpoints alike
        for p in parts:
            assert p[3] == nodes[p[8]][3]  # each endpoint under its own node's id
        first.close()  # the node stays while another part uses it
        still = [str(r.ok.key_expr) for r in session.liveliness().get("@ros2_lv/3/**", timeout=5.0) if r.ok]
        assert sum(t.split("/")[5] == "NN" for t in still) == 2
        for e in endpoints:
            e.undeclare()
        second.close()
        sensors.close()
        time.sleep(0.2)
        gone = [str(r.ok.key_expr) for r in session.liveliness().get("@ros2_lv/3/**", timeout=5.0) if r.ok]
        assert gone == []


def test_a_publishers_gid_is_xxh3_128_of_its_token_low_half_first() -> None:
    """rmw_zenoh's GID: XXH3-128 of the token key, low 64 bits then high 64, each little-endian (liveliness_utils.cpp
    memcpy's the hash struct's two halves). XXH3-128 of the empty input is 99aa06d3014798d8 6001c324468d497f (high,
    low; xxHash's own test vector)."""
    from app.bus.ros2 import entity_gid

    assert entity_gid("") == bytes.fromhex("7f498d4624c30160d8984701d306aa99")
    assert len(entity_gid("@ros2_lv/0/abc/0/1/MP/%/%/avhear")) == 16
