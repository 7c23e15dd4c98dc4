"""Each person's voice scored where the truth is known (issue 59's candidates, before any is built in).

A room of :mod:`sim.rooms`, or a scenario S1-S5 of :mod:`sim.scenario`, is rendered with each talker's own signals
kept (``render_audio(images=True)``); every person's voice is then taken from all the microphones by each candidate
of :mod:`avcore.beamform`, steered at the person's face in each frame (the truth's, which the cameras find within a
centimetre or two) and told when the person is silent by the truth's speaking states (what a perfect speaking state
would give):

* ``ds``: delay-and-sum (ODAS's default, the baseline); ``mvdr``: MVDR, the covariance of the frames where the
  person is silent; ``ds+mask``, ``mvdr+mask``: either, with the bins another visible person's direction explains
  better kept at -20 dB (:func:`avcore.beamform.direction_mask`);
* ``stream``: what the pipeline hands out (:class:`avcore.separation.VoiceSeparator`: MVDR learned online, from
  the people of ``voice_delay_s`` earlier, with the person's own reverberation as a diffuse field, each bin the
  quietest of it, the noise's beam and the superdirective beam, resampled and overlap-added), fed the truth's
  places and states;
* ``oracle-mask``: the reference microphone under the ideal ratio mask of the person's own image (the upper bound
  of a mask on one microphone, which keeps the image's reverberation);
* ``oracle-image``: the person's own image at the reference microphone, alone (perfect separation that keeps the
  reverberation);
* ``oracle-mwf``: the multichannel Wiener filter fitted with the truth, one filter of all the microphones per STFT
  frequency for the whole room, E|d - w^H x|^2 least with d the dry reference below (the upper bound of any fixed
  linear beamformer of this frame: it also undoes the reverberation that one frame of 32 ms can reach).

Each is scored by SI-SDR (``fast_bss_eval``) and STOI (``pystoi``, Taal et al. 2011: the intelligibility a listener
or a recogniser would find, 0-1) against the person's dry speech delayed by the direct path to the
reference microphone (the speech a recogniser wants: reverberation counts against every candidate, as the noise and
the other voices do), as its improvement over the reference microphone itself, separately where the person talks
alone and where another talks at once (each at least a second of speech).
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from avcore import beamform as bf

__all__ = ["CANDIDATES", "VoiceRow", "evaluate_voices", "summarise"]

CANDIDATES: tuple[str, ...] = ("ds", "mvdr", "ds+mask", "mvdr+mask", "stream", "oracle-mask", "oracle-image",
                                 "oracle-mwf")
_FS, _NFFT, _HOP, _GRID = 16000, 512, 256, 160  # Hz, STFT frame and hop (samples), the segments' grid (10 ms)
_MIN_SECONDS = 1.0
Progress = Callable[[str], None]


@dataclass(frozen=True)
class VoiceRow:
    """One person of one room, alone or in overlap: the reference microphone's SI-SDR (dB) and each candidate's
    improvement over it (dB)."""

    seed: int
    mics: str
    person: int
    kind: str  # "alone" or "overlap"
    seconds: float
    reference_db: float
    improvement_db: dict[str, float]
    stoi: dict[str, float]  # the reference microphone's ("reference") and each candidate's
    scenario: str | None = None  # S1..S5, or None: the room drawn from ``seed``

    def as_dict(self) -> dict[str, Any]:
        return {"scenario": self.scenario, "seed": self.seed, "mics": self.mics, "person": self.person,
                "kind": self.kind, "seconds": round(self.seconds, 1), "reference_db": round(self.reference_db, 2),
                "improvement_db": {k: round(v, 2) for k, v in self.improvement_db.items()},
                "stoi": {k: round(v, 3) for k, v in self.stoi.items()}}


def _si_sdr(reference: np.ndarray, estimate: np.ndarray) -> float:
    import fast_bss_eval.numpy as fbe

    return float(fbe.si_sdr(reference[None], estimate[None], zero_mean=True)[0])


def _stoi(reference: np.ndarray, estimate: np.ndarray) -> float:
    from pystoi import stoi

    return float(stoi(reference, estimate, _FS, extended=False))


def _oracle_mwf(spec: np.ndarray, target: np.ndarray, loading: float = 1e-9) -> np.ndarray:
    """The multichannel Wiener filter's output (F, T): per frequency, w = R_xx^-1 r_xd over all frames, with
    ``spec`` (Q, F, T) the microphones and ``target`` (F, T) the wanted signal (``loading`` times the trace keeps
    R_xx invertible in silent bands)."""
    cov = np.einsum("qft,rft->fqr", spec, spec.conj())
    cov += loading * np.trace(cov, axis1=1, axis2=2).real[:, None, None] * np.eye(spec.shape[0])
    cross = np.einsum("qft,ft->fq", spec, target.conj())
    weights = np.linalg.solve(cov, cross[..., None])[..., 0]  # (F, Q)
    return np.einsum("fq,qft->ft", weights.conj(), spec)


def _delayed(signal: np.ndarray, times_s: np.ndarray, delays_s: np.ndarray) -> np.ndarray:
    """``signal`` delayed by ``delays_s`` at ``times_s`` (a talker who walks: the delay between, linear). One
    delay: by the Fourier transform (fractional, zero-padded, no wrap); several: by linear interpolation."""
    n = signal.size
    delays = np.asarray(delays_s, dtype=np.float64)
    if np.ptp(delays) < 1e-9:  # one place all along
        spec = np.fft.rfft(signal, 2 * n) * np.exp(-2j * np.pi * np.fft.rfftfreq(2 * n, 1 / _FS) * delays[0])
        return np.fft.irfft(spec, 2 * n)[:n]
    t = np.arange(n) / _FS
    return np.interp(t - np.interp(t, times_s, delays), t, signal, left=0.0, right=0.0)


def evaluate_voices(seed: int, *, mic_array: str = "pair", duration_s: float | None = None,
                    data_dir: str | None = None, progress: Progress | None = None,
                    scenario: str | None = None) -> list[VoiceRow]:
    """Room ``seed`` with ``mic_array``, or with ``scenario`` ("S1" ... "S5") that preset of
    :func:`sim.scenario.make_scenario` drawn with ``seed`` (its digits and its fan): every person's rows (module
    docstring). People who walk are steered at where they are in each frame."""
    from sim.audio import load_background, load_clip_bank, load_sentence_bank, render_audio
    from sim.rooms import ROOM_DURATION_S, make_room
    from sim.scenario import make_scenario

    if scenario is None:
        bank = load_sentence_bank(_FS, data_dir, seed=seed)
        world, draw = make_room(seed, clip_durations_s=bank.durations_s, mics=mic_array,
                                duration_s=ROOM_DURATION_S if duration_s is None else duration_s)
        background = load_background(draw.noise_position_m, draw.noise_snr_db, _FS, data_dir, seed=seed)
        audio = render_audio(world, bank, background=background, images=True, progress=progress)
    else:
        bank = load_clip_bank(_FS, data_dir, seed=seed)
        world = make_scenario(scenario, clip_durations_s=bank.durations_s, duration_s=duration_s, seed=seed,
                              mics=mic_array)
        audio = render_audio(world, bank, images=True, progress=progress)
    return _score(world, audio, seed, mic_array, scenario)


def _score(world: Any, audio: Any, seed: int, mic_array: str, preset: str | None) -> list[VoiceRow]:
    """Every person's rows of a rendered world (``render_audio(images=True)``), a room's or ``preset``'s."""
    from scipy.signal import istft, stft

    from sim.audio import SOURCE_OFFSETS_M

    assert audio.images is not None
    x = audio.samples.T.astype(np.float64) / 32768.0  # (Q, n)
    n = x.shape[1]
    freqs, frames, spec = stft(x, fs=_FS, nperseg=_NFFT, noverlap=_NFFT - _HOP)  # (Q, F, T)
    mics = np.asarray(world.array.positions, dtype=np.float64)
    c = world.array.speed_of_sound
    places = np.stack([world.positions(float(t)) for t in frames])  # (T, N, 3) each frame's faces
    steers = [_steering_path(mics, places[:, k], freqs, c) for k in range(places.shape[1])]  # each (T, F, Q)
    talking_frames = world.speaking_at(frames)  # (T, N)
    talking = world.speaking_at(np.arange(0, n, _GRID) / _FS)  # (n / 10 ms, N)

    def wave(y: np.ndarray) -> np.ndarray:
        return istft(y, fs=_FS, nperseg=_NFFT, noverlap=_NFFT - _HOP)[1][:n]

    streams = _streams(x, mics, world, n)
    rows: list[VoiceRow] = []
    for k in range(places.shape[1]):
        mouth = places[:, k] + np.asarray(SOURCE_OFFSETS_M["speech"])  # (T, 3)
        reference = _delayed(audio.dry[k].astype(np.float64), frames, np.linalg.norm(mouth - mics[0], axis=1) / c)
        own = stft(audio.images[k, 0].astype(np.float64), fs=_FS, nperseg=_NFFT, noverlap=_NFFT - _HOP)[2]
        rest = spec[0] - own
        ideal = np.abs(own) ** 2 / np.maximum(np.abs(own) ** 2 + np.abs(rest) ** 2, 1e-20)
        cov = bf.covariance(spec, ~talking_frames[:, k])
        ds = np.einsum("tfq,qft->ft", np.conj(steers[k]), spec) / spec.shape[0]
        mvdr = np.stack([bf.apply(bf.mvdr_weights(cov, steers[k][t]), spec[:, :, t:t + 1])[:, 0]
                         for t in range(spec.shape[2])], axis=1) if _moves(places[:, k]) else \
            bf.apply(bf.mvdr_weights(cov, steers[k][0]), spec)
        mask = _direction_mask(spec, steers, k)
        dry = stft(reference, fs=_FS, nperseg=_NFFT, noverlap=_NFFT - _HOP)[2]
        outputs = {"ds": ds, "mvdr": mvdr, "ds+mask": ds * mask, "mvdr+mask": mvdr * mask,
                   "oracle-mask": spec[0] * ideal, "oracle-mwf": _oracle_mwf(spec, dry)}
        waves = {c: wave(y) for c, y in outputs.items()}
        waves["stream"] = streams[k]
        waves["oracle-image"] = audio.images[k, 0].astype(np.float64)
        mixture = x[0]
        others = np.delete(talking, k, axis=1).any(axis=1)
        for kind, where in (("alone", talking[:, k] & ~others), ("overlap", talking[:, k] & others)):
            samples = np.repeat(where, _GRID)[:n]
            if samples.sum() < _MIN_SECONDS * _FS:
                continue
            base = _si_sdr(reference[samples], mixture[samples])
            stois = {"reference": _stoi(reference[samples], mixture[samples])}
            stois.update({c: _stoi(reference[samples], w[samples]) for c, w in waves.items()})
            rows.append(VoiceRow(seed, mic_array, k, kind, float(samples.sum()) / _FS, base,
                                 {c: _si_sdr(reference[samples], w[samples]) - base for c, w in waves.items()},
                                 stois, preset))
    return rows


def _moves(path: np.ndarray) -> bool:
    """Whether the places (T, 3) of one person move by more than a millimetre."""
    return bool(np.ptp(path, axis=0).max() > 1e-3)


def _steering_path(mics: np.ndarray, path: np.ndarray, freqs: np.ndarray, c: float) -> np.ndarray:
    """(T, F, Q): the steering vectors of a person at their places (T, 3), one per frame (a view of one when they
    stay)."""
    if not _moves(path):
        one = bf.steering(mics, path[0], freqs, c)
        return np.broadcast_to(one[None], (path.shape[0], *one.shape))
    return np.stack([bf.steering(mics, p, freqs, c) for p in path])


def _direction_mask(spec: np.ndarray, steers: list[np.ndarray], target: int, floor: float = 0.1) -> np.ndarray:
    """:func:`avcore.beamform.direction_mask` with each frame's steering vectors (each person's (T, F, Q))."""
    if len(steers) < 2:
        return np.ones(spec.shape[1:], dtype=np.float64)
    power = np.stack([np.abs(np.einsum("tfq,qft->ft", np.conj(a), spec)) ** 2 for a in steers])  # (N, F, T)
    return np.where(power.argmax(axis=0) == target, 1.0, floor)


def _streams(x: np.ndarray, mics: np.ndarray, scenario: Any, n: int, block: int = 512,
             result_every_s: float = 1 / 30) -> list[np.ndarray]:
    """Each person's stream as the pipeline makes it, fed the truth (a result every ``result_every_s``), on the
    samples' own grid (zeros before it starts)."""
    from avcore.separation import VoiceSeparator

    separator = VoiceSeparator(mics, _FS, speed_of_sound=scenario.array.speed_of_sound)
    out = np.zeros((len(scenario.actors), n), dtype=np.float64)
    ids = np.arange(len(scenario.actors))
    next_result = 0.0

    def take(chunks: list) -> None:
        for c in chunks:
            start = int(round(c.stamp_s * _FS))
            end = min(start + c.samples.size, n)
            out[c.person_id, start:end] += c.samples[: end - start]

    for start in range(0, n, block):
        while next_result <= (start + block) / _FS:
            separator.push_people(next_result, ids, scenario.positions(next_result),
                                  scenario.speaking_at(np.array([next_result]))[0])
            next_result += result_every_s
        separator.push_audio(start / _FS, x[:, start:start + block].T)
        take(separator.pop())
    take(separator.flush())
    return list(out)


def summarise(rows: list[VoiceRow]) -> dict[str, dict[str, float]]:
    """Per kind ("alone", "overlap"): each candidate's mean improvement (dB) weighted by seconds, and the worst
    row's."""
    out: dict[str, dict[str, float]] = {}
    for kind in ("alone", "overlap"):
        chosen = [r for r in rows if r.kind == kind]
        if not chosen:
            continue
        seconds = np.array([r.seconds for r in chosen])
        for name in CANDIDATES:
            values = np.array([r.improvement_db[name] for r in chosen])
            out.setdefault(kind, {})[name] = float(np.sum(values * seconds) / np.sum(seconds))
            out[kind][f"{name} worst"] = float(values.min())
        for name in ("reference", *CANDIDATES):
            stois = np.array([r.stoi[name] for r in chosen])
            out[kind][f"{name} stoi"] = float(np.sum(stois * seconds) / np.sum(seconds))
        out[kind]["seconds"] = float(seconds.sum())
    return out
