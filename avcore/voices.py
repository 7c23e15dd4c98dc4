"""A voice that no visible person explains, and where it comes from (several microphone pairs).

Algorithm 2 gives every ITD to a visible face or to the outlier class; a talker out of view only feeds the outliers.
With several pairs the outliers carry a direction: a sound from direction u reaches the pairs with the ITDs that the
array's own mapping gives a point along u (eq. itd_up per pair, its correction included). So the ITD vectors of a
time frame that no face explains (no face's mapped ITD vector within ``tolerance_s`` on more than half of the pairs)
are matched against the mapped vectors of a grid of directions, computed once an array (every degree of azimuth,
elevations every 5 degrees where the microphones span some height, points ``distance_m`` away); the direction that
explains the most of them, at least ``min_windows``, is a voice. Its distance is unknown: only its direction is
reported.

Azimuth is measured in the scene frame (x right, y down, z forward) from straight ahead, positive to the right;
elevation positive upwards. A pair alone cannot tell front from back; an array whose pairs point several ways can.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from avcore.geometry import MicArray

__all__ = ["VoiceDirection", "VoiceTracks", "direction_vector", "unexplained_voice"]

_MIN_HEIGHT_SPAN_M = 0.10  # microphones spanning less height than this cannot tell elevation (NAO's 4.8 cm cannot)


@dataclass(frozen=True)
class VoiceDirection:
    """azimuth_rad, elevation_rad (None: the array cannot tell); windows : the ITD vectors it explains."""

    azimuth_rad: float
    elevation_rad: float | None
    windows: int


def direction_vector(azimuth_rad: np.ndarray, elevation_rad: np.ndarray) -> np.ndarray:
    """Unit vectors (..., 3) in the scene frame for azimuths (from ahead, positive right) and elevations (up)."""
    az, el = np.asarray(azimuth_rad, dtype=np.float64), np.asarray(elevation_rad, dtype=np.float64)
    return np.stack([np.sin(az) * np.cos(el), -np.sin(el), np.cos(az) * np.cos(el)], axis=-1)


def _grid(array: MicArray) -> tuple[np.ndarray, np.ndarray]:
    """Every degree of azimuth; elevations every 5 degrees from -30 to 30 when the microphones span any height
    (a talker above or below the array's plane then fits better, even where the elevation itself is not told)."""
    azimuths = np.radians(np.arange(-180.0, 180.0, 1.0))
    heights = np.asarray(array.positions, dtype=np.float64)[:, 1]
    elevations = np.radians(np.arange(-30.0, 31.0, 5.0)) if np.ptp(heights) > 0.0 else np.zeros(1)
    az, el = np.meshgrid(azimuths, elevations, indexing="ij")
    return az.ravel(), el.ravel()


_PREDICTED: dict = {}  # (id of the array, distance) -> its grid's mapped ITDs: the same array every result


def _predicted(array: MicArray, distance_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    key = (id(array), float(distance_m))
    cached = _PREDICTED.get(key)
    if cached is None or cached[0] is not array:
        az, el = _grid(array)
        cached = (array, az, el, array.itd(distance_m * direction_vector(az, el)))
        if len(_PREDICTED) > 8:
            _PREDICTED.clear()
        _PREDICTED[key] = cached
    return cached[1], cached[2], cached[3]


def unexplained_voice(itds_s: np.ndarray, array: MicArray, faces_xyz: np.ndarray, *, tolerance_s: float = 20e-6,
                      min_windows: int = 4, distance_m: float = 2.0,
                      face_margin_rad: float = np.radians(15.0)) -> VoiceDirection | None:
    """itds_s (K, P): a time frame's ITD vectors (NaN: a pair without one); faces_xyz (N, 3) metres: the visible
    faces. The direction of the ITD vectors that no face explains, or None (fewer than ``min_windows`` agree, or
    its azimuth lies within ``face_margin_rad`` of a visible face's: that face's own ITDs, off its mapping)."""
    if array.n_pairs < 2:
        return None
    itds = np.asarray(itds_s, dtype=np.float64).reshape(-1, array.n_pairs)
    itds = itds[np.isfinite(itds).sum(axis=1) >= max(2, array.n_pairs // 2)]  # enough pairs to point somewhere
    faces = np.asarray(faces_xyz, dtype=np.float64).reshape(-1, 3)
    if faces.shape[0]:
        mapped = array.itd(faces)  # (N, P)
        present = np.isfinite(itds).sum(axis=1)
        near = (np.abs(itds[:, None, :] - mapped[None, :, :]) < tolerance_s).sum(axis=2)  # (K, N)
        itds = itds[~(2 * near > present[:, None]).any(axis=1)]
    if itds.shape[0] < min_windows:
        return None
    az, el, predicted = _predicted(array, distance_m)  # (G,), (G,), (G, P)
    # a window fits a direction where most of its pairs do (more than half of them within the tolerance)
    present = np.isfinite(itds).sum(axis=1)
    near = (np.abs(itds[None, :, :] - predicted[:, None, :]) < tolerance_s).sum(axis=2)  # (G, K); NaN: no
    counts = (2 * near > present[None, :]).sum(axis=1)
    best = int(np.argmax(counts))
    if counts[best] < min_windows:
        return None
    # the middle of the directions that explain as many (a plateau, not its first degree)
    ties = np.flatnonzero(counts == counts[best])
    ties = ties[np.abs(np.angle(np.exp(1j * (az[ties] - az[best])))) <= np.radians(20.0)]
    azimuth = float(np.angle(np.mean(np.exp(1j * az[ties]))))
    elevation = float(np.mean(el[ties])) if np.ptp(np.asarray(array.positions)[:, 1]) >= _MIN_HEIGHT_SPAN_M else None
    if faces.shape[0]:  # in azimuth: people's heads stand at different heights, the same voice's direction
        beside = np.abs(np.angle(np.exp(1j * (np.arctan2(faces[:, 0], faces[:, 2]) - azimuth))))
        if (beside < face_margin_rad).any():
            return None
    return VoiceDirection(azimuth, elevation, int(counts[best]))


@dataclass(eq=False)
class VoiceTracks:
    """Stable ids for the voices out of view: a voice within ``same_rad`` of the azimuth of one heard in the last
    ``memory_s`` (10 s, as ROS4HRI's person manager remembers a person) keeps its id (the nearest such); otherwise
    it gets the next id. A voice is reported once heard in ``confirm`` results in a row: a single result's stray fit
    is not a talker, as a tracker does not start a track on one detection. ``update(stamp_s, voice)``, once per
    result (``voice`` None where the result has none) -> its id, or None while not confirmed. ``new_id`` draws a
    new voice's id (e.g. :meth:`avcore.tracking.NearestTracker.new_id`, so that people and voices share one
    numbering); without it the voices count from 0."""

    same_rad: float = np.radians(20.0)
    memory_s: float = 10.0
    confirm: int = 3
    _last: dict = field(default_factory=dict, init=False, repr=False)  # id -> (stamp, azimuth, results in a row)
    _next: int = field(default=0, init=False, repr=False)

    def update(self, stamp_s: float, voice: VoiceDirection | None,
               new_id: Callable[[], int] | None = None) -> int | None:
        self._last = {i: v for i, v in self._last.items() if stamp_s - v[0] <= self.memory_s}
        if voice is None:  # a result without a voice breaks every row
            self._last = {i: (t, a, 0) for i, (t, a, _) in self._last.items()}
            return None
        near = [(abs(np.angle(np.exp(1j * (a - voice.azimuth_rad)))), i) for i, (_, a, _) in self._last.items()]
        near = [(d, i) for d, i in near if d <= self.same_rad]
        run = 1
        if near:
            vid = min(near)[1]
            run = self._last[vid][2] + 1
        elif new_id is not None:
            vid = int(new_id())
        else:
            vid, self._next = self._next, self._next + 1
        self._last[vid] = (float(stamp_s), voice.azimuth_rad, run)
        return vid if run >= self.confirm else None
