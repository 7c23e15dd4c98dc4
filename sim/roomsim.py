"""A simulated reverberant room for tests and benchmarks: a robot head with two microphones, talkers, noise.

Built on pyroomacoustics (image-source model of a shoebox room; optional: ``pip install -e '.[sim]'``).

Coordinates: talkers and microphones are given in the project's **scene frame** (docs/architecture.md: origin at the
head, x right, y down, z forward, metres). The room's own frame (pyroomacoustics: origin at a corner, z up) only appears
inside this module; the head stands at ``AcousticRoom.head_m`` (room frame) looking along the room's +y axis.

Speech: real speech from ``../shared/data/speech`` (spoken digits, 8 kHz, resampled; or CMU ARCTIC sentences),
or, when that folder is absent, synthetic voiced speech (harmonic complexes with a moving pitch and formants,
syllabic envelope), so that the simulator runs on a clean machine. Background noise: the real kitchen recording
of ``../shared/data/noise`` (or synthetic pink noise) from a point source in a corner, reverberated by the room.
Ego-noise: a fan inside the head, a few centimetres from the microphones (blade-pass hum and its harmonics plus
low-passed broadband noise).

Ground truth: ``MicPair.itd`` of each talker (free-field direct path, eq. (itd) of the paper) and each talker's
dry signal aligned with its arrival at the head, from which benchmarks decide which windows hold speech.
"""
from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from math import gcd
from pathlib import Path
from typing import Literal

import numpy as np
from scipy.io import wavfile

from avcore._validate import as_points
from avcore.geometry import SPEED_OF_SOUND, MicArray, MicPair

__all__ = [
    "DEFAULT_DATA_DIR",
    "resolve_data_dir",
    "N_DIFFUSE",
    "AcousticRoom",
    "RoomRecording",
    "fan_noise",
    "load_speech",
    "noise_positions",
    "pink_noise",
    "simulate",
    "speech_turns",
    "synthetic_speech",
    "window_truth",
]

DATA_ENV = "AVHEAR_DATA"
DEFAULT_DATA_DIR = Path("../shared/data")  # relative to the current folder: the repository's root


EMBEDDED_DATA_DIR = Path(__file__).resolve().parent / "data"
"""The real speech and noise avhear ships (``sim/data/SOURCES.md``: each file's source and licence)."""


def data_path(relative: str, data_dir: str | Path | None = None) -> Path:
    """Where ``relative`` (``speech/digits``, ``speech/arctic``, ``noise/doing_the_dishes.wav``) is read: the data
    folder's (:func:`resolve_data_dir`) when it has it or was given by name (``data_dir``: a test's empty folder
    means "none"); else the copy shipped inside the package, when there is one; else the folder's path (absent:
    the caller falls back to synthetic sounds)."""
    path = resolve_data_dir(data_dir) / relative
    if path.exists() or data_dir is not None:
        return path
    shipped = EMBEDDED_DATA_DIR / relative
    return shipped if shipped.exists() else path


def resolve_data_dir(data_dir: str | Path | None = None) -> Path:
    """Where the real third-party data (faces, speech, noise) is read from: ``data_dir`` when given, else the
    ``AVHEAR_DATA`` environment variable, else ``../shared/data`` relative to the current folder. A folder that is
    not there makes the simulator fall back to drawn faces and synthetic sounds (and say so)."""
    if data_dir is not None:
        return Path(data_dir)
    return Path(os.environ.get(DATA_ENV) or DEFAULT_DATA_DIR)
SPEECH_LEVEL_RMS = 0.1  # active speech at the microphones, full scale 1 (-20 dBFS): 10 dB above the paper's E_A


def _release_heap() -> None:
    """Give the C heap's freed memory back to the system (glibc's ``malloc_trim``; elsewhere nothing).

    pyroomacoustics' image sources are many small C++ allocations; once freed they stay in the process's heap, held
    for the whole run unless given back (measured in docs/experiments.md, twenty-first session)."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):  # not glibc
        pass


def _pyroomacoustics():
    try:
        import pyroomacoustics as pra
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise ImportError("the room simulator needs pyroomacoustics; install it with pip install -e '.[sim]'") \
            from exc
    return pra


# ---------------------------------------------------------------------------------------------------------------
# signals


def read_wav(path: Path, samplerate_hz: int) -> np.ndarray:
    with warnings.catch_warnings():
        # the kitchen-noise file carries a LIST chunk that scipy skips with a warning; the audio is intact
        warnings.filterwarnings("ignore", message="Chunk .* not understood")
        fs, data = wavfile.read(path)
    x = data.astype(np.float64)
    if np.issubdtype(data.dtype, np.integer):
        x /= float(np.iinfo(data.dtype).max)
    if x.ndim == 2:
        x = x.mean(axis=1)
    if fs != samplerate_hz:
        from scipy.signal import resample_poly  # SciPy's signal module only where used: slow to import

        g = gcd(int(fs), int(samplerate_hz))
        x = resample_poly(x, samplerate_hz // g, fs // g)
    return x


def load_speech(samplerate_hz: int, kind: Literal["digits", "arctic"] = "digits",
                data_dir: Path | None = None) -> list[np.ndarray] | None:
    """Real utterances from ``speech/<kind>`` (:func:`data_path`: the data folder's, or the shipped copy),
    resampled to ``samplerate_hz``; None if absent.

    Returns a list of ``(n,)`` float arrays (full scale 1), sorted by file name; each trimmed of leading and
    trailing silence (below 1 % of its peak) and high-passed at about 60 Hz (removes DC and hum).
    """
    folder = data_path(f"speech/{kind}", data_dir)
    files = sorted(folder.glob("*.wav"))
    if not files:
        return None
    from scipy.signal import lfilter

    out = []
    for f in files:
        x = read_wav(f, samplerate_hz)
        x = lfilter([1.0, -1.0], [1.0, -(1.0 - 2 * np.pi * 60.0 / samplerate_hz)], x)
        loud = np.flatnonzero(np.abs(x) > 0.01 * np.max(np.abs(x)))
        if loud.size:
            out.append(x[loud[0]:loud[-1] + 1])
    return out


def pink_noise(n: int, rng: np.random.Generator) -> np.ndarray:
    """``(n,)`` noise with a 1/f power spectrum, unit RMS."""
    spec = np.fft.rfft(rng.standard_normal(n))
    f = np.arange(spec.shape[0], dtype=np.float64)
    f[0] = 1.0
    x = np.fft.irfft(spec / np.sqrt(f), n)
    return x / np.sqrt(np.mean(x**2))


def synthetic_speech(duration_s: float, samplerate_hz: int, rng: np.random.Generator) -> np.ndarray:
    """One synthetic voiced utterance, ``(round(duration_s * samplerate_hz),)``, peak about 0.5.

    A harmonic complex (pitch gliding between 100 and 220 Hz) shaped by three moving formants and a syllabic
    envelope at about 4 Hz, plus a little breath noise: voiced, broadband enough for ITDs, and not stationary.
    """
    n = round(duration_s * samplerate_hz)
    t = np.arange(n) / samplerate_hz
    f0 = rng.uniform(100, 220) * (1 + 0.15 * np.sin(2 * np.pi * rng.uniform(0.5, 2) * t + rng.uniform(0, 6)))
    phase = 2 * np.pi * np.cumsum(f0) / samplerate_hz
    nyq = samplerate_hz / 2
    formants = rng.uniform([500, 1200, 2400], [800, 2000, 3200])
    x = np.zeros(n)
    for h in range(1, 60):
        fh = h * f0
        gain = sum(1.0 / (1.0 + ((fh - fm) / (80.0 + 0.05 * fm)) ** 2) for fm in formants) / np.sqrt(h)
        x += np.where(fh < 0.9 * nyq, gain, 0.0) * np.sin(h * phase)
    x += 0.05 * rng.standard_normal(n) * np.std(x)
    rate = rng.uniform(3, 5)
    envelope = np.clip(np.sin(np.pi * rate * t + rng.uniform(0, np.pi)), 0, None) ** 0.5
    ramp = np.minimum(1.0, np.minimum(t, t[-1] - t) / 0.02)
    x *= envelope * ramp
    return 0.5 * x / np.max(np.abs(x))


def fan_noise(n: int, samplerate_hz: int, rng: np.random.Generator, blade_hz: float = 180.0) -> np.ndarray:
    """``(n,)`` fan-like ego-noise, unit RMS: blade-pass hum with harmonics and low-passed broadband noise."""
    t = np.arange(n) / samplerate_hz
    jitter = 1.0 + 0.01 * np.cumsum(rng.standard_normal(n)) / np.sqrt(n)
    phase = 2 * np.pi * blade_hz * np.cumsum(jitter) / samplerate_hz
    hum = sum((0.6**k) * np.sin(k * phase + rng.uniform(0, 2 * np.pi)) for k in range(1, 6))
    from scipy.signal import lfilter

    alpha = np.exp(-2 * np.pi * 2000.0 / samplerate_hz)
    broadband = lfilter([1 - alpha], [1, -alpha], rng.standard_normal(n))
    x = hum / np.sqrt(np.mean(hum**2)) + broadband / np.sqrt(np.mean(broadband**2))
    del t
    return x / np.sqrt(np.mean(x**2))


def speech_turns(n_talkers: int, duration_s: float, samplerate_hz: int, rng: np.random.Generator,
                 utterances: list[np.ndarray] | None = None, pause_s: tuple[float, float] = (0.15, 0.5)
                 ) -> np.ndarray:
    """Dry signals ``(n_talkers, n)`` of talkers speaking in turn (one utterance each, round-robin).

    ``utterances`` are drawn at random (for example the spoken digits: the natural counting turns of the
    paper's scenarios); without them, synthetic utterances of 0.4 to 1 s are made. Each utterance is scaled to
    unit RMS over its loud part, so that talkers are equally loud.
    """
    if n_talkers < 1:
        raise ValueError(f"n_talkers must be at least 1, got {n_talkers}")
    n = round(duration_s * samplerate_hz)
    out = np.zeros((n_talkers, n))
    pos = int(rng.uniform(*pause_s) * samplerate_hz)
    k = 0
    while True:
        if utterances:
            u = utterances[int(rng.integers(len(utterances)))]
        else:
            u = synthetic_speech(rng.uniform(0.4, 1.0), samplerate_hz, rng)
        if pos + u.shape[0] > n:
            break
        loud = np.abs(u) > 0.05 * np.max(np.abs(u))
        out[k % n_talkers, pos:pos + u.shape[0]] = u / np.sqrt(np.mean(u[loud] ** 2))
        pos += u.shape[0] + int(rng.uniform(*pause_s) * samplerate_hz)
        k += 1
    return out


# ---------------------------------------------------------------------------------------------------------------
# the room


@dataclass(frozen=True)
class AcousticRoom:
    """A shoebox room with a robot head.

    Parameters
    ----------
    dims_m : (3,) float, metres
        AcousticRoom size along the room's x (width), y (depth) and z (height).
    rt60_s : float, seconds
        Reverberation time (0.2 to 0.8 s in the benchmarks).
    head_m : (3,) float, metres
        Centre of the microphone pair in the room frame; the head looks along the room's +y axis.
    mic_distance_m : float, metres
        Distance between the two microphones (12 cm by default), on the scene x axis.
    samplerate_hz : int
    mic_positions_m : (Q, 3) metres, scene frame, or None
        Several microphones (an array such as :data:`avcore.geometry.ARRAY_PRESETS`' on the robot's head, origin
        at the head); None: the pair of ``mic_distance_m``.
    match_rt60 : bool
        The image-source model decays more slowly than Sabine's formula predicts; if True, the absorption is
        corrected once so that the RT60 measured on the simulated responses is close to ``rt60_s``.
    """

    dims_m: tuple[float, float, float] = (6.0, 5.0, 3.0)
    rt60_s: float = 0.4
    head_m: tuple[float, float, float] = (3.0, 1.5, 1.2)
    mic_distance_m: float = 0.12
    samplerate_hz: int = 16000
    match_rt60: bool = True
    mic_positions_m: tuple[tuple[float, float, float], ...] | None = None

    def __post_init__(self) -> None:
        dims = np.asarray(self.dims_m, dtype=np.float64)
        if dims.shape != (3,) or not np.all(dims > 0):
            raise ValueError(f"dims_m must be three positive lengths in metres, got {self.dims_m!r}")
        if not (0.05 <= self.rt60_s <= 3.0):
            raise ValueError(f"rt60_s must be a reverberation time between 0.05 and 3 s, got {self.rt60_s!r}")
        if not (0 < self.mic_distance_m < 1.0):
            raise ValueError(f"mic_distance_m must be in (0, 1) metres, got {self.mic_distance_m!r}")
        if not isinstance(self.samplerate_hz, (int, np.integer)) or self.samplerate_hz < 4000:
            raise ValueError(f"samplerate_hz must be an integer >= 4000, got {self.samplerate_hz!r}")
        if self.mic_positions_m is not None:
            object.__setattr__(self, "mic_positions_m", MicArray(tuple(self.mic_positions_m)).positions)
        for q, position in enumerate(self.mic_positions()):
            self._check_inside(self.scene_to_room(position), f"microphone {q}")

    def mic_positions(self) -> np.ndarray:
        """(Q, 3) the microphones in the scene frame: ``mic_positions_m``, or the pair ``(-+d/2, 0, 0)``."""
        if self.mic_positions_m is not None:
            return np.asarray(self.mic_positions_m, dtype=np.float64)
        h = self.mic_distance_m / 2
        return np.array([(-h, 0.0, 0.0), (h, 0.0, 0.0)])

    def mic_array(self, speed_of_sound: float = SPEED_OF_SOUND) -> MicArray:
        """The microphones as a :class:`MicArray` (every pair, the widest left-right first); channel q is
        microphone q."""
        return MicArray(tuple(map(tuple, self.mic_positions())), speed_of_sound=speed_of_sound)

    def mic_pair(self, speed_of_sound: float = SPEED_OF_SOUND) -> MicPair:
        """The microphone pair in the scene frame: ``(-d/2, 0, 0)`` and ``(+d/2, 0, 0)``, or an array's first
        pair."""
        if self.mic_positions_m is not None:
            return self.mic_array(speed_of_sound).pair(0)
        h = self.mic_distance_m / 2
        return MicPair(left=(-h, 0.0, 0.0), right=(h, 0.0, 0.0), speed_of_sound=speed_of_sound)

    def scene_to_room(self, points: object) -> np.ndarray:
        """Scene frame (x right, y down, z forward; origin at the head) to room frame (corner origin, z up)."""
        p = np.asarray(points, dtype=np.float64)
        head = np.asarray(self.head_m)
        return np.stack([head[0] + p[..., 0], head[1] + p[..., 2], head[2] - p[..., 1]], axis=-1)

    def room_to_scene(self, points: object) -> np.ndarray:
        """Inverse of :meth:`scene_to_room`."""
        p = np.asarray(points, dtype=np.float64) - np.asarray(self.head_m)
        return np.stack([p[..., 0], -p[..., 2], p[..., 1]], axis=-1)

    def _check_inside(self, room_point: np.ndarray, what: str, margin: float = 0.05) -> None:
        dims = np.asarray(self.dims_m)
        if not (np.all(room_point > margin) and np.all(room_point < dims - margin)):
            raise ValueError(f"{what} at {np.round(room_point, 3).tolist()} (room frame, metres) is not inside "
                             f"the room {list(self.dims_m)} with a {margin} m margin; move it or enlarge the room")

    def impulse_responses(self, sources_scene: object) -> tuple[np.ndarray, float]:
        """AcousticRoom impulse responses from each source to each microphone (:meth:`mic_positions`).

        sources_scene : (S, 3) float, metres, scene frame.
        Returns ``(S, Q, L)`` responses (pyroomacoustics' global delay of 40 samples included, the same for both
        microphones) and the RT60 measured on them, seconds.
        """
        src = as_points(sources_scene, "sources_scene", allow_empty=False)
        room_src = self.scene_to_room(src)
        for i, p in enumerate(room_src):
            self._check_inside(p, f"source {i}")
        mics = self.scene_to_room(self.mic_positions()).T  # (3, Q)
        key = (tuple(self.dims_m), self.samplerate_hz, self.rt60_s, self.match_rt60, room_src.tobytes(),
               mics.tobytes())
        found = _RIRS.get(key)
        if found is None:
            found = _RIRS[key] = self._impulse_responses(room_src, mics)
            _release_heap()
            while len(_RIRS) > _RIRS_KEPT:
                _RIRS.pop(next(iter(_RIRS)))
        rirs, measured = found
        return rirs.copy(), measured

    def _impulse_responses(self, room_src: np.ndarray, mics: np.ndarray) -> tuple[np.ndarray, float]:
        pra = _pyroomacoustics()

        def build(rt60: float):
            e_absorption, max_order = pra.inverse_sabine(rt60, list(self.dims_m))
            room = pra.ShoeBox(list(self.dims_m), fs=self.samplerate_hz, materials=pra.Material(e_absorption),
                               max_order=max_order)
            for p in room_src:
                room.add_source(p.tolist())
            room.add_microphone_array(mics)
            room.compute_rir()
            return room

        room = build(self.rt60_s)
        measured = float(np.mean(room.measure_rt60()))
        if self.match_rt60 and abs(measured - self.rt60_s) > 0.05 * self.rt60_s:
            room = build(max(0.05, self.rt60_s * self.rt60_s / measured))
            measured = float(np.mean(room.measure_rt60()))
        n_mics = mics.shape[1]
        length = max(len(room.rir[m][s]) for m in range(n_mics) for s in range(len(room_src)))
        rirs = np.zeros((len(room_src), n_mics, length))
        for s in range(len(room_src)):
            for m in range(n_mics):
                r = room.rir[m][s]
                rirs[s, m, :len(r)] = r
        return rirs, measured


_RIRS: dict[tuple, tuple[np.ndarray, float]] = {}  # the rooms computed in this process (the same room, twice: once)
_RIRS_KEPT = 16


@dataclass(frozen=True)
class RoomRecording:
    """What the microphones of a simulated room hear, by component, and the ground truth.

    speech, background, ego : (Q, n) float -- reverberant images at each microphone ((left, right) for the pair) of
        all talkers, of the background noise source, of the fan; ``mix`` adds them at chosen levels.
    dry : (T, n) float -- each talker's dry signal delayed to its direct-path arrival at the head (for deciding
        which windows hold speech).
    talkers_scene : (T, 3) float, metres.  talker_itds_s : (T,) float, seconds -- ``MicPair.itd`` of each talker.
    """

    room: AcousticRoom
    mics: MicPair
    speech: np.ndarray
    background: np.ndarray
    ego: np.ndarray
    dry: np.ndarray
    talkers_scene: np.ndarray
    talker_itds_s: np.ndarray
    measured_rt60_s: float
    meta: dict = field(default_factory=dict)

    @property
    def samplerate_hz(self) -> int:
        return self.room.samplerate_hz

    def mix(self, snr_db: float | None = 20.0, ego_snr_db: float | None = 25.0,
            level_rms: float = SPEECH_LEVEL_RMS) -> tuple[np.ndarray, np.ndarray]:
        """Left and right signals ``(n,)``: active speech at ``level_rms``, the background noise ``snr_db`` below
        it and the fan ``ego_snr_db`` below it (None leaves a component out). Levels are measured at the left
        microphone; speech power over the samples where some talker is active."""
        active = np.any(np.abs(self.dry) > 0, axis=0)
        if not np.any(active):
            active = np.ones(self.dry.shape[1], dtype=bool)
        p_speech = float(np.mean(self.speech[0, active] ** 2))
        gain = level_rms / np.sqrt(p_speech) if p_speech > 0 else 1.0
        out = gain * self.speech
        target = level_rms**2
        for component, snr in ((self.background, snr_db), (self.ego, ego_snr_db)):
            if snr is None:
                continue
            p = float(np.mean(component[0] ** 2))
            if p > 0:
                out = out + component * np.sqrt(target / 10 ** (snr / 10) / p)
        return out[0].copy(), out[1].copy()


N_DIFFUSE = 8


def noise_positions(room: AcousticRoom, noise: Literal["diffuse", "point"] = "diffuse") -> np.ndarray:
    """Default background-noise sources, scene frame ``(S, 3)`` metres: one in a back corner (``"point"``) or
    ``N_DIFFUSE`` spread around the room 0.4 m from the walls at varied heights (``"diffuse"``)."""
    dims = np.asarray(room.dims_m)
    if noise == "point":
        return room.room_to_scene(np.array([[0.5, dims[1] - 0.5, dims[2] - 0.4]]))
    if noise != "diffuse":
        raise ValueError(f"noise must be 'diffuse' or 'point', got {noise!r}")
    angles = 2 * np.pi * (np.arange(N_DIFFUSE) + 0.5) / N_DIFFUSE
    centre = dims / 2
    half = dims / 2 - 0.4
    pts = np.stack([centre[0] + half[0] * np.cos(angles), centre[1] + half[1] * np.sin(angles),
                    np.where(np.arange(N_DIFFUSE) % 2 == 0, 0.5, dims[2] - 0.5)], axis=1)
    return room.room_to_scene(pts)


def simulate(room: AcousticRoom, talkers_scene: object, duration_s: float = 10.0, seed: int = 0,
             data_dir: Path | None = None, speech: Literal["digits", "arctic", "synthetic"] = "digits",
             noise: Literal["diffuse", "point"] = "diffuse", noise_scene: object | None = None,
             fan_scene: object = (0.02, -0.04, -0.06), rirs: tuple[np.ndarray, float] | None = None
             ) -> RoomRecording:
    """Simulate ``duration_s`` seconds of talkers speaking in turn in ``room``.

    Parameters
    ----------
    talkers_scene : (T, 3) float, metres, scene frame
        One to three talkers (any number works).
    speech : "digits", "arctic" or "synthetic"
        Real speech from ``data_dir`` (default ``../shared/data``); falls back to synthetic speech (and pink
        background noise) when the data is absent, recorded in ``meta["speech"]``.
    noise : "diffuse" or "point"
        Background noise: ``"diffuse"``, uncorrelated excerpts of the noise recording from ``N_DIFFUSE`` sources
        spread near the walls (an approximately diffuse room noise), or ``"point"``, one source (a directional
        interferer, by default in a back corner).
    noise_scene : (S, 3) float, metres, optional
        Where the noise sources are (overrides the default positions; ``noise_positions`` gives the defaults).
    fan_scene : (3,) float, metres
        The fan inside the head (default: 6 cm behind the microphones, slightly up and to the right).
    rirs : optional
        The output of ``room.impulse_responses`` for the sources ``[*talkers, *noise sources, fan]``, to reuse.
    """
    rng = np.random.default_rng(seed)
    fs = room.samplerate_hz
    talkers = as_points(talkers_scene, "talkers_scene", allow_empty=False)
    noise_src = noise_positions(room, noise) if noise_scene is None else as_points(noise_scene, "noise_scene")
    sources = np.vstack([talkers, noise_src, np.asarray(fan_scene, dtype=np.float64)[None]])
    if rirs is None:
        rirs = room.impulse_responses(sources)
    responses, measured = rirs
    if responses.shape[0] != sources.shape[0]:
        raise ValueError(f"rirs hold {responses.shape[0]} sources, expected {sources.shape[0]} "
                         "(talkers, noise sources, fan)")
    n = round(duration_s * fs)

    utterances = None if speech == "synthetic" else load_speech(fs, speech, data_dir)
    used = speech if utterances else "synthetic"
    dry = speech_turns(talkers.shape[0], duration_s, fs, rng, utterances)

    noise_file = data_path("noise/doing_the_dishes.wav", data_dir)
    full = read_wav(noise_file, fs) if used != "synthetic" and noise_file.is_file() else None
    noise_kind = "doing_the_dishes.wav" if full is not None else "pink"
    n_talk = talkers.shape[0]

    from scipy.signal import fftconvolve

    def image(signal: np.ndarray, s: int) -> np.ndarray:
        return np.stack([fftconvolve(signal, responses[s, m])[:n] for m in range(responses.shape[1])])

    background = np.zeros((responses.shape[1], n))
    for j in range(noise_src.shape[0]):
        if full is not None:
            start = int(rng.integers(0, max(1, full.shape[0] - n)))
            excerpt = np.resize(full[start:start + n], n)
        else:
            excerpt = pink_noise(n, rng)
        background += image(excerpt, n_talk + j)
    speech_img = sum(image(dry[t], t) for t in range(n_talk))
    ego = image(fan_noise(n, fs, rng), n_talk + noise_src.shape[0])

    # Dry signals aligned with the direct sound at the head centre (plus pyroomacoustics' 40-sample delay).
    mics = room.mic_pair()
    aligned = np.zeros_like(dry)
    for t, p in enumerate(talkers):
        delay = round(np.linalg.norm(p) / mics.speed_of_sound * fs) + 40
        aligned[t, delay:] = dry[t, :n - delay]
    return RoomRecording(room=room, mics=mics, speech=speech_img, background=background, ego=ego, dry=aligned,
                         talkers_scene=talkers, talker_itds_s=np.atleast_1d(mics.itd(talkers)),
                         measured_rt60_s=measured,
                         meta={"speech": used, "noise": f"{noise} ({noise_kind})", "seed": seed})


def window_truth(dry: np.ndarray, samplerate_hz: float, window_s: float = 0.15, hop_s: float = 0.02,
                 active_db: float = -10.0) -> tuple[np.ndarray, np.ndarray]:
    """Which talker speaks in each analysis window (the windows of ``extract_itds``).

    dry : (T, n) float -- aligned dry talker signals (``RoomRecording.dry``).
    Returns ``times_s (W,)`` window centres and ``talker (W,)`` int: the index of the loudest talker in the window
    if its power is at least ``active_db`` relative to its mean power over its active samples (a speech window),
    else -1.
    """
    w = round(window_s * samplerate_hz)
    hop = round(hop_s * samplerate_hz)
    n = dry.shape[1]
    n_windows = 1 + (n - w) // hop
    csum = np.concatenate([np.zeros((dry.shape[0], 1)), np.cumsum(dry**2, axis=1)], axis=1)
    starts = np.arange(n_windows) * hop
    power = (csum[:, starts + w] - csum[:, starts]) / w  # (T, W)
    active_power = np.array([np.mean(d[np.abs(d) > 0] ** 2) if np.any(d) else np.inf for d in dry])
    loudest = np.argmax(power, axis=0)
    ok = power[loudest, np.arange(n_windows)] >= active_power[loudest] * 10 ** (active_db / 10)
    return (starts + 0.5 * w) / samplerate_hz, np.where(ok, loudest, -1)
