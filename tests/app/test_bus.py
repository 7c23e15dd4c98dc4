"""The bus: ROS4HRI messages in CDR through rosbags' own deserialiser, and `--publish` between real processes over
127.0.0.1 (a Zenoh subscriber in the test, avhear in a subprocess)."""
from __future__ import annotations

import json
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

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
    got = dict(Topics("robot1").messages(RECORD))
    voices = decode(got["robot1/humans/voices/tracked"], "hri_msgs/msg/IdsList")
    assert voices.ids == ["v0", "v3"] and voices.header.frame_id == "avhear_rig"
    assert (voices.header.stamp.sec, voices.header.stamp.nanosec) == (12, 250_000_000)
    assert decode(got["robot1/humans/voices/v0/is_speaking"], "std_msgs/msg/Bool").data is False
    assert decode(got["robot1/humans/voices/v3/is_speaking"], "std_msgs/msg/Bool").data is True
    assert decode(got["robot1/humans/faces/tracked"], "hri_msgs/msg/IdsList").ids == ["f0", "f3"]
    roi = decode(got["robot1/humans/faces/f3/roi"], "sensor_msgs/msg/RegionOfInterest")
    assert (roi.x_offset, roi.y_offset, roi.width, roi.height) == (410, 100, 30, 33)
    match = decode(got["robot1/humans/candidate_matches"], "hri_msgs/msg/IdsMatch")  # the last person's
    assert (match.id1, match.id1_type, match.id2, match.id2_type) == ("f3", FACE, "v3", VOICE) == ("f3", 2, "v3", 4)
    tf = decode(got["robot1/tf"], "tf2_msgs/msg/TFMessage")
    frames = {t.child_frame_id: t for t in tf.transforms}
    assert set(frames) == {"voice_v0", "voice_v3", "face_f0", "face_f3"}
    v = frames["voice_v3"].transform.translation
    assert (v.x, v.y, v.z) == (0.7, -0.1, 2.9) and frames["voice_v3"].header.frame_id == "avhear_rig"
    assert json.loads(got["robot1/avhear/results"]) == RECORD
    # CDR as ROS 2 sends it: the 4-byte encapsulation header, little-endian (CDR_LE = 0x0001)
    assert all(payload[:4] == b"\x00\x01\x00\x00" for key, payload in got.items() if not key.endswith("results"))


def test_motion_guided_results_have_voices_only() -> None:
    record = dict(RECORD, mode="motion", people=[{k: v for k, v in p.items() if k != "box_px"}
                                                 for p in RECORD["people"]])
    keys = [k for k, _ in Topics().messages(record)]
    assert "humans/voices/tracked" in keys and "tf" in keys
    assert not [k for k in keys if k.startswith("humans/faces") or k == "humans/candidate_matches"]


def test_an_undecodable_payload_is_a_value_error() -> None:
    with pytest.raises(ValueError, match="does not decode"):
        decode(b"\x00\x01\x00\x00\xff", "hri_msgs/msg/IdsList")


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_publish_between_two_processes() -> None:
    """The test listens on a loopback port; `avhear demo --publish` connects to it and publishes every result."""
    import zenoh

    port = _free_port()
    config = zenoh.Config()
    config.insert_json5("mode", '"peer"')
    config.insert_json5("scouting/multicast/enabled", "false")
    config.insert_json5("listen/endpoints", json.dumps([f"tcp/127.0.0.1:{port}"]))
    received: dict[str, list[bytes]] = {}
    lock = threading.Lock()

    def on_sample(sample: zenoh.Sample) -> None:
        with lock:
            received.setdefault(str(sample.key_expr), []).append(sample.payload.to_bytes())

    with zenoh.open(config) as session:
        session.declare_subscriber("lab/**", on_sample)
        done = subprocess.run(
            [sys.executable, "-m", "app", "demo", "--headless", "--duration", "2", "--fast", "--publish",
             "--bus-namespace", "lab", "--bus-connect", f"tcp/127.0.0.1:{port}",
             "--bus-listen", f"tcp/127.0.0.1:{_free_port()}"],
            capture_output=True, text=True, cwd=ROOT, timeout=120)

        def arrived(key: str) -> int:
            with lock:
                return len(received.get(key, []))

        # the last samples may still be in flight when the process ends: wait for them, not for a set time
        deadline = time.monotonic() + 30.0
        while min(arrived(f"lab/{k}") for k in ("avhear/results", "humans/voices/tracked", "tf")) < 60:
            assert time.monotonic() < deadline, {k: len(v) for k, v in received.items()}
            time.sleep(0.02)
    assert done.returncode == 0, done.stderr
    assert "60 results published on the bus (0 dropped" in done.stdout
    with lock:
        results = [json.loads(p) for p in received.get("lab/avhear/results", [])]
        tracked = [decode(p, "hri_msgs/msg/IdsList") for p in received.get("lab/humans/voices/tracked", [])]
        speaking = {k: [decode(p, "std_msgs/msg/Bool").data for p in v] for k, v in received.items()
                    if k.endswith("/is_speaking")}
        tf = [decode(p, "tf2_msgs/msg/TFMessage") for p in received.get("lab/tf", [])]
    assert len(results) == 60 and len(tracked) == 60 and len(tf) == 60
    assert [r["index"] for r in results] == sorted(r["index"] for r in results)
    ids = {p["id"] for r in results for p in r["people"]}
    assert {f"lab/humans/voices/v{i}/is_speaking" for i in ids} == set(speaking)
    assert any(any(v) for v in speaking.values())  # somebody speaks in S2's first two seconds
    assert all(len(t.transforms) == 2 * len(r["people"]) for t, r in zip(tf, results))


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
    publisher = ResultPublisher(session, queue_size=4)
    for k in range(40):
        publisher.publish(people_result(k / 30, [[0.1, 0.0, 2.0]], [True]))
    publisher.close(timeout_s=10)
    # a publish() that waited for the slow session would have lost nothing: dropping is the proof it did not wait
    assert publisher.dropped > 0 and publisher.published + publisher.dropped == 40
    assert session.sent.count("avhear/results") == publisher.published
