"""Streaming dereverberation of the microphones' spectra: multichannel weighted prediction error (WPE).

A talker a few metres away in a furnished room reaches the array mostly as reverberation: a perfect separation of
each talker's image leaves most of it (docs/results.md, "Each person's voice"), and a beamformer steered at the face
lets through the late reverberation that arrives from its own direction. WPE (Nakatani et al., "Speech
dereverberation based on variance-normalized delayed linear prediction", IEEE TASLP 18(7), 2010; multichannel:
Yoshioka and Nakatani, IEEE TASLP 20(10), 2012) predicts each bin's late reverberation from the frames ``delay`` to
``delay + taps - 1`` before it, on all Q microphones, and subtracts it:

    y_t = x_t - G^H x~_t,   x~_t = [x_{t-D}; ...; x_{t-D-K+1}]   (QK,)       (the delayed linear prediction)
    G = R^-1 P,   R = sum_t x~_t x~_t^H / lambda_t,   P = sum_t x~_t x_t^H / lambda_t
    lambda_t = mean over the microphones of |y_t|^2                           (the talker's time-varying power)

The 1/lambda weighting is what keeps the prediction off the speech itself (speech is a Gaussian of time-varying
variance; unweighted linear prediction would whiten it). The frames ``delay`` back do not overlap the current one,
so the direct sound and the early reflections within ``delay`` hops stay.

Streaming form, as measured in docs/experiments.md (2026-11-30), on frames ``frames_per_s`` a second: R and P are
sums with a memory of ``memory_s``, each frame weighted by the lambda of its output under the filter then in use
(one pass, not the offline form's iterations), gathered ``every`` frames and then solved with a diagonal loading of
``loading`` times R's mean diagonal. For the first ``warm_s`` the filter is not applied (a filter solved from a few
frames predicts the speech and removes it). The filter is the same for every talker: with more microphones than
talkers one multichannel prediction can shorten every talker's response at once (the 2012 paper's MIMO result).

Contract: :meth:`__call__` takes each frame's (F, Q) spectrum in time order and returns the (F, Q) dereverberated
one; :meth:`gap` forgets the frames before a gap in the audio (the filter and its statistics stay: the room is the
same). :class:`SignalDereverberator` runs the same on a stream of samples (before the ITDs, an option).
"""
from __future__ import annotations

import collections

import numpy as np

__all__ = ["Dereverberator", "SignalDereverberator"]


class Dereverberator:
    """Streaming multichannel WPE on (F, Q) frames (module docstring)."""

    def __init__(self, bins: int, channels: int, frames_per_s: float = 62.5, *, taps: int = 6, delay: int = 2,
                 memory_s: float = 5.0, every: int = 32, loading: float = 1e-2, warm_s: float = 2.0) -> None:
        if bins < 1 or channels < 1 or taps < 1 or delay < 1 or every < 1 or frames_per_s <= 0 or memory_s <= 0 \
                or loading < 0 or warm_s < 0:
            raise ValueError("bins, channels, taps, delay and every must be >= 1, frames_per_s and memory_s > 0, "
                             "loading and warm_s >= 0")
        self.bins, self.channels, self.taps, self.delay = bins, channels, taps, delay
        self.every, self.loading, self.warm = every, loading, int(warm_s * frames_per_s)  # warm: frames
        self._forget = float(np.exp(-1.0 / (memory_s * frames_per_s)))
        self._weights = self._forget ** np.arange(every - 1, -1, -1)  # the batch's frames, newest weighs 1
        dim = channels * taps
        self._r = np.zeros((bins, dim, dim), dtype=np.complex128)
        self._p = np.zeros((bins, dim, channels), dtype=np.complex128)
        self._apply: np.ndarray | None = None  # (F, Q, QK): G^H, once warm
        self._batch_past = np.zeros((bins, every, dim), dtype=np.complex128)
        self._batch_x = np.zeros((bins, every, channels), dtype=np.complex128)
        self._batch_power = np.ones((bins, every))
        self.frames = 0
        self.gap()

    def gap(self) -> None:
        """The audio jumped: the frames before it predict nothing of the next ones."""
        self._past = np.zeros((self.bins, self.channels * self.taps), dtype=np.complex128)  # x~ of the next frame
        self._recent: collections.deque[np.ndarray] = collections.deque()  # the frames not yet ``delay`` old
        self._filled = 0  # frames in the batch

    def __call__(self, spectrum: np.ndarray) -> np.ndarray:
        x = np.asarray(spectrum, dtype=np.complex128)
        if x.shape != (self.bins, self.channels):
            raise ValueError(f"a frame must be ({self.bins}, {self.channels}), got {x.shape}")
        y = x if self._apply is None else x - (self._apply @ self._past[:, :, None])[:, :, 0]
        b = self._filled
        self._batch_past[:, b] = self._past
        self._batch_x[:, b] = x
        self._batch_power[:, b] = np.maximum(np.mean(y.real ** 2 + y.imag ** 2, axis=1), 1e-12)
        self._filled += 1
        self.frames += 1
        if self._filled == self.every:
            self._solve()
        # the next frame's past: the frames delay .. delay + taps - 1 before it, newest first
        self._recent.append(x)
        if len(self._recent) == self.delay:
            self._past = np.concatenate([self._recent.popleft(), self._past[:, : -self.channels]], axis=1)
        return y

    def _solve(self) -> None:
        """Add the batch to R and P (each frame by 1/lambda and its age), and solve for G once warm."""
        scale = self._weights[None, :] / self._batch_power  # (F, B)
        weighted = np.swapaxes(self._batch_past * scale[:, :, None], 1, 2)  # (F, QK, B)
        decay = self._forget ** self.every
        self._r = decay * self._r + weighted @ np.conj(self._batch_past)
        self._p = decay * self._p + weighted @ np.conj(self._batch_x)
        self._filled = 0
        if self.frames < self.warm:
            return
        dim = self._r.shape[1]
        load = self.loading * np.real(np.trace(self._r, axis1=1, axis2=2)) / dim + 1e-12
        g = np.linalg.solve(self._r + load[:, None, None] * np.eye(dim), self._p)  # (F, QK, Q)
        self._apply = np.ascontiguousarray(np.conj(np.swapaxes(g, 1, 2)))


class SignalDereverberator:
    """The same WPE on a stream of samples: (n, Q) blocks in, the same samples dereverberated out.

    sqrt-Hann frames of ``frame_s`` (about 32 ms, half overlapping: analysis and synthesis windows whose squares
    sum to one), :class:`Dereverberator` on the bins up to ``max_hz`` (the ones above pass as they came), overlap-add.
    A sample is out once both frames over it are in: the output runs :attr:`lag` samples behind the input, each
    sample at its own place (the first ``lag`` samples out are the input's first). :meth:`gap` starts again after
    lost samples, keeping the room's filter.
    """

    def __init__(self, samplerate_hz: float, channels: int, *, frame_s: float = 0.032, max_hz: float | None = None,
                 taps: int = 6, delay: int = 2, memory_s: float = 5.0, every: int = 32, warm_s: float = 2.0) -> None:
        if samplerate_hz <= 0 or frame_s <= 0:
            raise ValueError(f"samplerate_hz and frame_s must be > 0, got {samplerate_hz!r} and {frame_s!r}")
        n = max(4, 2 * int(round(frame_s * samplerate_hz / 2)))
        self.frame, self.lag = n, n // 2
        bins = n // 2 + 1
        self.bins = bins if max_hz is None else max(1, min(bins, int(max_hz * n / samplerate_hz) + 1))
        self.wpe = Dereverberator(self.bins, channels, samplerate_hz / self.lag, taps=taps, delay=delay,
                                  memory_s=memory_s, every=every, warm_s=warm_s)
        self.channels = channels
        self._window = np.sqrt(np.hanning(n + 1)[:-1])[:, None]
        self.gap()

    def gap(self) -> None:
        """Samples were lost: the next block starts a new stream (the filter stays)."""
        self.wpe.gap()
        self._input = np.zeros((self.lag, self.channels))  # a silent half frame before the first sample
        self._sum = np.zeros((self.frame, self.channels))  # the overlap-add from the input's first sample on
        self._first = True

    def push(self, samples: np.ndarray) -> np.ndarray:
        """(m, Q) samples out, following the ones given before: every sample both of whose frames are in."""
        x = np.asarray(samples, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.channels:
            raise ValueError(f"samples must be (n, {self.channels}), got {x.shape}")
        self._input = np.concatenate([self._input, x])
        out = []
        while self._input.shape[0] >= self.frame:
            spec = np.fft.rfft(self._input[: self.frame] * self._window, axis=0)
            spec[: self.bins] = self.wpe(spec[: self.bins])
            self._sum += np.fft.irfft(spec, self.frame, axis=0) * self._window
            if not self._first:  # the first half frame out is the silence before the stream
                out.append(self._sum[: self.lag].copy())
            self._first = False
            self._sum = np.concatenate([self._sum[self.lag:], np.zeros((self.lag, self.channels))])
            self._input = self._input[self.lag:]
        return np.concatenate(out) if out else np.zeros((0, self.channels))
