"""SIGTERM and Ctrl-C on the commands that write (`simulate`, `record`, `run`): the folder or file is kept, ends at a
complete frame, replays, and the command says so and exits 130."""
from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from app.cli import main
from app.config import RigConfig, save_rig
from app.sources.recording import open_recording
from avcore.stereo import StereoRig

RIG = StereoRig.ideal(focal_px=100.0, image_size=(64, 48), baseline_m=0.12)


def _start(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "app", *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, cwd=Path(__file__).resolve().parents[2])


def _wait_for_rows(path: Path, rows: int, proc: subprocess.Popen, timeout_s: float = 120.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline and proc.poll() is None:
        if path.exists() and len(path.read_text().splitlines()) > rows:
            return
        time.sleep(0.05)
    proc.kill()
    raise AssertionError(f"{path} never reached {rows} rows: {proc.communicate()}")


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_stopped_simulate_leaves_a_recording_that_replays(tmp_path: Path, sig: int) -> None:
    out = tmp_path / "s2"
    proc = _start("simulate", "S2", "-o", str(out), "--duration", "16")
    _wait_for_rows(out / "frames.csv", 20, proc)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    info = json.loads((out / "recording.json").read_text())
    assert 20 <= info["n_frames"] < 480
    assert f"kept {info['n_frames']} of 480 frames in {out}" in stderr
    rec = open_recording(out)
    assert rec.n_frames == info["n_frames"] == len((out / "frames.csv").read_text().splitlines()) - 1
    stats = tmp_path / "stats.json"
    assert main(["run", "--source", f"replay:{out}", "--fast", "--headless", "--stats-json", str(stats)]) == 0
    assert json.loads(stats.read_text())["results"] == info["n_frames"]


def test_sigterm_during_a_run_keeps_the_results_and_exits_130(tmp_path: Path) -> None:
    results = tmp_path / "r.jsonl"
    proc = _start("demo", "--headless", "--duration", "60", "--results-jsonl", str(results))
    _wait_for_rows(results, 10, proc)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr and "interrupted" in stderr
    rows = [json.loads(line) for line in results.read_text().splitlines()]
    assert len(rows) > 10


def test_ctrl_c_to_the_terminals_group_keeps_every_voice_to_the_end(tmp_path: Path) -> None:
    """Ctrl-C in a terminal reaches the whole process group, the ITDs' and the voices' processes too
    (app/child_process.py): they keep going until the run ends them, and each person's WAV reaches the end of the
    sound the run took, as voices.json says."""
    out, results = tmp_path / "voices", tmp_path / "r.jsonl"
    proc = subprocess.Popen([sys.executable, "-m", "app", "run", "--source", "sim:S5", "--duration", "30",
                             "--headless", "--voices-dir", str(out), "--results-jsonl", str(results)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            cwd=Path(__file__).resolve().parents[2], start_new_session=True)
    _wait_for_rows(results, 20, proc)
    os.killpg(proc.pid, signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    rows = [json.loads(line) for line in results.read_text().splitlines()]
    # the people in each of the last 30 results (a busy machine may miss a face in a frame, or renumber a person)
    there = set.intersection(*({p["id"] for p in row["people"]} for row in rows[-30:]))
    index = {v["person_id"]: v for v in json.loads((out / "voices.json").read_text())["voices"]}
    assert there and there <= set(index)
    for pid in there:  # their streams go past the last result (the audio runs ahead of the results)
        assert index[pid]["end_s"] > rows[-1]["stamp_s"]  # (a busy machine may cost a stream a gap, counted there)


def test_sigterm_on_record_keeps_the_recording(tmp_path: Path, rig_file: Path, make_video,  # noqa: ANN001
                                               fake_sounddevice, paced_cameras,  # noqa: ANN001
                                               capsys: pytest.CaptureFixture[str]) -> None:
    """SIGTERM a second into a recording of cameras that would deliver 10 s (30 frames a second)."""
    fake_sounddevice.InputStream.n_blocks = 100_000
    left, right = make_video(tmp_path / "l.avi", 300, 64, 60), make_video(tmp_path / "r.avi", 300, 64, 200)
    out = tmp_path / "rec"
    before = signal.getsignal(signal.SIGTERM)
    timer = threading.Timer(1.0, os.kill, (os.getpid(), signal.SIGTERM))
    timer.start()
    code = main(["record", "-o", str(out), "--rig", str(rig_file), "--cameras", str(left), str(right)])
    timer.join()
    assert code == 130
    assert signal.getsignal(signal.SIGTERM) is before  # the handler is put back
    info = json.loads((out / "recording.json").read_text())
    assert info["n_frames"] > 0
    assert f"kept {info['n_frames']} frames in {out}" in capsys.readouterr().err
    assert open_recording(out).n_frames == info["n_frames"]


def test_a_failed_record_leaves_no_folder(tmp_path: Path, rig_file: Path, fake_sounddevice,  # noqa: ANN001
                                          capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "rec"
    code = main(["record", "-o", str(out), "--rig", str(rig_file), "--cameras", str(tmp_path / "nope0"),
                 str(tmp_path / "nope1")])
    assert code == 2
    err = capsys.readouterr().err
    assert "nothing recorded" in err and "cannot open camera" in err and "Traceback" not in err
    assert not out.exists()


def test_a_rig_without_microphones_says_how_to_add_them(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "rig.yaml"
    save_rig(path, RigConfig(RIG, None))
    assert main(["record", "-o", str(tmp_path / "x"), "--rig", str(path)]) == 2
    err = capsys.readouterr().err
    assert "no 'microphones' section" in err and "left_m:" in err and "right_m:" in err
    assert not (tmp_path / "x").exists()


def test_ctrl_c_keeps_the_consoles_recording_to_the_last_result(tmp_path: Path) -> None:
    """The console's recording lives in a process of its own (app/console/process.py), which the terminal's Ctrl-C
    reaches too: it ignores it, and the run has it log what was queued and close the file. The .rrd holds the run's
    last result and opens."""
    from rerun.chunk import RrdReader

    rrd, results = tmp_path / "run.rrd", tmp_path / "r.jsonl"
    proc = subprocess.Popen([sys.executable, "-m", "app", "run", "--source", "sim:S1", "--duration", "60", "--save",
                             str(rrd), "--results-jsonl", str(results)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, cwd=Path(__file__).resolve().parents[2],
                            start_new_session=True)
    _wait_for_rows(results, 20, proc)
    os.killpg(proc.pid, signal.SIGINT)
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 130, stderr
    assert "Traceback" not in stderr
    last = json.loads(results.read_text().splitlines()[-1])["index"]
    frames = set()
    for chunk in RrdReader(rrd).stream().to_chunks():
        if chunk.entity_path == "/scene/cameras/left/faces":
            batch = chunk.to_record_batch()
            frames.update(batch.column("frame").to_pylist())
    assert last in frames and len(frames) >= 20, (last, sorted(frames)[-5:])
