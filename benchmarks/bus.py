"""The bus on loopback: VGA stereo at 30 FPS and 16 kHz audio from `avhear sensors` to `avhear run --source bus`,
against the same pipeline in one process.

    python benchmarks/bus.py                   # 60 s of the simulated room S2
    python benchmarks/bus.py --duration 30
    python benchmarks/bus.py --ros             # an RGB-D camera and a 4-microphone array as ROS 2 drivers publish
                                               # them (avhear sensors --ros, avhear run --source ros), rmw_zenoh keys
    python benchmarks/bus.py --scenario S5 --read-lips   # moving mouths, the face mesh on every face

Three real processes for the bus (sensors, run, nothing else) and one for the reference (`avhear run --source
sim:S2` in real time). Printed: frames published and fused (lost = published - fused - the source's own late
frames), results per second, latency from capture stamp to result (p50, p95; both sides share the machine's
monotonic clock, so the bus's share is the difference from one process), megabytes per second on the bus, and the
CPU time of each process (user + system, as a share of one core over the run).
"""
from __future__ import annotations

import argparse
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _start(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "app", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=ROOT)


def _finish(proc: subprocess.Popen) -> tuple[str, float, float]:
    """stdout, CPU seconds (user + system) and wall seconds of a child, read with wait4."""
    start = getattr(proc, "started", time.monotonic())
    _, status, usage = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    out = proc.stdout.read() if proc.stdout else ""
    if proc.returncode != 0:
        raise SystemExit(f"{proc.args} failed: {proc.stderr.read() if proc.stderr else ''}")
    return out, usage.ru_utime + usage.ru_stime, time.monotonic() - start


def _cpu_s(pid: int) -> float:
    """CPU seconds (user + system) a running child has used so far (Linux's /proc)."""
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _wait_for(proc: subprocess.Popen, word: str) -> None:
    """Read the child's standard error until a line with ``word``; a child that ends first is a failure."""
    assert proc.stderr is not None
    seen = []
    for line in proc.stderr:
        if word in line:
            return
        seen.append(line)
    proc.wait()
    raise SystemExit(f"{proc.args} ended before it said {word!r}: {''.join(seen[-5:])}")


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--duration", type=float, default=60.0)
    p.add_argument("--scenario", default="S2")
    p.add_argument("--ros", action="store_true", help="RGB-D and ReSpeaker 4-mic array as ROS 2 driver topics")
    p.add_argument("--read-lips", action="store_true",
                   help="the simulated mouths move and the face mesh reads every face (--lips, --read-lips)")
    args = p.parse_args()
    d = args.duration
    lips = ("--lips",) if args.read_lips else ()
    read = ("--read-lips",) if args.read_lips else ("--no-read-lips",)  # the figures before the default
    sim = ("--camera", "rgbd", "--mics", "respeaker4", *lips) if args.ros else lips
    robot_side = ("--ros", "--mics", "respeaker4", *lips) if args.ros else lips
    laptop = ("run", "--source", "ros", *read) if args.ros else ("run", "--source", "bus", *read)
    with tempfile.TemporaryDirectory() as tmp:
        one = Path(tmp) / "one.json"
        ref = _start("run", "--source", f"sim:{args.scenario}", "--duration", str(d), "--headless",
                     "--stats-json", str(one), *sim, *read)
        ref.started = time.monotonic()
        _, ref_cpu, ref_wall = _finish(ref)
        robot = _free_port()
        stats = Path(tmp) / "bus.json"
        sensors = _start("sensors", "--source", f"sim:{args.scenario}", "--duration", str(d + 8),
                         "--bus-listen", f"tcp/127.0.0.1:{robot}", *robot_side)
        _wait_for(sensors, "publishing")  # the simulated room is prepared (minutes for a long one) before it publishes
        sensors.started, prepared_cpu = time.monotonic(), _cpu_s(sensors.pid)  # the publishing alone is measured
        run = _start(*laptop, "--headless", "--duration", str(d), "--stats-json", str(stats),
                     "--bus-connect", f"tcp/127.0.0.1:{robot}", "--bus-listen", f"tcp/127.0.0.1:{_free_port()}")
        run.started = time.monotonic()
        _, run_cpu, run_wall = _finish(run)
        sensors_out, sensors_cpu, sensors_wall = _finish(sensors)
        sensors_cpu -= prepared_cpu
        a, b = json.loads(one.read_text()), json.loads(stats.read_text())
    published = int(sensors_out.split("published ")[1].split(" ")[0])
    mb_s = float(sensors_out.split("(")[-1].split(" MB/s")[0])
    what = ("640x480 colour + 16UC1 depth at 30 FPS, 16 kHz 4-channel audio, ROS 2 driver topics" if args.ros
            else "640x480 stereo at 30 FPS, 16 kHz audio") + (", the lips read" if args.read_lips else "")
    print(f"\n{d:g} s of {args.scenario} ({what}), loopback")
    print(f"{'':34s} {'one process':>14s} {'over the bus':>14s}")
    rows = [
        ("results per second", a["fps"], b["fps"]),
        ("frames fused (30 FPS x duration)", f"{a['frames']} / {round(30 * d)}", f"{b['frames']} / {round(30 * d)}"),
        ("latency p50 (ms)", a["latency_ms_p50"], b["latency_ms_p50"]),
        ("latency p95 (ms)", a["latency_ms_p95"], b["latency_ms_p95"]),
        ("late frames skipped", a["late_frames"], b["late_frames"]),
        ("drops (all counters)", sum(a["drops"].values()), sum(b["drops"].values())),
        ("CPU, method side (% of a core)", round(100 * ref_cpu / ref_wall), round(100 * run_cpu / run_wall)),
        ("CPU, sensors side (% of a core)", "", round(100 * sensors_cpu / sensors_wall)),
    ]
    for name, x, y in rows:
        print(f"{name:34s} {str(x):>14s} {str(y):>14s}")
    lost = {k: v for k, v in b["drops"].items() if v}
    print(f"drops over the bus, by counter: {lost or 'none'}")
    print(f"bus: {published} frames published during the sensors' {d + 8:g} s, {mb_s:.2f} MB/s; "
          f"latency added by the bus at p95: {b['latency_ms_p95'] - a['latency_ms_p95']:+.1f} ms")
    return 0


if __name__ == "__main__":
    sys.exit(main())
