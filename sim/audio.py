"""The microphone signals of a simulated scenario (paper section 7.3's room): every sound event from its actor through
the room's image-source responses, the robot's fan, the converter's noise; and the speech clips it uses (real spoken
digits or synthetic stand-ins)."""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from scipy.signal import fftconvolve

from sim.roomsim import AcousticRoom, data_path, fan_noise, load_speech, pink_noise, read_wav, synthetic_speech
from sim.scenario import (
    SOURCE_OFFSETS_M,
    ClipBank,
    Scenario,
    normalise_clip,
    synthetic_clip_bank,
    trim_quiet_ends,
)

__all__ = ["Background", "SimAudio", "load_background", "load_clip_bank", "load_sentence_bank", "render_audio"]

log = logging.getLogger(__name__)

REFERENCE_DISTANCE_M = 1.0
FAN_POSITION_M = (0.02, -0.04, -0.06)  # the fan inside the head, behind the microphones (as sim.roomsim)
PRA_DELAY_SAMPLES = 40   # pyroomacoustics' global delay in its responses (sim.roomsim.AcousticRoom.impulse_responses)
def load_clip_bank(samplerate_hz: int = 16000, data_dir: str | Path | None = None, n_voices: int = 3,
                   seed: int = 0) -> ClipBank:
    """The spoken digits of ``speech/digits`` (:func:`sim.roomsim.data_path`: the data folder's, else the copy
    avhear ships) grouped by speaker (``{digit}_{speaker}_N.wav``), one voice per speaker with its ten digits, each
    cut to its audible part (:func:`sim.scenario.trim_quiet_ends`: the truth's speaking states follow the clips);
    :func:`sim.scenario.synthetic_clip_bank` when the folder is absent or incomplete."""
    folder = data_path("speech/digits", data_dir)
    names = sorted(p.name for p in folder.glob("*.wav")) if folder.is_dir() else []
    clips = load_speech(samplerate_hz, "digits", data_dir) if names else None
    if clips is not None and len(clips) == len(names):
        by_speaker: dict[str, dict[int, np.ndarray]] = {}
        for name, clip in zip(names, clips):
            parts = name[:-4].split("_")
            if len(parts) >= 2 and parts[0].isdigit():
                by_speaker.setdefault(parts[1], {}).setdefault(int(parts[0]), clip)
        complete = [s for s in sorted(by_speaker) if sorted(by_speaker[s]) == list(range(10))]
        if complete:
            voices = tuple(tuple(normalise_clip(trim_quiet_ends(by_speaker[s][d], samplerate_hz)) for d in range(10))
                           for s in complete)
            return ClipBank(samplerate_hz, voices, "digits", tuple(complete))
    log.info("no spoken digits under %s: synthetic voiced clips instead", folder)
    return synthetic_clip_bank(samplerate_hz, n_voices=n_voices, seed=seed)


def load_sentence_bank(samplerate_hz: int = 16000, data_dir: str | Path | None = None, seed: int = 0) -> ClipBank:
    """Read sentences for the rooms (:mod:`sim.rooms`): the CMU ARCTIC excerpts of ``speech/arctic`` (the data
    folder's, else the shipped copy: :func:`sim.roomsim.data_path`), one voice per speaker
    (``cmu_arctic_us_<speaker>_<id>.wav``; a file without a speaker is a voice of its own), each cut to its audible
    part and scaled to unit RMS; three synthetic voices of six 1.5-3.5 s utterances when the folder is absent
    (``ClipBank.source`` says which: "arctic" or "synthetic")."""
    folder = data_path("speech/arctic", data_dir)
    names = sorted(p.name for p in folder.glob("*.wav")) if folder.is_dir() else []
    clips = load_speech(samplerate_hz, "arctic", data_dir) if names else None
    if clips is not None and len(clips) == len(names):
        by_speaker: dict[str, list[np.ndarray]] = {}
        for name, clip in zip(names, clips):
            parts = name[:-4].split("_")
            speaker = parts[3] if len(parts) >= 5 and parts[0] == "cmu" else name[:-4]
            by_speaker.setdefault(speaker, []).append(normalise_clip(trim_quiet_ends(clip, samplerate_hz)))
        speakers = tuple(sorted(by_speaker))
        return ClipBank(samplerate_hz, tuple(tuple(by_speaker[s]) for s in speakers), "arctic", speakers)
    log.info("no read sentences under %s: synthetic voiced utterances instead", folder)
    voices = []
    for v in range(3):
        rng = np.random.default_rng([seed, v, 17])
        voices.append(tuple(normalise_clip(synthetic_speech(float(rng.uniform(1.5, 3.5)), samplerate_hz, rng))
                            for _ in range(6)))
    return ClipBank(samplerate_hz, tuple(voices), "synthetic", tuple(f"synthetic{v}" for v in range(3)))


# What each shipped ARCTIC excerpt says: the CMU ARCTIC prompts (festvox.org/cmu_arctic, cmuarctic.data), in words
# as a recogniser writes them (lower case, no punctuation): the truth the words are scored against.
ARCTIC_PROMPTS = {
    "a0001": "author of the danger trail philip steels etc",
    "a0002": "not at this particular case tom apologized whittemore",
    "a0003": "for the twentieth time that evening the two men shook hands",
    "a0004": "lord but i'm glad to see you again phil",
    "a0005": "will we ever forget it",
    "a0006": "god bless 'em i hope i'll go on seeing them forever",
    "a0010": "i'm playing a single hand in what looks like a losing game",
}
DIGIT_WORDS = ("zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine")


def spoken_words(bank: ClipBank, voice: int, clip: int, label: str) -> str:
    """What a speech event says: the digit's word (the scenarios' counting, ``label`` the digit), or the ARCTIC
    prompt of the sentence ``clip`` of ``voice`` (the rooms); "" where it is not known (synthetic speech)."""
    if bank.source == "digits" or label.isdigit():
        return " ".join(DIGIT_WORDS[int(c)] for c in label) if label.isdigit() else ""
    if bank.source != "arctic":
        return ""
    speaker = bank.speakers[voice]
    names = sorted(p.name for p in data_path("speech/arctic", None).glob("*.wav"))
    mine = [n for n in names if (n.split("_")[3] if n.startswith("cmu_") else n[:-4]) == speaker]
    return ARCTIC_PROMPTS.get(mine[clip][:-4].split("_")[-1], "") if clip < len(mine) else ""


@dataclass(frozen=True, eq=False)
class Background:
    """A noise in the room besides the robot's fan: ``signal`` (any length, looped) played from ``position_m``
    (scene frame) at ``snr_db`` under the speech's RMS at the first microphone (over the times someone speaks);
    ``source`` names it ("kitchen" or "pink")."""

    signal: np.ndarray
    position_m: tuple[float, float, float]
    snr_db: float
    source: str = "pink"


def load_background(position_m: tuple[float, float, float], snr_db: float, samplerate_hz: int = 16000,
                    data_dir: str | Path | None = None, seed: int = 0) -> Background:
    """The kitchen noise of ``noise/doing_the_dishes.wav`` (Speech Commands' background noise; the data folder's,
    else the shipped copy), or pink noise without it, at ``position_m`` and ``snr_db``."""
    path = data_path("noise/doing_the_dishes.wav", data_dir)
    if path.is_file():
        return Background(read_wav(path, samplerate_hz), position_m, snr_db, "kitchen")
    return Background(pink_noise(60 * samplerate_hz, np.random.default_rng([seed, 29])), position_m, snr_db, "pink")


# ---------------------------------------------------------------------------------------------------------------
# audio


@dataclass(frozen=True, eq=False)
class SimAudio:
    """The microphone signals of a whole scenario.

    samples : (n, Q) int16 -- one channel per microphone (left, right for the pair), as a 16-bit sound card gives
        them (full scale 32768);
    dry : (N, n) float32 -- what each actor emits (speech, claps, loudspeaker noise), at the source, by actor;
    measured_rt60_s : the reverberation time measured on the simulated responses; n_sources : how many responses
    were computed; clipped : samples that hit full scale; images : (N, Q, n) float32 or None -- what each actor
    alone puts on every microphone (reverberation included, in the samples' full-scale units: ``samples / 32768``
    is their sum plus the noises), with ``render_audio(images=True)``: the truth a voice's separation is scored on.
    """

    samples: np.ndarray
    samplerate_hz: int
    dry: np.ndarray
    measured_rt60_s: float
    n_sources: int
    clipped: int = 0
    images: np.ndarray | None = None


def _clap(rng: np.random.Generator, n: int, fs: int) -> np.ndarray:
    """A hand clap: a bright noise burst, 1 ms attack, 10 ms decay; RMS 3 over its first 20 ms (speech clips have
    unit RMS), i.e. about 10 dB louder than speech."""
    t = np.arange(n) / fs
    x = np.diff(rng.standard_normal(n + 1)) * np.minimum(1.0, t / 0.001) * np.exp(-t / 0.010)
    head = x[: max(1, round(0.02 * fs))]
    return 3.0 * x / np.sqrt(np.mean(head**2))


def _anchors(scenario: Scenario, start_s: float, end_s: float, actor: int, max_step_m: float,
             max_hop_s: float = 0.25) -> np.ndarray:
    """Times (K,) at which a sound source is given its own impulse response: one (the middle) for a still source,
    else a grid fine enough that the source moves at most ``max_step_m`` between two anchors."""
    path = scenario.actors[actor].path
    probe = np.linspace(start_s, end_s, 9)
    pos = path.at(probe)
    if np.max(np.linalg.norm(pos - pos[0], axis=1)) < 0.005:
        return np.array([(start_s + end_s) / 2])
    speed = np.max(np.linalg.norm(np.diff(path.at(np.linspace(start_s, end_s, 200)), axis=0), axis=1)) \
        / ((end_s - start_s) / 199)
    hop = min(max_hop_s, max_step_m / max(speed, 1e-6))
    k = max(1, int(np.ceil((end_s - start_s) / hop)))
    return np.linspace(start_s, end_s, k + 1)


def _source_pieces(scenario: Scenario, bank: ClipBank, n: int, fs: int, max_step_m: float
                   ) -> tuple[np.ndarray, list[tuple[np.ndarray, int, np.ndarray, int]]]:
    """What each actor emits (``dry``, (N, n)) and the pieces to convolve: (source position, first sample, signal,
    actor), a moving source cut into triangular cross-fades between anchors at most ``max_step_m`` apart."""
    n_actors = len(scenario.actors)
    dry = np.zeros((n_actors, n), dtype=np.float64)

    # pieces: (anchor position, first sample, signal, actor)
    pieces: list[tuple[np.ndarray, int, np.ndarray, int]] = []
    for e in scenario.events:
        s0 = round(e.start_s * fs)
        if s0 >= n:
            continue
        if e.kind == "speech":
            sig = bank.clip(scenario.actors[e.actor].voice, e.clip)
        elif e.kind == "clap":
            sig = _clap(np.random.default_rng(e.clip), round((e.end_s - e.start_s) * fs), fs)
        else:
            sig = np.random.default_rng(e.clip).standard_normal(round((e.end_s - e.start_s) * fs))
        sig = sig[: n - s0]
        dry[e.actor, s0:s0 + sig.size] += sig
        t_end = (s0 + sig.size) / fs
        anchors = _anchors(scenario, s0 / fs, t_end, e.actor, max_step_m)
        offset = np.asarray(SOURCE_OFFSETS_M[e.kind])
        if anchors.size == 1:
            pieces.append((scenario.actors[e.actor].path.at(anchors[0]) + offset, s0, sig, e.actor))
            continue
        t = (s0 + np.arange(sig.size)) / fs
        hop = anchors[1] - anchors[0]
        for c in anchors:
            w = np.clip(1.0 - np.abs(t - c) / hop, 0.0, None)  # triangles: a partition of unity between anchors
            nz = np.flatnonzero(w)
            if nz.size:
                pieces.append((scenario.actors[e.actor].path.at(c) + offset, s0 + int(nz[0]),
                               (sig * w)[nz[0]:nz[-1] + 1], e.actor))
    return dry, pieces


def render_audio(scenario: Scenario, bank: ClipBank, *, speech_level_rms: float = 0.1, fan_snr_db: float = 25.0,
                 sensor_noise_rms: float = 1e-4, max_step_m: float = 0.08, background: Background | None = None,
                 images: bool = False, progress: Callable[[str], None] | None = None) -> SimAudio:
    """The microphones' signals of ``scenario`` (paper section 7.3's room: reverberation, the robot's fan), one
    channel per microphone of ``scenario.room`` (two for the default pair).

    Every sound event leaves from its actor (mouth, hands, loudspeaker: ``SOURCE_OFFSETS_M``) and reaches the
    microphones through the room's image-source response. A moving source is cut into pieces with triangular
    cross-fades between anchors at most ``max_step_m`` apart, each piece through the response of its anchor.

    speech_level_rms : RMS of active speech at the microphones from a talker 1 m away (direct sound; farther talkers
        are quieter, 1/r); fan_snr_db : the fan this far below that level at the left microphone;
    sensor_noise_rms : white noise of the converter; background : a noise from a point in the room, at its SNR
    under the speech (:class:`Background`); images : keep each actor's own signals too (:attr:`SimAudio.images`).
    """
    room = scenario.room
    fs = room.samplerate_hz
    if bank.samplerate_hz != fs:
        raise ValueError(f"the clip bank is at {bank.samplerate_hz} Hz but the room at {fs} Hz; load the clips at {fs}")
    n = round(scenario.duration_s * fs)
    rng = np.random.default_rng([scenario.seed, 11])
    dry, pieces = _source_pieces(scenario, bank, n, fs, max_step_m)

    # one impulse response per distinct position (millimetres), plus the fan
    keys: dict[tuple[int, int, int], int] = {}
    for pos, _, _, _ in pieces:
        keys.setdefault(tuple(int(v) for v in np.round(pos * 1000)), len(keys))
    extra = [] if background is None else [background.position_m]
    positions = np.array([np.array(k) / 1000.0 for k in keys] + extra + [FAN_POSITION_M], dtype=np.float64)
    if progress:
        progress(f"room impulse responses for {positions.shape[0]} source positions ...")
    rirs, rt60 = _impulse_responses(room, positions)
    rirs = rirs[:, :, PRA_DELAY_SAMPLES:]
    if progress:
        progress(f"convolving {len(pieces)} sounds ...")

    gain = speech_level_rms * REFERENCE_DISTANCE_M  # pyroomacoustics' direct path has amplitude 1/r (r in metres)
    length = n + rirs.shape[2]
    n_mics = rirs.shape[1]
    out = np.zeros((n_mics, length))
    kept = np.zeros((len(scenario.actors), n_mics, length), dtype=np.float32) if images else None
    by_source: dict[tuple[int, int], list[tuple[int, np.ndarray]]] = {}  # (response, actor) -> pieces
    for pos, s0, sig, actor in pieces:
        by_source.setdefault((keys[tuple(int(v) for v in np.round(pos * 1000))], actor), []).append((s0, sig))
    for (src, actor), items in by_source.items():
        lo = min(s0 for s0, _ in items)
        hi = max(s0 + sig.size for s0, sig in items)
        track = np.zeros(hi - lo)
        for s0, sig in items:
            track[s0 - lo:s0 - lo + sig.size] += sig
        for m in range(n_mics):
            y = fftconvolve(track, rirs[src, m])
            out[m, lo:lo + y.size] += gain * y
            if kept is not None:
                kept[actor, m, lo:lo + y.size] += gain * y
    out = out[:, :n]
    if background is not None:  # scaled against the speech's RMS at the first microphone where someone speaks
        talking = np.zeros(n, dtype=bool)
        for e in scenario.events:
            if e.kind == "speech":
                talking[round(e.start_s * fs):round(e.end_s * fs)] = True
        speech_rms = float(np.sqrt(np.mean(out[0, talking] ** 2))) if talking.any() else speech_level_rms
        sig = np.resize(np.asarray(background.signal, dtype=np.float64), n)
        noise = np.stack([fftconvolve(sig, rirs[-2, m])[:n] for m in range(n_mics)])
        noise_rms = float(np.sqrt(np.mean(noise[0] ** 2)))
        if noise_rms > 0:
            out += noise * (speech_rms * 10 ** (-background.snr_db / 20) / noise_rms)

    fan = np.stack([fftconvolve(fan_noise(n, fs, rng), rirs[-1, m])[:n] for m in range(n_mics)])
    fan_rms = float(np.sqrt(np.mean(fan[0] ** 2)))
    if fan_rms > 0:
        out += fan * (speech_level_rms * 10 ** (-fan_snr_db / 20) / fan_rms)
    out += sensor_noise_rms * rng.standard_normal(out.shape)
    scaled = np.round(out.T * 32768.0)
    clipped = int(np.count_nonzero((scaled > 32767) | (scaled < -32768)))
    if clipped:
        log.warning("%d samples clipped at full scale; lower speech_level_rms", clipped)
    samples = np.clip(scaled, -32768, 32767).astype(np.int16)
    return SimAudio(samples, fs, dry.astype(np.float32), rt60, int(positions.shape[0]), clipped,
                    None if kept is None else kept[:, :, :n])


def _impulse_responses(room: AcousticRoom, positions: np.ndarray) -> tuple[np.ndarray, float]:
    """``room.impulse_responses`` for many sources with one RT60 correction measured on a single source (the
    correction does not depend on where the source is, and building the room twice for every source costs twice)."""
    if not room.match_rt60:
        return room.impulse_responses(positions)
    plain = replace(room, match_rt60=False)
    _, measured = plain.impulse_responses(positions[:1])
    target = room.rt60_s
    if abs(measured - target) > 0.05 * target:
        target = max(0.05, min(3.0, target * target / measured))
    corrected = replace(room, rt60_s=target, match_rt60=False)
    return corrected.impulse_responses(positions)
