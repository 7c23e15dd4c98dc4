"""Tests of app.sources.recording: the raw recording folder, written and read back; broken files give clear errors."""
from __future__ import annotations

import csv
import json
import shutil
import time
from pathlib import Path

import cv2
import numpy as np
import pytest
from scipy.io import wavfile

from app.config import RigConfig, save_rig
from app.sources.recording import RecordingError, open_recording, write_recording
from app.events import AudioBlock, StereoFrame
from app.sources.sim import SimSource
from avcore.stereo import StereoRig


@pytest.fixture(scope="module")
def source(tmp_path_factory):
    missing = tmp_path_factory.mktemp("clean") / "no-shared-data"
    return SimSource.from_preset("S2", duration_s=1.5, seed=1, fps=10, data_dir=missing)


@pytest.fixture(scope="module")
def png_folder(source, tmp_path_factory):
    return write_recording(tmp_path_factory.mktemp("rec") / "s2", source, video="png")


@pytest.fixture(scope="module")
def avi_folder(source, tmp_path_factory):
    return write_recording(tmp_path_factory.mktemp("rec") / "s2avi", source, video="avi")


def test_lossless_round_trip_gives_the_same_stream(source, png_folder):
    rec = open_recording(png_folder)
    a, b = list(source.stream()), list(rec.stream())
    assert len(a) == len(b) and rec.n_frames == source.n_frames == 15
    for x, y in zip(a, b):
        assert type(x) is type(y) and x.stamp_s == y.stamp_s
        if isinstance(x, StereoFrame):
            np.testing.assert_array_equal(x.left, y.left)
            np.testing.assert_array_equal(x.right, y.right)
            assert x.right_stamp_s == y.right_stamp_s
            tx, ty = source.truth(x.index), rec.truth(y.index)
            np.testing.assert_allclose(tx.positions_m, ty.positions_m)
            np.testing.assert_array_equal(tx.speaking, ty.speaking)
            np.testing.assert_array_equal(tx.visible, ty.visible)
            np.testing.assert_allclose(tx.boxes_left, ty.boxes_left)
            assert tx.names == ty.names
        else:
            np.testing.assert_array_equal(x.samples, y.samples)
    assert rec.fps == 10 and rec.samplerate_hz == 16000 and rec.channels == {"left": 0, "right": 1}
    assert rec.mics == source.mics and rec.stereo.focal_px == source.stereo.focal_px
    assert len(rec.events) == len(source.scenario.events) and rec.meta["scenario"] == "S2"


def test_mjpg_round_trip_is_close(source, avi_folder):
    rec = open_recording(avi_folder)
    frames = [f for f in rec.frames()]
    assert len(frames) == 15
    original = source._images(7)[0].astype(np.float64)
    assert np.mean(np.abs(frames[7].left - original)) < 4.0


def test_real_time_replay_keeps_the_recordings_stamps(png_folder):
    """Paced in real time from a given instant, a replay still stamps on the recording's own clock."""
    rec = open_recording(png_folder)
    stamps = [item.stamp_s for item in rec.stream(realtime=True, start_s=time.monotonic())]
    assert stamps[0] == pytest.approx(rec.start_s)
    assert rec.start_s < 1.0  # the recording's clock, not the machine's uptime
    assert rec.stats.frames + rec.stats.frames_dropped == 15


def _copy(folder, tmp_path):
    dst = tmp_path / "copy"
    shutil.copytree(folder, dst)
    return dst


def test_truncated_wav_is_reported_with_what_to_do(png_folder, tmp_path):
    folder = _copy(png_folder, tmp_path)
    data = (folder / "audio.wav").read_bytes()
    (folder / "audio.wav").write_bytes(data[: len(data) // 2])
    with pytest.raises(RecordingError, match=r"audio\.wav is truncated.*sox"):
        open_recording(folder)
    (folder / "audio.wav").write_bytes(b"not a wav at all")
    with pytest.raises(RecordingError, match=r"audio\.wav: not a WAV file"):
        open_recording(folder)


def test_truncated_video_is_reported_with_the_file_and_frame(avi_folder, tmp_path):
    folder = _copy(avi_folder, tmp_path)
    data = (folder / "left.avi").read_bytes()
    (folder / "left.avi").write_bytes(data[: len(data) // 2])
    with pytest.raises(RecordingError, match=r"left\.avi.*(truncated|corrupt)"):
        rec = open_recording(folder)
        list(rec.frames())


def test_missing_or_corrupt_files_are_named(png_folder, tmp_path):
    folder = _copy(png_folder, tmp_path)
    (folder / "right" / "000014.png").unlink()
    with pytest.raises(RecordingError, match=r"right: holds 14 images but frames.csv lists 15"):
        open_recording(folder)
    (folder / "right" / "000014.png").write_bytes(b"garbage")
    with pytest.raises(RecordingError, match=r"000014.png: cannot be decoded"):
        list(open_recording(folder).frames())
    shutil.copy(png_folder / "right" / "000014.png", folder / "right" / "000014.png")
    lines = (folder / "frames.csv").read_text().splitlines()
    lines[5] = "4,zero,0.4"
    (folder / "frames.csv").write_text("\n".join(lines) + "\n")
    with pytest.raises(RecordingError, match=r"frames.csv, line 6"):
        open_recording(folder)
    (folder / "frames.csv").unlink()
    with pytest.raises(RecordingError, match=r"frames.csv: missing"):
        open_recording(folder)
    with pytest.raises(RecordingError, match="no such recording folder"):
        open_recording(tmp_path / "nowhere")


def test_a_folder_made_with_other_tools_opens(tmp_path):
    """Images from any camera tool, a float WAV from any recorder, a CSV by hand, no recording.json."""
    folder = tmp_path / "handmade"
    rig = StereoRig.ideal(500.0, (320, 240), 0.1)
    folder.mkdir()
    save_rig(folder / "rig.yaml", RigConfig(stereo=rig))
    rng = np.random.default_rng(0)
    for side in ("left", "right"):
        (folder / side).mkdir()
        for k in range(4):
            cv2.imwrite(str(folder / side / f"img{k:03d}.png"), rng.integers(0, 255, (240, 320, 3), dtype=np.uint8))
    audio = (0.1 * rng.standard_normal((8000, 4))).astype(np.float32)
    wavfile.write(folder / "audio.wav", 16000, audio)
    with open(folder / "frames.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["frame", "left_stamp_s", "right_stamp_s"])
        for k in range(4):
            w.writerow([k, 0.1 * k, 0.1 * k + 0.003])
    rec = open_recording(folder, block_size=1000)
    items = list(rec.stream())
    blocks = [i for i in items if isinstance(i, AudioBlock)]
    assert rec.n_channels == 4 and rec.fps == pytest.approx(10.0) and not rec.has_truth and rec.mics is None
    np.testing.assert_array_equal(np.concatenate([b.samples for b in blocks]), audio)
    assert [f.right_stamp_s for f in items if isinstance(f, StereoFrame)] == pytest.approx([0.003, 0.103, 0.203,
                                                                                          0.303])
    (folder / "recording.json").write_text(json.dumps({"channels": {"left": 0, "right": 7}}))
    with pytest.raises(RecordingError, match="does not name a left and a right channel"):
        open_recording(folder)


def test_a_simulated_array_recording_replays_with_every_pair(tmp_path: Path) -> None:
    """`avhear simulate --mics nao`: four channels, the array in the folder's rig.yaml, and a replay that uses its
    six pairs with the first pair's channels as left and right."""
    from app.sources.open import StreamAdapter

    source = SimSource.from_preset("S1", duration_s=2.0, seed=0, mics="nao")
    write_recording(tmp_path / "nao", source)
    rec = open_recording(tmp_path / "nao")
    assert rec.n_channels == 4 and rec.array is not None and rec.array.positions == source.array.positions
    adapter = StreamAdapter(rec, realtime=False, channels=(rec.channels["left"], rec.channels["right"]))
    assert adapter.array is not None and adapter.array.n_pairs == 6
    assert adapter.channels == tuple(rec.array.channels[i] for i in rec.array.pairs[0])
    rec.close()


def test_a_recording_joined_late_replays_as_the_live_run(tmp_path):
    """A robot whose streams had run 3 s when the recorder joined: the first audio block written is the stream's
    sample 48000, and the WAV's sample 0 must carry that block's stamp. The replay then gives the live run's
    results over the same seconds: the same frames, the same ITDs, the same people speaking."""
    from app.config import RigConfig
    from app.pipeline import Pipeline, PipelineConfig
    from app.sources.open import StreamAdapter
    from app.sources.recording import RecordingWriter

    join_s = 3.0
    robot = SimSource.from_preset("S1", duration_s=7.0, seed=0, fps=15,
                                  data_dir=tmp_path / "no-shared-data")

    def run(stream):  # noqa: ANN001, ANN202
        results = []
        Pipeline(StreamAdapter(stream, realtime=False), PipelineConfig(), results.append).run()
        return {round(r.stamp_s, 4): r for r in results}

    live = run(robot)
    with RecordingWriter(tmp_path / "late", rig=RigConfig(robot.stereo, robot.mics), fps=robot.fps,
                         samplerate_hz=robot.samplerate_hz, n_channels=robot.n_channels, video="png") as writer:
        for item in robot.stream(realtime=False, block_size=256):
            if item.stamp_s >= join_s:
                (writer.add_frame if isinstance(item, StereoFrame) else writer.add_audio)(item)
    rec = open_recording(tmp_path / "late")
    assert rec.audio_start_s == pytest.approx(join_s, abs=256 / 16000)
    replay = run(rec)
    # after one time frame of warm-up (0.2 s of ITDs on each side), every result is the live run's (lossless
    # images; the audio through 16-bit PCM)
    compared = [s for s in replay if join_s + 0.5 <= s <= 6.5]
    assert len(compared) >= 40 and all(s in live for s in compared)
    matched = total = 0
    for s in compared:
        assert abs(replay[s].itds_s.shape[0] - live[s].itds_s.shape[0]) <= 2, f"the ITDs at {s} s differ"
        assert np.array_equal(replay[s].output.speaking, live[s].output.speaking), f"who speaks at {s} s differs"
        mine, theirs = np.ravel(replay[s].itds_s), np.ravel(live[s].itds_s)
        if mine.size and theirs.size:
            matched += int(np.sum(np.min(np.abs(mine[:, None] - theirs[None, :]), axis=1) <= 10e-6))
        total += mine.size
    assert total > 200 and matched / total >= 0.95  # the same ITDs, not only as many
    assert sum(live[s].output.speaking.sum() for s in compared) > 10  # someone speaks in these seconds


def test_an_rgbd_recording_keeps_the_depth(tmp_path):
    """An RGB-D camera's recording: the colour images and a depth/ folder of 16-bit PNG millimetres, no right
    camera; it replays the same colour images and the depth to the millimetre, holes where the depth had none; a
    stereo recording written over it later is stereo again."""
    missing = tmp_path / "no-shared-data"
    source = SimSource.from_preset("S1", duration_s=1.0, seed=2, fps=10, data_dir=missing, camera="rgbd")
    folder = write_recording(tmp_path / "rgbd", source, video="png")
    assert (folder / "depth").is_dir() and not (folder / "right").exists()
    rec = open_recording(folder)
    a = [x for x in source.stream() if isinstance(x, StereoFrame)]
    b = [x for x in rec.stream() if isinstance(x, StereoFrame)]
    assert len(a) == len(b) == 10
    for x, y in zip(a, b):
        assert y.right is None
        np.testing.assert_array_equal(x.left, y.left)
        np.testing.assert_array_equal(np.isnan(x.depth_m), np.isnan(y.depth_m))
        ok = ~np.isnan(x.depth_m)
        assert np.max(np.abs(x.depth_m[ok] - y.depth_m[ok])) <= 0.0005 + 1e-6
    stereo = SimSource.from_preset("S1", duration_s=1.0, seed=2, fps=10, data_dir=missing)
    write_recording(folder, stereo, video="png", overwrite=True)
    again = open_recording(folder)
    frame = next(x for x in again.stream() if isinstance(x, StereoFrame))
    assert frame.depth_m is None and frame.right is not None


def test_one_cameras_recording_replays_one_camera(tmp_path, capsys):
    """One camera's recording: its images alone and "camera": "mono" in recording.json; it replays the same images
    with no right image and no depth, the face-guided pipeline places the faces within 25 % of their true depth (drawn
    faces here, whose Haar boxes are wider than a real face's: tests/avcore/test_mono.py measures real ones), and a
    motion-guided run is refused in one line (Algorithm 1 needs depth)."""
    from app.cli import main
    from app.pipeline import Pipeline, PipelineConfig
    from app.sources.open import StreamAdapter

    missing = tmp_path / "no-shared-data"
    source = SimSource.from_preset("S1", duration_s=1.0, seed=2, fps=10, data_dir=missing, camera="mono")
    folder = write_recording(tmp_path / "mono", source, video="png")
    assert json.loads((folder / "recording.json").read_text())["camera"] == "mono"
    assert not (folder / "right").exists() and not (folder / "depth").exists()
    rec = open_recording(folder)
    a = [x for x in source.stream() if isinstance(x, StereoFrame)]
    b = [x for x in rec.stream() if isinstance(x, StereoFrame)]
    assert len(a) == len(b) == 10 and all(y.right is None and y.depth_m is None for y in b)
    assert all(np.array_equal(x.left, y.left) for x, y in zip(a, b))
    errors = []

    def keep(result) -> None:
        truth = rec.truth(result.index)
        for xyz in result.xyz:
            true = truth.positions_m[np.argmin(np.linalg.norm(truth.positions_m - xyz, axis=1))]
            errors.append(abs(xyz[2] - true[2]) / true[2])

    stats = Pipeline(StreamAdapter(rec, realtime=False), PipelineConfig(), keep).run()
    assert stats.bad_frames == 0 and len(errors) >= 10 and np.median(errors) < 0.25
    assert main(["run", "--source", f"replay:{folder}", "--motion", "--headless", "--fast"]) == 2
    err = capsys.readouterr().err
    assert "needs depth" in err and "Traceback" not in err


def test_an_interrupted_recording_keeps_the_events_of_what_it_holds(tmp_path):
    """A stop (Ctrl-C in `avhear simulate`) after 40 frames: the folder is a whole recording of 40 frames, and its
    events end with its last frame (none starts after it; one that runs on is cut there)."""
    import threading

    source = SimSource.from_preset("S2", duration_s=6.0, seed=0, fps=10, data_dir=tmp_path / "none")
    stop = threading.Event()

    def progress(done: int, total: int) -> None:
        if done == 40:
            stop.set()

    folder = write_recording(tmp_path / "cut", source, video="png", progress=progress, stop=stop)
    rec = open_recording(folder)
    last = 39 / 10.0
    assert rec.n_frames == 40
    with open(folder / "events.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    assert rows and all(float(r["start_s"]) < last + 1e-9 and float(r["end_s"]) <= last + 1e-9 for r in rows)
    assert len(rows) < len(source.scenario.events)
