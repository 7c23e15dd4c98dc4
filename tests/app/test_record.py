"""`avhear record` through the real capture code: video files as the cameras, the patched PortAudio stream."""
from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from app.config import RigConfig, save_rig
from app.sources.recording import RecordingWriter, open_recording
from avcore.stereo import StereoRig

RIG = StereoRig.ideal(focal_px=100.0, image_size=(64, 48), baseline_m=0.12)


def test_record_then_replay(tmp_path: Path, rig_file: Path, make_video, fake_sounddevice,  # noqa: ANN001
                            capsys: pytest.CaptureFixture[str]) -> None:
    # the microphone stays open after its blocks, so that the video files' end is what stops the recording (a
    # stopped device is said after 0.3 s of silence, about when the cameras' 30 failed reads end: a race on a busy host)
    fake_sounddevice.InputStream.stays_open = True
    left = make_video(tmp_path / "l.avi", 12, 64, 40)
    right = make_video(tmp_path / "r.avi", 12, 64, 200)
    out = tmp_path / "rec"
    code = main(["record", "-o", str(out), "--rig", str(rig_file), "--cameras", str(left), str(right),
                 "--audio-channels", "4", "--mic-channels", "1", "3", "--duration", "5"])
    assert code == 0
    printed = capsys.readouterr()
    assert "written to" in printed.out
    assert "stopped delivering frames" in printed.err  # the video files end: reported, the data kept
    rec = open_recording(out)
    assert rec.n_frames >= 8
    assert rec.channels == {"left": 1, "right": 3}
    frames = list(rec.frames())
    assert frames[0].left.mean() < frames[0].right.mean()  # left and right kept apart
    blocks = list(rec.audio_blocks())
    samples = np.concatenate([b.samples for b in blocks])
    assert samples.shape[1] == 4 and samples.shape[0] > 0
    # the fake device's block k holds the value k / 1000: every block kept, in order, through 16-bit PCM
    size = blocks[0].samples.shape[0]
    n = samples.shape[0] // size
    assert n >= 10
    np.testing.assert_allclose(samples[: n * size: size, 0], np.arange(n) / 1000, atol=1 / 32768)


def test_record_needs_microphones(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "rig.yaml"
    save_rig(path, RigConfig(RIG, None))
    assert main(["record", "-o", str(tmp_path / "x"), "--rig", str(path)]) == 2
    assert "microphones" in capsys.readouterr().err


def test_a_recording_whose_audio_device_fails_is_an_error(tmp_path: Path, rig_file: Path, make_video,  # noqa: ANN001
                                                          fake_sounddevice, monkeypatch: pytest.MonkeyPatch,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    """The cameras work, the microphone does not open: the frames are kept, but the command says that the
    recording it was asked for has no audio and exits 2 (it used to say "kept 6 frames" and exit 0)."""
    written = threading.Event()
    add_frame = RecordingWriter.add_frame

    def add_and_count(self, frame) -> None:  # noqa: ANN001
        add_frame(self, frame)
        if self.n_frames >= 3:
            written.set()

    def no_device(**kwargs: object) -> None:  # the device fails once the cameras have delivered frames
        assert written.wait(30.0)
        raise RuntimeError("Error opening InputStream: Invalid number of channels [PaErrorCode -9998]")

    monkeypatch.setattr(RecordingWriter, "add_frame", add_and_count)
    fake_sounddevice.InputStream = no_device
    left = make_video(tmp_path / "l.avi", 12, 64, 40)
    right = make_video(tmp_path / "r.avi", 12, 64, 200)
    out = tmp_path / "rec"
    code = main(["record", "-o", str(out), "--rig", str(rig_file), "--cameras", str(left), str(right),
                 "--duration", "5"])
    err = capsys.readouterr().err
    assert code == 2, err
    assert "has no audio" in err and "Invalid number of channels" in err and "Traceback" not in err
    assert (out / "frames.csv").is_file()  # what the cameras gave is kept
