"""ROS 2 camera and microphone messages to and from arrays: sensor_msgs/Image (the encodings RGB-D drivers publish),
sensor_msgs/CompressedImage, sensor_msgs/CameraInfo, and audio_common's stamped audio with its AudioInfo.

Encodings (sensor_msgs/image_encodings.hpp): ``rgb8``, ``bgr8``, ``mono8`` (colour, to BGR uint8), ``rgba8``,
``bgra8``; ``16UC1`` (depth in millimetres, 0 where invalid: RealSense's aligned depth) and ``32FC1`` (depth in
metres). Rows may be padded (``step`` > width x pixel size) and big-endian data is byte-swapped. audio_common's
``audio_capture`` publishes interleaved ``S16LE`` samples when run with ``format:=wave`` (its default, mp3, is
compressed audio avhear cannot use).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import cv2
import numpy as np

from app.bus.messages import AUDIO_INFO, AUDIO_STAMPED, CAMERA_INFO, IMAGE, make_header, typestore

__all__ = ["AudioFormat", "audio_format", "audio_messages", "audio_samples", "camera_info", "camera_matrix",
           "image_from_msg", "image_message", "stamp_s"]

_CHANNELS = {"rgb8": 3, "bgr8": 3, "mono8": 1, "rgba8": 4, "bgra8": 4, "16UC1": 1, "mono16": 1, "32FC1": 1}
_DTYPES = {"16UC1": np.uint16, "mono16": np.uint16, "32FC1": np.float32}


def stamp_s(header: Any) -> float:
    """A std_msgs/Header's stamp in seconds."""
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def image_from_msg(msg: Any) -> np.ndarray:
    """The array of a sensor_msgs/Image: BGR uint8 (h, w, 3) for colour encodings, (h, w) uint16 or float32 for
    depth; ValueError for an encoding or a size the message does not hold."""
    encoding = str(msg.encoding)
    if encoding not in _CHANNELS:
        raise ValueError(f"image encoding {encoding!r} is not one of {', '.join(_CHANNELS)}")
    h, w, step = int(msg.height), int(msg.width), int(msg.step)
    dtype = np.dtype(_DTYPES.get(encoding, np.uint8)).newbyteorder(">" if msg.is_bigendian else "<")
    row = w * _CHANNELS[encoding] * dtype.itemsize
    data = np.asarray(msg.data, dtype=np.uint8)
    if h <= 0 or w <= 0 or step < row or data.size < step * (h - 1) + row:
        raise ValueError(f"a {w}x{h} {encoding} image needs {step} x {h} bytes, the message holds {data.size}")
    rows = np.lib.stride_tricks.as_strided(data, shape=(h, row), strides=(step, 1))
    pixels = np.ascontiguousarray(rows).view(dtype).reshape(h, w, _CHANNELS[encoding]).astype(dtype.newbyteorder("="))
    if encoding in _DTYPES:
        return pixels[..., 0]
    conversions = {"rgb8": cv2.COLOR_RGB2BGR, "mono8": cv2.COLOR_GRAY2BGR, "rgba8": cv2.COLOR_RGBA2BGR,
                   "bgra8": cv2.COLOR_BGRA2BGR}
    return cv2.cvtColor(pixels, conversions[encoding]) if encoding in conversions else pixels


def image_message(image: np.ndarray, encoding: str, stamp: float, frame_id: str) -> Any:
    """A sensor_msgs/Image of ``image`` (BGR uint8 for ``rgb8``/``bgr8``, uint16 for ``16UC1``, float32 for
    ``32FC1``), as a camera driver publishes it."""
    if encoding == "rgb8":
        image = cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
    pixels = np.ascontiguousarray(image, dtype=_DTYPES.get(encoding, np.uint8))
    h, w = pixels.shape[:2]
    return typestore().types[IMAGE](header=make_header(stamp, frame_id), height=h, width=w, encoding=encoding,
                                    is_bigendian=0, step=pixels.strides[0],
                                    data=pixels.view(np.uint8).reshape(-1))


def camera_matrix(info: Any) -> tuple[np.ndarray, tuple[int, int]]:
    """K (3, 3) and (width, height) of a sensor_msgs/CameraInfo; ValueError when it holds no calibration."""
    k = np.asarray(info.k, dtype=np.float64).reshape(3, 3)
    size = (int(info.width), int(info.height))
    if not (k[0, 0] > 0 and k[1, 1] > 0) or min(size) <= 0:
        raise ValueError(f"the CameraInfo holds no calibration (K {k.ravel().tolist()}, size {size})")
    return k, size


@dataclass(frozen=True)
class AudioFormat:
    """An audio_common AudioInfo: ``samplerate_hz``, ``channels``, ``sample_format`` (``S16LE``)."""

    samplerate_hz: int
    channels: int
    sample_format: str = "S16LE"


def audio_format(info: Any) -> AudioFormat:
    """The format of an audio_common AudioInfo; ValueError when avhear cannot read such audio."""
    coding = str(info.coding_format).lower()
    if coding not in ("wave", "wav", ""):
        raise ValueError(f"the microphone publishes {info.coding_format!r} audio; run audio_capture with "
                         "format:=wave (16-bit PCM)")
    if str(info.sample_format) != "S16LE":
        raise ValueError(f"the microphone's samples are {info.sample_format!r}; avhear reads S16LE "
                         "(audio_capture's default sample_format)")
    if int(info.channels) < 1 or int(info.sample_rate) < 1:
        raise ValueError(f"an AudioInfo of {info.channels} channels at {info.sample_rate} Hz")
    return AudioFormat(int(info.sample_rate), int(info.channels), "S16LE")


def audio_samples(msg: Any, fmt: AudioFormat) -> np.ndarray:
    """(n, channels) float32 in [-1, 1) of an audio_common AudioDataStamped in ``fmt``."""
    data = np.asarray(msg.audio.data, dtype=np.uint8)
    frame_bytes = 2 * fmt.channels
    if data.size % frame_bytes:
        raise ValueError(f"{data.size} bytes are not whole frames of {fmt.channels} 16-bit channels")
    return data.view("<i2").reshape(-1, fmt.channels).astype(np.float32) / np.float32(32768.0)


def audio_messages(samples: np.ndarray, stamp: float, samplerate_hz: int) -> tuple[Any, Any]:
    """(AudioDataStamped, AudioInfo) of float samples (n, channels), as audio_capture publishes them with
    format:=wave."""
    t = typestore().types
    pcm = np.ascontiguousarray(np.clip(np.rint(np.asarray(samples, np.float32) * 32768.0), -32768, 32767), "<i2")
    stamped = t[AUDIO_STAMPED](header=make_header(stamp, "avhear_mics"),
                               audio=t["audio_common_msgs/msg/AudioData"](data=pcm.view(np.uint8).reshape(-1)))
    info = t[AUDIO_INFO](channels=pcm.shape[1], sample_rate=int(samplerate_hz), sample_format="S16LE",
                         bitrate=16 * pcm.shape[1] * int(samplerate_hz), coding_format="wave")
    return stamped, info


def camera_info(k: np.ndarray, size: tuple[int, int], stamp: float, frame_id: str) -> Any:
    """A sensor_msgs/CameraInfo of a pinhole camera without distortion (plumb_bob, zeros)."""
    t = typestore().types
    p = np.hstack([k, np.zeros((3, 1))])
    return t[CAMERA_INFO](header=make_header(stamp, frame_id), height=size[1], width=size[0],
                          distortion_model="plumb_bob", d=np.zeros(5), k=np.asarray(k, np.float64).ravel(),
                          r=np.eye(3).ravel(), p=p.ravel(), binning_x=0, binning_y=0,
                          roi=t["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0, width=0,
                                                                   do_rectify=False))
