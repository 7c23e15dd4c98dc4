"""Whether the microphones are where the rig file says (beyond the paper): a wrong preset or a mismeasured spacing
otherwise fails silently, every ITD mapped through the wrong geometry.

Two signs, per pair, from what the run hears anyway:

- ITDs beyond what the pair's declared spacing allows in free field (``d / nu``): the extractor searches lags up to
  1.2 times that, so a pair wider than declared puts a share of its ITDs out there (a share above
  ``beyond_share`` of at least ``min_itds_total`` ITDs counts). The results where a face in view lies near the
  pair's axis (its ITD over ``endfire_share`` of the reach) are counted apart, with ``endfire_beyond_share``: a
  pair that points at its talkers (a flat array's front-back pair, people ahead) hears them at the reach itself,
  and the measurement's spread puts a share past it, up to the search's edge (docs/experiments.md, 2026-11-29);
  microphones farther apart than declared put most of them there. So are the results with no face in view: their
  sound may come from the axis too;
- one-source ITDs that are a steady multiple of what the geometry predicts for the face that talks: a time frame
  whose ITDs on a pair spread less than ``max_spread_s`` (one source, as :mod:`avcore.selfcal` takes them) gives
  the ratio of their median to the raw ITD (eq. itd) of the face that explains it (with one pair: the one face in
  view; with an array: the face whose ITD vector, scaled within ``plausible_scale``, lies closest to the medians,
  and only when it fits ``clear_margin`` times better than the next face: with three people a freely scaled
  vector of the wrong face, even turned round by a negative scale, often fits best), where that face's ITD is
  at least ``min_itd_s`` off zero and the ratio within ``plausible_scale`` (a face alone in view is not the only
  possible source: a person the camera missed, the noise behind the robot). Reverberation pulls measured ITDs
  towards zero (section 5.3's c1) and a head between the microphones lengthens them (NAO's rear pairs:
  docs/experiments.md), so only a median ratio outside ``scale_range`` over ``min_observations`` counts.

Each finding says which pair, the spacing the rig file declares and the one the sound suggests.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from avcore.geometry import MicArray

__all__ = ["MicCheck", "MicFinding"]


@dataclass(frozen=True)
class MicFinding:
    """pair : the pair's index; mics : its two microphones; kind : "beyond" (ITDs beyond the spacing's reach) or
    "scale" (one-source ITDs a steady multiple of the geometry's); value : the share beyond, or the median ratio;
    declared_m : the rig file's spacing; implied_m : the spacing the sound suggests (at least, for "beyond");
    observations : the ITDs (beyond) or one-source time frames (scale) it rests on."""

    pair: int
    mics: tuple[int, int]
    kind: str
    value: float
    declared_m: float
    implied_m: float
    observations: int

    def message(self) -> str:
        i, j = self.mics
        said = f"microphones {i} and {j} ({1e3 * self.declared_m:.0f} mm apart in the rig file)"
        check = "Check the rig file's microphones (array: preset or positions_m, or the microphones section)"
        if self.kind == "beyond":
            return (f"{said}: {self.value:.0%} of their ITDs exceed what that spacing allows, so they are farther "
                    f"apart: at least {1e3 * self.implied_m:.0f} mm. {check}")
        return (f"{said}: the ITDs heard are {self.value:.2f} times what that geometry predicts for the faces in view "
                f"({self.observations} times one person talked), so they are about {1e3 * self.implied_m:.0f} mm "
                f"apart. {check}")


@dataclass
class MicCheck:
    """Collects each result's faces and ITDs (:meth:`push`) and says what they show (:meth:`findings`)."""

    array: MicArray
    max_spread_s: float = 12e-6
    min_itds: int = 5
    min_itd_s: float = 60e-6
    min_observations: int = 40
    scale_range: tuple[float, float] = (0.75, 1.6)
    min_itds_total: int = 300
    beyond_share: float = 0.1
    beyond_margin: float = 1.05
    endfire_share: float = 0.8
    endfire_beyond_share: float = 0.4
    clear_margin: float = 2.0
    plausible_scale: tuple[float, float] = (0.4, 2.5)
    _ratios: list[list[float]] = field(init=False, repr=False)
    _counts: np.ndarray = field(init=False, repr=False)
    _beyond: np.ndarray = field(init=False, repr=False)
    _largest: list[list[float]] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        p = self.array.n_pairs
        self._ratios = [[] for _ in range(p)]
        self._counts = np.zeros((2, p), np.int64)  # ITDs of results without, with a face near the pair's axis
        self._beyond = np.zeros((2, p), np.int64)
        self._largest = [[] for _ in range(p)]
        self._reach = np.array([self.array.pair(k).max_itd_s for k in range(p)])

    def push(self, faces_xyz: np.ndarray, itds_s: np.ndarray) -> None:
        """One result: the visible faces (N, 3) metres and its time frame's ITDs (K, P) seconds."""
        itds = np.asarray(itds_s, dtype=np.float64).reshape(-1, self.array.n_pairs)
        finite = np.isfinite(itds)
        faces = np.asarray(faces_xyz, dtype=np.float64).reshape(-1, 3)
        raw = self.array.raw_itd(faces).reshape(faces.shape[0], self.array.n_pairs)  # (N, P)
        endfire = (np.abs(raw) > self.endfire_share * self._reach).any(axis=0).astype(int)  # (P,) 0 or 1
        if faces.shape[0] == 0:  # nothing says where the sound comes from: the axis too
            endfire[:] = 1
        columns = np.arange(self.array.n_pairs)
        np.add.at(self._counts, (endfire, columns), finite.sum(axis=0))
        out = finite & (np.abs(np.where(finite, itds, 0.0)) > self.beyond_margin * self._reach)
        np.add.at(self._beyond, (endfire, columns), out.sum(axis=0))
        for p in np.flatnonzero(out.any(axis=0)):
            if len(self._largest[p]) < 5000:
                self._largest[p].extend(np.abs(itds[out[:, p], p]).tolist())
        if faces.shape[0] == 0:
            return
        tau = np.full(self.array.n_pairs, np.nan)
        for p in range(self.array.n_pairs):
            column = itds[finite[:, p], p]
            if column.size >= self.min_itds:
                median = float(np.median(column))
                if 1.4826 * float(np.median(np.abs(column - median))) <= self.max_spread_s:
                    tau[p] = median
        ok = np.isfinite(tau)
        if not ok.any():
            return
        if self.array.n_pairs == 1 or ok.sum() == 1:
            if faces.shape[0] != 1:
                return  # one pair cannot tell which face talks
            face = 0
        else:
            x = raw[:, ok]
            scale = (x @ tau[ok]) / np.maximum((x * x).sum(axis=1), 1e-18)
            scale = np.clip(scale, *self.plausible_scale)
            residual = np.linalg.norm(tau[ok][None] - scale[:, None] * x, axis=1)
            order = np.argsort(residual)
            face = int(order[0])
            if order.size > 1 and residual[order[1]] < self.clear_margin * residual[face]:
                return  # two faces explain these ITDs about as well: whose they are is not known
        lo, hi = self.plausible_scale
        for p in np.flatnonzero(ok & (np.abs(raw[face]) >= self.min_itd_s)):
            ratio = float(tau[p] / raw[face, p])
            if lo <= ratio <= hi:  # else another source spoke (a person the camera missed, the noise behind)
                self._ratios[p].append(ratio)

    def findings(self) -> list[MicFinding]:
        out = []
        for p in range(self.array.n_pairs):
            mics = tuple(int(m) for m in self.array.pairs[p])  # type: ignore[index]
            declared = self.array.pair(p).distance_m
            wide = [n >= self.min_itds_total and beyond / n > limit for n, beyond, limit in
                    zip(self._counts[:, p], self._beyond[:, p], (self.beyond_share, self.endfire_beyond_share))]
            n, beyond = int(self._counts[:, p].sum()), int(self._beyond[:, p].sum())
            if any(wide):
                far = float(np.percentile(self._largest[p], 90)) if self._largest[p] else 0.0
                out.append(MicFinding(p, mics, "beyond", beyond / n, declared, declared * far / self._reach[p], n))
                continue
            ratios = self._ratios[p]
            if len(ratios) >= self.min_observations:
                scale = float(np.median(ratios))
                if not self.scale_range[0] <= scale <= self.scale_range[1]:
                    out.append(MicFinding(p, mics, "scale", scale, declared, declared * scale, len(ratios)))
        return out
