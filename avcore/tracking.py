"""Stable person identities across time intervals (avhear, beyond the paper's instantaneous processing).

The paper processes each interval on its own (section 7.2: "because of the instantaneous processing of robocentric
data"); a console that plots each person's speaking probability over time needs to know that the face at
(0.4, 0, 2.1) now is the face at (0.41, 0, 2.1) a frame ago. People move little between frames, so a greedy
nearest-neighbour association in 3D with a distance gate is enough; a person unseen for a while (a missed
detection, an occlusion, a walk out of view and back to about the same place) keeps their identity: for
``max_missed`` updates, or, given the updates' stamps, for ``memory_s`` seconds (:data:`PERSON_MEMORY_S`, the 10 s
over which ROS4HRI's person manager lets a person's location confidence fall to 0).
"""
from __future__ import annotations

import numpy as np

from avcore._validate import as_points

__all__ = ["PERSON_MEMORY_S", "NearestTracker"]

PERSON_MEMORY_S = 10.0


class NearestTracker:
    """Assign stable integer ids to 3D positions update after update.

    gate_m : a position farther than this from every known person is a new person, metres.
    max_missed : a person unseen for more updates than this is forgotten (updates without a stamp).
    memory_s : a person unseen for longer than this is forgotten, seconds (updates with a stamp).
    """

    def __init__(self, gate_m: float = 0.4, max_missed: int = 15, memory_s: float = PERSON_MEMORY_S) -> None:
        if not gate_m > 0:
            raise ValueError(f"gate_m must be > 0 metres, got {gate_m!r}")
        if max_missed < 0:
            raise ValueError(f"max_missed must be >= 0, got {max_missed!r}")
        self.gate_m = float(gate_m)
        self.max_missed = int(max_missed)
        if not memory_s > 0:
            raise ValueError(f"memory_s must be > 0 seconds, got {memory_s!r}")
        self.memory_s = float(memory_s)
        self._seen_s = np.empty(0)
        self._ids = np.empty(0, dtype=np.int64)
        self._pos = np.empty((0, 3))
        self._missed = np.empty(0, dtype=np.int64)
        self._next = 0

    def new_id(self) -> int:
        """An id no person has had nor will have: for what the tracker does not follow (a voice out of view) but
        that must not share a number with a person."""
        self._next += 1
        return self._next - 1

    def update(self, positions: object, stamp_s: float | None = None) -> np.ndarray:
        """positions : (N, 3) metres -> (N,) int ids, in the order of ``positions``; stamp_s : the update's time,
        seconds (then ``memory_s`` decides who is forgotten, else ``max_missed``)."""
        pts = as_points(positions, "positions")
        ids = np.full(pts.shape[0], -1, dtype=np.int64)
        if self._ids.size and pts.shape[0]:
            d = np.linalg.norm(pts[:, None, :] - self._pos[None, :, :], axis=2)
            # greedy: the closest pair first, each person and each position used once
            for flat in np.argsort(d, axis=None):
                i, j = divmod(int(flat), d.shape[1])
                if d[i, j] > self.gate_m:
                    break
                if ids[i] >= 0 or np.isin(self._ids[j], ids):
                    continue
                ids[i] = self._ids[j]
        seen = np.isin(self._ids, ids)
        self._missed[seen] = 0
        self._missed[~seen] += 1
        for i in np.flatnonzero(ids < 0):
            ids[i] = self._next
            self._next += 1
        now = np.nan if stamp_s is None else float(stamp_s)
        self._seen_s[seen] = now
        if stamp_s is None:
            keep = self._missed <= self.max_missed
        else:
            with np.errstate(invalid="ignore"):  # a person last seen in an update without a stamp: NaN, kept
                keep = ~(now - self._seen_s > self.memory_s)
        old_ids, old_pos, old_missed = self._ids[keep], self._pos[keep], self._missed[keep]
        old_seen = self._seen_s[keep]
        # the known people take their new positions; newcomers are added
        new = ~np.isin(ids, old_ids)
        for k, pid in enumerate(old_ids):
            where = np.flatnonzero(ids == pid)
            if where.size:
                old_pos[k] = pts[where[0]]
        self._ids = np.concatenate([old_ids, ids[new]])
        self._pos = np.concatenate([old_pos, pts[new]])
        self._missed = np.concatenate([old_missed, np.zeros(int(new.sum()), dtype=np.int64)])
        self._seen_s = np.concatenate([old_seen, np.full(int(new.sum()), now)])
        return ids
