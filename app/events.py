"""The items a stream delivers: stereo frames as a camera does, audio blocks as a sound card does.

Shared by every source (live devices, the simulated room, recordings) and by the pipeline that consumes them.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["AudioBlock", "StereoFrame"]


@dataclass(frozen=True, eq=False)
class StereoFrame:
    """One frame of the cameras: a stereo pair, or an RGB-D camera's colour and depth.

    index : frame number from 0; stamp_s, right_stamp_s : capture times of the left and right images, seconds on the
    stream clock; left, right : (h, w, 3) uint8 BGR images (rectified for the simulator; as recorded otherwise);
    depth_m : an RGB-D camera's depth aligned to ``left`` (its colour image), (h, w) float32 metres, NaN where it
    has none; ``right`` is None then. Ground truth is not the camera's: a source that knows it answers
    ``source.truth(index)`` (the simulator, a recording with ``truth.csv``).
    """

    index: int
    stamp_s: float
    left: np.ndarray
    right: np.ndarray | None
    right_stamp_s: float
    depth_m: np.ndarray | None = None


@dataclass(frozen=True, eq=False)
class AudioBlock:
    """One block of samples as a sound card delivers it.

    index : block number from 0; first_sample : absolute index of its first sample in the stream; stamp_s : time of
    that sample, seconds (``audio_start + first_sample / samplerate_hz``); samples : (n, C) float32 in [-1, 1),
    channel order as in the recording (the simulator: 0 = left, 1 = right microphone).
    """

    index: int
    first_sample: int
    stamp_s: float
    samples: np.ndarray
    samplerate_hz: int

    @property
    def end_stamp_s(self) -> float:
        """Time just after the last sample, seconds: when a sound card hands the block over."""
        return self.stamp_s + self.samples.shape[0] / self.samplerate_hz
