"""Device faults through the real live code path (video files as cameras, the patched PortAudio stream): the user
gets one line and status 2, no traceback, and what was written so far is kept."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from app.cli import main
from avcore.geometry import MicPair
from avcore.stereo import StereoRig

RIG = StereoRig.ideal(focal_px=100.0, image_size=(64, 48), baseline_m=0.12)


def _one_line_error(err: str, *needles: str) -> None:
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if line.startswith("avhear: error:")]
    assert len(errors) == 1, err
    assert all(n in errors[0] for n in needles), errors[0]


def test_no_camera(tmp_path: Path, rig_file: Path, fake_sounddevice, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    results = tmp_path / "r.jsonl"
    code = main(["run", "--source", "live", "--rig", str(rig_file), "--cameras", str(tmp_path / "no-cam-0"),
                 str(tmp_path / "no-cam-1"), "--headless", "--results-jsonl", str(results), "--duration", "5"])
    assert code == 2
    _one_line_error(capsys.readouterr().err, "cannot open camera")
    assert results.exists()


def test_camera_that_stops_mid_run(tmp_path: Path, rig_file: Path, make_video, fake_sounddevice,  # noqa: ANN001
                                   paced_cameras, capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    """Video files that end after 40 frames (at a camera's 30 frames a second) are cameras unplugged mid-run; the
    audio keeps coming."""
    fake_sounddevice.InputStream.n_blocks = 4000  # about 4 s of blocks: the audio outlasts the cameras' 1.3 s
    left, right = make_video(tmp_path / "l.avi", 40, 64, 60), make_video(tmp_path / "r.avi", 40, 64, 200)
    results, rrd = tmp_path / "r.jsonl", tmp_path / "run.rrd"
    code = main(["run", "--source", "live", "--rig", str(rig_file), "--cameras", str(left), str(right),
                 "--save", str(rrd), "--results-jsonl", str(results), "--duration", "30"])
    assert code == 2
    captured = capsys.readouterr()
    _one_line_error(captured.err, "camera stopped delivering")
    assert rrd.exists() and rrd.stat().st_size > 0  # the console's data so far is kept
    assert "results kept in" in captured.err
    lines = results.read_text().splitlines()
    assert len(lines) >= 10  # the results of the frames before the cameras stopped are kept ...
    assert all(isinstance(json.loads(line)["index"], int) for line in lines)  # ... each one whole


def test_audio_device_that_vanishes(fake_sounddevice) -> None:  # noqa: ANN001
    """The fake stream delivers 20 blocks and goes inactive, as an unplugged device: the audio iterator raises
    at once (the pipeline then stops and the command line prints the message, as for a camera)."""
    import threading

    from app.sources.live import LiveConfig, LiveSource
    from app.sound import DeviceError

    fake_sounddevice.InputStream.n_blocks = 20
    src = LiveSource(LiveConfig(left="a", right="b"), RIG, MicPair())
    got = []
    with pytest.raises(DeviceError, match="audio input .* stopped: was the device unplugged"):
        for block in src.audio(threading.Event()):
            got.append(block)
    assert len(got) == 20  # every block before the fault was delivered


def test_audio_stream_that_fails_to_open(tmp_path: Path, rig_file: Path, make_video, fake_sounddevice,  # noqa: ANN001
                                         capsys: pytest.CaptureFixture[str]) -> None:
    def broken(**kwargs: object) -> None:
        raise OSError("Error opening InputStream: Device unavailable [PaErrorCode -9985]")

    fake_sounddevice.InputStream = broken
    left, right = make_video(tmp_path / "l.avi", 300, 64, 60), make_video(tmp_path / "r.avi", 300, 64, 200)
    code = main(["run", "--source", "live", "--rig", str(rig_file), "--cameras", str(left), str(right),
                 "--headless", "--duration", "20", "--audio-device", "7"])
    assert code == 2
    _one_line_error(capsys.readouterr().err, "cannot open the audio input 7", "Device unavailable")


def test_no_portaudio(tmp_path: Path, rig_file: Path, make_video, monkeypatch: pytest.MonkeyPatch,
                      capsys: pytest.CaptureFixture[str]) -> None:  # noqa: ANN001
    import app.sources.live
    from app.sound import DeviceError

    def missing() -> None:
        raise DeviceError("sounddevice cannot load PortAudio (PortAudio library not found); install it")

    monkeypatch.setattr(app.sources.live, "load_sounddevice", missing)
    left, right = make_video(tmp_path / "l.avi", 300, 64, 60), make_video(tmp_path / "r.avi", 300, 64, 200)
    code = main(["run", "--source", "live", "--rig", str(rig_file), "--cameras", str(left), str(right),
                 "--headless", "--duration", "20"])
    assert code == 2
    _one_line_error(capsys.readouterr().err, "PortAudio")
