"""Lazy access to `sounddevice` (PortAudio), needed only for live capture and playback."""
from __future__ import annotations

import importlib
from types import ModuleType

from app.errors import UserError


class DeviceError(UserError, RuntimeError):
    """A capture device is missing, busy, unusable or gone; the message says what to do. A user's problem: the
    command line prints it as one line (exit status 2), also when a pipeline thread raised it."""


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
