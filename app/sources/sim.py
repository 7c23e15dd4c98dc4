"""The simulated room as a sensor stream: stereo frames and microphone blocks with timestamps, plus the truth.

The embedded default source (DESIGN.md, "What users get"): a :class:`SimSource` delivers what a real rig delivers --
640x480 left/right frames at ``fps`` (15-30) and 16 kHz two-channel audio in blocks of ``block_size`` samples, each
stamped on one clock -- from a scenario of :mod:`sim.scenario` (the paper's section 7.3 presets S1-S5 and the
section 5.3 calibration), with the ground truth of every frame.

Audio is computed once, when the source is made (the whole scenario: image-source room impulse responses from
:mod:`sim.roomsim`, one per still sound source and one per ``max_step_m`` of a moving one, cross-faded; the
robot's fan; 16-bit quantisation as a sound card does). Frames are rendered on demand by
:class:`sim.render.StereoSceneRenderer`; a frame whose scene did not change (nobody moved or nodded) reuses the
previous rendering with fresh sensor noise, so still scenes cost little.

Streams (shared with :class:`app.sources.recording.Recording`, see :class:`StreamSource`): ``stream()`` yields frames and
audio blocks merged in delivery order (a frame at its stamp, an audio block when its last sample has been captured),
``frames()`` and ``audio_blocks()`` yield one kind each (for a grabber thread and an audio thread). With
``realtime=True`` each item is delivered at its time on ``time.monotonic()``, stamps rebased onto that clock, and a
frame that cannot be rendered in time is dropped (counted in ``stats``) as a camera drops frames; otherwise items
come as fast as they can be made, stamped from 0.

Real data (faces, spoken digits) come from ``data_dir`` (default ``../shared/data``); when it is absent, drawn faces
and synthetic voiced clips are used (``SimSource.meta`` says which).
"""
from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
from scipy.signal import fftconvolve

from app.events import AudioBlock, StereoFrame
from avcore.faces import HaarFaceDetector
from avcore.geometry import MicPair
from sim.render import (
    FaceTexture,
    Person,
    StereoSceneRenderer,
    drawn_face_texture,
    load_face_textures,
)
from sim.roomsim import Room, fan_noise, load_speech, resolve_data_dir
from sim.scenario import (
    SOURCE_OFFSETS_M,
    ClipBank,
    FrameTruth,
    Scenario,
    make_scenario,
    normalise_clip,
    synthetic_clip_bank,
    trim_quiet_ends,
)
from avcore.stereo import StereoRig

__all__ = [
    "AudioBlock",
    "StereoFrame",
    "StreamSource",
    "SimAudio",
    "SimSource",
    "load_clip_bank",
    "load_textures",
    "render_audio",
]

log = logging.getLogger(__name__)

PRA_DELAY_SAMPLES = 40   # pyroomacoustics' global delay in its responses (sim.roomsim.Room.impulse_responses)
FAN_POSITION_M = (0.02, -0.04, -0.06)  # the fan inside the head, behind the microphones (as sim.roomsim)
REFERENCE_DISTANCE_M = 1.0
NOD_HZ = 2.0


# ---------------------------------------------------------------------------------------------------------------
# stream items and the shared streaming logic


@dataclass
class StreamStats:
    """What a stream delivered: frames, frames dropped because they were late (real-time only), audio blocks."""

    frames: int = 0
    frames_dropped: int = 0
    blocks: int = 0


class StreamSource:
    """Frames and audio blocks on one clock, from any source that can give frame ``k`` and samples ``[a, b)``.

    Subclasses provide ``stereo``, ``mics``, ``fps``, ``samplerate_hz``, ``n_channels``, ``frame_stamps_s`` (n,) and
    ``right_stamps_s`` (n,) seconds, ``audio_start_s``, ``n_samples``, ``_images(k)`` (called with increasing ``k``
    within one stream), ``_samples(a, b)`` -> (b - a, C) float32, and ``truth(k)``.
    """

    stereo: StereoRig
    mics: MicPair | None
    fps: float
    samplerate_hz: int
    n_channels: int
    frame_stamps_s: np.ndarray
    right_stamps_s: np.ndarray
    audio_start_s: float
    n_samples: int
    block_size: int = 512

    def __init__(self) -> None:
        self.stats = StreamStats()

    # -------------------------------------------------------------- to implement
    def _images(self, k: int) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - abstract
        raise NotImplementedError

    def _samples(self, a: int, b: int) -> np.ndarray:  # pragma: no cover - abstract
        raise NotImplementedError

    def truth(self, k: int) -> FrameTruth | None:
        """The ground truth of frame ``k``, or None when unknown."""
        return None

    def _reset(self) -> None:
        """Called at the start of every stream (a recording rewinds its videos)."""

    # -------------------------------------------------------------- derived
    @property
    def n_frames(self) -> int:
        return int(self.frame_stamps_s.shape[0])

    @property
    def start_s(self) -> float:
        """The earliest stamp of the source (first frame or first sample), on its own clock."""
        first = [self.audio_start_s] if self.n_samples else []
        if self.n_frames:
            first.append(float(min(self.frame_stamps_s[0], self.right_stamps_s[0])))
        return min(first) if first else 0.0

    @property
    def duration_s(self) -> float:
        """From the earliest stamp to the end of the last frame or sample, seconds."""
        ends = [self.audio_start_s + self.n_samples / self.samplerate_hz] if self.n_samples else []
        if self.n_frames:
            ends.append(float(self.frame_stamps_s[-1]) + 1.0 / self.fps)
        return (max(ends) - self.start_s) if ends else 0.0

    def frames(self, *, realtime: bool = False, start_s: float | None = None) -> Iterator[StereoFrame]:
        """Only the frames (for a grabber thread); see :meth:`stream`."""
        yield from self._run(realtime, start_s, want_frames=True, want_audio=False,  # type: ignore[misc]
                             block_size=None)

    def audio_blocks(self, *, realtime: bool = False, start_s: float | None = None,
                     block_size: int | None = None) -> Iterator[AudioBlock]:
        """Only the audio blocks (for an audio thread); see :meth:`stream`."""
        yield from self._run(realtime, start_s, want_frames=False, want_audio=True,  # type: ignore[misc]
                             block_size=block_size)

    def stream(self, *, realtime: bool = False, start_s: float | None = None,
               block_size: int | None = None) -> Iterator[StereoFrame | AudioBlock]:
        """Frames and audio blocks merged in delivery order.

        realtime : deliver each item at its time on ``time.monotonic()`` (frames at their stamp, blocks once their
            last sample is captured) and drop frames that are more than one frame period late; else as fast as
            possible.
        start_s : the stamp given to the source's earliest instant; default ``time.monotonic()`` at the start in
            real time (the pipeline's clock), else the source's own stamps (0-based for the simulator). Threads that
            consume :meth:`frames` and :meth:`audio_blocks` separately in real time pass the same ``start_s``.
        block_size : samples per audio block (default the source's ``block_size``).
        """
        return self._run(realtime, start_s, want_frames=True, want_audio=True, block_size=block_size)

    def _run(self, realtime: bool, start_s: float | None, *, want_frames: bool, want_audio: bool,
             block_size: int | None) -> Iterator[StereoFrame | AudioBlock]:
        bs = int(block_size or self.block_size)
        if bs < 1:
            raise ValueError(f"block_size must be a positive number of samples, got {block_size!r}")
        if want_frames:
            self._reset()  # rewinds the videos; an audio-only stream in another thread leaves them alone
            self.stats.frames = self.stats.frames_dropped = 0
        if want_audio:
            self.stats.blocks = 0
        clock0 = time.monotonic()
        base = (clock0 if realtime else self.start_s) if start_s is None else float(start_s)
        if realtime:
            # deliver each item when its stamp comes on the monotonic clock: threads that share start_s are paced
            # together, and a stamp is the time of capture as a device would give it
            clock0 = base
        shift = base - self.start_s  # added to the source's own stamps
        period = 1.0 / self.fps
        fs = self.samplerate_hz
        k = 0 if want_frames else self.n_frames
        a = 0 if want_audio else self.n_samples
        block = 0
        while k < self.n_frames or a < self.n_samples:
            frame_due = float(self.frame_stamps_s[k]) if k < self.n_frames else np.inf
            b = min(a + bs, self.n_samples)
            audio_due = self.audio_start_s + b / fs if a < self.n_samples else np.inf
            if audio_due <= frame_due:
                if realtime:
                    _sleep_until(clock0 + audio_due - self.start_s)
                samples = self._samples(a, b)
                self.stats.blocks += 1
                yield AudioBlock(block, a, self.audio_start_s + a / fs + shift, samples, fs)
                block += 1
                a = b
                continue
            if realtime:
                late = time.monotonic() - (clock0 + frame_due - self.start_s)
                if late > period:
                    self.stats.frames_dropped += 1
                    k += 1
                    continue
                _sleep_until(clock0 + frame_due - self.start_s)
            left, right = self._images(k)
            self.stats.frames += 1
            yield StereoFrame(k, frame_due + shift, left, right, float(self.right_stamps_s[k]) + shift,
                              self.truth(k))
            k += 1


def _sleep_until(deadline: float) -> None:
    delay = deadline - time.monotonic()
    if delay > 0:
        time.sleep(delay)


# ---------------------------------------------------------------------------------------------------------------
# real data or its stand-ins


def load_clip_bank(samplerate_hz: int = 16000, data_dir: str | Path | None = None, n_voices: int = 3,
                   seed: int = 0) -> ClipBank:
    """The spoken digits of ``data_dir/speech/digits`` grouped by speaker (``{digit}_{speaker}_N.wav``), one voice
    per speaker with its ten digits, each cut to its audible part (:func:`sim.scenario.trim_quiet_ends`: the
    truth's speaking states follow the clips); :func:`sim.scenario.synthetic_clip_bank` when the folder is absent
    or incomplete. ``data_dir`` defaults to :func:`sim.roomsim.resolve_data_dir`."""
    root = resolve_data_dir(data_dir)
    folder = root / "speech" / "digits"
    names = sorted(p.name for p in folder.glob("*.wav")) if folder.is_dir() else []
    clips = load_speech(samplerate_hz, "digits", root) if names else None
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


def load_textures(data_dir: str | Path | None = None) -> tuple[list[FaceTexture], str]:
    """Face textures cut from ``data_dir/faces`` (kept only where OpenCV's detector finds them), or five drawn faces
    when the folder is absent. Returns the textures and "faces" or "drawn"."""
    root = resolve_data_dir(data_dir)
    try:
        textures = load_face_textures(root / "faces", detector=HaarFaceDetector())
    except FileNotFoundError:
        textures = []
    if textures:
        return textures, "faces"
    skins = ((150, 180, 220), (110, 140, 190), (90, 120, 160), (130, 160, 205), (70, 95, 130))
    return [drawn_face_texture(skin_bgr=s) for s in skins], "drawn"


# ---------------------------------------------------------------------------------------------------------------
# audio


@dataclass(frozen=True, eq=False)
class SimAudio:
    """The microphone signals of a whole scenario.

    samples : (n, 2) int16 -- left, right, as a 16-bit sound card gives them (full scale 32768);
    dry : (N, n) float32 -- what each actor emits (speech, claps, loudspeaker noise), at the source, by actor;
    measured_rt60_s : the reverberation time measured on the simulated responses; n_sources : how many responses
    were computed; clipped : samples that hit full scale.
    """

    samples: np.ndarray
    samplerate_hz: int
    dry: np.ndarray
    measured_rt60_s: float
    n_sources: int
    clipped: int = 0


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


def render_audio(scenario: Scenario, bank: ClipBank, *, speech_level_rms: float = 0.1, fan_snr_db: float = 25.0,
                 sensor_noise_rms: float = 1e-4, max_step_m: float = 0.08,
                 progress: Callable[[str], None] | None = None) -> SimAudio:
    """The two microphone signals of ``scenario`` (paper section 7.3's room: reverberation, the robot's fan).

    Every sound event leaves from its actor (mouth, hands, loudspeaker: ``SOURCE_OFFSETS_M``) and reaches the
    microphones through the room's image-source response. A moving source is cut into pieces with triangular
    cross-fades between anchors at most ``max_step_m`` apart, each piece through the response of its anchor.

    speech_level_rms : RMS of active speech at the microphones from a talker 1 m away (direct sound; farther talkers
        are quieter, 1/r); fan_snr_db : the fan this far below that level at the left microphone;
    sensor_noise_rms : white noise of the converter.
    """
    room = scenario.room
    fs = room.samplerate_hz
    if bank.samplerate_hz != fs:
        raise ValueError(f"the clip bank is at {bank.samplerate_hz} Hz but the room at {fs} Hz; load the clips at {fs}")
    n = round(scenario.duration_s * fs)
    rng = np.random.default_rng([scenario.seed, 11])
    n_actors = len(scenario.actors)
    dry = np.zeros((n_actors, n), dtype=np.float64)

    # pieces: (anchor position, first sample, signal)
    pieces: list[tuple[np.ndarray, int, np.ndarray]] = []
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
            pieces.append((scenario.actors[e.actor].path.at(anchors[0]) + offset, s0, sig))
            continue
        t = (s0 + np.arange(sig.size)) / fs
        hop = anchors[1] - anchors[0]
        for c in anchors:
            w = np.clip(1.0 - np.abs(t - c) / hop, 0.0, None)  # triangles: a partition of unity between anchors
            nz = np.flatnonzero(w)
            if nz.size:
                pieces.append((scenario.actors[e.actor].path.at(c) + offset, s0 + int(nz[0]),
                               (sig * w)[nz[0]:nz[-1] + 1]))

    # one impulse response per distinct position (millimetres), plus the fan
    keys: dict[tuple[int, int, int], int] = {}
    for pos, _, _ in pieces:
        keys.setdefault(tuple(int(v) for v in np.round(pos * 1000)), len(keys))
    positions = np.array([np.array(k) / 1000.0 for k in keys] + [FAN_POSITION_M], dtype=np.float64)
    if progress:
        progress(f"room impulse responses for {positions.shape[0]} source positions ...")
    rirs, rt60 = _impulse_responses(room, positions)
    rirs = rirs[:, :, PRA_DELAY_SAMPLES:]
    if progress:
        progress(f"convolving {len(pieces)} sounds ...")

    gain = speech_level_rms * REFERENCE_DISTANCE_M  # pyroomacoustics' direct path has amplitude 1/r (r in metres)
    length = n + rirs.shape[2]
    out = np.zeros((2, length))
    by_source: dict[int, list[tuple[int, np.ndarray]]] = {}
    for pos, s0, sig in pieces:
        by_source.setdefault(keys[tuple(int(v) for v in np.round(pos * 1000))], []).append((s0, sig))
    for src, items in by_source.items():
        lo = min(s0 for s0, _ in items)
        hi = max(s0 + sig.size for s0, sig in items)
        track = np.zeros(hi - lo)
        for s0, sig in items:
            track[s0 - lo:s0 - lo + sig.size] += sig
        for m in range(2):
            y = fftconvolve(track, rirs[src, m])
            out[m, lo:lo + y.size] += gain * y
    out = out[:, :n]

    fan = np.stack([fftconvolve(fan_noise(n, fs, rng), rirs[-1, m])[:n] for m in range(2)])
    fan_rms = float(np.sqrt(np.mean(fan[0] ** 2)))
    if fan_rms > 0:
        out += fan * (speech_level_rms * 10 ** (-fan_snr_db / 20) / fan_rms)
    out += sensor_noise_rms * rng.standard_normal(out.shape)
    scaled = np.round(out.T * 32768.0)
    clipped = int(np.count_nonzero((scaled > 32767) | (scaled < -32768)))
    if clipped:
        log.warning("%d samples clipped at full scale; lower speech_level_rms", clipped)
    samples = np.clip(scaled, -32768, 32767).astype(np.int16)
    return SimAudio(samples, fs, dry.astype(np.float32), rt60, int(positions.shape[0]), clipped)


def _impulse_responses(room: Room, positions: np.ndarray) -> tuple[np.ndarray, float]:
    """``room.impulse_responses`` for many sources with one RT60 correction measured on a single source (the
    correction does not depend on where the source is, and building the room twice for every source costs twice)."""
    if not room.match_rt60:
        return room.impulse_responses(positions)
    plain = Room(room.dims_m, room.rt60_s, room.head_m, room.mic_distance_m, room.samplerate_hz, match_rt60=False)
    _, measured = plain.impulse_responses(positions[:1])
    target = room.rt60_s
    if abs(measured - target) > 0.05 * target:
        target = max(0.05, min(3.0, target * target / measured))
    corrected = Room(room.dims_m, target, room.head_m, room.mic_distance_m, room.samplerate_hz, match_rt60=False)
    return corrected.impulse_responses(positions)


# ---------------------------------------------------------------------------------------------------------------
# the source


@dataclass
class _FrameCache:
    key: tuple | None = None
    left: np.ndarray | None = None
    right: np.ndarray | None = None


class SimSource(StreamSource):
    """A scenario of :mod:`sim.scenario` as a stream of frames and audio blocks with ground truth.

    Parameters
    ----------
    scenario : the scenario (see :meth:`from_preset` to make one from a preset name).
    bank : the speech clips its timeline was laid out with (``make_scenario(clip_durations_s=bank.durations_s)``).
    textures : face textures (default: :func:`load_textures` of ``data_dir``).
    fps : frames per second, 1-60 (the paper's cameras: 15-30).
    block_size : samples per audio block (512 = 32 ms at 16 kHz).
    noise_std : grey levels of sensor noise on every pixel.
    audio : a precomputed :class:`SimAudio` of the same scenario (else computed here: seconds per scenario minute).
    """

    def __init__(self, scenario: Scenario, bank: ClipBank, *, textures: list[FaceTexture] | None = None,
                 data_dir: str | Path | None = None, fps: float = 30.0, block_size: int = 512,
                 noise_std: float = 1.5, audio: SimAudio | None = None,
                 progress: Callable[[str], None] | None = None) -> None:
        super().__init__()
        if not (np.isfinite(fps) and 1.0 <= fps <= 60.0):
            raise ValueError(f"fps must be between 1 and 60 frames per second, got {fps!r}")
        if isinstance(block_size, bool) or not isinstance(block_size, (int, np.integer)) or block_size < 1:
            raise ValueError(f"block_size must be a positive number of samples, got {block_size!r}")
        if noise_std < 0:
            raise ValueError(f"noise_std must be >= 0 grey levels, got {noise_std!r}")
        self.scenario = scenario
        self.bank = bank
        faces_kind = "given"
        if textures is None:
            textures, faces_kind = load_textures(data_dir)
        if not textures:
            raise ValueError("textures is empty; give at least one face texture (or None for the defaults)")
        self.textures = textures
        # distinct faces for distinct people (as long as there are enough textures), chosen by the scenario's seeds
        order = np.random.default_rng([a.face for a in scenario.actors]).permutation(len(textures))
        self._face_of = [int(order[i % len(order)]) for i in range(len(scenario.actors))]
        self.stereo = scenario.rig
        self.mics = scenario.mics
        self.fps = float(fps)
        self.samplerate_hz = scenario.room.samplerate_hz
        self.n_channels = 2
        self.block_size = int(block_size)
        self.noise_std = float(noise_std)
        n_frames = int(np.floor(scenario.duration_s * self.fps - 1e-9)) + 1
        self.frame_stamps_s = np.arange(n_frames) / self.fps
        self.right_stamps_s = self.frame_stamps_s.copy()
        self.audio_start_s = 0.0
        self.audio = audio if audio is not None else render_audio(scenario, bank, progress=progress)
        if self.audio.samples.shape != (round(scenario.duration_s * self.samplerate_hz), 2):
            raise ValueError(f"audio holds {self.audio.samples.shape} samples, not the scenario's "
                             f"({round(scenario.duration_s * self.samplerate_hz)}, 2)")
        self.n_samples = int(self.audio.samples.shape[0])
        self.meta = {"scenario": scenario.name, "seed": scenario.seed, "duration_s": scenario.duration_s,
                     "speech": bank.source, "faces": faces_kind, "measured_rt60_s": self.audio.measured_rt60_s,
                     "description": scenario.description}
        self._renderer = StereoSceneRenderer(self.stereo, [], room=scenario.visual_room, noise_std=0.0,
                                             seed=scenario.seed)
        self._cache = _FrameCache()
        rng = np.random.default_rng([scenario.seed, 23])
        w, h = self.stereo.image_size
        # sensor noise: a few precomputed fields, one drawn per image (cheap, deterministic)
        self._noise = [np.round(rng.normal(0.0, self.noise_std, (h, w, 3))).astype(np.int16) for _ in range(7)] \
            if self.noise_std > 0 else []

    @classmethod
    def from_preset(cls, name: str, *, duration_s: float | None = None, seed: int = 0, fps: float = 30.0,
                    data_dir: str | Path | None = None, block_size: int = 512, rt60_s: float = 0.4,
                    progress: Callable[[str], None] | None = None) -> SimSource:
        """A preset of :data:`sim.scenario.PRESETS` with real faces and digits from ``data_dir`` (default
        ``../shared/data``; drawn faces and synthetic clips when it is absent)."""
        bank = load_clip_bank(16000, data_dir, seed=seed)
        scenario = make_scenario(name, clip_durations_s=bank.durations_s, duration_s=duration_s, seed=seed,
                                 rt60_s=rt60_s)
        return cls(scenario, bank, data_dir=data_dir, fps=fps, block_size=block_size, progress=progress)

    # -------------------------------------------------------------- StreamSource
    def people(self, t: float) -> list[Person]:
        """The renderer's people at ``t`` seconds: each actor's face texture at its path position, nodding while
        speaking."""
        pos = self.scenario.positions(t)
        nods = self.scenario.nod_amplitudes(t)
        return [Person(face=self.textures[self._face_of[i]], position=tuple(p), shirt_bgr=a.shirt_bgr,
                       nod_rad=float(nod), nod_hz=NOD_HZ, phase=1.3 * i)
                for i, (a, p, nod) in enumerate(zip(self.scenario.actors, pos, nods))]

    def _images(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        t = float(self.frame_stamps_s[k])
        people = self.people(t)
        angles = [p.nod_rad * np.sin(2 * np.pi * p.nod_hz * t + p.phase) for p in people]
        key = tuple(np.round(np.concatenate([np.ravel([p.position for p in people]), angles]), 5))
        if key != self._cache.key:
            self._renderer.people = people
            frame = self._renderer.render(t)
            self._cache = _FrameCache(key, frame.left, frame.right)
        left, right = self._cache.left, self._cache.right
        assert left is not None and right is not None
        if self._noise:
            n = len(self._noise)
            left = cv2.add(left, self._noise[(2 * k + self.scenario.seed) % n], dtype=cv2.CV_8U)
            right = cv2.add(right, self._noise[(2 * k + 1 + self.scenario.seed) % n], dtype=cv2.CV_8U)
        else:
            left, right = left.copy(), right.copy()
        return left, right

    def _samples(self, a: int, b: int) -> np.ndarray:
        return self.audio.samples[a:b].astype(np.float32) / np.float32(32768.0)

    def truth(self, k: int) -> FrameTruth:
        return self.scenario.truth(float(self.frame_stamps_s[k]))
