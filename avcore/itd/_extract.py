"""Windowing, the energy gate, the batch form ``extract_itds`` and the streaming form ``PairStream``."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..ringbuffer import RingBuffer
from ._base import ItdMethod
from .correlogram import Correlogram
from .gcc_phat import GccPhat
from .robust import FrameState, RobustCorrelogram, RobustGccPhat

__all__ = ["METHODS", "PairStream", "ItdTrack", "extract_itds", "geometry_options", "gives_frame_itds", "make_method"]

METHODS: dict[str, type[ItdMethod]] = {
    cls.name: cls for cls in (Correlogram, GccPhat, RobustCorrelogram, RobustGccPhat)
}
"""The extractors by name; the one place where a method is added."""

_CHUNK_WINDOWS = 64  # windows processed together: vectorised FFTs with bounded memory


def geometry_options(method: str, mic_distance_m: float, speed_of_sound: float) -> dict[str, float]:
    """The microphone geometry that ``method`` takes as options: the frame-based (robust) methods model the diffuse
    field of the pair (its coherence ``sinc(2 f d / c)``); the others need nothing."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {sorted(METHODS)}, got {method!r}")
    if not METHODS[method].frame_based:
        return {}
    return {"mic_distance_m": float(mic_distance_m), "speed_of_sound": float(speed_of_sound)}


def gives_frame_itds(method: str) -> bool:
    """Whether ``PairStream(method, frame_itds=True)`` can pass the single frames' ITDs and their bands' peaks."""
    return bool(getattr(METHODS.get(method), "frame_itds_capable", False))


@dataclass(frozen=True)
class ItdTrack:
    """ITDs of the windows that passed the energy gate.

    times_s : (K,) float, seconds -- window centres, from the first sample of the signal (or stream).
    itds_s : (K,) float, seconds -- t_left - t_right (positive: source on the right), docs/architecture.md.
    confidence : (K,) float in [-1, 1] -- the method's normalised peak height.
    energy : (K,) float -- the window's mean power, ``mean((left^2 + right^2) / 2)`` (full scale 1).
    """

    times_s: np.ndarray
    itds_s: np.ndarray
    confidence: np.ndarray
    energy: np.ndarray

    def __len__(self) -> int:
        return int(self.itds_s.shape[0])

    @staticmethod
    def empty() -> ItdTrack:
        """The track of no window: one shared instance with read-only arrays (cheap to return per block)."""
        return _EMPTY

    @staticmethod
    def concatenate(tracks: list[ItdTrack]) -> ItdTrack:
        tracks = [t for t in tracks if len(t)]
        if not tracks:
            return ItdTrack.empty()
        if len(tracks) == 1:
            return tracks[0]
        return ItdTrack(*(np.concatenate([getattr(t, f) for t in tracks])
                          for f in ("times_s", "itds_s", "confidence", "energy")))


def _empty_track() -> ItdTrack:
    z = np.zeros(0)
    z.flags.writeable = False  # shared by every empty result
    return ItdTrack(z, z, z, z)


_EMPTY = _empty_track()


@dataclass(frozen=True)
class _Framing:
    samplerate_hz: float
    window_len: int
    hop_len: int
    energy_threshold: float
    min_confidence: float


def _positive(value: Any, name: str, unit: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise TypeError(f"{name} must be a number of {unit}, got {type(value).__name__}")
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive number of {unit}, got {value!r}")
    return float(value)


def make_method(samplerate: float, method: str = "correlogram", window_s: float = 0.15, hop_s: float = 0.02,
                energy_threshold: float = 1e-3, max_itd_s: float = 1e-3, min_confidence: float = -1.0,
                **options: Any) -> tuple[ItdMethod, _Framing]:
    """Validate the parameters shared by the batch and streaming forms and build the method."""
    fs = _positive(samplerate, "samplerate", "hertz")
    window_s = _positive(window_s, "window_s", "seconds")
    hop_s = _positive(hop_s, "hop_s", "seconds")
    max_itd_s = _positive(max_itd_s, "max_itd_s", "seconds")
    if isinstance(energy_threshold, bool) or not np.isfinite(energy_threshold) or energy_threshold < 0:
        raise ValueError(f"energy_threshold must be a non-negative mean power, got {energy_threshold!r}")
    if not (-1.0 <= min_confidence <= 1.0):
        raise ValueError(f"min_confidence must lie in [-1, 1], got {min_confidence!r}")
    if method not in METHODS:
        raise ValueError(f"method must be one of {sorted(METHODS)}, got {method!r}")
    window_len = round(window_s * fs)
    hop_len = round(hop_s * fs)
    if window_len < 16:
        raise ValueError(f"window_s={window_s} s is only {window_len} samples at {fs} Hz; use a longer window")
    if hop_len < 1:
        raise ValueError(f"hop_s={hop_s} s is shorter than one sample at {fs} Hz")
    max_lag = int(np.ceil(max_itd_s * fs))
    if 2 * max_lag >= window_len:
        raise ValueError(f"max_itd_s={max_itd_s} s ({max_lag} samples) needs a window longer than "
                         f"{2 * max_lag} samples, got window_s={window_s} s ({window_len} samples)")
    if METHODS[method].frame_based:
        # frames on a grid that every window starts on: half the hop when it is even
        options = {**options, "frame_hop_len": hop_len // 2 if hop_len % 2 == 0 else hop_len}
    try:
        impl = METHODS[method](fs, window_len, max_itd_s, **options)
    except TypeError as exc:
        raise TypeError(f"method {method!r} does not take these options: {sorted(options)} ({exc})") from None
    return impl, _Framing(fs, window_len, hop_len, float(energy_threshold), float(min_confidence))


def _signal(values: Any, name: str) -> np.ndarray:
    if (isinstance(values, np.ndarray) and values.dtype == np.float64 and values.ndim == 1
            and np.isfinite(values).all()):
        return values  # the common case, checked cheaply (the ITD worker calls this for every block)
    arr = np.asarray(values)
    if arr.ndim != 1:
        raise ValueError(f"{name} must be a 1-D array of samples, got shape {arr.shape}")
    if not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
        raise TypeError(f"{name} must hold real samples, got dtype {arr.dtype}")
    arr = arr.astype(np.float64, copy=False)
    if not np.all(np.isfinite(arr)):
        bad = int(np.count_nonzero(~np.isfinite(arr)))
        raise ValueError(f"{name} holds {bad} NaN or infinite sample(s); clean the audio before extracting ITDs")
    return arr


def _signal_pair(left: Any, right: Any, what: str) -> tuple[np.ndarray, np.ndarray]:
    """Both channels checked by :func:`_signal`, and of one length (``what``: "" or " blocks", for the message)."""
    left_arr, right_arr = _signal(left, "left"), _signal(right, "right")
    if left_arr.shape != right_arr.shape:
        raise ValueError(f"left and right{what} must have the same length, got {left_arr.shape[0]} and "
                         f"{right_arr.shape[0]} samples")
    return left_arr, right_arr


def _mean_power(frames_l: np.ndarray, frames_r: np.ndarray) -> np.ndarray:
    """``(n,)`` mean power ``mean((left^2 + right^2) / 2)`` of ``(n, w)`` frames: the paper's activity measure."""
    w = frames_l.shape[1]
    return (np.einsum("ij,ij->i", frames_l, frames_l) + np.einsum("ij,ij->i", frames_r, frames_r)) / (2 * w)


def _interleaved_power(windows: np.ndarray) -> np.ndarray:
    """``(n,)`` mean power of ``(n, w, 2)`` (left, right) windows: :func:`_mean_power` in one pass."""
    flat = windows.reshape(windows.shape[0], -1)
    return np.einsum("ij,ij->i", flat, flat) / flat.shape[1]


def _process_windows(impl: ItdMethod, framing: _Framing, frames_l: np.ndarray, frames_r: np.ndarray,
                     starts: np.ndarray) -> ItdTrack:
    """Energy gate, then the method, on ``(n, window_len)`` frames whose first samples are at ``starts``."""
    energy = _mean_power(frames_l, frames_r)
    keep = _gate(framing, energy)
    if not np.any(keep):
        return ItdTrack.empty()
    itds, conf = impl.estimate(frames_l[keep], frames_r[keep])
    return _track(framing, starts[keep], itds, conf, energy[keep])


def _gate(framing: _Framing, energy: np.ndarray) -> np.ndarray:
    """The paper's activity test: which windows reach the energy threshold E_A (and are not silent)."""
    keep = energy >= framing.energy_threshold
    if framing.energy_threshold == 0:
        keep &= energy > 0
    return keep


def _track(framing: _Framing, starts: np.ndarray, itds: np.ndarray, conf: np.ndarray,
           energy: np.ndarray) -> ItdTrack:
    """The windows starting at ``starts`` that gave an ITD with enough confidence."""
    times = (starts + 0.5 * framing.window_len) / framing.samplerate_hz
    ok = np.isfinite(itds) & (conf >= framing.min_confidence)
    if ok.all():
        return ItdTrack(times, itds, conf, energy)
    return ItdTrack(times[ok], itds[ok], conf[ok], energy[ok])


def extract_itds(left: Any, right: Any, samplerate: float, method: str = "correlogram", window_s: float = 0.15,
                 hop_s: float = 0.02, energy_threshold: float = 1e-3, max_itd_s: float = 1e-3,
                 min_confidence: float = -1.0, **options: Any) -> ItdTrack:
    """ITDs of a two-channel signal, one per window of ``window_s`` every ``hop_s`` that passes the energy gate.

    Parameters
    ----------
    left, right : (n,) float, full scale 1
        The left and right microphone signals.
    samplerate : float, hertz
    method : str
        A key of ``METHODS``: ``"correlogram"`` (the paper's, Christensen et al. 2007), ``"gcc-phat"``, or their
        reverberation- and noise-robust forms ``"correlogram-robust"`` and ``"gcc-phat-robust"``
        (``avcore.itd.robust``).
    window_s, hop_s : float, seconds
        Integration window W and frame shift f (paper, "Implementation Details": 150 ms and 20 ms).
    energy_threshold : float
        The activity threshold E_A of the paper (0.001): a window whose mean power
        ``mean((left^2 + right^2) / 2)`` is below it yields no ITD.
    max_itd_s : float, seconds
        Lags searched within ``+-max_itd_s`` (use the microphone distance over the speed of sound plus a margin).
    min_confidence : float in [-1, 1]
        Windows whose confidence is below this yield no ITD (-1, the default, keeps all).
    **options
        Passed to the method (for example ``n_channels``, ``low_hz``, ``high_hz`` for the correlogram).

    Returns
    -------
    ItdTrack
        ``times_s`` are window centres, seconds from the first sample; ``itds_s`` are ``t_left - t_right``.
    """
    impl, framing = make_method(samplerate, method, window_s, hop_s, energy_threshold, max_itd_s,
                                min_confidence, **options)
    left_arr, right_arr = _signal_pair(left, right, "")
    n = left_arr.shape[0]
    if n < framing.window_len:
        raise ValueError(f"the signal ({n} samples) is shorter than one window ({framing.window_len} samples, "
                         f"window_s={window_s} s); give more audio or a shorter window")
    if impl.frame_based:
        # Stateful methods (noise floor): one pass through the streaming form, which bounds memory too.
        stream = PairStream(samplerate, method, window_s, hop_s, energy_threshold, max_itd_s, min_confidence,
                           **options)
        return stream.push(left_arr, right_arr)
    n_windows = 1 + (n - framing.window_len) // framing.hop_len
    view_l = np.lib.stride_tricks.sliding_window_view(left_arr, framing.window_len)[::framing.hop_len]
    view_r = np.lib.stride_tricks.sliding_window_view(right_arr, framing.window_len)[::framing.hop_len]
    starts = np.arange(n_windows) * framing.hop_len
    tracks = [
        _process_windows(impl, framing, view_l[i:i + _CHUNK_WINDOWS], view_r[i:i + _CHUNK_WINDOWS],
                         starts[i:i + _CHUNK_WINDOWS])
        for i in range(0, n_windows, _CHUNK_WINDOWS)
    ]
    return ItdTrack.concatenate(tracks)


class PairStream:
    """One pair's streaming form of :func:`extract_itds`: feed blocks of any size, get ITDs as windows complete. The
    engine under :class:`avcore.itd.PairsItdStream` (the one stream the application uses, one of these per pair)
    and under the batch form.

    The parameters are those of :func:`extract_itds`. Windows start at sample ``k * hop`` of the stream, as in the
    batch form. The plain methods process each window on its own (the gammatone filterbank acts on the window's
    spectrum), so no filter state crosses windows; the robust methods carry their state (noise floor, previous
    frame, coherence averages) from frame to frame, and ``extract_itds`` runs them through this class. Either way
    the numbers equal the batch form's on the same signal, whatever the block sizes (to rounding: the FFTs and
    matrix products may group their sums differently for different numbers of windows).

    The windows a block completes go through the method together, both channels in one FFT call; with 10 ms blocks
    that is one window every other block, so the per-call cost of the method (``ItdMethod._peak``) is kept low.

    ``times_s`` are seconds from the stream's first sample; add the stream's start time for the shared clock.
    Memory is bounded: a ring buffer of one window plus 4096 samples, room for the windows (and frames) that 4096
    samples can complete, and the frame terms of one window.
    """

    def __init__(self, samplerate: float, method: str = "correlogram", window_s: float = 0.15, hop_s: float = 0.02,
                 energy_threshold: float = 1e-3, max_itd_s: float = 1e-3, min_confidence: float = -1.0,
                 frame_itds: bool = False, frame_bins: bool = False, **options: Any) -> None:
        self._impl, self._framing = make_method(samplerate, method, window_s, hop_s, energy_threshold, max_itd_s,
                                                min_confidence, **options)
        for name, asked in (("frame_itds", frame_itds), ("frame_bins", frame_bins)):
            if asked and not getattr(self._impl, "gives_frame_itds", False):
                raise ValueError(f"{name} needs the per-frame correlations of 'gcc-phat-robust' (frame_corr_power > "
                                 f"0); method {method!r} has none: pass {name}=False")
        self._frame_bins: list[tuple[np.ndarray, np.ndarray]] | None = [] if frame_bins else None
        if frame_bins:
            self._impl.keep_bins = True  # type: ignore[attr-defined]
        self._frame_itds: list[ItdTrack] | None = [] if frame_itds else None
        self._band_itds: list[ItdTrack] | None = [] if frame_itds else None
        if frame_itds:
            self._impl.keep_band_peaks = True  # type: ignore[attr-defined]
        w, hop = self._framing.window_len, self._framing.hop_len
        self._piece = max(hop, 4096)
        self._buffer = RingBuffer(2, w + self._piece)
        self._block = np.empty((self._piece, 2))  # (left, right) pairs of one piece, interleaved for the buffer
        # the windows (and frames) that one piece can complete are read into these, without allocating
        self._windows = np.empty((self._piece // hop + 1, w, 2))
        if self._impl.frame_based:
            self._frames = np.empty((self._piece // self._impl.frame_hop + 1, self._impl.frame_len, 2))
        self._next_start = 0
        # frame methods: state carried from frame to frame, and the weighted terms of the frames still needed
        self._state = FrameState()
        self._next_frame = 0
        self._first_kept = 0  # index of the first frame whose terms are kept
        self._terms: dict[str, list[np.ndarray]] = {}

    @property
    def samples_seen(self) -> int:
        return self._buffer.total_written

    def push(self, left: Any, right: Any) -> ItdTrack:
        """Append one block of left and right samples ``(n,)``; return the ITDs of the windows it completed."""
        left_arr, right_arr = _signal_pair(left, right, " blocks")
        n = left_arr.shape[0]
        if n <= self._piece:  # the usual case: one audio callback's block
            return self._append(left_arr, right_arr)
        # Pieces no longer than the spare capacity: no window is overwritten before it is read.
        return ItdTrack.concatenate([self._append(left_arr[i:i + self._piece], right_arr[i:i + self._piece])
                                     for i in range(0, n, self._piece)])

    def _append(self, left: np.ndarray, right: np.ndarray) -> ItdTrack:
        block = self._block[:left.shape[0]]
        block[:, 0] = left
        block[:, 1] = right
        self._buffer.append(block)
        if self._impl.frame_based:
            return self._drain_frames()
        return self._drain()

    def push_stereo(self, block: Any) -> ItdTrack:
        """Append an ``(n, 2)`` block of (left, right) frames."""
        arr = np.asarray(block)
        if arr.ndim != 2 or arr.shape[1] != 2:
            raise ValueError(f"block must have shape (n, 2) (left, right), got shape {arr.shape}")
        return self.push(arr[:, 0], arr[:, 1])

    def _drain(self) -> ItdTrack:
        """Plain methods: the windows completed since the last call, all in one call to the method."""
        w, hop = self._framing.window_len, self._framing.hop_len
        available = self._buffer.total_written
        first = self._next_start
        if first + w > available:
            return ItdTrack.empty()
        n = (available - w - first) // hop + 1
        self._next_start = first + n * hop
        windows = self._read(self._windows, first, n, hop)
        energy = _interleaved_power(windows)
        keep = _gate(self._framing, energy)
        if keep.all():  # the usual case while someone speaks: no copy of the windows
            itds, conf = self._impl.estimate_stereo(windows)
            return _track(self._framing, first + hop * np.arange(n), itds, conf, energy)
        if not keep.any():
            return ItdTrack.empty()
        starts = first + hop * np.flatnonzero(keep)
        itds, conf = self._impl.estimate_stereo(windows[keep])
        return _track(self._framing, starts, itds, conf, energy[keep])

    def _read(self, scratch: np.ndarray, first: int, count: int, step: int) -> np.ndarray:
        """``(count, length, 2)`` stretches of the buffer starting at ``first, first + step, ...``, read into
        ``scratch`` (``(>= count, length, 2)``), which the result is a view of."""
        length = scratch.shape[1]
        out = scratch[:count]
        for i in range(count):
            self._buffer.read_ending_at(first + i * step + length, length, out=out[i])
        return out

    def pop_frame_itds(self) -> ItdTrack:
        """The ITDs of the single frames (32 ms every 10 ms for gcc-phat-robust) analysed since the last call, of
        the frames that pass the energy gate; ``times_s`` are frame centres. Needs ``frame_itds=True``."""
        if self._frame_itds is None:
            raise RuntimeError("this PairStream keeps no frame ITDs: create it with frame_itds=True")
        out = ItdTrack.concatenate(self._frame_itds)
        self._frame_itds.clear()
        return out

    def pop_band_itds(self) -> ItdTrack:
        """The peaks of the frames' bands (``band_edges_hz`` of gcc-phat-robust) analysed since the last call, of the
        frames that pass the energy gate: one ITD per frame and band that has weight, ``times_s`` the frame's centre,
        ``confidence`` nan (a band's peak height is not kept). Needs ``frame_itds=True``."""
        if self._band_itds is None:
            raise RuntimeError("this PairStream keeps no frame ITDs: create it with frame_itds=True")
        out = ItdTrack.concatenate(self._band_itds)
        self._band_itds.clear()
        return out

    @property
    def bin_freqs_hz(self) -> np.ndarray:
        """(B,) the frequencies of the bins that :meth:`pop_frame_bins` returns."""
        return self._impl.freqs_hz[:self._impl.n_used]

    def pop_frame_bins(self) -> tuple[np.ndarray, np.ndarray]:
        """Every frame analysed since the last call as ``(times_s (m,), bins (m, B))``: the frame centres and their
        weighted phase transforms (complex64; the weights carry each bin's SNR, onset, coherence and direct-sound
        cues, so a silent or diffuse bin weighs little). No energy gate: a bin's weight says how much it counts.
        Needs ``frame_bins=True``."""
        if self._frame_bins is None:
            raise RuntimeError("this PairStream keeps no frame bins: create it with frame_bins=True")
        if not self._frame_bins:
            return np.zeros(0), np.zeros((0, self._impl.n_used), dtype=np.complex64)
        times = np.concatenate([t for t, _ in self._frame_bins])
        bins = np.concatenate([b for _, b in self._frame_bins])
        self._frame_bins.clear()
        return times, bins

    def _frame_times(self, count: int) -> np.ndarray:
        """Centres (seconds from the stream's start) of the ``count`` frames from ``self._next_frame`` on."""
        impl = self._impl
        starts = (self._next_frame + np.arange(count)) * impl.frame_hop
        return (starts + 0.5 * impl.frame_len) / self._framing.samplerate_hz

    def _keep_frame_itds(self, frames: np.ndarray, terms: dict[str, np.ndarray]) -> None:
        impl = self._impl
        energy = _interleaved_power(frames)
        itds, height = impl.frame_itds(terms)  # type: ignore[attr-defined]
        times = self._frame_times(frames.shape[0])
        ok = _gate(self._framing, energy) & np.isfinite(itds)
        if ok.any():
            self._frame_itds.append(ItdTrack(times[ok], itds[ok], height[ok], energy[ok]))  # type: ignore[union-attr]
        bands = terms.get("frame_band_itds")
        if bands is not None:
            keep = ok[:, None] & np.isfinite(bands)
            if keep.any():
                rows = np.nonzero(keep)[0]
                self._band_itds.append(ItdTrack(times[rows], bands[keep], np.full(rows.size, np.nan),  # type: ignore
                                                energy[rows]))

    def _drain_frames(self) -> ItdTrack:
        """Frame methods: analyse every new frame (updating the method's state), then finish complete windows."""
        impl = self._impl
        fl, fh = impl.frame_len, impl.frame_hop
        available = self._buffer.total_written
        last = (available - fl) // fh  # index of the last complete frame
        if last >= self._next_frame:
            frames = self._read(self._frames, self._next_frame * fh, last + 1 - self._next_frame, fh)
            terms = impl.frame_terms(frames[:, :, 0], frames[:, :, 1], self._state)
            if self._frame_itds is not None:
                self._keep_frame_itds(frames, terms)
            if self._frame_bins is not None:
                self._frame_bins.append((self._frame_times(frames.shape[0]), terms["frame_bins"]))
            for key, value in terms.items():
                if not key.startswith("frame_"):  # the frames' own results, not summed into windows
                    self._terms.setdefault(key, []).extend(value)
            self._next_frame = int(last) + 1
        w, hop = self._framing.window_len, self._framing.hop_len
        if self._next_start + w > available:
            return ItdTrack.empty()
        starts = np.arange(self._next_start, available - w + 1, hop)
        energy = _interleaved_power(self._read(self._windows, self._next_start, starts.shape[0], hop))
        keep = _gate(self._framing, energy)
        npw = impl.frames_per_window
        sums: dict[str, list[np.ndarray]] = {key: [] for key in self._terms}
        for s in starts[keep]:
            j0 = int(s) // fh - self._first_kept
            for key, values in self._terms.items():
                sums[key].append(np.sum(values[j0:j0 + npw], axis=0))
        self._next_start = int(starts[-1]) + hop
        stored = len(next(iter(self._terms.values()), []))
        drop = min(max(self._next_start // fh - self._first_kept, 0), stored)  # frames no later window uses
        for values in self._terms.values():
            del values[:drop]
        self._first_kept += drop
        if not np.any(keep):
            return ItdTrack.empty()
        itds, conf = impl.estimate_windows({key: np.stack(v) for key, v in sums.items()})
        return _track(self._framing, starts[keep], itds, conf, energy[keep])
