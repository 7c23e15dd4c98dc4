"""The topic names of the ROS 2 drivers avhear reads (``--source ros``) and `avhear sensors --ros` imitates, known
without loading the message types (the command line's defaults)."""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["RosTopics"]


@dataclass(frozen=True)
class RosTopics:
    """The topics of a ROS 2 robot's RGB-D camera and microphone as their drivers name them by default:
    realsense2_camera 4.x (``align_depth.enable:=true``: colour rgb8, depth 16UC1 millimetres aligned to it, the
    colour camera's CameraInfo) and audio_common's ``audio_capture`` (namespace ``audio``; ``format:=wave``).
    Read by :class:`app.bus.ros_source.RosSource`, published by :class:`app.bus.sensors.RosDriverPublisher`."""

    colour: str = "/camera/camera/color/image_raw"
    depth: str = "/camera/camera/aligned_depth_to_color/image_raw"
    camera_info: str = "/camera/camera/color/camera_info"
    audio: str = "/audio/audio_stamped"
    audio_info: str = "/audio/audio_info"
