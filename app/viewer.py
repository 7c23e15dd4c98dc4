"""Where the Rerun data goes: the native viewer, a running viewer, an .rrd file, or nowhere."""
from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import rerun as rr

from layouts.blueprint import APPLICATION_ID, default_blueprint

__all__ = ["ViewerTarget", "display_available", "open_recording_stream"]


def display_available() -> bool:
    """Whether a native viewer window can open here (a display and the viewer binary)."""
    has_display = bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")) or os.name == "nt"
    return has_display and shutil.which("rerun") is not None


@dataclass(frozen=True)
class ViewerTarget:
    """save : an .rrd path; connect : a viewer URL ("" for the default local viewer); spawn : open the native viewer;
    none of them: log nothing (headless)."""

    save: Path | None = None
    connect: str | None = None
    spawn: bool = False


def open_recording_stream(target: ViewerTarget) -> rr.RecordingStream | None:
    """A recording stream with the default blueprint, sent to ``target``; None when nothing is to be logged."""
    if target.save is None and target.connect is None and not target.spawn:
        return None
    rec = rr.RecordingStream(APPLICATION_ID)
    blueprint = default_blueprint()
    if target.save is not None:
        target.save.parent.mkdir(parents=True, exist_ok=True)
        rec.save(str(target.save), default_blueprint=blueprint)
    elif target.connect is not None:
        rec.connect_grpc(target.connect or None, default_blueprint=blueprint)
    else:
        rec.spawn(default_blueprint=blueprint)
    return rec
