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
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import numpy as np

from avcore.geometry import MicPair

__all__ = ["SelfCalibration", "SelfCalibrationFit"]


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
