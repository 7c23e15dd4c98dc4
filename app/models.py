"""The model files avhear runs (:mod:`avcore.models` finds them), or a :class:`UserError` that says how to get them."""
from __future__ import annotations

from pathlib import Path

from app.errors import UserError
from avcore.models import BLAZEFACE_FILE, FACEMESH_FILE, INSTALL_HINT, installed_model

__all__ = ["BLAZEFACE_FILE", "FACEMESH_FILE", "INSTALL_HINT", "blazeface_model", "facemesh_model", "no_face_detector"]


def blazeface_model(path: str | Path | None = None) -> Path:
    """The BlazeFace model file: ``path`` if given, else ``$AVHEAR_BLAZEFACE``, else the installed package's; a
    :class:`UserError` that says how to get it otherwise."""
    found = Path(path) if path else installed_model(BLAZEFACE_FILE)
    if found is None:
        raise UserError(f"the BlazeFace face detector's model is not installed: {INSTALL_HINT} (or use "
                        "--face-detector haar)")
    if not found.is_file():
        raise UserError(f"--face-model {found}: no such file; give the path of {BLAZEFACE_FILE}")
    return found


def no_face_detector(opencv_version: str) -> UserError:
    """The error of a machine that can find no face: an OpenCV without Haar cascades and no BlazeFace model."""
    return UserError(f"OpenCV {opencv_version} has no Haar cascades and BlazeFace's model is not installed: "
                     f"{INSTALL_HINT}")


def facemesh_model() -> Path:
    """The face mesh model file: ``$AVHEAR_FACEMESH``, else the installed package's; a :class:`UserError` that
    says how to get it otherwise."""
    found = installed_model(FACEMESH_FILE)
    if found is None:
        raise UserError(f"the face mesh's model (the lips) is not installed: {INSTALL_HINT} (or leave out --read-lips)")
    if not found.is_file():
        raise UserError(f"AVHEAR_FACEMESH={found}: no such file; give the path of {FACEMESH_FILE}")
    return found
