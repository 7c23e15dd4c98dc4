from __future__ import annotations

import importlib
import sys

import pytest

import app.sound
from app.sound import DeviceError, load_sounddevice


def test_app_does_not_import_sounddevice_at_start() -> None:
    code = "import sys, app.cli; app.cli.build_parser(); print('sounddevice' in sys.modules)"
    import subprocess

    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


@pytest.mark.parametrize("error", [ImportError("No module named 'sounddevice'"), OSError("PortAudio library not found")])
def test_missing_sounddevice_or_portaudio_says_how_to_install(monkeypatch: pytest.MonkeyPatch, error: Exception) -> None:
    real = importlib.import_module

    def fake(name: str, *args: object) -> object:
        if name == "sounddevice":
            raise error
        return real(name, *args)

    monkeypatch.setattr(app.sound.importlib, "import_module", fake)
    with pytest.raises(DeviceError, match="libportaudio2"):
        load_sounddevice()


def test_real_sounddevice_when_portaudio_is_installed() -> None:
    try:
        sd = load_sounddevice()
    except DeviceError as exc:
        pytest.skip(f"PortAudio not installed here: {exc}")
    assert hasattr(sd, "InputStream")
