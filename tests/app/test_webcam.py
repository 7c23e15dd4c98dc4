"""One webcam and a laptop's microphones with no calibration session: the real live path with a video file as the
camera (no camera on CI), and `avhear devices`."""
from __future__ import annotations

import threading
from pathlib import Path

import cv2
import numpy as np
import pytest

from app.cli import main
from app.sources.live import LiveConfig, webcam_rig
from app.sources.open import webcam
from app.sources.sim import SimSource
from avcore.mono import locate_faces_mono


def test_a_field_of_view_gives_the_intrinsics() -> None:
    """f = (w / 2) / tan(fov / 2): 90 degrees across 640 px is 320 px; the principal point at the centre."""
    rig = webcam_rig((640, 480), 90.0)
    assert rig.image_size == (640, 480)
    np.testing.assert_allclose(rig.camera_matrix_left, [[320.0, 0, 319.5], [0, 320.0, 239.5], [0, 0, 1]])
    with pytest.raises(ValueError, match="between 10 and 170"):
        webcam_rig((640, 480), 5.0)


def _scene_video(tmp_path: Path) -> tuple[Path, SimSource]:
    """The simulated room's left camera (S3: three people 1.6-2.6 m away), 1 s at 10 FPS, as an MJPG file."""
    source = SimSource.from_preset("S3", duration_s=1.0, seed=1, fps=10, data_dir=tmp_path / "none", camera="mono")
    path = tmp_path / "webcam.avi"
    w, h = source.stereo.image_size
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 10.0, (w, h))
    for frame in source.frames(realtime=False):
        writer.write(frame.left)
    writer.release()
    return path, source


def test_a_webcam_without_calibration_places_the_faces(tmp_path: Path, face_finder) -> None:  # noqa: ANN001
    """The simulated camera (60 degrees across 640 px) read as a webcam: its intrinsics from the image size and the
    field of view match the rig's within a pixel, the laptop's two microphones are 10 cm apart either side of the
    camera, and the faces of its frames lie along their true directions at depths within 25 % (drawn faces here,
    whose boxes are wider than a real face's: tests/avcore/test_mono.py measures real ones)."""
    video, sim = _scene_video(tmp_path)
    fov = float(np.degrees(2 * np.arctan(320.0 / sim.stereo.focal_px)))
    source = webcam(LiveConfig(left=str(video), right=None, max_failed_reads=2), fov_deg=fov)
    assert source.rig.image_size == (640, 480) and source.rig.focal_px == pytest.approx(sim.stereo.focal_px, abs=1.0)
    assert source.array is None and source.mics.left == (-0.05, 0.0, 0.0) and source.mics.right == (0.05, 0.0, 0.0)
    errors = []
    frames = source.frames(threading.Event())
    for k in range(10):
        frame = next(frames)
        assert frame.right is None and frame.depth_m is None
        found = locate_faces_mono(frame.left, source.rig, detector=face_finder)
        truth = sim.truth(k)
        for true in truth.positions_m[truth.visible]:
            true_cam = true + np.array([sim.stereo.baseline_m / 2, 0.0, 0.0])  # the webcam's frame is the camera's
            near = found.points[np.argmin(np.linalg.norm(found.points[:, :2] - true_cam[:2], axis=1))]
            errors.append(abs(near[2] - true_cam[2]) / true_cam[2])
            cos = near @ true_cam / np.linalg.norm(near) / np.linalg.norm(true_cam)
            assert np.degrees(np.arccos(min(cos, 1.0))) < 2.0
    assert len(errors) >= 20 and np.median(errors) < 0.25


def test_a_webcams_microphones_from_an_option(tmp_path: Path, make_video) -> None:  # noqa: ANN001
    video = make_video(tmp_path / "cam.avi", 3, 64, 90)
    source = webcam(LiveConfig(left=str(video), right=None), mic_spacing_m=0.2)
    assert source.mics.left == (-0.1, 0.0, 0.0) and source.rig.image_size == (64, 48)
    nao = webcam(LiveConfig(left=str(video), right=None, n_channels=4), mics="nao")
    assert nao.array is not None and nao.array.n_pairs == 6


@pytest.mark.parametrize(("argv", "message"), [
    (["--cameras", "/nonexistent/cam.avi"], "cannot read camera '/nonexistent/cam.avi'"),
    (["--motion"], "--motion (Algorithm 1) needs depth"),
    (["--side-by-side"], "--side-by-side is a stereo camera's"),
    (["--mics", "nao", "--mic-spacing", "0.1"], "--mic-spacing sets the laptop's two microphones apart"),
])
def test_a_webcams_mistakes_are_one_line(argv: list[str], message: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--source", "webcam", "--headless", *argv]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_the_devices_are_listed(monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """`avhear devices` on a machine without a camera, with two audio inputs (a stand-in for PortAudio's list)."""
    import types

    import app.commands.devices as devices

    fake = types.SimpleNamespace(
        default=types.SimpleNamespace(device=[2, 0]),
        query_devices=lambda: [{"name": "HDMI out", "max_input_channels": 0, "default_samplerate": 48000.0},
                               {"name": "USB array", "max_input_channels": 6, "default_samplerate": 16000.0},
                               {"name": "Laptop mic", "max_input_channels": 2, "default_samplerate": 48000.0}])
    monkeypatch.setattr(devices, "load_sounddevice", lambda: fake)
    monkeypatch.setattr(devices, "camera_indices", lambda n: [])
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    assert "none found" in out and "1: USB array: 6 channels, 16000 Hz" in out
    assert "2: Laptop mic: 2 channels, 48000 Hz  (default)" in out and "HDMI" not in out


def test_the_sensors_command_refuses_one_camera(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`avhear sensors` publishes a stereo pair (or an RGB-D camera): a webcam or a one-camera recording is one line."""
    from app.sources.recording import write_recording

    assert main(["sensors", "--source", "webcam"]) == 2
    assert "a webcam's one camera goes with avhear run --source webcam" in capsys.readouterr().err
    folder = write_recording(tmp_path / "mono", SimSource.from_preset("S1", duration_s=1.0, fps=5,
                                                                      data_dir=tmp_path / "none", camera="mono"))
    assert main(["sensors", "--source", f"replay:{folder}", "--bus-listen", "tcp/127.0.0.1:0"]) == 2
    err = capsys.readouterr().err
    assert "has one camera" in err and "Traceback" not in err
