"""Rooms we did not draw: a family of scenes drawn wholly from a seed, for checking rather than tuning.

The presets S1-S6 (:mod:`sim.scenario`) are rooms we drew by hand, and avhear's defaults were chosen on them. A room
of this family is drawn from its seed alone, inside the ranges a robot meets (issue 55):

- the room 4-9 m a side (2.5-3.2 m high), RT60 0.2-0.7 s; the robot's head 1.0 m above the floor, 0.5-1.5 m from
  the back wall, anywhere across it that leaves the view inside the room;
- 2-4 people in the cameras' view, seated or standing, 1.0-2.8 m away (:data:`MAX_DISTANCE_M`), at least 0.5 m apart
  and down to 10 degrees apart seen from the robot (a person too close to another in either is drawn again);
- sentences, not digits (a :class:`~sim.scenario.ClipBank` of read speech: the CMU ARCTIC excerpts, see
  :func:`sim.audio.load_sentence_bank`), taken in turns with 15-40 % of the speech time overlapped (two or more
  voices at once): a turn starts during the previous one with a chance chosen so the drawn share is met;
- background noise (:attr:`RoomDraw.noise_snr_db`, 10-30 dB under the speech at the microphones) from a point out of
  view, besides the robot's fan.

Whether the faces' mouths move is not drawn: it is the source's choice (``SimSource(lips=...)``), so the same room
can be checked with still faces and with moving mouths. Seeds below 100 are for choosing defaults; 100-119 are held
out (:data:`HELD_OUT_SEEDS`).
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from avcore.geometry import MicArray
from sim.roomsim import AcousticRoom
from sim.scenario import Actor, Path3D, Scenario, SoundEvent, _SHIRTS, default_rig

__all__ = ["HELD_OUT_SEEDS", "ROOM_DURATION_S", "RoomDraw", "draw_room", "make_room", "overlap_share"]

ROOM_DURATION_S = 30.0
HELD_OUT_SEEDS: tuple[int, ...] = tuple(range(100, 120))
"""Seeds kept untouched while defaults are chosen (on seeds below 100), and reported at the end."""
MAX_DISTANCE_M = 2.8
"""The farthest face: at 3 m a face is under 30 px wide in the simulated 640 x 480 camera (60 degrees across), where
BlazeFace finds none, and a face not found hands its voice to the nearest face found. This family checks who speaks,
not how small a face is found (docs/experiments.md, "2026-11-28 (wave 4)")."""
MIN_APART_M = 0.5
MIN_APART_DEG = 10.0
HEAD_HEIGHT_M = 1.0
FACE_MARGIN_DEG = 6.0  # a face's half width and a little: the whole face box stays inside the image
_OFFSET = 1000  # the rooms' random streams, apart from the presets' ([seed, preset index])


@dataclass(frozen=True)
class RoomDraw:
    """What a seed drew: the room (``dims_m``: width, depth, height; ``rt60_s``; ``head_m`` in the room frame),
    the people (face centres in the scene frame, postures), the share of speech time to overlap, the noise's level
    under the speech (dB) and where it comes from (scene frame)."""

    seed: int
    dims_m: tuple[float, float, float]
    rt60_s: float
    head_m: tuple[float, float, float]
    faces_m: tuple[tuple[float, float, float], ...]
    postures: tuple[str, ...]
    overlap_target: float
    noise_snr_db: float
    noise_position_m: tuple[float, float, float]

    def as_dict(self) -> dict:
        return {"seed": self.seed, "dims_m": [round(v, 2) for v in self.dims_m], "rt60_s": round(self.rt60_s, 3),
                "people": len(self.faces_m), "postures": list(self.postures),
                "faces_m": [[round(v, 2) for v in f] for f in self.faces_m],
                "azimuths_deg": [round(math.degrees(math.atan2(f[0], f[2])), 1) for f in self.faces_m],
                "overlap_target": round(self.overlap_target, 3), "noise_snr_db": round(self.noise_snr_db, 1)}


def _azimuth_deg(p: Sequence[float]) -> float:
    return math.degrees(math.atan2(p[0], p[2]))


def draw_room(seed: int) -> RoomDraw:
    """The room, people and levels of ``seed`` (deterministic; the timeline is drawn by :func:`make_room`)."""
    rng = np.random.default_rng([_OFFSET, seed])
    rig = default_rig()
    half_view = math.degrees(math.atan((rig.image_size[0] / 2) / rig.focal_px)) - FACE_MARGIN_DEG
    width, depth = float(rng.uniform(4.0, 9.0)), float(rng.uniform(4.0, 9.0))
    height = float(rng.uniform(2.5, 3.2))
    back = float(rng.uniform(0.5, 1.5))
    reach = min(MAX_DISTANCE_M, depth - back - 0.4)  # the farthest a face may be, 0.4 m from the far wall
    # the head anywhere across the back wall that keeps the view's edges at the farthest reach inside the room
    side = reach * math.tan(math.radians(half_view)) + 0.3
    lo, hi = min(side, width / 2), max(width - side, width / 2)
    head = (float(rng.uniform(lo, hi)), back, HEAD_HEIGHT_M)
    n = int(rng.integers(2, 5))
    faces: list[tuple[float, float, float]] = []
    postures: list[str] = []
    scenario_check = _visibility_check(width, depth, height, head)
    for _ in range(10_000):
        if len(faces) == n:
            break
        az = math.radians(float(rng.uniform(-half_view, half_view)))
        r = float(rng.uniform(1.0, reach))
        standing = bool(rng.uniform() < 0.35)
        y = float(rng.uniform(-0.7, -0.5)) if standing else float(rng.uniform(-0.25, -0.05))
        p = (r * math.sin(az), y, r * math.cos(az))
        if any(math.dist(p, q) < MIN_APART_M or abs(_azimuth_deg(p) - _azimuth_deg(q)) < MIN_APART_DEG
               for q in faces):
            continue
        if not scenario_check(faces + [p]):
            continue
        faces.append(p)
        postures.append("standing" if standing else "seated")
    if len(faces) < 2:  # pragma: no cover - the ranges always leave room for two
        raise RuntimeError(f"room seed {seed}: could not place two people")
    # the noise: a point behind or level with the robot (no face there), at least 0.5 m from the head
    while True:
        room_xy = (float(rng.uniform(0.3, width - 0.3)), float(rng.uniform(0.3, back + 0.5)))
        noise_position = (room_xy[0] - head[0], float(rng.uniform(-0.8, 0.4)), room_xy[1] - back)
        if math.dist(noise_position, (0.0, 0.0, 0.0)) >= 0.5:
            break
    return RoomDraw(seed, (width, depth, height), float(rng.uniform(0.2, 0.7)), head, tuple(faces),
                    tuple(postures), float(rng.uniform(0.15, 0.40)), float(rng.uniform(10.0, 30.0)),
                    noise_position)


def _visibility_check(width: float, depth: float, height: float, head: tuple[float, float, float]):
    """A test of a set of face centres: every face wholly in view and hidden by nobody (the scenario's own test)."""
    room = AcousticRoom(dims_m=(width, depth, height), rt60_s=0.3, head_m=head)

    def check(faces: list[tuple[float, float, float]]) -> bool:
        actors = tuple(Actor(f"p{i}", Path3D.still(f), 0, i) for i, f in enumerate(faces))
        s = Scenario("check", "", 1.0, 0, actors, (), room=room)
        return bool(s.visible(0.0).all())

    return check


def overlap_share(events: Sequence[SoundEvent], step_s: float = 0.01) -> float:
    """The share of the speech time during which two or more people speak (0 without speech)."""
    speech = [e for e in events if e.kind == "speech"]
    if not speech:
        return 0.0
    end = max(e.end_s for e in speech)
    t = np.arange(0.0, end, step_s)
    talking = np.zeros(t.size)
    for e in speech:
        talking += (t >= e.start_s) & (t < e.end_s)
    return float(np.sum(talking >= 2) / max(np.sum(talking >= 1), 1))


def _turns(n: int, voices: Sequence[int], durations: list[list[float]], rng: np.random.Generator,
           duration_s: float, chance: float) -> list[SoundEvent]:
    """Sentences in turns: each by someone other than the last talker; with ``chance`` a turn starts during the
    previous sentence (0.3 s up to most of it before its end), else 0.2-1.0 s after it; never during the talker's
    own previous sentence."""
    events: list[SoundEvent] = []
    own_end = [0.0] * n
    t_prev_end, prev = float(rng.uniform(0.3, 1.0)), -1
    prev_d = 0.0
    k = 0
    while True:
        actor = int(rng.integers(n)) if prev < 0 else int((prev + 1 + rng.integers(n - 1)) % n)
        v = voices[actor] % len(durations)
        clip = int(rng.integers(len(durations[v])))
        d = durations[v][clip]
        if events and rng.uniform() < chance:
            start = t_prev_end - float(rng.uniform(0.3, max(0.31, 0.9 * min(prev_d, d))))
        else:
            start = t_prev_end + (float(rng.uniform(0.2, 1.0)) if events else 0.0)
        start = max(start, own_end[actor] + 0.2)
        if start + d > duration_s - 0.1:
            break
        events.append(SoundEvent(actor, "speech", start, start + d, clip, f"sentence {k + 1}"))
        own_end[actor] = start + d
        if start + d > t_prev_end:
            t_prev_end, prev_d = start + d, d
        prev = actor
        k += 1
    return events


def make_room(seed: int, *, clip_durations_s: Sequence[Sequence[float]], duration_s: float = ROOM_DURATION_S,
              mics: str = "pair") -> tuple[Scenario, RoomDraw]:
    """The room of ``seed`` as a :class:`~sim.scenario.Scenario` (named ``room<seed>``) and what was drawn.

    clip_durations_s : ``ClipBank.durations_s`` of the sentences (:func:`sim.audio.load_sentence_bank`); mics : a
    name of :data:`avcore.geometry.ARRAY_PRESETS` on the head ("pair": the 12 cm pair). The timeline is drawn
    until its overlapped share is within 0.03 of the drawn target (the nearest of 300 draws otherwise)."""
    if not (math.isfinite(duration_s) and 5.0 <= duration_s <= 3600.0):
        raise ValueError(f"duration_s must be between 5 and 3600 seconds, got {duration_s!r}")
    durations = [[float(d) for d in v] for v in clip_durations_s]
    if not durations or any(not v for v in durations):
        raise ValueError("clip_durations_s must list, for at least one voice, the durations of its clips")
    draw = draw_room(seed)
    n = len(draw.faces_m)
    rng = np.random.default_rng([_OFFSET, seed, 1])
    order = rng.permutation(max(len(durations), n))
    voices = [int(order[i]) % len(durations) for i in range(n)]
    faces = [int(f) for f in rng.permutation(1000)[:n]]
    best: tuple[float, list[SoundEvent]] | None = None
    for attempt in range(300):
        chance = float(rng.uniform(0.1, 0.95))
        events = _turns(n, voices, durations, np.random.default_rng([_OFFSET, seed, 2, attempt]), duration_s,
                        chance)
        miss = abs(overlap_share(events) - draw.overlap_target)
        if best is None or miss < best[0]:
            best = (miss, events)
        if miss < 0.03:
            break
    assert best is not None
    room = AcousticRoom(dims_m=draw.dims_m, rt60_s=draw.rt60_s, head_m=draw.head_m, mic_distance_m=0.12)
    if mics != "pair":
        room = replace(room, mic_positions_m=MicArray.preset(mics).positions)
    actors = tuple(Actor(f"person{i}", Path3D.still(p), voice=voices[i], face=faces[i],
                         shirt_bgr=_SHIRTS[i % len(_SHIRTS)], posture=draw.postures[i])
                   for i, p in enumerate(draw.faces_m))
    events = tuple(sorted(best[1], key=lambda e: (e.start_s, e.actor)))
    description = (f"a {draw.dims_m[0]:.1f} x {draw.dims_m[1]:.1f} m room (RT60 {draw.rt60_s:.2f} s), {n} people "
                   f"reading sentences in turns, {100 * overlap_share(events):.0f} % of the speech overlapped, noise "
                   f"{draw.noise_snr_db:.0f} dB under the speech")
    return Scenario(name=f"room{seed}", description=description, duration_s=float(duration_s), seed=seed,
                    actors=actors, events=events, rig=default_rig(), room=room), draw
