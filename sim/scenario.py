"""The simulated-room scenarios of the paper's section 7.3 (S1-S5) and the audio-visual calibration of section 5.3.

A :class:`Scenario` is a pure description: who is in the room, where each head is at any instant (a piecewise-linear
path of the face centre), and a timeline of sound events (spoken digits, hand claps, a loudspeaker playing white
noise). From it come the ground truth of any instant (:meth:`Scenario.truth`: 3D head positions, visibility,
speaking state) and, in :mod:`app.sources.sim`, the rendered frames and the simulated microphone signals.

Presets (section 7.3, "Results on NAO"; the paper's room is about 5 x 5 m, the robot and the people seated):

- ``S1``: one person sitting in front of the robot, counting.
- ``S2``: three seated people counting in turns (one number each, round-robin).
- ``S3``: as S2, with one of them standing (a higher elevation).
- ``S4``: as S2, with one of the talkers outside the cameras' field of view.
- ``S5``: three people speaking independently (overlaps happen), one walking while speaking, and hand claps.
- ``S6`` (beyond the paper): two people in one direction at different depths, both in view: one seated at 1.3 m,
  one standing behind at 2.7 m whose face shows above the first one's head. Their mouths give the 12 cm pair the same
  ITD (and a planar array nearly so), so direction cannot tell them apart; they count in turns for the first half
  and independently (at times at once) for the second.
- ``calibration`` (section 5.3): one person holding a loudspeaker just below the face, playing white noise, walking
  a zig-zag across the whole field of view. The noise comes in bursts of 150 ms every 0.5 s (``CALIBRATION_BURST_S``),
  not continuously as in the paper: see :data:`avcore.calibration.CALIBRATION_BURST_S` for why.

Scene frame (docs/architecture.md): the cyclopean frame of the rectified rig, metres, x right, y down, z forward; the
robot's head (cameras and microphones) is at the origin, 1.0 m above the floor. Times are seconds from the start of the
scenario (the stream's clock adds its start).

Everything is deterministic for a seed. Nothing here reads files or touches devices: the speech clips come in as a
:class:`ClipBank` (real digits loaded by :mod:`app.sources.sim`, or :func:`synthetic_clip_bank` on a clean machine).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from avcore.calibration import CALIBRATION_BURST_S
from avcore.evaluation import FrameTruth
from avcore.geometry import MicArray, MicPair
from sim.render import VisualRoom
from sim.roomsim import AcousticRoom
from sim.roomsim import synthetic_speech
from avcore.stereo import StereoRig
from sim.presets import DEFAULT_DURATION_S, PRESETS

__all__ = [
    "PRESETS",
    "DEFAULT_DURATION_S",
    "SOURCE_OFFSETS_M",
    "Path3D",
    "Actor",
    "SoundEvent",
    "FrameTruth",
    "ClipBank",
    "Scenario",
    "make_scenario",
    "synthetic_clip_bank",
    "trim_quiet_ends",
    "default_rig",
    "default_acoustic_room",
]

EventKind = Literal["speech", "clap", "noise"]
# where each kind of sound leaves the person, relative to the face centre (metres, scene frame): the mouth, the hands
# clapping in front of the chest, the loudspeaker held just below the face (section 5.3)
SOURCE_OFFSETS_M: dict[str, tuple[float, float, float]] = {
    "speech": (0.0, 0.05, -0.03),
    "clap": (0.0, 0.40, -0.25),
    "noise": (0.0, 0.15, -0.06),
}
FACE_WIDTH_M = 0.16          # the labelled face box of a person (sim.render.Person.face_width_m)
HEAD_HALF_M = 0.8 * FACE_WIDTH_M  # half side of a rendered head texture (render.FACE_MARGIN = 1.6 face widths)
BODY_HALF_M, BODY_TOP_M, BODY_HEIGHT_M = 0.23, 0.12, 0.7  # a rendered body plane, below the face centre
COUNT_TO = 16                # the paper's people count from one up to sixteen, then start again


def default_rig(scale: float = 1.0) -> StereoRig:
    """The simulated stereo pair: rectified 640x480 cameras, focal 554 px (60 degrees across), baseline 0.12 m;
    ``scale`` < 1 gives the same view in fewer pixels (every face as small as one ``1 / scale`` times farther)."""
    return StereoRig.ideal(focal_px=554.0 * scale, image_size=(round(640 * scale), round(480 * scale)),
                           baseline_m=0.12)


def default_acoustic_room(rt60_s: float = 0.4) -> AcousticRoom:
    """A 5 x 5 x 2.7 m room (the paper's NAO room is "around 5 x 5 meters"); the head 1.0 m above the floor,
    0.8 m from the back wall, facing the room; microphones 0.12 m apart on the scene x axis."""
    return AcousticRoom(dims_m=(5.0, 5.0, 2.7), rt60_s=rt60_s, head_m=(2.5, 0.8, 1.0), mic_distance_m=0.12)


# ---------------------------------------------------------------------------------------------------------------
# paths, actors, events


@dataclass(frozen=True)
class Path3D:
    """A piecewise-linear path of a face centre: ``times_s (K,)`` increasing seconds, ``points_m (K, 3)`` metres.

    Before the first key time the path stays at the first point, after the last at the last point.
    """

    times_s: tuple[float, ...]
    points_m: tuple[tuple[float, float, float], ...]

    def __post_init__(self) -> None:
        t = np.asarray(self.times_s, dtype=np.float64)
        p = np.asarray(self.points_m, dtype=np.float64)
        if t.ndim != 1 or t.size == 0 or p.shape != (t.size, 3):
            raise ValueError(f"a path needs K key times and K points of 3 metres, got times of shape {t.shape} "
                             f"and points of shape {p.shape}")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(p))) or np.any(np.diff(t) <= 0):
            raise ValueError("path key times must be finite and strictly increasing, and points finite")
        object.__setattr__(self, "times_s", tuple(float(v) for v in t))
        object.__setattr__(self, "points_m", tuple(tuple(float(c) for c in row) for row in p))

    @staticmethod
    def still(point: Sequence[float]) -> Path3D:
        """A path that stays at ``point`` (3,) metres."""
        return Path3D((0.0,), (tuple(point),))  # type: ignore[arg-type]

    def at(self, t: object) -> np.ndarray:
        """Position at time(s) ``t`` seconds: scalar -> (3,), (T,) -> (T, 3), metres."""
        tt = np.asarray(t, dtype=np.float64)
        p = np.asarray(self.points_m)
        if len(self.times_s) == 1:
            return np.broadcast_to(p[0], tt.shape + (3,)).copy()
        out = np.stack([np.interp(tt, self.times_s, p[:, k]) for k in range(3)], axis=-1)
        return out

    @property
    def is_still(self) -> bool:
        p = np.asarray(self.points_m)
        return bool(np.all(np.abs(p - p[0]) < 1e-9))


@dataclass(frozen=True)
class Actor:
    """One person: a name, the path of the face centre, a voice (index into the :class:`ClipBank`), a face (an
    integer the application maps onto its face textures), a shirt colour, and the head-nod amplitude shown while
    speaking (radians; gives the motion-guided variant some motion where the talker is)."""

    name: str
    path: Path3D
    voice: int
    face: int
    shirt_bgr: tuple[int, int, int] = (140, 70, 40)
    nod_rad: float = 0.12
    posture: str = "seated"


@dataclass(frozen=True)
class SoundEvent:
    """One sound made by one actor between ``start_s`` and ``end_s`` (seconds).

    kind : "speech" (a spoken digit: ``clip`` indexes the actor's voice in the clip bank, ``label`` is the number
    counted), "clap" (a hand clap, ``clip`` seeds its waveform) or "noise" (white noise from a hand-held loudspeaker).
    The sound leaves from the face centre plus ``SOURCE_OFFSETS_M[kind]``.
    """

    actor: int
    kind: EventKind
    start_s: float
    end_s: float
    clip: int = 0
    label: str = ""


# ---------------------------------------------------------------------------------------------------------------
# speech clips


@dataclass(frozen=True, eq=False)
class ClipBank:
    """Dry speech clips: ``voices[v][d]`` is the digit ``d`` (0-9) said by voice ``v``, a ``(n,)`` float array at
    ``samplerate_hz``, scaled to unit RMS over its loud part. ``source`` says where they came from ("digits" for the
    Free Spoken Digit Dataset of ``../shared/data/speech/digits``, "synthetic" otherwise)."""

    samplerate_hz: int
    voices: tuple[tuple[np.ndarray, ...], ...]
    source: str = "synthetic"
    speakers: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if not self.voices or any(len(v) == 0 for v in self.voices):
            raise ValueError("a clip bank needs at least one voice with at least one clip")
        for v, clips in enumerate(self.voices):
            for d, c in enumerate(clips):
                if not isinstance(c, np.ndarray) or c.ndim != 1 or c.size == 0 or not np.all(np.isfinite(c)):
                    raise ValueError(f"clip {d} of voice {v} must be a non-empty finite 1-D array of samples")

    @property
    def durations_s(self) -> tuple[tuple[float, ...], ...]:
        """Duration of every clip, seconds, ``[voice][clip]``."""
        return tuple(tuple(c.size / self.samplerate_hz for c in v) for v in self.voices)

    def clip(self, voice: int, clip: int) -> np.ndarray:
        v = self.voices[voice % len(self.voices)]
        return v[clip % len(v)]


def trim_quiet_ends(x: np.ndarray, samplerate_hz: float, below_db: float = 30.0, frame_s: float = 0.01) -> np.ndarray:
    """``x`` without its leading and trailing ``frame_s`` frames whose power is more than ``below_db`` under the
    loudest frame's.

    The spoken digits are recorded at 8 kHz, which keeps little of a fricative's energy (mostly above 4 kHz): the
    /s/ of a "six" or "seven" is left as a lead-in 30-40 dB under the vowel, up to 0.3 s long (and the /ks/ of "six"
    as a tail). Played into the room from the presets' 1.4-3.2 m, that lies at or under the robot's fan at the
    microphones (the loudest frames of the speech reach 27-31 dB above the fan's floor in S1, S2 and S5, seed 0: a
    throwaway measurement of 32 ms frames), so no listener and no method could hear it, yet the truth would call it
    speech. The clip, and with it the truth's speaking state, runs from the first to the last whole frame within
    ``below_db`` of the loudest (a clip shorter than one frame is returned as it is).
    """
    n = max(int(round(frame_s * samplerate_hz)), 1)
    frames = x[: x.size // n * n].reshape(-1, n)
    if frames.shape[0] == 0:
        return x
    power = np.mean(frames**2, axis=1)
    loud = np.flatnonzero(power >= power.max() * 10.0 ** (-below_db / 10.0))  # never empty: the loudest is in it
    return x[loud[0] * n:(loud[-1] + 1) * n]


def normalise_clip(x: np.ndarray) -> np.ndarray:
    """Scale a clip to unit RMS over its loud part (samples above 5 % of the peak), so that voices are equally loud."""
    loud = np.abs(x) > 0.05 * np.max(np.abs(x))
    return x / np.sqrt(np.mean(x[loud] ** 2))


def synthetic_clip_bank(samplerate_hz: int = 16000, n_voices: int = 3, seed: int = 0) -> ClipBank:
    """Ten synthetic voiced "digits" (0.35-0.7 s each) per voice, for machines without ``../shared/data``.

    Uses :func:`sim.roomsim.synthetic_speech` (harmonic complex, moving formants, syllabic envelope).
    """
    if n_voices < 1:
        raise ValueError(f"n_voices must be at least 1, got {n_voices!r}")
    voices = []
    for v in range(n_voices):
        rng = np.random.default_rng([seed, v, 7])
        voices.append(tuple(normalise_clip(synthetic_speech(float(rng.uniform(0.35, 0.7)), samplerate_hz, rng))
                            for _ in range(10)))
    return ClipBank(samplerate_hz, tuple(voices), "synthetic", tuple(f"synthetic{v}" for v in range(n_voices)))


# ---------------------------------------------------------------------------------------------------------------
# the scenario


@dataclass(frozen=True, eq=False)
class Scenario:
    """A scenario: actors, sound events, the rig and the rooms (visual and acoustic), ``duration_s`` seconds."""

    name: str
    description: str
    duration_s: float
    seed: int
    actors: tuple[Actor, ...]
    events: tuple[SoundEvent, ...]
    rig: StereoRig = field(default_factory=default_rig)
    room: AcousticRoom = field(default_factory=default_acoustic_room)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.duration_s) and self.duration_s > 0):
            raise ValueError(f"duration_s must be a positive number of seconds, got {self.duration_s!r}")
        for e in self.events:
            if not 0 <= e.actor < len(self.actors):
                raise ValueError(f"event {e} names actor {e.actor}, but there are {len(self.actors)} actors")
            if not e.end_s > e.start_s:
                raise ValueError(f"event {e} ends before it starts")

    # -------------------------------------------------------------- geometry
    @property
    def mics(self) -> MicPair:
        """The microphone pair in the scene frame (identity affine correction: the simulator's mics are exact)."""
        return self.room.mic_pair()

    @property
    def array(self) -> MicArray:
        """All the microphones (channel q is microphone q), every pair, the widest left-right first."""
        return self.room.mic_array()

    @property
    def visual_room(self) -> VisualRoom:
        """The same room for the renderer: walls at the acoustic room's walls, seen from the head."""
        dims, head = self.room.dims_m, self.room.head_m
        half = min(head[0], dims[0] - head[0])
        return VisualRoom(half_width=half, depth=dims[1] - head[1], floor_y=head[2], ceiling_y=head[2] - dims[2])

    def positions(self, t: float) -> np.ndarray:
        """Face centres at ``t`` seconds, (N, 3) metres."""
        return np.array([a.path.at(t) for a in self.actors], dtype=np.float64).reshape(-1, 3)

    def source_position(self, event: SoundEvent, t: float) -> np.ndarray:
        """Where the sound of ``event`` leaves at ``t`` seconds, (3,) metres."""
        return self.actors[event.actor].path.at(t) + np.asarray(SOURCE_OFFSETS_M[event.kind])

    def active_events(self, t: float) -> list[SoundEvent]:
        return [e for e in self.events if e.start_s <= t < e.end_s]

    def speaking(self, t: float) -> np.ndarray:
        """(N,) bool: who is speaking at ``t`` seconds."""
        out = np.zeros(len(self.actors), dtype=bool)
        for e in self.active_events(t):
            if e.kind == "speech":
                out[e.actor] = True
        return out

    def speaking_at(self, times_s: object, hold_s: float = 0.0) -> np.ndarray:
        """(T, N) bool: who is speaking at each of ``times_s`` (T,) seconds (e.g. ITD window centres); with
        ``hold_s`` > 0, each speech event held that much longer at both ends."""
        if not (math.isfinite(hold_s) and hold_s >= 0):
            raise ValueError(f"hold_s must be >= 0 seconds, got {hold_s!r}")
        t = np.asarray(times_s, dtype=np.float64).reshape(-1)
        out = np.zeros((t.size, len(self.actors)), dtype=bool)
        for e in self.events:
            if e.kind == "speech":
                out[:, e.actor] |= (t >= e.start_s - hold_s) & (t < e.end_s + hold_s)
        return out

    def visible(self, t: float) -> np.ndarray:
        """(N,) bool: the whole face box inside both images, its centre not hidden by a nearer person."""
        pos = self.positions(t)
        w, h = self.rig.image_size
        out = np.zeros(len(self.actors), dtype=bool)
        for i, p in enumerate(pos):
            corners = p + np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]) * (FACE_WIDTH_M / 2)
            if np.any(corners[:, 2] <= 0.05):
                continue
            inside = True
            for uv in self.rig.project(corners):
                inside &= bool(np.all((uv[:, 0] >= -0.5) & (uv[:, 0] <= w - 0.5) & (uv[:, 1] >= -0.5)
                                      & (uv[:, 1] <= h - 0.5)))
            out[i] = inside and not self._hidden(i, pos)
        return out

    def _hidden(self, i: int, pos: np.ndarray) -> bool:
        """Is the face centre of actor ``i`` behind the head or body plane of a nearer actor, in either image?"""
        centre = pos[i][None]
        for j, q in enumerate(pos):
            if j == i or q[2] >= pos[i][2]:
                continue
            head = (q[0] - HEAD_HALF_M, q[0] + HEAD_HALF_M, q[1] - HEAD_HALF_M, q[1] + HEAD_HALF_M, q[2])
            body = (q[0] - BODY_HALF_M, q[0] + BODY_HALF_M, q[1] + BODY_TOP_M, q[1] + BODY_TOP_M + BODY_HEIGHT_M,
                    q[2] + 0.06)
            for x0, x1, y0, y1, z in (head, body):
                rect = np.array([[x0, y0, z], [x1, y1, z]])
                for side in range(2):
                    uv_r = self.rig.project(rect)[side]
                    uv_c = self.rig.project(centre)[side][0]
                    if uv_r[0, 0] <= uv_c[0] <= uv_r[1, 0] and uv_r[0, 1] <= uv_c[1] <= uv_r[1, 1]:
                        return True
        return False

    def face_boxes_left(self, t: float) -> np.ndarray:
        """(N, 4) float: each face box (x, y, w, h) in the left image, pixels (OpenCV Rect convention, as
        :class:`sim.render.RenderedFrame`); NaN rows for faces behind the cameras."""
        out = np.full((len(self.actors), 4), np.nan)
        for i, p in enumerate(self.positions(t)):
            corners = p + np.array([[-1, -1, 0], [1, 1, 0]]) * (FACE_WIDTH_M / 2)
            if np.all(corners[:, 2] > 0.05):
                uv = self.rig.project(corners)[0]
                out[i] = [uv[0, 0] + 0.5, uv[0, 1] + 0.5, uv[1, 0] - uv[0, 0], uv[1, 1] - uv[0, 1]]
        return out

    def truth(self, t: float) -> FrameTruth:
        """The ground truth at ``t`` seconds (see :class:`FrameTruth`)."""
        pos = self.positions(t)
        sounding = np.zeros(len(self.actors), dtype=bool)
        loudspeaker = np.zeros(len(self.actors), dtype=bool)
        for e in self.active_events(t):
            sounding[e.actor] = True
            loudspeaker[e.actor] |= e.kind == "noise"
        # the ITD of the mouth, or of the loudspeaker while it plays
        sources = np.array([p + np.asarray(SOURCE_OFFSETS_M["noise" if loudspeaker[i] else "speech"])
                            for i, p in enumerate(pos)]).reshape(-1, 3)
        return FrameTruth(time_s=float(t), positions_m=pos, visible=self.visible(t), speaking=self.speaking(t),
                          sounding=sounding, boxes_left=self.face_boxes_left(t),
                          itds_s=np.atleast_1d(self.mics.itd(sources)).reshape(-1),
                          names=tuple(a.name for a in self.actors))

    def nod_amplitudes(self, t: float) -> np.ndarray:
        """(N,) radians: the head-nod amplitude of each actor at ``t`` (their ``nod_rad`` while speaking, else 0)."""
        speaking = self.speaking(t)
        return np.array([a.nod_rad if s else 0.0 for a, s in zip(self.actors, speaking)])


# ---------------------------------------------------------------------------------------------------------------
# presets


def _check_durations(clip_durations_s: Sequence[Sequence[float]]) -> list[list[float]]:
    out = [[float(d) for d in v] for v in clip_durations_s]
    if not out or any(not v for v in out) or any(not (0 < d < 10) for v in out for d in v):
        raise ValueError("clip_durations_s must list, for at least one voice, the durations (0-10 s) of its clips; "
                         "pass ClipBank.durations_s")
    return out


def _counting(order: Sequence[int], voices: Sequence[int], durations: list[list[float]], rng: np.random.Generator,
              duration_s: float, pause_s: tuple[float, float]) -> list[SoundEvent]:
    """People counting 1, 2, ..., 16, 1, ... in turns: number ``k`` is said by ``order[(k - 1) % len(order)]``."""
    events = []
    t = float(rng.uniform(0.3, 0.6))
    k = 1
    while True:
        actor = order[(k - 1) % len(order)]
        voice = voices[actor] % len(durations)
        clip = (k % 10) % len(durations[voice])
        d = durations[voice][clip]
        if t + d > duration_s - 0.1:
            break
        events.append(SoundEvent(actor, "speech", t, t + d, clip, str(k)))
        t += d + float(rng.uniform(*pause_s))
        k = k % COUNT_TO + 1
    return events


def _independent(actor: int, voice: int, durations: list[list[float]], rng: np.random.Generator,
                 duration_s: float) -> list[SoundEvent]:
    """One person counting at their own pace (S5): pauses of 0.3-2 s, independent of the others."""
    events = []
    t = float(rng.uniform(0.2, 1.5))
    k = 1
    v = voice % len(durations)
    while True:
        clip = (k % 10) % len(durations[v])
        d = durations[v][clip]
        if t + d > duration_s - 0.1:
            break
        events.append(SoundEvent(actor, "speech", t, t + d, clip, str(k)))
        t += d + float(rng.uniform(0.3, 2.0))
        k = k % COUNT_TO + 1
    return events


def _claps(n_actors: int, rng: np.random.Generator, duration_s: float) -> list[SoundEvent]:
    """Bursts of one to three hand claps (0.3 s apart) every 2.5-5 s, by a random person."""
    events = []
    t = float(rng.uniform(1.0, 3.0))
    while t < duration_s - 1.0:
        actor = int(rng.integers(n_actors))
        for c in range(int(rng.integers(1, 4))):
            s = t + 0.3 * c
            events.append(SoundEvent(actor, "clap", s, s + 0.08, int(rng.integers(2**31)), "clap"))
        t += float(rng.uniform(2.5, 5.0))
    return events


def _walk(xs: Sequence[float], y: float, z: float, speed_m_s: float, duration_s: float, t0: float = 0.0) -> Path3D:
    """Back and forth along x between the listed turning points, at ``speed_m_s``, until ``duration_s``."""
    times, points = [0.0], [(xs[0], y, z)]
    t, i = t0, 0
    while t < duration_s + 1.0:
        a, b = xs[i % len(xs)], xs[(i + 1) % len(xs)]
        t += abs(b - a) / speed_m_s
        times.append(t)
        points.append((b, y, z))
        i += 1
    if t0 > 0:
        times.insert(1, t0)
        points.insert(1, points[0])
    return Path3D(tuple(times), tuple(points))  # type: ignore[arg-type]


def _zigzag(rig: StereoRig, duration_s: float, rng: np.random.Generator, speed_m_s: float = 0.7) -> Path3D:
    """Section 5.3: a zig-zag over the whole field of view: legs from one edge of the view to the other, the depth
    changing from leg to leg between 1.3 and 2.9 m, the height a little (a person lifting and lowering the hand)."""
    half_tan = (rig.image_size[0] / 2 - 20) / rig.focal_px  # a face-width margin from the image border
    depths = (1.3, 1.7, 2.1, 2.5, 2.9, 2.5, 2.1, 1.7)
    side = -1 if rng.uniform() < 0.5 else 1
    k0 = int(rng.integers(len(depths)))
    z = depths[k0]
    y = float(rng.uniform(-0.35, -0.05))
    times, points = [0.0], [(side * (half_tan * z - 0.1), y, z)]
    t, k = 0.0, k0
    while t < duration_s + 1.0:
        k += 1
        z = depths[k % len(depths)]
        side = -side
        y = float(rng.uniform(-0.35, -0.05))
        p = (side * (half_tan * z - 0.1), y, z)
        t += float(np.linalg.norm(np.subtract(p, points[-1]))) / speed_m_s
        times.append(t)
        points.append(p)
    return Path3D(tuple(times), tuple(points))  # type: ignore[arg-type]


_SHIRTS = ((140, 70, 40), (40, 120, 160), (60, 60, 170), (60, 140, 60))
_DESCRIPTIONS = {
    "S1": "one person sitting in front of the robot, counting",
    "S2": "three seated people counting in turns",
    "S3": "three people counting in turns, one of them standing",
    "S4": "three people counting in turns, one of them outside the field of view",
    "S5": "three people speaking independently, one walking while speaking, hand claps",
    "S6": "two people in one direction, one standing behind the other, counting in turns, then independently",
    "calibration": "a person holding a loudspeaker (white-noise bursts) below the face, walking a zig-zag over the "
                   "view",
}


def make_scenario(name: str, *, clip_durations_s: Sequence[Sequence[float]], duration_s: float | None = None,
                  seed: int = 0, rt60_s: float = 0.4, mics: str = "pair") -> Scenario:
    """A preset of :data:`PRESETS`, ``duration_s`` seconds long (default :data:`DEFAULT_DURATION_S`).

    mics : the robot's microphones, a name of :data:`avcore.geometry.ARRAY_PRESETS` placed on the head (the scene
    origin); "pair" is the 12 cm pair of the paper's setting.

    clip_durations_s : ``ClipBank.durations_s`` of the clips the audio will be made of; the speech timeline is laid
    out with them so that utterances never overlap their own speaker's next one.
    seed : the same seed and durations give the same scenario (timeline, faces, voices, paths).
    """
    if name not in PRESETS:
        raise ValueError(f"unknown scenario {name!r}; choose one of {', '.join(PRESETS)}")
    durations = _check_durations(clip_durations_s)
    dur = DEFAULT_DURATION_S[name] if duration_s is None else float(duration_s)
    if not (math.isfinite(dur) and 1.0 <= dur <= 3600.0):
        raise ValueError(f"duration_s must be between 1 and 3600 seconds, got {duration_s!r}")
    rng = np.random.default_rng([seed, PRESETS.index(name)])
    faces = [int(f) for f in rng.permutation(1000)[:3]]
    # the voices too change with the seed (a stream of their own, so the rest of the draws stay as they were)
    order = np.random.default_rng([seed, PRESETS.index(name), 1]).permutation(len(durations))
    voices = [int(order[i % order.size]) for i in range(3)]
    rig = default_rig()
    room = default_acoustic_room(rt60_s)
    if mics != "pair":
        room = replace(room, mic_positions_m=MicArray.preset(mics).positions)
    seated = [(-0.75, -0.15, 1.9), (0.0, -0.1, 2.4), (0.8, -0.15, 2.0)]

    def actor(i: int, path: Path3D, posture: str = "seated") -> Actor:
        return Actor(f"person{i}", path, voice=voices[i], face=faces[i], shirt_bgr=_SHIRTS[i], posture=posture)

    events: list[SoundEvent] = []
    if name == "S1":
        actors = [actor(0, Path3D.still((0.05, -0.15, 1.4)))]
        events = _counting([0], voices[:1], durations, rng, dur, (0.3, 0.7))
    elif name in ("S2", "S3", "S4"):
        positions = list(seated)
        postures = ["seated"] * 3
        if name == "S3":
            positions[2] = (0.8, -0.6, 2.0)  # standing: the head 0.45 m higher
            postures[2] = "standing"
        if name == "S4":
            positions[0] = (-1.6, -0.15, 1.2)  # 53 degrees to the left: outside the 60-degree view
        actors = [actor(i, Path3D.still(p), s) for i, (p, s) in enumerate(zip(positions, postures))]
        events = _counting([0, 1, 2], voices, durations, rng, dur, (0.25, 0.6))
    elif name == "S5":
        walker = _walk((-1.0, 1.0), -0.6, 3.0, 0.5, dur, t0=float(rng.uniform(0.0, 1.0)))
        actors = [actor(0, Path3D.still((-0.8, -0.15, 1.9))), actor(1, walker, "walking"),
                  actor(2, Path3D.still((0.85, -0.15, 2.0)))]
        for i in range(3):
            events += _independent(i, voices[i], durations, rng, dur)
        events += _claps(3, rng, dur)
    elif name == "S6":
        # the far face centre is placed where its mouth gives the 12 cm pair the near mouth's ITD (within 1 us)
        actors = [actor(0, Path3D.still((0.30, -0.05, 1.3))), actor(1, Path3D.still((0.646, -0.65, 2.7)), "standing")]
        half = round(dur / 2, 3)
        events = _counting([0, 1], voices[:2], durations, rng, half, (0.25, 0.6))
        for i in range(2):
            events += [replace(e, start_s=e.start_s + half, end_s=e.end_s + half)
                       for e in _independent(i, voices[i], durations, rng, dur - half)]
    else:  # calibration
        actors = [Actor("person0", _zigzag(rig, dur, rng), voice=0, face=faces[0], shirt_bgr=_SHIRTS[0],
                        nod_rad=0.0, posture="walking")]
        on, off = CALIBRATION_BURST_S
        events = [SoundEvent(0, "noise", float(t), float(t) + on, int(rng.integers(2**31)), "white noise")
                  for t in np.arange(0.3, dur - 0.2 - on, on + off)]
    events.sort(key=lambda e: (e.start_s, e.actor))
    return Scenario(name=name, description=_DESCRIPTIONS[name], duration_s=dur, seed=seed, actors=tuple(actors),
                    events=tuple(events), rig=rig, room=room)
