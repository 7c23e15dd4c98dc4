"""Each person's voice as a stream: MVDR steered at where the cameras see them, learned from when they are silent.

The paper's introduction: once the robot knows who speaks it should "maximize the signal-to-noise ratio, and
eventually retrieve a clean speech signal". :class:`VoiceSeparator` is the streaming form of
:mod:`avcore.beamform`'s MVDR (``w = R^-1 a / (a^H R^-1 a)``; Capon 1969), the candidate that measured best
(docs/results.md, "Each person's voice"):

* the microphones' short-time spectra (sqrt-Hann frames of about 32 ms, half overlapping) are first dereverberated
  (``dereverb``: :class:`avcore.dereverb.Dereverberator`, streaming multichannel WPE, one filter for the room; by
  default with three or more microphones: one filter shortens several talkers' responses only with more
  microphones than talkers, and the pair's worst talker alone lost to it, docs/results.md), then steered at each
  person's place (``a``: the direct path's relative transfer, :func:`avcore.beamform.steering`);
* ``R``, one per person, is the covariance of the frames where that person is silent -- the other talkers and the
  noise -- averaged with a memory of ``memory_s``; the speaking states say when;
* plus the person's own reverberation, which their silences cannot show: a diffuse field
  (:func:`avcore.beamform.diffuse_coherence`) of ``diffuse`` times their voice's own power (the microphones' power
  while they talk less ``R``'s), so that MVDR also turns down what reaches the array from every direction while
  they talk (a room's late reverberation; MVDR against a diffuse field is the superdirective beamformer, Bitzer
  and Simmer 2001), measured in docs/results.md;
* two more beams, also distortionless at the person: one takes the covariance of the frames where nobody speaks
  (the noise alone) plus the same diffuse term, the other the diffuse field alone (superdirective); in each bin of
  each frame the stream keeps whichever of the three beams lets least through (``quiet_beams``). All pass the
  person's direct sound unchanged, so the quietest has taken out most of the rest (MPDR's minimum-power choice, Cox
  1973, made between constrained beams): while the person talks alone the first beam spends its degrees of freedom
  on talkers who are silent now; in overlap it nulls them. The speaking states come ``learn_delay_s`` late, so the
  frame, not the states, chooses (docs/results.md). Each chunk also carries the first beam alone (``plain``):
  pocketsphinx heard more digits than were said in the choice's output;
* the output is resampled to ``out_rate_hz`` (16 kHz, what recognisers take) in the same inverse transform (the
  bins up to its Nyquist frequency), and overlap-added: a stream per person that goes on through their silence.

Everything a frame at time ``t`` uses comes from the people's updates stamped at or before ``t - learn_delay_s``
(who is there, where, who spoke when): the speaking states arrive later than the sound they judge, and a fixed rule
in stream time makes a replay as fast as possible give the streams of the live run. Frames wait for those updates;
``max_wait_s`` (a live run) bounds the wait, after which the last update known is used.

Contract: :meth:`push_audio` takes (n, Q) blocks of the Q microphones with the stamp of their first sample;
:meth:`push_people` takes ``(stamp, ids, positions, speaking)``; :meth:`pop` returns the :class:`VoiceChunk` s that
became final, per person and in time order; :meth:`flush` ends the stream. A gap in the audio's stamps restarts the
framing (each chunk carries its own stamp).
"""
from __future__ import annotations

import collections
import math
from dataclasses import dataclass

import numpy as np

from avcore import beamform as bf
from avcore.dereverb import Dereverberator
from avcore.geometry import SPEED_OF_SOUND

__all__ = ["VoiceChunk", "VoiceSeparator", "frame_sizes"]


@dataclass(frozen=True, eq=False)
class VoiceChunk:
    """``samples`` (n,) float32 of person ``person_id``'s voice at ``samplerate_hz``, its first sample captured at
    ``stamp_s`` (the audio's clock). ``plain`` (n,) float32 or None: the same span from the first beam alone (MVDR,
    no choice between beams), which a recogniser takes better (with ``quiet_beams``; docs/results.md)."""

    person_id: int
    stamp_s: float
    samples: np.ndarray
    samplerate_hz: int
    plain: np.ndarray | None = None

    @property
    def end_s(self) -> float:
        return self.stamp_s + self.samples.size / self.samplerate_hz


@dataclass(frozen=True)
class _Update:
    stamp_s: float
    ids: np.ndarray  # (N,) int
    positions: np.ndarray  # (N, 3)
    speaking: np.ndarray  # (N,) bool


def _join(chunks: list[VoiceChunk]) -> VoiceChunk:
    first = chunks[0]
    if len(chunks) == 1:
        return first
    plain = None if any(c.plain is None for c in chunks) else np.concatenate([c.plain for c in chunks])
    return VoiceChunk(first.person_id, first.stamp_s, np.concatenate([c.samples for c in chunks]),
                      first.samplerate_hz, plain)


def frame_sizes(samplerate_hz: float, out_rate_hz: int = 16000, frame_s: float = 0.032) -> tuple[int, int]:
    """(n_in, n_out): even frame lengths at the input and output rates that last the same time, about ``frame_s``
    (so that the output is the input's bins up to ``out_rate_hz / 2``, inverse-transformed at its own length)."""
    fs = int(round(samplerate_hz))
    g = math.gcd(fs, int(out_rate_hz))
    k = max(1, int(round(frame_s * g)))
    while (fs // g * k) % 2 or (out_rate_hz // g * k) % 2:
        k += 1
    return fs // g * k, int(out_rate_hz) // g * k


class VoiceSeparator:
    """Streaming voices (module docstring). ``mic_positions_m`` (Q, 3) in the people's frame."""

    def __init__(self, mic_positions_m: np.ndarray, samplerate_hz: float, *, out_rate_hz: int = 16000,
                 frame_s: float = 0.032, learn_delay_s: float = 0.3, memory_s: float = 3.0, loading: float = 1e-2,
                 diffuse: float = 1.0, quiet_beams: bool = True, dereverb: bool | None = None,
                 max_wait_s: float | None = None, forget_s: float = 10.0,
                 speed_of_sound: float = SPEED_OF_SOUND) -> None:
        self.mics = np.asarray(mic_positions_m, dtype=np.float64).reshape(-1, 3)
        if self.mics.shape[0] < 2:
            raise ValueError(f"a voice needs at least 2 microphones, got {self.mics.shape[0]}")
        if samplerate_hz <= 0 or learn_delay_s < 0 or memory_s <= 0 or loading < 0 or diffuse < 0:
            raise ValueError("samplerate_hz and memory_s must be > 0, learn_delay_s, loading and diffuse >= 0")
        self.samplerate_hz = float(samplerate_hz)
        self.out_rate_hz = int(out_rate_hz)
        self.n_in, self.n_out = frame_sizes(samplerate_hz, out_rate_hz, frame_s)
        self.hop_in, self.hop_out = self.n_in // 2, self.n_out // 2
        self.learn_delay_s, self.max_wait_s, self.forget_s = learn_delay_s, max_wait_s, forget_s
        self.loading, self.diffuse, self.speed_of_sound = loading, diffuse, speed_of_sound
        self.quiet_beams = quiet_beams
        if dereverb is None:  # by default with three microphones or more (module docstring)
            dereverb = self.mics.shape[0] >= 3
        self.bins = min(self.n_in, self.n_out) // 2 + 1  # the input's bins the output keeps
        self.freqs_hz = np.arange(self.bins) * self.samplerate_hz / self.n_in
        self._coherence = bf.diffuse_coherence(self.mics, self.freqs_hz, speed_of_sound)  # (F, Q, Q)
        self._coherence_inv = np.linalg.inv(self._coherence + loading * np.eye(self.mics.shape[0]))  # superdirective
        self._win_in = np.sqrt(np.hanning(self.n_in + 1)[:-1])  # periodic: sqrt-Hann analysis and synthesis
        self._win_out = np.sqrt(np.hanning(self.n_out + 1)[:-1]) * (self.n_out / self.n_in)
        self._decay = math.exp(-self.hop_in / self.samplerate_hz / memory_s)
        self.dereverb = Dereverberator(self.bins, self.mics.shape[0], self.samplerate_hz / self.hop_in) \
            if dereverb else None
        self._buf = np.zeros((0, self.mics.shape[0]))
        self._buf_stamp: float | None = None  # stamp of the buffer's first sample
        self._next_stamp: float | None = None  # where the next block should start
        self._newest_s = -math.inf  # the end of the audio pushed
        self._updates: collections.deque[_Update] = collections.deque()
        self._pending: collections.deque[tuple[float, np.ndarray]] = collections.deque()  # frames to learn from
        self._cov: dict[int, np.ndarray] = {}  # person -> (F, Q, Q)
        self._noise: np.ndarray | None = None  # (F, Q, Q) the frames where nobody speaks
        self._power: dict[int, np.ndarray] = {}  # person -> (F,) the microphones' mean power while they talk
        self._seen: dict[int, float] = {}  # person -> the last frame time they were there
        self._steer: dict[int, tuple[np.ndarray, np.ndarray, np.ndarray]] = {}  # person -> (place, steering, SD)
        self._tails: dict[int, tuple[float, np.ndarray]] = {}  # person -> (stamp, second half of their last frame)
        self._out: list[VoiceChunk] = []
        self.frames = 0

    # -- input ---------------------------------------------------------------------------------------------------

    def push_audio(self, stamp_s: float, samples: np.ndarray) -> None:
        """(n, Q) samples of the microphones in the order of ``mic_positions_m``, first sample at ``stamp_s``."""
        x = np.asarray(samples, dtype=np.float64)
        if x.ndim != 2 or x.shape[1] != self.mics.shape[0]:
            raise ValueError(f"samples must be (n, {self.mics.shape[0]}), got {x.shape}")
        x = np.nan_to_num(x, nan=0.0, posinf=0.0, neginf=0.0)
        if self._next_stamp is not None and abs(stamp_s - self._next_stamp) > self.hop_in / self.samplerate_hz:
            self._drain(math.inf)  # a gap: what is buffered is final with the updates known, then start again
            self._end_tails()
            if self.dereverb is not None:
                self.dereverb.gap()
            self._buf = np.zeros((0, self.mics.shape[0]))
            self._buf_stamp = None
        if self._buf_stamp is None:
            self._buf_stamp = float(stamp_s)
        self._buf = np.concatenate([self._buf, x])
        self._next_stamp = float(stamp_s) + x.shape[0] / self.samplerate_hz
        self._newest_s = self._next_stamp

    def push_people(self, stamp_s: float, ids: np.ndarray, positions_m: np.ndarray, speaking: np.ndarray) -> None:
        """The people of one result: ids (N,), places (N, 3) metres, speaking (N,) bool, in stamp order."""
        ids = np.asarray(ids, dtype=np.int64).reshape(-1)
        pos = np.asarray(positions_m, dtype=np.float64).reshape(-1, 3)
        spk = np.asarray(speaking, dtype=bool).reshape(-1)
        if not ids.size == pos.shape[0] == spk.size:
            raise ValueError(f"ids, positions and speaking disagree: {ids.size}, {pos.shape[0]}, {spk.size}")
        if self._updates and stamp_s < self._updates[-1].stamp_s:
            return  # out of order: the stream keeps what it has
        self._updates.append(_Update(float(stamp_s), ids, pos, spk))

    # -- output --------------------------------------------------------------------------------------------------

    def pop(self) -> list[VoiceChunk]:
        """The chunks that are final: every frame whose updates are known (``learn_delay_s``) or has waited
        ``max_wait_s``."""
        known = self._updates[-1].stamp_s + self.learn_delay_s if self._updates else -math.inf
        if self.max_wait_s is not None:
            known = max(known, self._newest_s - self.max_wait_s)
        self._drain(known)
        return self._take()

    def flush(self) -> list[VoiceChunk]:
        """The end of the stream: every frame with the updates known, and each voice's last half frame."""
        self._drain(math.inf)
        self._end_tails()
        return self._take()

    def _take(self) -> list[VoiceChunk]:
        """The chunks made since the last call, each person's contiguous ones joined."""
        joined: dict[int, list[VoiceChunk]] = {}
        order: list[VoiceChunk] = []
        for c in self._out:
            run = joined.setdefault(c.person_id, [])
            if run and abs(run[-1].end_s - c.stamp_s) < 0.5 / c.samplerate_hz:
                run.append(c)
                continue
            if run:
                order.append(_join(run))
            joined[c.person_id] = [c]
        order.extend(_join(run) for run in joined.values() if run)
        self._out = []
        return sorted(order, key=lambda c: (c.stamp_s, c.person_id))

    # -- the frames ----------------------------------------------------------------------------------------------

    def _drain(self, known_s: float) -> None:
        while self._buf_stamp is not None and self._buf.shape[0] >= self.n_in:
            centre = self._buf_stamp + self.n_in / 2 / self.samplerate_hz
            if centre > known_s:
                return
            self._frame(self._buf_stamp, centre, self._buf[: self.n_in])
            self._buf = self._buf[self.hop_in:]
            self._buf_stamp += self.hop_in / self.samplerate_hz

    def _state_at(self, time_s: float) -> _Update | None:
        """The last update stamped at or before ``time_s``."""
        best = None
        for u in self._updates:
            if u.stamp_s > time_s:
                break
            best = u
        return best

    def _frame(self, start_s: float, centre_s: float, block: np.ndarray) -> None:
        spec = np.fft.rfft(block * self._win_in[:, None], axis=0)[: self.bins]  # (F, Q)
        if self.dereverb is not None:
            spec = self.dereverb(spec)
        self.frames += 1
        self._learn(centre_s, spec)
        now = self._state_at(centre_s - self.learn_delay_s)
        while len(self._updates) > 1 and self._updates[1].stamp_s <= centre_s - self.learn_delay_s - 1.0:
            self._updates.popleft()  # keep a second of updates before the ones in use
        present = set()
        if now is not None:
            for pid, pos in zip(now.ids.tolist(), now.positions):
                present.add(pid)
                self._seen[pid] = centre_s
                steer, superdirective = self._steering(pid, pos)
                cov, power = self._cov.get(pid), self._power.get(pid)
                reverb = 0.0
                if cov is not None and power is not None and self.diffuse > 0:
                    # the voice's own power: what the microphones hear while the person talks less what they
                    # hear while the person is silent (the others and the noise, already in ``cov``)
                    own = np.maximum(power - np.real(np.trace(cov, axis1=1, axis2=2)) / cov.shape[1], 0.0)
                    reverb = self.diffuse * own[:, None, None] * self._coherence
                w = steer / steer.shape[1] if cov is None else bf.mvdr_weights(cov + reverb, steer, self.loading)
                out = np.einsum("fq,fq->f", np.conj(w), spec)
                if self.quiet_beams:  # the stream, and the first beam alone for a recogniser
                    out = np.stack([self._quietest(out, spec, steer, superdirective, reverb), out])
                self._emit(pid, start_s, out.reshape(-1, self.bins))
        for pid in [p for p in self._tails if p not in present]:
            self._end_tail(pid)
        for pid in [p for p, t in self._seen.items() if centre_s - t > self.forget_s]:
            self._seen.pop(pid)
            self._cov.pop(pid, None)
            self._power.pop(pid, None)
            self._steer.pop(pid, None)

    def _steering(self, pid: int, position: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(steering (F, Q), the superdirective beam's weights (F, Q)) at the person's place, kept while it stays."""
        kept = self._steer.get(pid)
        if kept is not None and np.array_equal(kept[0], position):
            return kept[1], kept[2]
        steer = bf.steering(self.mics, position, self.freqs_hz, self.speed_of_sound)
        ra = np.einsum("fqp,fp->fq", self._coherence_inv, steer)
        superdirective = ra / np.einsum("fq,fq->f", np.conj(steer), ra)[:, None]
        self._steer[pid] = (position.copy(), steer, superdirective)
        return steer, superdirective

    def _quietest(self, out: np.ndarray, spec: np.ndarray, steer: np.ndarray, superdirective: np.ndarray,
                  reverb: np.ndarray | float) -> np.ndarray:
        """``out`` (F,), the first beam's bins, each replaced by the noise's beam's or the superdirective beam's
        where that lets less through (module docstring)."""
        for w in [superdirective] + ([] if self._noise is None else
                                     [bf.mvdr_weights(self._noise + reverb, steer, self.loading)]):
            other = np.einsum("fq,fq->f", np.conj(w), spec)
            out = np.where(np.abs(other) < np.abs(out), other, out)
        return out

    def _learn(self, centre_s: float, spec: np.ndarray) -> None:
        """Each person's covariance takes the frames, ``learn_delay_s`` old, where that person was silent; their
        power, the frames where they talked; the noise's covariance, the frames where nobody in view talked."""
        self._pending.append((centre_s, spec))
        outer = None
        while self._pending and self._pending[0][0] <= centre_s - self.learn_delay_s:
            t, x = self._pending.popleft()
            state = self._state_at(t)
            if state is None:
                continue
            outer = np.einsum("fq,fp->fqp", x, np.conj(x))
            now = np.mean(np.abs(x) ** 2, axis=1)  # (F,) the microphones' mean power
            if not state.speaking.any():
                self._noise = (1 - self._decay) * outer if self._noise is None else (
                    self._decay * self._noise + (1 - self._decay) * outer)
            for pid, talking in zip(state.ids.tolist(), state.speaking.tolist()):
                if talking:
                    power = self._power.get(pid)
                    self._power[pid] = (1 - self._decay) * now if power is None else (
                        self._decay * power + (1 - self._decay) * now)
                    continue
                cov = self._cov.get(pid)
                self._cov[pid] = (1 - self._decay) * outer if cov is None else (
                    self._decay * cov + (1 - self._decay) * outer)
        del outer

    def _emit(self, pid: int, start_s: float, spectra: np.ndarray) -> None:
        """(1 or 2, F) spectra of one frame: the stream's, and the plain beam's."""
        full = np.zeros((spectra.shape[0], self.n_out // 2 + 1), dtype=np.complex128)
        full[:, : self.bins] = spectra
        y = np.fft.irfft(full, self.n_out, axis=1) * self._win_out
        head, tail = y[:, : self.hop_out], y[:, self.hop_out:]
        previous = self._tails.get(pid)
        if previous is not None and abs(previous[0] - start_s) < 0.5 / self.out_rate_hz + 1e-9:
            head = head + previous[1]
        elif previous is not None:
            self._end_tail(pid)
        self._out.append(self._chunk(pid, start_s, head))
        self._tails[pid] = (start_s + self.hop_out / self.out_rate_hz, tail)

    def _chunk(self, pid: int, stamp_s: float, rows: np.ndarray) -> VoiceChunk:
        rows = rows.astype(np.float32)
        return VoiceChunk(pid, stamp_s, rows[0], self.out_rate_hz, rows[1] if rows.shape[0] > 1 else None)

    def _end_tail(self, pid: int) -> None:
        stamp, tail = self._tails.pop(pid)
        self._out.append(self._chunk(pid, stamp, tail))

    def _end_tails(self) -> None:
        for pid in list(self._tails):
            self._end_tail(pid)
