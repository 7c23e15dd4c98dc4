"""Lazy access to `sounddevice` (PortAudio), needed only for live capture and playback."""
from __future__ import annotations

import importlib
from types import ModuleType


class DeviceError(RuntimeError):
    """A capture device is missing, busy or unusable; the message says what to do."""


_INSTALL_HINT = (
    "live audio needs the PortAudio library: install it with 'sudo apt-get install libportaudio2' "
    "(Debian/Ubuntu) or 'brew install portaudio' (macOS), then 'pip install sounddevice'"
)


def load_sounddevice() -> ModuleType:
    """Import and return the `sounddevice` module, or raise :class:`DeviceError` saying how to install it.

    `sounddevice` loads the system PortAudio library when it is imported, so it is imported here, when a live
    source is opened, and never at start-up: replay, simulation and tests run without PortAudio.
    """
    try:
        return importlib.import_module("sounddevice")
    except ImportError as exc:  # the package is missing
        raise DeviceError(f"cannot import sounddevice ({exc}); {_INSTALL_HINT}") from exc
    except OSError as exc:  # the package is there but PortAudio is not
        raise DeviceError(f"sounddevice cannot load PortAudio ({exc}); {_INSTALL_HINT}") from exc
