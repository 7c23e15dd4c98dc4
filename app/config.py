"""Configuration files: YAML in, frozen dataclasses out (and back).

The only module that touches YAML (docs/architecture.md). Every error names the file and the key, and says what was
expected, so that a user can fix the file without reading the code.

The rig calibration file (one per robot or laptop) holds the stereo rig and the microphones::

    stereo:                       # avcore.stereo.StereoRig.to_dict(); written by `avhear calibrate stereo`
      image_size: [640, 480]      # width, height, pixels
      left:  {camera_matrix: [[fx, 0, cx], [0, fy, cy], [0, 0, 1]], dist_coeffs: [k1, k2, p1, p2, k3]}
      right: {camera_matrix: ..., dist_coeffs: ...}
      rotation: [[...], [...], [...]]    # left camera frame -> right camera frame (OpenCV)
      translation_m: [-0.12, 0, 0]       # x_right = R x_left + T, metres
    microphones:                  # avcore.geometry.MicPair, scene (cyclopean) frame, metres
      left_m: [-0.06, 0, 0]
      right_m: [0.06, 0, 0]
      speed_of_sound_m_s: 343.0
      c1: 1.0                     # affine audio-visual correction, paper eq. (itd_up)
      c0_s: 0.0

    array:                        # several microphones (avcore.geometry.MicArray) instead of, or beside, one pair
      preset: nao                 # one of ARRAY_PRESETS (nao, respeaker4, respeaker-usb, respeaker6, ps3eye, uma8),
                                  # or positions_m: [[x, y, z], ...] in the scene frame
      rotation: [[1, 0, 0], [0, 1, 0], [0, 0, 1]]   # optional: the preset's frame -> the scene frame
      translation_m: [0, -0.05, 0]                   # optional: where the preset's origin is in the scene frame
      pairs: [[0, 1], [0, 2], ...]  # optional: the pairs used, [i, j] each, i as the "left" (default: every pair,
                                  # i the one more to the left, in the preset's order when it is placed)
      channels: [0, 1, 2, 3]      # optional: the input stream's channel of each microphone (default the preset's)
      c1: [0.98, 1.01, ...]       # optional: each pair's correction of eq. (itd_up), in the order of the pairs
      c0_s: [0.0, 1.0e-6, ...]    # (avhear calibrate av writes them; default 1 and 0)

Any section may be absent (a rig calibrated for its cameras but not yet for sound), not all. With an ``array``,
a live run uses every pair of it; without, the ``microphones`` pair.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from app.errors import UserError
from avcore.geometry import ARRAY_PRESETS, SPEED_OF_SOUND, MicArray, MicPair
from avcore.stereo import StereoRig

__all__ = ["RigConfig", "load_rig", "save_rig", "rig_to_dict", "rig_from_dict"]

_TOP_KEYS = ("stereo", "microphones", "array")
_ARRAY_KEYS = ("preset", "positions_m", "rotation", "translation_m", "pairs", "channels", "speed_of_sound_m_s", "c1",
               "c0_s")
_MIC_KEYS = ("left_m", "right_m", "speed_of_sound_m_s", "c1", "c0_s")
_MIC_REQUIRED = ("left_m", "right_m")


@dataclass(frozen=True)
class RigConfig:
    """What a rig file holds: the stereo rig, the microphone pair and a microphone array, each optional."""

    stereo: StereoRig | None = None
    microphones: MicPair | None = None
    array: MicArray | None = None


# ---------------------------------------------------------------------- validation helpers
def _fail(path: Path | str, key: str, message: str) -> UserError:
    return UserError(f"{path}: key '{key}': {message}")


def _check_mapping(value: object, path: Path | str, key: str, allowed: tuple[str, ...],
                   required: tuple[str, ...]) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise _fail(path, key, f"must be a mapping with keys {list(allowed)}, got {type(value).__name__} {value!r}")
    for k in value:
        if k not in allowed:
            raise _fail(path, f"{key}.{k}" if key else str(k),
                        f"unknown key; allowed here: {list(allowed)} (check the spelling)")
    for k in required:
        if k not in value:
            raise _fail(path, f"{key}.{k}" if key else k, "missing; it is required")
    return value


def _number(value: object, path: Path | str, key: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise _fail(path, key, f"must be a finite number, got {type(value).__name__} {value!r}")
    return float(value)


def _integer(value: object, path: Path | str, key: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise _fail(path, key, f"must be a positive integer, got {type(value).__name__} {value!r}")
    return value


def _numbers(value: object, path: Path | str, key: str, shape: tuple[int, ...] | None) -> list[Any]:
    """A (nested) list of finite numbers of the given shape (None: any flat length)."""
    if shape is None:
        if not isinstance(value, list) or not value:
            raise _fail(path, key, f"must be a non-empty list of numbers, got {type(value).__name__} {value!r}")
        return [_number(v, path, f"{key}[{i}]") for i, v in enumerate(value)]
    if not isinstance(value, list) or len(value) != shape[0]:
        raise _fail(path, key, f"must be a list of {shape[0]} {'numbers' if len(shape) == 1 else 'rows'}, "
                               f"got {value!r}")
    if len(shape) == 1:
        return [_number(v, path, f"{key}[{i}]") for i, v in enumerate(value)]
    return [_numbers(v, path, f"{key}[{i}]", shape[1:]) for i, v in enumerate(value)]


# ---------------------------------------------------------------------- dict <-> dataclasses
def rig_from_dict(data: object, path: Path | str = "<rig>") -> RigConfig:
    """Validate a parsed rig file into a :class:`RigConfig`; errors are :class:`UserError` naming path and key."""
    top = _check_mapping(data, path, "", _TOP_KEYS, ())
    if not top:
        raise UserError(f"{path}: the rig file is empty; it needs a 'stereo' and/or a 'microphones' section")
    stereo = None
    if "stereo" in top:
        s = _check_mapping(top["stereo"], path, "stereo", ("image_size", "left", "right", "rotation", "translation_m"),
                           ("image_size", "left", "right", "rotation", "translation_m"))
        size = s["image_size"]
        if not isinstance(size, list) or len(size) != 2:
            raise _fail(path, "stereo.image_size", f"must be [width, height] in pixels, got {size!r}")
        clean: dict[str, Any] = {"image_size": [_integer(v, path, f"stereo.image_size[{i}]")
                                                for i, v in enumerate(size)]}
        for side in ("left", "right"):
            cam = _check_mapping(s[side], path, f"stereo.{side}", ("camera_matrix", "dist_coeffs"),
                                 ("camera_matrix", "dist_coeffs"))
            clean[side] = {
                "camera_matrix": _numbers(cam["camera_matrix"], path, f"stereo.{side}.camera_matrix", (3, 3)),
                "dist_coeffs": _numbers(cam["dist_coeffs"], path, f"stereo.{side}.dist_coeffs", None),
            }
        clean["rotation"] = _numbers(s["rotation"], path, "stereo.rotation", (3, 3))
        clean["translation_m"] = _numbers(s["translation_m"], path, "stereo.translation_m", (3,))
        try:
            stereo = StereoRig.from_dict(clean)
        except ValueError as exc:
            raise UserError(f"{path}: section 'stereo': {exc}") from None
    mics = None
    if "microphones" in top:
        m = _check_mapping(top["microphones"], path, "microphones", _MIC_KEYS, _MIC_REQUIRED)
        kwargs: dict[str, Any] = {
            "left": tuple(_numbers(m["left_m"], path, "microphones.left_m", (3,))),
            "right": tuple(_numbers(m["right_m"], path, "microphones.right_m", (3,))),
        }
        for key, arg in (("speed_of_sound_m_s", "speed_of_sound"), ("c1", "c1"), ("c0_s", "c0")):
            if key in m:
                kwargs[arg] = _number(m[key], path, f"microphones.{key}")
        try:
            mics = MicPair(**kwargs)
        except ValueError as exc:
            raise UserError(f"{path}: section 'microphones': {exc}") from None
    array = _array_from_dict(top["array"], path) if "array" in top else None
    return RigConfig(stereo=stereo, microphones=mics, array=array)


def _array_from_dict(value: object, path: Path | str) -> MicArray:
    """The ``array`` section: a preset placed by ``rotation`` and ``translation_m``, or ``positions_m``."""
    a = _check_mapping(value, path, "array", _ARRAY_KEYS, ())
    if ("preset" in a) == ("positions_m" in a):
        raise _fail(path, "array", "give either 'preset' (one of " + ", ".join(ARRAY_PRESETS) + ") or "
                                   "'positions_m' (a list of [x, y, z] in metres)")
    speed = _number(a["speed_of_sound_m_s"], path, "array.speed_of_sound_m_s") if "speed_of_sound_m_s" in a \
        else SPEED_OF_SOUND
    try:
        if "preset" in a:
            if a["preset"] not in ARRAY_PRESETS:
                raise _fail(path, "array.preset", f"unknown array {a['preset']!r}; choose one of "
                                                  f"{', '.join(ARRAY_PRESETS)}")
            rotation = _numbers(a["rotation"], path, "array.rotation", (3, 3)) if "rotation" in a else None
            translation = _numbers(a["translation_m"], path, "array.translation_m", (3,)) \
                if "translation_m" in a else None
            array = MicArray.preset(a["preset"], rotation=rotation, translation_m=translation, speed_of_sound=speed)
        else:
            positions = a["positions_m"]
            if not isinstance(positions, list) or len(positions) < 2:
                raise _fail(path, "array.positions_m", f"must list at least two [x, y, z], got {positions!r}")
            array = MicArray(tuple(tuple(_numbers(p, path, f"array.positions_m[{i}]", (3,)))
                                   for i, p in enumerate(positions)), speed_of_sound=speed)
        if "pairs" in a:
            pairs = a["pairs"]
            if not isinstance(pairs, list) or not pairs or any(
                    not isinstance(ij, list) or len(ij) != 2 or any(isinstance(k, bool) or not isinstance(k, int)
                                                                  for k in ij) for ij in pairs):
                raise _fail(path, "array.pairs", f"must be a list of [i, j] microphone numbers, got {pairs!r}")
            array = MicArray(array.positions, tuple((i, j) for i, j in pairs), array.speed_of_sound,
                             channels=array.channels)
        if "channels" in a:
            channels = a["channels"]
            if not isinstance(channels, list) or any(isinstance(c, bool) or not isinstance(c, int) for c in channels):
                raise _fail(path, "array.channels", f"must be a list of channel numbers, got {channels!r}")
            array = MicArray(array.positions, array.pairs, array.speed_of_sound, array.c1, array.c0, tuple(channels))
        if "c1" in a or "c0_s" in a:
            n = array.n_pairs
            c1 = _numbers(a["c1"], path, "array.c1", (n,)) if "c1" in a else array.c1
            c0 = _numbers(a["c0_s"], path, "array.c0_s", (n,)) if "c0_s" in a else array.c0
            array = MicArray(array.positions, array.pairs, array.speed_of_sound, tuple(c1), tuple(c0), array.channels)
    except ValueError as exc:
        raise UserError(f"{path}: section 'array': {exc}") from None
    return array


MICROPHONES_HINT = ("add the measured microphone positions to it, in metres in the scene frame (x right, y down, z "
                     "forward, origin midway between the cameras), e.g.\n  microphones:\n    left_m: [-0.06, 0.0, 0.0]"
                     "\n    right_m: [0.06, 0.0, 0.0]\n(avhear calibrate av then fits c1 and c0)")


def require_live_rig(path: str | Path) -> RigConfig:
    """The rig of a live run or recording: both sections present, or a :class:`UserError` that says how to add the
    missing one (``calibrate stereo`` writes only the stereo section)."""
    rig = load_rig(Path(path))
    if rig.stereo is None:
        raise UserError(f"{path} has no 'stereo' section: make one with avhear calibrate stereo")
    if rig.microphones is None and rig.array is None:
        raise UserError(f"{path} has no 'microphones' section: {MICROPHONES_HINT}")
    return rig


def rig_to_dict(rig: RigConfig) -> dict[str, Any]:
    """A :class:`RigConfig` as plain lists and numbers, in the layout :func:`rig_from_dict` reads."""
    out: dict[str, Any] = {}
    if rig.stereo is not None:
        out["stereo"] = rig.stereo.to_dict()
    if rig.microphones is not None:
        m = rig.microphones
        out["microphones"] = {
            "left_m": list(m.left), "right_m": list(m.right), "speed_of_sound_m_s": float(m.speed_of_sound),
            "c1": float(m.c1), "c0_s": float(m.c0),
        }
    if rig.array is not None:
        out["array"] = {"positions_m": [list(p) for p in rig.array.positions],
                        "pairs": [list(ij) for ij in rig.array.pairs],  # type: ignore[union-attr]
                        "channels": list(rig.array.channels),  # type: ignore[arg-type]
                        "speed_of_sound_m_s": float(rig.array.speed_of_sound),
                        "c1": [float(v) for v in rig.array.c1],  # type: ignore[union-attr]
                        "c0_s": [float(v) for v in rig.array.c0]}  # type: ignore[union-attr]
    return out


# ---------------------------------------------------------------------- files
def load_rig(path: str | Path) -> RigConfig:
    """Read and validate a rig YAML file."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UserError(f"{p}: rig file not found; create it with `avhear calibrate stereo ... -o {p}`") from None
    except UnicodeDecodeError as exc:
        raise UserError(f"{p}: the rig file is not UTF-8 text (byte {exc.start} is not: a comment with an accent "
                        "saved as Latin-1?); save it as UTF-8") from None
    except OSError as exc:
        raise UserError(f"{p}: cannot read the rig file ({exc.strerror})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:  # one line: where, and what the parser found (not its excerpt of the file)
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        what = getattr(exc, "problem", None) or " ".join(str(exc).split())
        raise UserError(f"{p}: not valid YAML{where}: {what}") from None
    if data is None:
        raise UserError(f"{p}: the rig file is empty; it needs a 'stereo' and/or a 'microphones' section")
    return rig_from_dict(data, p)


def save_rig(path: str | Path, rig: RigConfig, *, header: str | None = None) -> None:
    """Write a rig YAML file that :func:`load_rig` reads back to the same values (floats in full precision)."""
    if rig.stereo is None and rig.microphones is None and rig.array is None:
        raise ValueError("rig holds neither a stereo rig nor microphones; there is nothing to save")
    p = Path(path)
    text = yaml.safe_dump(rig_to_dict(rig), sort_keys=False, default_flow_style=None, width=120)
    if header:
        text = "".join(f"# {line}\n" for line in header.splitlines()) + text
    try:
        p.write_text(text, encoding="utf-8")
    except OSError as exc:
        raise UserError(f"{p}: cannot write the rig file ({exc.strerror})") from None
