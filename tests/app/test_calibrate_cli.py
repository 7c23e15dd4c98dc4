"""Tests of `avhear calibrate stereo`: on the real chessboard pairs and on bad input."""
from __future__ import annotations

import argparse
import shutil

import cv2
import numpy as np
import pytest

from app.commands import calibrate
from app.config import RigConfig, load_rig, save_rig
from app.errors import UserError
from avcore.geometry import MicPair


def _run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="avhear")
    calibrate.add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(argv)
    return args.func(args)


def _stereo(tmp_path, left: str, right: str, *extra: str) -> list[str]:
    return ["calibrate", "stereo", "--left", left, "--right", right, "--pattern", "9x6", "--square", "0.025",
            "-o", str(tmp_path / "rig.yaml"), *extra]


def _copy_pairs(shared_data, tmp_path, names):
    src = shared_data / "stereo-chessboard"
    for n in names:
        for side in ("left", "right"):
            shutil.copy(src / f"{side}{n}.jpg", tmp_path / f"{side}{n}.jpg")


@pytest.mark.shared_data
def test_calibrates_the_real_pairs_and_keeps_microphones(shared_data, tmp_path, capsys):
    src = shared_data / "stereo-chessboard"
    out = tmp_path / "rig.yaml"
    mics = MicPair(left=(-0.1, 0.0, 0.0), right=(0.1, 0.0, 0.0), c1=1.2)
    save_rig(out, RigConfig(microphones=mics))
    status = _run(_stereo(tmp_path, str(src / "left*.jpg"), str(src / "right*.jpg")))
    assert status == 0
    text = capsys.readouterr().out
    assert "left14.jpg / right14.jpg" in text and "stereo        rms" in text
    rig = load_rig(out)
    assert rig.microphones == mics
    assert rig.stereo.baseline_m == pytest.approx(3.33 * 0.025, rel=0.05)
    corners = cv2.imread(str(tmp_path / "rig_corners.png"))
    assert corners is not None and corners.shape[0] > 240


@pytest.mark.shared_data
def test_wrong_pattern_says_what_to_check(shared_data, tmp_path):
    src = shared_data / "stereo-chessboard"
    argv = _stereo(tmp_path, str(src / "left0[1-3].jpg"), str(src / "right0[1-3].jpg"))
    argv[argv.index("9x6")] = "7x5"
    with pytest.raises(UserError, match="check --pattern"):
        _run(argv)


@pytest.mark.shared_data
def test_too_few_views(shared_data, tmp_path):
    _copy_pairs(shared_data, tmp_path, ["01", "02"])
    with pytest.raises(UserError, match="at least 3"):
        _run(_stereo(tmp_path, str(tmp_path / "left*.jpg"), str(tmp_path / "right*.jpg")))


@pytest.mark.shared_data
def test_corrupt_image_is_named(shared_data, tmp_path):
    _copy_pairs(shared_data, tmp_path, ["01", "02", "03"])
    (tmp_path / "right02.jpg").write_bytes(b"not a jpeg")
    with pytest.raises(UserError, match="right02.jpg: cannot read"):
        _run(_stereo(tmp_path, str(tmp_path / "left*.jpg"), str(tmp_path / "right*.jpg")))


def test_missing_and_unpaired_pictures(tmp_path):
    with pytest.raises(UserError, match="matches no file"):
        _run(_stereo(tmp_path, str(tmp_path / "left*.jpg"), str(tmp_path / "right*.jpg")))
    blank = np.full((48, 64), 200, np.uint8)
    for name in ("left1.png", "left2.png", "right1.png"):
        cv2.imwrite(str(tmp_path / name), blank)
    with pytest.raises(UserError, match="pairs"):
        _run(_stereo(tmp_path, str(tmp_path / "left*.png"), str(tmp_path / "right*.png")))


def test_pictures_without_a_board(tmp_path):
    blank = np.full((48, 64), 200, np.uint8)
    for name in ("left1.png", "right1.png", "left2.png", "right2.png", "left3.png", "right3.png"):
        cv2.imwrite(str(tmp_path / name), blank)
    with pytest.raises(UserError, match="no chessboard"):
        _run(_stereo(tmp_path, str(tmp_path / "left*.png"), str(tmp_path / "right*.png")))


def test_bad_option_values_are_rejected_by_the_parser(tmp_path, capsys):
    for bad in (["--pattern", "9by6"], ["--square", "-1"]):
        argv = _stereo(tmp_path, "l*.jpg", "r*.jpg")
        i = argv.index(bad[0])
        argv[i + 1] = bad[1]
        with pytest.raises(SystemExit):
            _run(argv)
    assert "COLSxROWS" in capsys.readouterr().err


@pytest.mark.shared_data
def test_a_mismatched_pair_is_flagged(shared_data, tmp_path, capsys):
    """Pair 07 gets the right picture of pair 01: its reprojection error stands out and is flagged."""
    _copy_pairs(shared_data, tmp_path, ["01", "02", "03", "04", "05", "06"])
    src = shared_data / "stereo-chessboard"
    shutil.copy(src / "left07.jpg", tmp_path / "left07.jpg")
    shutil.copy(src / "right01.jpg", tmp_path / "right07.jpg")
    assert _run(_stereo(tmp_path, str(tmp_path / "left*.jpg"), str(tmp_path / "right*.jpg"))) == 0
    lines = capsys.readouterr().out.splitlines()
    flagged = [line for line in lines if "bad view" in line]
    assert len(flagged) >= 1 and any(line.startswith("left07.jpg") for line in flagged), lines


def test_signal_writes_the_loudspeaker_wav(tmp_path, capsys):
    import wave

    out = tmp_path / "calibration.wav"
    assert _run(["calibrate", "signal", "-o", str(out), "--duration", "2", "--samplerate", "16000"]) == 0
    with wave.open(str(out)) as f:
        assert (f.getnchannels(), f.getsampwidth(), f.getframerate(), f.getnframes()) == (1, 2, 16000, 32000)
        pcm = np.frombuffer(f.readframes(32000), dtype="<i2")
    assert 0.25 < np.mean(pcm != 0) < 0.35  # 150 ms of noise every 0.5 s
    assert "150 ms bursts" in capsys.readouterr().out
    with pytest.raises(UserError, match="wav"):
        _run(["calibrate", "signal", "-o", str(tmp_path / "x.mp3")])
    assert _run(["calibrate", "signal", "-o", str(tmp_path / "missing" / "x.wav"), "--duration", "1"]) == 0
    assert (tmp_path / "missing" / "x.wav").stat().st_size > 0  # parent folders are created, as by every command
    with pytest.raises(UserError, match="cannot write -o /proc/x.wav"):
        _run(["calibrate", "signal", "-o", "/proc/x.wav"])
    with pytest.raises(SystemExit):
        _run(["calibrate", "signal", "-o", str(out), "--samplerate", "0"])
    assert "--samplerate" in capsys.readouterr().err
