"""The live source through its real code paths: OpenCV reading video files as cameras, and the sounddevice
callback path with a patched device (no camera or microphone on CI; the PulseAudio test comes with issue 6)."""
from __future__ import annotations

import threading
import types
from pathlib import Path

import numpy as np
import pytest

import app.sources.live
from app.sources.live import LiveConfig, LiveSource
from app.sound import DeviceError
from avcore.geometry import MicPair
from avcore.stereo import StereoRig

RIG = StereoRig.ideal(focal_px=100.0, image_size=(64, 48), baseline_m=0.12)


def test_two_cameras_then_unplugged(tmp_path: Path, make_video) -> None:  # noqa: ANN001
    left = make_video(tmp_path / "l.avi", 8, 64, 40)
    right = make_video(tmp_path / "r.avi", 8, 64, 200)
    src = LiveSource(LiveConfig(left=str(left), right=str(right), max_failed_reads=3), RIG, MicPair())
    frames = []
    with pytest.raises(DeviceError, match="stopped delivering frames"):
        for f in src.frames(threading.Event()):
            frames.append(f)
    assert len(frames) >= 6  # ApproximateTime keeps the last pair waiting for a better match
    assert all(f.left.shape == (48, 64, 3) and f.right.shape == (48, 64, 3) for f in frames)
    assert all(f.left.mean() < f.right.mean() for f in frames)  # left and right not swapped
    assert [f.index for f in frames] == list(range(len(frames)))
    assert all(b.stamp_s >= a.stamp_s for a, b in zip(frames, frames[1:]))


def test_side_by_side_camera(tmp_path: Path, make_video) -> None:  # noqa: ANN001
    video = make_video(tmp_path / "sbs.avi", 4, 128, 90)
    src = LiveSource(LiveConfig(left=str(video), right=None, side_by_side=True, max_failed_reads=2), RIG,
                     MicPair())
    frames = []
    with pytest.raises(DeviceError):
        for f in src.frames(threading.Event()):
            frames.append(f)
    assert len(frames) == 4 and frames[0].left.shape == (48, 64, 3)


def test_missing_camera_is_a_clear_error() -> None:
    src = LiveSource(LiveConfig(left="/nonexistent/cam.avi", right="/nonexistent/cam2.avi"), RIG, MicPair())
    with pytest.raises(DeviceError, match="cannot open camera"):
        next(src.frames(threading.Event()))


def test_bad_config() -> None:
    with pytest.raises(ValueError, match="side-by-side"):
        LiveConfig(left=0, right=1, side_by_side=True)
    with pytest.raises(ValueError, match="channels"):
        LiveConfig(channels=(0, 0))


def test_audio_callback_path(fake_sounddevice) -> None:  # noqa: ANN001
    src = LiveSource(LiveConfig(n_channels=4, channels=(1, 3), block_frames=256), RIG, MicPair())
    stop = threading.Event()
    blocks = []
    for block in src.audio(stop):
        blocks.append(block)
        if len(blocks) == 20:
            stop.set()
    assert [round(float(b.samples[0, 0]) * 1000) for b in blocks] == list(range(20))
    assert all(b.samples.shape == (256, 4) for b in blocks)
    gaps = np.diff([b.stamp_s for b in blocks])
    np.testing.assert_allclose(gaps, 256 / 16000, rtol=1e-9)
    assert src.overflows == 1


def test_audio_device_error(monkeypatch: pytest.MonkeyPatch) -> None:
    def refuse(**kwargs: object) -> None:
        raise ValueError("No input device matching 'usb'")

    monkeypatch.setattr(app.sources.live, "load_sounddevice", lambda: types.SimpleNamespace(InputStream=refuse))
    src = LiveSource(LiveConfig(audio_device="usb"), RIG, MicPair())
    with pytest.raises(DeviceError, match="python -m sounddevice"):
        next(src.audio(threading.Event()))


def test_a_rig_array_uses_every_pair_on_the_channels_asked_for() -> None:
    """A rig file's array: the live source hears every pair, on the rig's channels or those of --mic-channels (one
    per microphone); a mismatch is a UserError that says what to change."""
    import argparse

    from app.errors import UserError
    from app.commands.options import live_config
    from avcore.geometry import MicArray

    array = MicArray.preset("respeaker4")
    src = LiveSource(LiveConfig(n_channels=6), RIG, None, array)
    assert src.array is array and src.mics == array.pair(0)
    assert src.channels == tuple(array.channels[i] for i in array.pairs[0])
    args = argparse.Namespace(cameras=["0", "1"], side_by_side=False, audio_device=None, audio_channels=6,
                              mic_channels=[5, 4, 3, 2])
    config = live_config(args)
    assert config.array_channels == (5, 4, 3, 2)
    chosen = LiveSource(config, RIG, None, array)
    assert chosen.array.channels == (5, 4, 3, 2) and chosen.array.positions == array.positions
    with pytest.raises(UserError, match="one channel per microphone"):
        LiveSource(LiveConfig(n_channels=6, array_channels=(0, 1, 2)), RIG, None, array)
    with pytest.raises(UserError, match="--audio-channels"):
        LiveSource(LiveConfig(n_channels=2), RIG, None, array)
