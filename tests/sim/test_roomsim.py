from __future__ import annotations

import builtins
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pyroomacoustics", reason="the room simulator needs the 'sim' extra")

from sim import roomsim
from avcore.itd import extract_itds
from sim.roomsim import AcousticRoom, load_speech, simulate, window_truth

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def small_recording():
    """3 s of synthetic speech from a talker on the right in a dry room (fast: RT60 0.2 s, two noise sources)."""
    room = AcousticRoom(dims_m=(5.0, 4.0, 2.8), rt60_s=0.2, head_m=(2.5, 1.2, 1.2))
    talker = np.array([[0.9, -0.2, 1.2]])
    noise = np.array([[-2.0, -1.0, 2.4], [2.0, 1.0, 2.5]])
    return simulate(room, talker, duration_s=3.0, seed=4, speech="synthetic", noise_scene=noise)


def test_scene_and_room_frames_are_inverse_and_mics_are_on_the_x_axis():
    room = AcousticRoom()
    pts = np.random.default_rng(0).uniform(-1, 1, (5, 3))
    np.testing.assert_allclose(room.room_to_scene(room.scene_to_room(pts)), pts)
    mics = room.mic_pair()
    assert mics.left == (-0.06, 0.0, 0.0) and mics.right == (0.06, 0.0, 0.0)
    # scene z (forward) is the room's +y, scene y (down) is the room's -z
    np.testing.assert_allclose(room.scene_to_room([0, -1, 2]), np.add(room.head_m, [0, 2, 1]))


def test_room_rejects_sources_outside_and_bad_parameters():
    room = AcousticRoom(rt60_s=0.2)
    with pytest.raises(ValueError, match="not inside the room"):
        room.impulse_responses(np.array([[0.0, 0.0, 10.0]]))
    with pytest.raises(ValueError, match="rt60_s"):
        AcousticRoom(rt60_s=0.0)
    with pytest.raises(ValueError, match="mic_distance_m"):
        AcousticRoom(mic_distance_m=2.0)


def test_recording_components_ground_truth_and_levels(small_recording):
    rec = small_recording
    n = 3 * 16000
    assert rec.speech.shape == rec.background.shape == rec.ego.shape == (2, n)
    assert rec.dry.shape == (1, n)
    assert rec.meta["speech"] == "synthetic"
    # the talker at (0.9, -0.2, 1.2) m and the paper's pair at x = -6 cm and +6 cm: the sound travels
    # 1.5497 m to the left microphone and 1.4784 m to the right one, 71.3 mm more, 208 us at 343 m/s
    far, near = np.sqrt(0.96**2 + 0.2**2 + 1.2**2), np.sqrt(0.84**2 + 0.2**2 + 1.2**2)
    assert (far - near) / 343.0 == pytest.approx(208.0e-6, abs=0.1e-6)
    np.testing.assert_allclose(rec.talker_itds_s, [(far - near) / 343.0], rtol=1e-9)
    assert 0.1 < rec.measured_rt60_s < 0.35
    left, _ = rec.mix(snr_db=10.0, ego_snr_db=None)
    active = np.any(rec.dry != 0, axis=0)
    speech_only, _ = rec.mix(snr_db=None, ego_snr_db=None)
    assert np.sqrt(np.mean(speech_only[active] ** 2)) == pytest.approx(roomsim.SPEECH_LEVEL_RMS, rel=1e-6)
    noise_power = np.mean((left - speech_only) ** 2)
    assert 10 * np.log10(np.mean(speech_only[active] ** 2) / noise_power) == pytest.approx(10.0, abs=0.01)


@pytest.mark.parametrize("method", ["correlogram", "gcc-phat-robust"])
def test_itds_from_the_simulated_room_match_the_geometry(small_recording, method):
    rec = small_recording
    left, right = rec.mix(snr_db=20.0, ego_snr_db=30.0)
    _, talker = window_truth(rec.dry, 16000)
    track = extract_itds(left, right, 16000, method=method, max_itd_s=4.2e-4)
    index = np.round((track.times_s - 0.075) / 0.02).astype(int)
    speech = talker[index] >= 0
    assert speech.sum() > 20
    err = np.abs(track.itds_s[speech] - rec.talker_itds_s[0])
    assert np.median(err) < 40e-6  # the sign and the geometry agree end to end


def test_window_truth_marks_the_loudest_talker():
    fs = 1000
    dry = np.zeros((2, 3 * fs))
    dry[0, 200:900] = 1.0
    dry[1, 1800:2600] = 1.0
    times, talker = window_truth(dry, fs, window_s=0.1, hop_s=0.05)
    assert talker[np.argmin(np.abs(times - 0.5))] == 0
    assert talker[np.argmin(np.abs(times - 2.2))] == 1
    assert talker[np.argmin(np.abs(times - 1.4))] == -1


def test_synthetic_signals_without_data_are_deterministic():
    a = roomsim.speech_turns(2, 3.0, 16000, np.random.default_rng(7))
    b = roomsim.speech_turns(2, 3.0, 16000, np.random.default_rng(7))
    np.testing.assert_array_equal(a, b)
    assert np.all(np.any(a != 0, axis=1))  # both talkers get a turn
    assert not np.any((a[0] != 0) & (a[1] != 0))  # turns do not overlap
    fan = roomsim.fan_noise(16000, 16000, np.random.default_rng(0))
    assert np.sqrt(np.mean(fan**2)) == pytest.approx(1.0)


def test_missing_data_falls_back_to_synthetic(tmp_path):
    assert load_speech(16000, "digits", data_dir=tmp_path) is None
    room = AcousticRoom(rt60_s=0.2)
    rec = simulate(room, np.array([[-0.5, 0.0, 1.5]]), duration_s=1.5, data_dir=tmp_path,
                   noise_scene=np.array([[1.0, -0.5, 2.5]]))
    assert rec.meta["speech"] == "synthetic" and "pink" in rec.meta["noise"]


def test_real_digits_load_resampled(shared_data):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        digits = load_speech(16000, "digits", data_dir=shared_data)
    assert digits is not None and len(digits) == 60
    assert all(0.1 < d.shape[0] / 16000 < 1.2 for d in digits)


def test_missing_pyroomacoustics_says_how_to_install(monkeypatch):
    real_import = builtins.__import__

    def fake_import(name, *args, **kwargs):
        if name == "pyroomacoustics":
            raise ImportError("No module named 'pyroomacoustics'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", fake_import)
    with pytest.raises(ImportError, match=r"pip install -e '\.\[sim\]'"):
        AcousticRoom(rt60_s=0.2).impulse_responses(np.array([[0.0, 0.0, 1.0]]))


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the resident memory from /proc")
def test_the_image_sources_memory_goes_back_to_the_system() -> None:
    """pyroomacoustics' image sources are many small C allocations; freed, they stayed in the heap for the whole run.
    In a fresh process, 30 positions' responses leave under 100 MB behind."""
    code = """
import numpy as np
import sim.roomsim as rs
def rss(): return int(open('/proc/self/statm').read().split()[1]) * 4096 / 2**20
room = rs.AcousticRoom(dims_m=(5.0, 5.0, 2.7), rt60_s=0.32, head_m=(2.5, 0.5, 1.2), match_rt60=False)
rs._pyroomacoustics()
rng = np.random.default_rng(0)
points = np.stack([rng.uniform(-1.5, 1.5, 30), rng.uniform(-0.3, 0.3, 30), rng.uniform(1.0, 3.5, 30)], 1)
before = rss()
rirs, _ = room.impulse_responses(points)
print(rirs.shape[0], rss() - before)
"""
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert done.returncode == 0, done.stderr
    n, grown_mb = done.stdout.split()
    assert int(n) == 30 and float(grown_mb) < 100, grown_mb
