"""The real sounddevice path of the live source against a PulseAudio null sink: what is played into the sink comes
back through its monitor, as from a microphone (issue 6, section 5). Skipped where PulseAudio is not installed
(`.ci/run` installs it: pulseaudio pulseaudio-utils libportaudio2 libasound2-plugins)."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Iterator

import numpy as np
import pytest

from app.sources.live import LiveConfig, LiveSource
from avcore.geometry import MicPair
from avcore.itd import extract_itds
from avcore.stereo import StereoRig

FS = 16_000


@pytest.fixture(scope="module")
def null_sink(tmp_path_factory: pytest.TempPathFactory) -> Iterator[str]:
    """A user-space PulseAudio daemon with a null sink as default sink and its monitor as default source."""
    if shutil.which("pulseaudio") is None or shutil.which("pactl") is None:
        pytest.skip("PulseAudio is not installed (apt-get install pulseaudio pulseaudio-utils libasound2-plugins)")
    runtime = tmp_path_factory.mktemp("pulse")
    os.chmod(runtime, 0o700)
    env = dict(os.environ, XDG_RUNTIME_DIR=str(runtime))
    started = subprocess.run(
        ["pulseaudio", "-D", "-n", "--exit-idle-time=-1", "--disallow-exit", "--load=module-native-protocol-unix",
         "--load=module-null-sink sink_name=avhear_null"], env=env, capture_output=True, text=True, timeout=20)
    if started.returncode != 0:
        pytest.skip(f"PulseAudio did not start: {started.stderr.strip()[-200:]}")
    for cmd in (["pactl", "set-default-sink", "avhear_null"], ["pactl", "set-default-source", "avhear_null.monitor"]):
        subprocess.run(cmd, env=env, check=True, capture_output=True, timeout=10)
    old = os.environ.get("XDG_RUNTIME_DIR")
    os.environ["XDG_RUNTIME_DIR"] = str(runtime)
    if "sounddevice" in sys.modules:
        # PortAudio lists devices once, when initialised: an earlier test may have done it before this daemon ran
        sd = sys.modules["sounddevice"]
        sd._terminate()
        sd._initialize()
    try:
        yield "pulse"
    finally:
        subprocess.run(["pulseaudio", "--kill"], env=env, capture_output=True, timeout=10)
        if old is None:
            os.environ.pop("XDG_RUNTIME_DIR", None)
        else:
            os.environ["XDG_RUNTIME_DIR"] = old


def test_live_audio_through_a_null_sink(null_sink: str) -> None:
    sd = pytest.importorskip("sounddevice")
    rng = np.random.default_rng(0)
    noise = 0.2 * rng.standard_normal(FS * 2).astype(np.float32)
    delay = 4  # the right channel lags by 4 samples: ITD = t_left - t_right = -250 us
    played = np.c_[noise, np.roll(noise, delay)]
    rig = StereoRig.ideal(focal_px=100.0, image_size=(64, 48), baseline_m=0.12)
    src = LiveSource(LiveConfig(audio_device=null_sink, samplerate_hz=FS, n_channels=2, block_frames=512), rig,
                     MicPair())
    stop = threading.Event()
    blocks = []

    def play() -> None:
        time.sleep(0.3)
        sd.play(played, FS, device=null_sink)
        sd.wait()
        time.sleep(0.3)
        stop.set()

    player = threading.Thread(target=play)
    player.start()
    for block in src.audio(stop):
        blocks.append(block)
    player.join()
    assert len(blocks) > 40  # about 2.6 s of 32 ms blocks
    assert [b.first_sample for b in blocks] == list(np.cumsum([0] + [b.samples.shape[0] for b in blocks[:-1]]))
    stamps = np.array([b.stamp_s for b in blocks])
    assert np.all(np.diff(stamps) > 0) and abs(stamps[0] - time.monotonic()) < 10  # on the monotonic clock
    audio = np.concatenate([b.samples for b in blocks])
    assert np.abs(audio).max() > 0.1  # the noise came back
    track = extract_itds(audio[:, 0], audio[:, 1], FS, method="gcc-phat")
    assert len(track) > 20
    assert np.median(track.itds_s) == pytest.approx(-delay / FS, abs=40e-6)
