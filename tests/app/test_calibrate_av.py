"""Tests of `avhear calibrate av` (paper section 5.3) on a short simulated calibration recording, and its errors."""
from __future__ import annotations

import argparse
import re
import shutil
import wave

import cv2
import numpy as np
import pytest

from app.av_calibration import FaceTrack, pair_faces_with_itds
from app.cli import main
from app.commands import calibrate
from app.config import RigConfig, load_rig, save_rig
from app.errors import UserError
from app.sources.recording import RecordingWriter, open_recording, write_recording
from app.events import AudioBlock, StereoFrame
from app.sources.sim import SimSource
from avcore.geometry import MicPair
from avcore.itd import ItdTrack

MIC_ERROR_M = 0.015


def _run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="avhear")
    calibrate.add_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(argv)
    return args.func(args)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    """Eight seconds of the calibration preset at 15 FPS, drawn faces (no ../shared/data needed)."""
    missing = tmp_path_factory.mktemp("clean") / "no-shared-data"
    source = SimSource.from_preset("calibration", duration_s=8.0, seed=3, fps=15, data_dir=missing)
    return write_recording(tmp_path_factory.mktemp("rec") / "calib", source)


@pytest.fixture(scope="module")
def measured_rig(recording, tmp_path_factory):
    """The recording's rig with each microphone moved 1.5 cm in a random direction, as a hand measurement is off."""
    rig = load_rig(recording / "rig.yaml")
    rng = np.random.default_rng(7)

    def off(p: tuple[float, float, float]) -> np.ndarray:
        d = rng.normal(size=3)
        return np.asarray(p) + MIC_ERROR_M * d / np.linalg.norm(d)

    mics = MicPair(off(rig.microphones.left), off(rig.microphones.right), rig.microphones.speed_of_sound)
    path = tmp_path_factory.mktemp("rig") / "measured.yaml"
    save_rig(path, RigConfig(stereo=rig.stereo, microphones=mics))
    return path


def _residuals(text: str) -> tuple[float, float]:
    m = re.search(r"before ([\d.]+) us, after ([\d.]+) us", text)
    assert m, text
    return float(m.group(1)), float(m.group(2))


def test_fits_c1_c0_writes_the_rig_and_the_figure(recording, measured_rig, tmp_path, capsys):
    out = tmp_path / "rig.yaml"
    shutil.copy(measured_rig, out)
    assert _run(["calibrate", "av", str(recording), "--rig", str(out), "-o", str(out)]) == 0
    text = capsys.readouterr().out
    before, after = _residuals(text)
    assert after < before
    assert re.search(r"pairs\s+\d+ face/ITD pairs", text) and "inliers" in text

    written = load_rig(out)
    measured = load_rig(measured_rig)
    assert written.stereo.to_dict() == measured.stereo.to_dict()  # the stereo section is kept
    assert written.microphones.left == measured.microphones.left  # positions untouched without --refine-positions
    c1, c0 = written.microphones.c1, written.microphones.c0
    assert c1 != 1.0 and 0.5 < c1 < 1.2  # reverberation pulls the measured ITDs towards zero: c1 < 1 is expected
    assert abs(c0) < 30e-6
    # the fitted mapping follows the measured ITDs better than the hand-measured one, on the same recording
    assert "# avhear rig calibration: audio-visual c1, c0 (robust)" in out.read_text()

    png = tmp_path / "rig_av_calibration.png"
    image = cv2.imread(str(png))
    assert image is not None and image.ndim == 3 and image.shape[0] >= 400 and image.shape[1] >= 800
    # the three series are drawn: red ITD circles, blue and green face lines (BGR)
    colours = image.reshape(-1, 3)
    for bgr in ((40, 40, 214), (180, 119, 31), (44, 160, 44)):
        assert np.any(np.all(np.abs(colours.astype(int) - bgr) < 8, axis=1)), bgr
    rrd = tmp_path / "rig_av_calibration.rrd"
    assert rrd.is_file() and rrd.stat().st_size > 1000


def test_lstsq_and_refined_positions(recording, measured_rig, tmp_path, capsys):
    out = tmp_path / "out.yaml"
    figure = tmp_path / "fig.png"
    assert _run(["calibrate", "av", str(recording), "--rig", str(measured_rig), "-o", str(out), "--method", "lstsq",
                 "--refine-positions", "--figure", str(figure), "--no-rrd"]) == 0
    text = capsys.readouterr().out
    before, after = _residuals(text)
    assert after < before and "lstsq" in text
    written, measured = load_rig(out).microphones, load_rig(measured_rig).microphones
    shifts = [np.linalg.norm(np.subtract(a, b)) for a, b in ((written.left, measured.left),
                                                             (written.right, measured.right))]
    # Positions move only within what a hand measurement can be off (the 2 cm prior; more than 5 cm is rejected)
    assert "refinement rejected" not in text and "microphones moved by" in text
    assert 0 < max(shifts) <= 0.05
    assert cv2.imread(str(figure)) is not None
    assert not figure.with_suffix(".rrd").exists()


def test_missing_recording_says_how_to_make_one(measured_rig, tmp_path, capsys):
    argv = ["calibrate", "av", str(tmp_path / "nowhere"), "--rig", str(measured_rig), "-o", str(tmp_path / "o.yaml")]
    with pytest.raises(UserError, match="no such recording folder.*simulate calibration"):
        _run(argv)
    assert main(argv) == 2  # the console script reports it without a traceback
    assert "avhear: error:" in capsys.readouterr().err


def test_rig_without_microphones_says_what_to_add(recording, tmp_path):
    rig = tmp_path / "stereo_only.yaml"
    save_rig(rig, RigConfig(stereo=load_rig(recording / "rig.yaml").stereo))
    with pytest.raises(UserError, match=r"(?s)no .microphones. section.*left_m"):
        _run(["calibrate", "av", str(recording), "--rig", str(rig), "-o", str(tmp_path / "o.yaml")])
    assert not (tmp_path / "o.yaml").exists()


def test_silent_audio_gives_no_itds(recording, measured_rig, tmp_path):
    silent = tmp_path / "silent"
    shutil.copytree(recording, silent)
    with wave.open(str(recording / "audio.wav"), "rb") as w:
        channels, rate, n = w.getnchannels(), w.getframerate(), w.getnframes()
    with wave.open(str(silent / "audio.wav"), "wb") as w:
        w.setnchannels(channels)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(np.zeros((n, channels), "<i2").tobytes())
    with pytest.raises(UserError, match="No audio window passed the energy gate"):
        _run(["calibrate", "av", str(silent), "--rig", str(measured_rig), "-o", str(tmp_path / "o.yaml")])


def test_no_face_in_view(recording, measured_rig, tmp_path):
    """Grey frames and white noise: ITDs but no face to pair them with."""
    rig = load_rig(measured_rig)
    w, h = rig.stereo.image_size
    rng = np.random.default_rng(0)
    folder = tmp_path / "empty"
    with RecordingWriter(folder, rig=rig, fps=10, samplerate_hz=16000, n_channels=2) as writer:
        grey = np.full((h, w, 3), 128, np.uint8)
        for k in range(10):
            writer.add_frame(StereoFrame(k, k / 10, grey, grey, k / 10))
        noise = (0.1 * rng.standard_normal((16000, 2))).astype(np.float32)
        writer.add_audio(AudioBlock(0, 0, 0.0, noise, 16000))
    assert open_recording(folder).n_frames == 10
    with pytest.raises(UserError, match="No frame shows exactly one face"):
        _run(["calibrate", "av", str(folder), "--rig", str(measured_rig), "-o", str(tmp_path / "o.yaml")])


# ---------------------------------------------------------------------------------------------------------------
# pairing


def _track(stamps, n_faces, xs) -> FaceTrack:
    points = np.array([[x, 0.0, 2.0] if n == 1 else [np.nan] * 3 for n, x in zip(n_faces, xs)])
    return FaceTrack(np.asarray(stamps, float), np.asarray(n_faces), points)


def _itds(times) -> ItdTrack:
    t = np.asarray(times, float)
    return ItdTrack(t, np.arange(t.size) * 1e-6, np.ones(t.size), np.ones(t.size))


def test_pairs_interpolate_between_single_face_frames():
    faces = _track([0.0, 0.1, 0.2, 0.3], [1, 1, 1, 1], [0.0, 0.1, 0.2, 0.3])
    pairs = pair_faces_with_itds(faces, _itds([0.05, 0.125, 0.3]))
    assert len(pairs) == 3
    np.testing.assert_allclose(pairs.faces_xyz[:, 0], [0.05, 0.125, 0.3])
    np.testing.assert_allclose(pairs.itds_s, [0.0, 1e-6, 2e-6])


def test_pairs_skip_frames_without_exactly_one_face():
    # frame 1 has two faces, frame 2 none: ITDs near them are not paired; frame 0 and 3 still are
    faces = _track([0.0, 0.1, 0.2, 0.3], [1, 2, 0, 1], [0.0, 0.1, 0.2, 0.3])
    pairs = pair_faces_with_itds(faces, _itds([0.01, 0.1, 0.16, 0.2, 0.29, 0.5]))
    np.testing.assert_allclose(pairs.times_s, [0.01, 0.29])
    np.testing.assert_allclose(pairs.faces_xyz[:, 0], [0.0, 0.3])  # nearest single-face frame, no interpolation
    assert len(pair_faces_with_itds(faces, _itds([]))) == 0
    with pytest.raises(ValueError, match="max_gap_s"):
        pair_faces_with_itds(faces, _itds([0.0]), max_gap_s=0.0)


@pytest.fixture(scope="module")
def nao_recording(tmp_path_factory):
    """Eight seconds of the calibration preset heard by NAO's four microphones (the array is in its rig.yaml)."""
    missing = tmp_path_factory.mktemp("clean-nao") / "no-shared-data"
    source = SimSource.from_preset("calibration", duration_s=8.0, seed=3, fps=15, data_dir=missing, mics="nao")
    return write_recording(tmp_path_factory.mktemp("rec-nao") / "calib", source)


def test_an_array_gets_c1_c0_on_every_pair(nao_recording, tmp_path, capsys):
    """With an array in the rig, every pair is fitted on the same faces and its own two channels, and each fit lowers
    its pair's residuals; NAO's front-rear pair hears every face in view at nearly one ITD, so its fit is refused
    and it keeps its values, with the reason on its row; the rig file keeps each pair's c1, c0 and reads back."""
    rig = load_rig(nao_recording / "rig.yaml")
    assert rig.array is not None and rig.array.n_pairs == 6
    out = tmp_path / "rig.yaml"
    assert _run(["calibrate", "av", str(nao_recording), "--rig", str(nao_recording / "rig.yaml"), "-o", str(out),
                 "--no-rrd"]) == 0
    printed = capsys.readouterr().out
    rows = re.findall(r"^\s+(\d) +\d-\d +[\d.]+ +(\d+) +([\d.]+) +([+-][\d.]+) +([\d.]+) -> +([\d.]+)$", printed,
                      flags=re.M)
    kept = re.findall(r"^\s+(\d) +(\d)-(\d) +[\d.]+ +kept c1 1.0000, c0 \+0.00 us: .*one azimuth", printed, flags=re.M)
    assert len(rows) == 5 and len(kept) == 1, printed
    front_rear = {rig.array.positions[int(kept[0][1])][2], rig.array.positions[int(kept[0][2])][2]}
    assert max(front_rear) - min(front_rear) > 0.08  # the refused pair lies along the cameras' axis (z)
    fitted = load_rig(out).array
    assert fitted is not None and fitted.positions == rig.array.positions and fitted.pairs == rig.array.pairs
    for k, n_pairs, c1, c0, before, after in rows:
        assert fitted.c1[int(k)] == pytest.approx(float(c1), abs=1e-4)
        assert fitted.c0[int(k)] == pytest.approx(float(c0) * 1e-6, abs=1e-8)
        assert int(n_pairs) >= 50 and 0.5 < float(c1) < 1.5 and float(after) < float(before)
    assert fitted.c1[int(kept[0][0])] == 1.0 and fitted.c0[int(kept[0][0])] == 0.0
    # the rig file's per-pair values are checked on load: one per pair
    text = out.read_text().replace("c1: [", "c1: [1.0, ", 1)
    bad = tmp_path / "bad.yaml"
    bad.write_text(text)
    with pytest.raises(UserError, match="key 'array.c1': must be a list of 6 numbers"):
        load_rig(bad)


def test_an_array_with_channels_the_recording_lacks_is_one_line(nao_recording, tmp_path):
    rig = load_rig(nao_recording / "rig.yaml")
    wide = tmp_path / "wide.yaml"
    text = (nao_recording / "rig.yaml").read_text()
    save_rig(wide, RigConfig(stereo=rig.stereo, array=type(rig.array)(rig.array.positions,
                                                                        channels=(0, 1, 2, 7))))
    assert "channels" in text
    with pytest.raises(UserError, match=r"uses channels \[0, 1, 2, 7\] but the recording has 4"):
        _run(["calibrate", "av", str(nao_recording), "--rig", str(wide), "-o", str(tmp_path / "out.yaml"), "--no-rrd"])
