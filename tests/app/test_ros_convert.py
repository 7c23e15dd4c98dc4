"""ROS 2 camera messages to arrays: every encoding an RGB-D driver publishes, padded rows and big-endian data, built
by rosbags as a driver would send them."""
from __future__ import annotations

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore

from app.bus.convert import camera_matrix, image_from_msg

STORE = get_typestore(Stores.ROS2_JAZZY)
T = STORE.types


def _image(pixels: np.ndarray, encoding: str, *, pad: int = 0, big_endian: bool = False):  # noqa: ANN202
    """A sensor_msgs/Image through rosbags' CDR and back, rows padded by ``pad`` bytes."""
    h, w = pixels.shape[:2]
    raw = pixels.astype(pixels.dtype.newbyteorder(">" if big_endian else "<"))
    rows = raw.reshape(h, -1).view(np.uint8)
    data = np.concatenate([rows, np.zeros((h, pad), np.uint8)], axis=1).reshape(-1)
    header = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=1, nanosec=0), frame_id="cam")
    msg = T["sensor_msgs/msg/Image"](header=header, height=h, width=w, encoding=encoding,
                                     is_bigendian=int(big_endian), step=rows.shape[1] + pad, data=data)
    return STORE.deserialize_cdr(STORE.serialize_cdr(msg, "sensor_msgs/msg/Image"), "sensor_msgs/msg/Image")


RNG = np.random.default_rng(0)
BGR = RNG.integers(0, 255, (5, 7, 3), np.uint8)


@pytest.mark.parametrize(("pixels", "encoding", "expected"), [
    (BGR[..., ::-1].copy(), "rgb8", BGR),
    (BGR, "bgr8", BGR),
    (BGR[..., 0].copy(), "mono8", np.repeat(BGR[..., :1], 3, axis=2)),
    (np.dstack([BGR[..., ::-1], np.full((5, 7), 255, np.uint8)]), "rgba8", BGR),
])
@pytest.mark.parametrize("pad", [0, 3])
def test_colour_encodings_come_back_as_bgr(pixels: np.ndarray, encoding: str, expected: np.ndarray, pad: int) -> None:
    np.testing.assert_array_equal(image_from_msg(_image(pixels, encoding, pad=pad)), expected)


@pytest.mark.parametrize("big_endian", [False, True])
def test_depth_encodings_keep_their_values(big_endian: bool) -> None:
    mm = RNG.integers(0, 9000, (5, 7)).astype(np.uint16)
    np.testing.assert_array_equal(image_from_msg(_image(mm, "16UC1", pad=2, big_endian=big_endian)), mm)
    metres = RNG.uniform(0.3, 9.0, (5, 7)).astype(np.float32)
    np.testing.assert_array_equal(image_from_msg(_image(metres, "32FC1", big_endian=big_endian)), metres)


def test_what_does_not_read_is_a_value_error() -> None:
    with pytest.raises(ValueError, match="encoding 'yuv422'"):
        image_from_msg(_image(BGR[..., 0].copy(), "yuv422"))
    short = _image(BGR, "bgr8")
    short.data = short.data[:-5]
    with pytest.raises(ValueError, match="needs"):
        image_from_msg(short)
    info = T["sensor_msgs/msg/CameraInfo"](
        header=T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), frame_id=""),
        height=0, width=0, distortion_model="", d=np.zeros(0), k=np.zeros(9), r=np.zeros(9), p=np.zeros(12),
        binning_x=0, binning_y=0, roi=T["sensor_msgs/msg/RegionOfInterest"](x_offset=0, y_offset=0, height=0,
                                                                           width=0, do_rectify=False))
    with pytest.raises(ValueError, match="no calibration"):
        camera_matrix(info)
