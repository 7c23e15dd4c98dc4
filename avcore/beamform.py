"""One person's voice from a microphone array, steered at where the cameras see them (issue 59's candidates).

The paper's introduction: once the robot knows who speaks it should "maximize the signal-to-noise ratio, and
eventually retrieve a clean speech signal". Everything here works on short-time Fourier transforms ``X`` of shape
(Q, F, T): Q microphones, F frequencies, T frames.

* :func:`steering` -- the direct path's relative transfer from a point to each microphone, the first microphone the
  reference: ``a_q(f) = exp(-2 i pi f (|s - m_q| - |s - m_0|) / c)``, so that a source at ``s`` gives
  ``X_q = a_q X_0`` in free field (the same delays as the ITDs of eq. itd, on every pair at once).
* :func:`delay_and_sum` -- ``y = a^H X / Q``: the sound from ``s`` adds in phase, the rest does not (ODAS's default,
  the baseline).
* :func:`mvdr_weights` -- the minimum-variance distortionless response, ``w = R^-1 a / (a^H R^-1 a)``, with ``R``
  the covariance of what is not the target (the other talkers and the noise), learned from the frames where the
  target is silent (:func:`covariance`; the speaking states say when): the target passes unchanged, the rest is
  made as small as the microphones allow (Capon 1969; Van Trees, Optimum Array Processing, ch. 6).
* :func:`direction_mask` -- a time-frequency mask from the same per-bin evidence the speaking test uses (speech is
  sparse: each bin is dominated by one voice, W-disjoint orthogonality): each bin goes to the visible person whose
  steering vector explains its phases best; the others' bins are kept at ``floor``.

A pair has one degree of freedom: MVDR can null one interferer at most, and the mask then carries the rest.
"""
from __future__ import annotations

import numpy as np

from avcore.geometry import SPEED_OF_SOUND

__all__ = ["apply", "covariance", "delay_and_sum", "diffuse_coherence", "direction_mask", "mvdr_weights", "steering"]


def steering(positions_m: np.ndarray, source_xyz: np.ndarray, freqs_hz: np.ndarray,
             speed_of_sound: float = SPEED_OF_SOUND) -> np.ndarray:
    """(F, Q) complex: the relative transfer from ``source_xyz`` (3,) metres to the microphones at
    ``positions_m`` (Q, 3), the first microphone the reference (its entries are 1)."""
    mics = np.asarray(positions_m, dtype=np.float64).reshape(-1, 3)
    dist = np.linalg.norm(mics - np.asarray(source_xyz, dtype=np.float64).reshape(1, 3), axis=1)
    delays = (dist - dist[0]) / speed_of_sound  # (Q,) seconds after the reference microphone
    return np.exp(-2j * np.pi * np.asarray(freqs_hz, dtype=np.float64)[:, None] * delays[None, :])


def diffuse_coherence(positions_m: np.ndarray, freqs_hz: np.ndarray, speed_of_sound: float = SPEED_OF_SOUND
                      ) -> np.ndarray:
    """(F, Q, Q): the coherence of a spherically isotropic (diffuse) field between the microphones at
    ``positions_m`` (Q, 3), ``sin(2 pi f d / c) / (2 pi f d / c)`` for microphones ``d`` apart (Cook et al. 1955):
    the model of a room's late reverberation, which reaches the array from every direction at once."""
    mics = np.asarray(positions_m, dtype=np.float64).reshape(-1, 3)
    dist = np.linalg.norm(mics[:, None, :] - mics[None, :, :], axis=2)
    return np.sinc(2.0 * np.asarray(freqs_hz, dtype=np.float64)[:, None, None] * dist[None] / speed_of_sound)


def apply(weights: np.ndarray, stft: np.ndarray) -> np.ndarray:
    """(F, T): ``w^H X`` for weights (F, Q) and X (Q, F, T)."""
    return np.einsum("fq,qft->ft", np.conj(weights), stft)


def delay_and_sum(stft: np.ndarray, steer: np.ndarray) -> np.ndarray:
    """(F, T): the microphones aligned on the steered point and averaged, ``a^H X / Q``."""
    return apply(steer / steer.shape[1], stft)


def covariance(stft: np.ndarray, frames: np.ndarray | None = None) -> np.ndarray:
    """(F, Q, Q): the spatial covariance ``E[X X^H]`` over the frames selected by ``frames`` (T,) bool (None: all;
    none selected: zeros)."""
    x = np.asarray(stft)
    if frames is not None:
        x = x[:, :, np.asarray(frames, dtype=bool)]
    if x.shape[2] == 0:
        return np.zeros((x.shape[1], x.shape[0], x.shape[0]), dtype=np.complex128)
    return np.einsum("qft,pft->fqp", x, np.conj(x)) / x.shape[2]


def mvdr_weights(cov: np.ndarray, steer: np.ndarray, loading: float = 1e-2) -> np.ndarray:
    """(F, Q): ``R^-1 a / (a^H R^-1 a)`` for covariances (F, Q, Q) and steering vectors (F, Q); ``R`` is loaded with
    ``loading`` times its mean diagonal (a steering vector a little off the true one, a covariance from few frames:
    without it MVDR cancels the target too). A frequency with no covariance gets delay-and-sum's weights."""
    q = steer.shape[1]
    diag = np.real(np.trace(cov, axis1=1, axis2=2)) / q  # (F,)
    eye = np.eye(q)[None]
    loaded = cov + (loading * diag + 1e-12)[:, None, None] * eye
    ra = np.linalg.solve(loaded, steer[:, :, None])[:, :, 0]  # (F, Q)
    norm = np.einsum("fq,fq->f", np.conj(steer), ra)
    w = ra / np.where(np.abs(norm) > 0, norm, 1.0)[:, None]
    return np.where((diag > 0)[:, None], w, steer / q)


def direction_mask(stft: np.ndarray, steers: np.ndarray, target: int, floor: float = 0.1) -> np.ndarray:
    """(F, T) in [floor, 1]: 1 where person ``target``'s steering vector (of ``steers`` (N, F, Q), the visible
    people's) explains the bin's phases best -- the normalised delay-and-sum power ``|a_n^H X|^2 / (Q |X|^2)`` --
    and ``floor`` where another person's does. One person: ones."""
    a = np.asarray(steers)
    if a.shape[0] < 2:
        return np.ones(stft.shape[1:], dtype=np.float64)
    power = np.abs(np.einsum("nfq,qft->nft", np.conj(a), stft)) ** 2  # (N, F, T)
    best = power.argmax(axis=0)
    return np.where(best == target, 1.0, floor)
