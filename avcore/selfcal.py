"""Self-calibration: the affine correction c1, c0 of eq. (itd_up) learned while avhear runs (beyond the paper).

Section 5.3 fits c1, c0 on a minute of a loudspeaker carried across the view, where every ITD belongs to the one
face. Without that session, people talking in view give the same evidence, with two differences: several faces
may be in view, and only some of the time does one of them talk alone. So each result's time frame is used only
when its ITDs come from one source (their robust spread below ``max_spread_s``: two people talking at once, or
noise, spread them), and then as one observation, the ITDs' median tau, paired with every visible face's raw
mapping x_j = A(S_j): the true pairing lies on the line tau = c1 x + c0, the others scatter. The line that the
most observations support (each at most once, within ``tolerance_s``), among lines with a plausible scale and
offset, is found by RANSAC over pairs of observations and refined by least squares on its inliers, as section 5.3
refines its fit. A talker out of view gives observations paired only with the wrong faces: they scatter too.

``fit()`` returns None until the inliers span ``min_span_s`` of raw ITD (two people at least ten degrees apart,
or one who moved) and number ``min_inliers``; its ``confidence`` is the share of the one-source observations the
line explains. Observations older than ``memory`` are forgotten, so the estimate follows a microphone that moved.

With several pairs, the array's turn about the vertical relative to the camera (a rig file that places it wrongly,
a head that turned) is learned first (:class:`ArrayYawCalibration`): a source's ITD vector over the pairs points
in one direction of the array's own frame, so one face talking alone fixes the turn; the turn most one-source
observations agree with (and a common scale of the ITDs) is searched over the plausible range, then refined on
its inliers; the rig's placement stands until another turn clearly explains more.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from avcore.geometry import MicArray, MicPair

__all__ = ["ArrayYawCalibration", "SelfCalibration", "SelfCalibrationFit", "YawFit"]


@dataclass(frozen=True)
class SelfCalibrationFit:
    """c1, c0 (eq. itd_up); inliers: observations on the line; observations: one-source time frames kept;
    confidence: inliers / observations; scale_s: the inliers' residual standard deviation."""

    c1: float
    c0: float
    inliers: int
    observations: int
    confidence: float
    scale_s: float


@dataclass
class SelfCalibration:
    """Collects one-source time frames (:meth:`push`) and fits c1, c0 on them (:meth:`fit`); see the module."""

    mics: MicPair
    max_spread_s: float = 12e-6
    min_itds: int = 5
    tolerance_s: float = 8e-6
    min_inliers: int = 30
    min_span_s: float = 60e-6
    c1_range: tuple[float, float] = (0.5, 1.5)
    max_offset_s: float = 100e-6
    memory: int = 6000
    trials: int = 400
    seed: int = 0
    _obs: deque = field(init=False, repr=False)

    def __post_init__(self) -> None:
        if not (self.max_spread_s > 0 and self.tolerance_s > 0 and self.min_span_s > 0):
            raise ValueError("max_spread_s, tolerance_s and min_span_s must be > 0 seconds")
        if not (self.min_itds >= 2 and self.min_inliers >= 2 and self.memory >= self.min_inliers):
            raise ValueError("need min_itds >= 2, min_inliers >= 2 and memory >= min_inliers")
        self._obs = deque(maxlen=self.memory)

    def __len__(self) -> int:
        return len(self._obs)

    def push(self, faces_xyz: np.ndarray, itds_s: np.ndarray) -> bool:
        """One result: its visible faces (N, 3) metres and its time frame's ITDs (K,) seconds on this pair. Kept
        (True) when there is a face and the ITDs come from one source."""
        faces = np.asarray(faces_xyz, dtype=np.float64).reshape(-1, 3)
        itds = np.asarray(itds_s, dtype=np.float64).reshape(-1)
        itds = itds[np.isfinite(itds)]
        if faces.shape[0] == 0 or itds.size < self.min_itds:
            return False
        tau = float(np.median(itds))
        if 1.4826 * float(np.median(np.abs(itds - tau))) > self.max_spread_s:
            return False
        self._obs.append((tau, self.mics.raw_itd(faces).reshape(-1)))
        return True

    def fit(self) -> SelfCalibrationFit | None:
        """The line most one-source observations support, refined on its inliers; None while too few support it
        or they span too little."""
        if len(self._obs) < self.min_inliers:
            return None
        tau = np.array([t for t, _ in self._obs])
        xs = [x for _, x in self._obs]
        owner = np.concatenate([np.full(x.size, k) for k, x in enumerate(xs)])
        x_all = np.concatenate(xs)
        y_all = tau[owner]
        rng = np.random.default_rng(self.seed)
        i = rng.integers(0, x_all.size, self.trials)
        j = rng.integers(0, x_all.size, self.trials)
        dx = x_all[j] - x_all[i]
        ok = (owner[i] != owner[j]) & (np.abs(dx) > self.min_span_s / 4)
        if not ok.any():
            return None
        c1 = (y_all[j] - y_all[i])[ok] / dx[ok]
        c0 = y_all[i][ok] - c1 * x_all[i][ok]
        plausible = (c1 >= self.c1_range[0]) & (c1 <= self.c1_range[1]) & (np.abs(c0) <= self.max_offset_s)
        if not plausible.any():
            return None
        c1, c0 = c1[plausible], c0[plausible]
        # each candidate line's support: the observations (groups of points, in order) with a point near it
        close = np.abs(y_all[None, :] - (c1[:, None] * x_all[None, :] + c0[:, None])) <= self.tolerance_s
        starts = np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
        best = int(np.argmax(np.logical_or.reduceat(close, starts, axis=1).sum(axis=1)))
        n, picked = self._support(x_all, y_all, owner, c1[best], c0[best])
        if n < self.min_inliers or np.ptp(x_all[picked]) < self.min_span_s:
            return None
        a, b = np.polyfit(x_all[picked], y_all[picked], 1)
        n, picked = self._support(x_all, y_all, owner, a, b)  # the refined line's own inliers, once more
        if n < self.min_inliers:
            return None
        a, b = np.polyfit(x_all[picked], y_all[picked], 1)
        residual = y_all[picked] - (a * x_all[picked] + b)
        return SelfCalibrationFit(float(a), float(b), int(n), len(self._obs), n / len(self._obs),
                                  float(np.std(residual)))

    def _support(self, x: np.ndarray, y: np.ndarray, owner: np.ndarray, c1: float, c0: float
                 ) -> tuple[int, np.ndarray]:
        """The observations within ``tolerance_s`` of the line, each counted once (its nearest face)."""
        r = np.abs(y - (c1 * x + c0))
        close = r <= self.tolerance_s
        if not close.any():
            return 0, close
        order = np.lexsort((r, owner))  # by observation, nearest first
        first = np.zeros(x.size, dtype=bool)
        keep = order[np.r_[True, owner[order][1:] != owner[order][:-1]]]
        first[keep] = True
        picked = close & first
        return int(picked.sum()), picked


@dataclass(frozen=True)
class YawFit:
    """The array's turn about the vertical (radians, :meth:`avcore.geometry.MicArray.turned`); scale: the ITDs'
    common scale found with it (every pair's c1); inliers: one-source observations it explains; observations: those
    kept; confidence: inliers / observations; scale_s: the inliers' root-mean-square residual over the pairs."""

    yaw_rad: float
    scale: float
    inliers: int
    observations: int
    confidence: float
    scale_s: float


@dataclass
class ArrayYawCalibration:
    """Collects one-source time frames of an array (:meth:`push`) and finds its turn about the vertical
    (:meth:`fit`) that maps the most of them onto a visible face; see the module.

    An observation is the median ITD of each pair over the time frame, with the visible faces; a pair counts when it
    has ``min_itds`` ITDs spread less than ``max_spread_s`` (one source), and the observation is kept when more than
    half of the pairs count (two people at once spread most of them). A turn explains it when one face's ITD
    vector, on the array so turned with its correction, lies within ``tolerance_s`` of it (the median over the
    pairs of the absolute differences) with the ITDs of every pair times a common scale: measured ITDs come out
    shorter than the geometry's (reverberation pulls them towards zero, section 5.3's c1), by the same share on
    every pair. Turn and scale are searched every ``coarse_deg`` within ``max_yaw_deg`` and every
    ``coarse_scale`` within ``scale_range``, then by ``fine_deg`` and ``fine_scale`` within one coarse step of the
    best, the latter on the best's inliers by their mean squared residual.
    """

    array: MicArray
    max_spread_s: float = 12e-6
    min_itds: int = 5
    tolerance_s: float = 10e-6
    min_inliers: int = 20
    max_yaw_deg: float = 45.0
    coarse_deg: float = 1.0
    scale_range: tuple[float, float] = (0.7, 1.1)
    coarse_scale: float = 0.05
    coarse_observations: int = 150
    switch_margin: float = 1.25
    memory: int = 600
    _obs: deque = field(init=False, repr=False)
    _turned: list = field(init=False, repr=False, default_factory=list)

    def __post_init__(self) -> None:
        if self.array.n_pairs < 2:
            raise ValueError("the array's turn needs at least two pairs")
        if not (self.max_spread_s > 0 and self.tolerance_s > 0):
            raise ValueError("max_spread_s and tolerance_s must be > 0 seconds")
        if not (0 < self.coarse_deg <= self.max_yaw_deg <= 180):
            raise ValueError("need 0 < coarse_deg <= max_yaw_deg <= 180 degrees")
        if not (0 < self.coarse_scale and 0 < self.scale_range[0] < self.scale_range[1]):
            raise ValueError("need 0 < coarse_scale and 0 < scale_range[0] < scale_range[1]")
        if not (self.min_itds >= 2 and self.min_inliers >= 2 and self.memory >= self.min_inliers):
            raise ValueError("need min_itds >= 2, min_inliers >= 2 and memory >= min_inliers")
        if not self.switch_margin >= 1:
            raise ValueError(f"switch_margin must be >= 1, got {self.switch_margin}")
        self._obs = deque(maxlen=self.memory)

    def __len__(self) -> int:
        return len(self._obs)

    def push(self, faces_xyz: np.ndarray, itds_s: np.ndarray) -> bool:
        """One result: its visible faces (N, 3) metres and its time frame's ITD vectors (K, P) seconds (NaN where a
        pair has none). Kept (True) when there is a face and every pair's ITDs come from one source."""
        faces = np.asarray(faces_xyz, dtype=np.float64).reshape(-1, 3)
        itds = np.asarray(itds_s, dtype=np.float64).reshape(-1, self.array.n_pairs)
        if faces.shape[0] == 0:
            return False
        tau = np.full(self.array.n_pairs, np.inf)  # a pair without enough ITDs: never within the tolerance
        for p in range(self.array.n_pairs):
            x = itds[:, p][np.isfinite(itds[:, p])]
            if x.size < self.min_itds:
                continue
            mid = float(np.median(x))
            if 1.4826 * float(np.median(np.abs(x - mid))) <= self.max_spread_s:
                tau[p] = mid
        if np.sum(np.isfinite(tau)) <= self.array.n_pairs // 2:  # the residual is the median over the pairs
            return False
        self._obs.append((tau, faces))
        return True

    def _coarse(self) -> list[tuple[float, MicArray]]:
        """The coarse grid's turns and the array turned by each, made on the first fit and kept."""
        if not self._turned:
            yaws = np.deg2rad(np.arange(-self.max_yaw_deg, self.max_yaw_deg + 1e-9, self.coarse_deg))
            self._turned = [(float(y), self.array.turned(float(y))) for y in yaws]
        return self._turned

    def _residuals(self, turned: MicArray, scales: np.ndarray, tau: np.ndarray, faces: np.ndarray,
                   owner: np.ndarray, starts: np.ndarray) -> np.ndarray:
        """(scales, observations): each observation's residual (seconds) with its best face, on the array
        ``turned`` with its ITDs times each scale."""
        predicted = turned.itd(faces)  # (F, P)
        r = np.median(np.abs(tau[owner][None] - scales[:, None, None] * predicted[None]), axis=2)  # (S, F)
        return np.minimum.reduceat(r, starts, axis=1)

    def fit(self, incumbent_rad: float = 0.0) -> YawFit | None:
        """The turn the most one-source observations agree with, refined on them; None while fewer than
        ``min_inliers`` agree. ``incumbent_rad``, the turn in use (0: the rig file's placement), stays unless
        another explains ``switch_margin`` times as many observations: the rig is believed until the data clearly
        says otherwise, and one talker out of view that a wrong turn maps onto a face does not move it."""
        if len(self._obs) < self.min_inliers:
            return None
        obs = list(self._obs)
        every = max(1, len(obs) // self.coarse_observations)
        scales = np.arange(self.scale_range[0], self.scale_range[1] + 1e-9, self.coarse_scale)
        sub = _stacked(obs[::every])
        (yaw, scale), inside = self._best(self._coarse(), scales, sub, None)
        held = self._residuals(self.array.turned(incumbent_rad), scales, *sub) <= self.tolerance_s  # (S, O)
        if inside.sum() < self.switch_margin * held.sum(axis=1).max():
            yaw, scale = incumbent_rad, float(scales[int(np.argmax(held.sum(axis=1)))])
        data = _stacked(obs)
        keep = self._residuals(self.array.turned(yaw), np.array([scale]), *data)[0] <= self.tolerance_s
        if keep.sum() < self.min_inliers:
            return None
        # within half a coarse step (and a little) of the coarse best, on its inliers
        yaws = yaw + np.deg2rad(np.arange(-0.6, 0.6 + 1e-9, 0.2) * self.coarse_deg)
        scales = scale + np.arange(-0.6, 0.6 + 1e-9, 0.2) * self.coarse_scale
        (yaw, scale), _ = self._best([(float(y), self.array.turned(float(y))) for y in yaws], scales, data, keep)
        r = self._residuals(self.array.turned(yaw), np.array([scale]), *data)[0]
        inside = r <= self.tolerance_s
        n = int(inside.sum())
        if n < self.min_inliers:
            return None
        rms = float(np.sqrt(np.mean(r[inside] ** 2)))
        return YawFit(float(yaw), float(scale), n, len(obs), n / len(obs), rms)

    def _best(self, turns: list[tuple[float, MicArray]], scales: np.ndarray, data: tuple, keep: np.ndarray | None
              ) -> tuple[tuple[float, float], np.ndarray]:
        """Over the grid of turns (each with its turned array) and scales: the most inliers, then the smallest mean
        squared residual among them (``keep`` given: the smallest mean squared residual of those observations)."""
        best_key, best = None, None
        for yaw, turned in turns:
            res = self._residuals(turned, scales, *data)  # (S, O)
            inside = res <= self.tolerance_s if keep is None else np.broadcast_to(keep, res.shape)
            counts = inside.sum(axis=1)
            mse = (np.where(inside, res, 0.0) ** 2).sum(axis=1) / np.maximum(counts, 1)
            for k in range(scales.size):
                key = (-int(counts[k]), float(mse[k]))
                if best_key is None or key < best_key:
                    best_key, best = key, ((float(yaw), float(scales[k])), inside[k])
        assert best is not None
        return best


def _stacked(obs: list) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Observations [(tau (P,), faces (N, 3))] as tau (O, P), faces (F, 3), each face's observation (F,), and
    where each observation's faces start (O,)."""
    tau = np.array([t for t, _ in obs])
    faces = np.concatenate([f for _, f in obs])
    owner = np.concatenate([np.full(f.shape[0], k) for k, (_, f) in enumerate(obs)])
    return tau, faces, owner, np.flatnonzero(np.r_[True, owner[1:] != owner[:-1]])
