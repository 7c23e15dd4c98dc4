"""Streaming dereverberation of the microphones' spectra: multichannel weighted prediction error (WPE).

A talker 1-4 m away in a room of RT60 0.2-0.7 s reaches the array mostly as reverberation: a perfect separation of
each talker's image gains only about +5 dB over the reference microphone against their dry speech
(docs/results.md, "Each person's voice"), and a beamformer steered at the face lets through the late
reverberation that arrives from its own direction. WPE (Nakatani et al., "Speech dereverberation based on
variance-normalized delayed linear prediction", IEEE TASLP 18(7), 2010; multichannel: Yoshioka and Nakatani, IEEE
TASLP 20(10), 2012) predicts each bin's late reverberation from the frames ``delay`` to ``delay + taps - 1`` before
it, on all Q microphones, and subtracts it:

    y_t = x_t - G^H x~_t,   x~_t = [x_{t-D}; ...; x_{t-D-K+1}]   (QK,)       (the delayed linear prediction)
    G = R^-1 P,   R = sum_t x~_t x~_t^H / lambda_t,   P = sum_t x~_t x_t^H / lambda_t
    lambda_t = mean over the microphones of |y_t|^2                           (the talker's time-varying power)

The 1/lambda weighting is what keeps the prediction off the speech itself (speech is a Gaussian of time-varying
variance; unweighted linear prediction would whiten it). The frames ``delay`` back do not overlap the current one,
so the direct sound and the early reflections within ``delay`` hops stay.

Streaming form, as measured in docs/experiments.md (2026-11-30): R and P are sums with a memory of ``memory``
frames, each frame weighted by the lambda of its output under the filter then in use (one pass, not the offline
form's iterations), gathered ``every`` frames and then solved with a diagonal loading of ``loading`` times R's mean
diagonal. For the first ``warm`` frames the filter is not applied (a filter solved from a few frames predicts the
speech and removes it). The filter is the same for every talker: with more microphones than talkers one
multichannel prediction can shorten every talker's response at once (the 2012 paper's MIMO result).

Contract: :meth:`__call__` takes each frame's (F, Q) spectrum in time order and returns the (F, Q) dereverberated
one; :meth:`gap` forgets the frames before a gap in the audio (the filter and its statistics stay: the room is
the same).
"""
from __future__ import annotations

import numpy as np

__all__ = ["Dereverberator"]


class Dereverberator:
    """Streaming multichannel WPE on (F, Q) frames (module docstring)."""

    def __init__(self, bins: int, channels: int, *, taps: int = 6, delay: int = 2, memory: float = 1250.0,
                 every: int = 16, loading: float = 1e-2, warm: int = 125) -> None:
        if bins < 1 or channels < 1 or taps < 1 or delay < 1 or every < 1 or memory <= 0 or loading < 0 or warm < 0:
            raise ValueError("bins, channels, taps, delay and every must be >= 1, memory > 0, loading and warm >= 0")
        self.bins, self.channels, self.taps, self.delay = bins, channels, taps, delay
        self.every, self.loading, self.warm = every, loading, warm
        self._forget = float(np.exp(-1.0 / memory))
        self._weights = self._forget ** np.arange(every - 1, -1, -1)  # the batch's frames, newest weighs 1
        dim = channels * taps
        self._r = np.zeros((bins, dim, dim), dtype=np.complex128)
        self._p = np.zeros((bins, dim, channels), dtype=np.complex128)
        self._filter: np.ndarray | None = None  # (F, QK, Q)
        self.frames = 0
        self.gap()

    def gap(self) -> None:
        """The audio jumped: the frames before it predict nothing of the next ones."""
        self._history = np.zeros((self.delay + self.taps - 1, self.bins, self.channels), dtype=np.complex128)
        self._batch: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def __call__(self, spectrum: np.ndarray) -> np.ndarray:
        x = np.asarray(spectrum, dtype=np.complex128)
        if x.shape != (self.bins, self.channels):
            raise ValueError(f"a frame must be ({self.bins}, {self.channels}), got {x.shape}")
        # the frames delay .. delay + taps - 1 back, newest first, stacked per bin as (QK,)
        past = self._history[self.delay - 1:].transpose(1, 0, 2).reshape(self.bins, -1)
        y = x if self._filter is None else x - np.einsum("fkq,fk->fq", np.conj(self._filter), past)
        power = np.maximum(np.mean(np.abs(y) ** 2, axis=1), 1e-12)
        self._batch.append((past, x, power))
        self.frames += 1
        if len(self._batch) == self.every:
            self._solve()
        self._history = np.roll(self._history, 1, axis=0)
        self._history[0] = x
        return y

    def _solve(self) -> None:
        """Add the batch to R and P (each frame by 1/lambda and its age), and solve for G once warm."""
        past = np.stack([b[0] for b in self._batch], axis=1)  # (F, B, QK)
        x = np.stack([b[1] for b in self._batch], axis=1)  # (F, B, Q)
        scale = self._weights[None, :] / np.stack([b[2] for b in self._batch], axis=1)  # (F, B)
        weighted = np.swapaxes(past * scale[:, :, None], 1, 2)  # (F, QK, B)
        decay = self._forget ** len(self._batch)
        self._r = decay * self._r + weighted @ np.conj(past)
        self._p = decay * self._p + weighted @ np.conj(x)
        self._batch = []
        if self.frames < self.warm:
            return
        dim = self._r.shape[1]
        load = self.loading * np.real(np.trace(self._r, axis1=1, axis2=2)) / dim + 1e-12
        self._filter = np.linalg.solve(self._r + load[:, None, None] * np.eye(dim), self._p)
