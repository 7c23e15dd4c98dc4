"""Input checks shared by avcore: arrays of the right shape, finite values, errors that name the argument."""
from __future__ import annotations

import numpy as np


def as_points(points: object, name: str = "points", *, allow_empty: bool = True) -> np.ndarray:
    """Return ``points`` as a float64 ``(n, 3)`` array of finite metres, or raise ``ValueError``."""
    arr = np.asarray(points, dtype=np.float64)
    if arr.ndim == 1 and arr.size == 0:
        arr = arr.reshape(0, 3)
    if arr.ndim != 2 or arr.shape[1] != 3:
        raise ValueError(f"{name} must be an (n, 3) array of metres, got shape {arr.shape}")
    if not allow_empty and arr.shape[0] == 0:
        raise ValueError(f"{name} must hold at least one point, got none")
    if not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr).all(axis=1)))
        raise ValueError(f"{name} holds {bad} row(s) with NaN or infinite coordinates; drop them before the call")
    return arr


def as_samples(values: object, name: str, unit: str = "seconds") -> np.ndarray:
    """Return ``values`` as a finite float64 1-D array, or raise ``ValueError``."""
    arr = np.asarray(values, dtype=np.float64)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array of {unit}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        raise ValueError(f"{name} holds {bad} NaN or infinite value(s); drop them before the call")
    return arr


def as_weights(weights: object, n: int, name: str = "weights") -> np.ndarray:
    """Return non-negative finite weights of length ``n``."""
    arr = np.asarray(weights, dtype=np.float64)
    if arr.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name} must be finite and non-negative")
    return arr
