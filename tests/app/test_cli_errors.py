"""A user's mistake on the command line: one line that names the problem, exit status 2, no traceback, and nothing
done (or half done) before the mistake is found. Each case is one that used to crash or hang."""
from __future__ import annotations

import socket
import subprocess
import threading
import time
import sys
from pathlib import Path

import pytest

from app.cli import main

ROOT = Path(__file__).resolve().parents[2]


def _cli(*args: str, timeout_s: float = 120.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "app", *args], capture_output=True, text=True, cwd=ROOT,
                          timeout=timeout_s)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_connect_with_no_viewer_is_an_error_before_the_run() -> None:
    url = f"rerun+http://127.0.0.1:{_free_port()}/proxy"
    done = _cli("demo", "--connect", url, "--duration", "1", "--fast", timeout_s=60)
    assert done.returncode == 2
    assert f"no Rerun viewer at {url}: start one with `rerun`, or use --save" in done.stderr
    assert "Traceback" not in done.stderr and "running" not in done.stderr


def test_a_port_that_does_not_speak_grpc_is_no_viewer() -> None:
    with socket.socket() as server:  # accepts connections (the kernel's backlog) but never answers
        server.bind(("127.0.0.1", 0))
        server.listen(8)
        url = f"rerun+http://127.0.0.1:{server.getsockname()[1]}/proxy"
        done = _cli("demo", "--connect", url, "--duration", "1", "--fast", timeout_s=60)
    assert done.returncode == 2
    assert "does not answer as a viewer" in done.stderr and "Traceback" not in done.stderr


def test_a_viewer_that_stops_answering_cannot_hang_the_exit() -> None:
    """A server that answers the gRPC handshake's first frame, then reads nothing more, as a viewer that froze:
    the command ends within its bounded waits, with a warning or an error, never a hang."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held: list[socket.socket] = []

    def answer_once(conn: socket.socket) -> None:
        try:
            conn.settimeout(5.0)
            if conn.recv(64):  # the client's preface
                conn.sendall(bytes(3) + b"\x04" + bytes(5))  # an empty SETTINGS frame, then silence
        except OSError:
            pass

    def frozen_viewer() -> None:
        server.settimeout(0.2)
        end = time.monotonic() + 60
        while time.monotonic() < end:
            try:
                conn, _ = server.accept()
            except OSError:
                if server.fileno() == -1:
                    return
                continue
            held.append(conn)
            threading.Thread(target=answer_once, args=(conn,), daemon=True).start()

    worker = threading.Thread(target=frozen_viewer, daemon=True)
    worker.start()
    url = f"rerun+http://127.0.0.1:{server.getsockname()[1]}/proxy"
    try:
        done = _cli("demo", "--connect", url, "--duration", "1", "--fast", timeout_s=90)
    finally:
        server.close()
        for conn in held:
            conn.close()
    assert done.returncode in (0, 2), done.stderr
    assert "Traceback" not in done.stderr
    assert ("the viewer did not take the last data" in done.stderr
            or "did not take the connection" in done.stderr), done.stderr[-500:]


@pytest.mark.parametrize("argv, option", [
    (["demo", "--duration", "-1"], "--duration"),
    (["demo", "--duration", "0"], "--duration"),
    (["demo", "--duration", "100000"], "--duration"),
    (["run", "--source", "sim:S2", "--duration", "-1"], "--duration"),
    (["run", "--itd-method", "gcc-phta"], "--itd-method"),
    (["demo", "--scenario", "S9"], "--scenario"),
    (["demo", "--grpc-port", "70000"], "--grpc-port"),
    (["run", "--seed", "-3"], "--seed"),
    (["run", "--mic-channels", "0", "-1"], "--mic-channels"),
    (["simulate", "S2", "-o", "x", "--duration", "nan"], "--duration"),
    (["record", "-o", "x", "--rig", "r.yaml", "--fps", "0"], "--fps"),
    (["eval", "scenarios", "--vote-frames", "0"], "--vote-frames"),
    (["calibrate", "signal", "-o", "x.wav", "--seed", "-1"], "--seed"),
    (["demo", "--mics", "nao5"], "--mics"),
    (["eval", "scenarios", "--mics", "kinect"], "--mics"),
])
def test_out_of_range_options_are_refused_when_parsed(argv: list[str], option: str,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}" in err and "Traceback" not in err


@pytest.mark.parametrize(("flag", "message"), [
    (["--mics", "nao"], "--mics nao chooses the simulated room's microphones"),
    (["--bodies"], "--bodies chooses how the simulated room's people are drawn"),
    (["--no-bodies"], "--no-bodies chooses how the simulated room's people are drawn"),
])
def test_simulator_options_on_a_real_source_are_one_line(flag: list[str], message: str, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--source", f"replay:{tmp_path}", *flag, "--headless"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_sensors_refuse_simulated_microphones_on_a_real_source(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sensors", "--source", f"replay:{tmp_path}", "--mics", "nao"]) == 2
    err = capsys.readouterr().err
    assert "--mics nao chooses the simulated room's microphones" in err and "Traceback" not in err


def test_a_simulated_run_longer_than_the_simulator_allows(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--source", "sim:S2", "--duration", "5000", "--headless"]) == 2
    assert "at most 1800 s" in capsys.readouterr().err


@pytest.mark.parametrize("flag, path, message", [
    ("--save", "/proc/x.rrd", "cannot write --save /proc/x.rrd"),
    ("--stats-json", "{blocker}/stats.json", "is a file, not a folder"),
    ("--results-jsonl", "{blocker}/r.jsonl", "results file"),
])
def test_unwritable_outputs_fail_before_the_run(tmp_path: Path, flag: str, path: str, message: str,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    extra = [] if flag == "--save" else ["--headless"]
    assert main(["demo", "--duration", "1", "--fast", flag, path.format(blocker=blocker), *extra]) == 2
    captured = capsys.readouterr()
    assert message in captured.err and "Traceback" not in captured.err
    assert "preparing" not in captured.err and "results in" not in captured.out  # before any work


def test_calibrate_outputs_are_checked_before_the_work(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["calibrate", "stereo", "--left", str(tmp_path / "l*.jpg"), "--right", str(tmp_path / "r*.jpg"),
                 "--pattern", "9x6", "--square", "0.025", "-o", "/proc/rig.yaml"]) == 2
    assert "cannot write -o /proc/rig.yaml" in capsys.readouterr().err  # before looking for the pictures
    assert main(["calibrate", "signal", "-o", "/proc/c.wav"]) == 2
    err = capsys.readouterr().err
    assert "cannot write -o /proc/c.wav" in err and "Exception ignored" not in err


def test_eval_timeline_folder_that_is_a_file(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert main(["eval", "scenarios", "--timeline", str(blocker), "--scenario", "S1"]) == 2
    assert "--timeline" in capsys.readouterr().err


def test_ctrl_c_while_the_commands_load(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    import app.cli

    def interrupted(name: str) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(app.cli.importlib, "import_module", interrupted)
    assert main(["demo"]) == 130
    assert capsys.readouterr().err.strip() == "avhear: interrupted"


def test_opencv_warnings_stay_out_of_the_output(tmp_path: Path) -> None:
    rig = tmp_path / "rig.yaml"
    from app.config import RigConfig, save_rig
    from avcore.geometry import MicPair
    from avcore.stereo import StereoRig

    save_rig(rig, RigConfig(StereoRig.ideal(focal_px=100.0, image_size=(64, 48), baseline_m=0.12), MicPair()))
    done = _cli("run", "--source", "live", "--rig", str(rig), "--cameras", str(tmp_path / "cam0"),
                str(tmp_path / "cam1"), "--headless", "--duration", "5", timeout_s=60)
    assert done.returncode == 2
    assert "WARN" not in done.stderr and "Traceback" not in done.stderr
    assert [line for line in done.stderr.splitlines() if line.startswith("avhear: error:")]


def test_the_demo_says_when_it_falls_back_to_drawn_faces(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("AVHEAR_DATA", str(tmp_path / "no-data"))
    assert main(["demo", "--duration", "1", "--fast", "--headless"]) == 0
    assert "no ../shared/data here: the simulated room uses drawn faces" in capsys.readouterr().err


def test_demo_help_gives_the_real_default_duration(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    assert "default 20" in " ".join(capsys.readouterr().out.split())


def test_a_bad_method_combination_is_refused_before_the_preparation(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--vote-frames", "4", "--headless"]) == 2
    err = capsys.readouterr().err
    assert "vote_frames must be an odd number" in err and "preparing" not in err
