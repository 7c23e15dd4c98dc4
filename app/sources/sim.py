"""The simulated room as a sensor stream: stereo frames and microphone blocks with timestamps, plus the truth.

The embedded default source (`avhear demo`): a :class:`SimSource` delivers what a real rig
delivers -- 640x480 left/right frames at ``fps`` (15-30) and 16 kHz two-channel audio in blocks of ``block_size``
samples, each stamped on one clock -- from a scenario of :mod:`sim.scenario` (the paper's section 7.3 presets S1-S5 and
the section 5.3 calibration), with the ground truth of every frame.

Audio is computed once, when the source is made (the whole scenario: image-source room impulse responses from
:mod:`sim.roomsim`, one per still sound source and one per ``max_step_m`` of a moving one, cross-faded; the
robot's fan; 16-bit quantisation as a sound card does). Frames are rendered on demand by
:class:`sim.render.StereoSceneRenderer`; a frame whose scene did not change (nobody moved or nodded) reuses the
previous rendering with fresh sensor noise, so still scenes cost little.

Streams (:class:`app.sources.replay.ReplayStream`, shared with :class:`app.sources.recording.Recording`):
``stream()`` yields frames and audio blocks merged in delivery order (a frame at its stamp, an audio block when its
last sample has been captured),
``frames()`` and ``audio_blocks()`` yield one kind each (for a grabber thread and an audio thread). With
``realtime=True`` each item is delivered at its time on ``time.monotonic()``, stamps rebased onto that clock, and a
frame that cannot be rendered in time is dropped (counted in ``stats``) as a camera drops frames; otherwise items
come as fast as they can be made, stamped from 0.

Real data (faces, spoken digits) come from ``data_dir`` (default ``../shared/data``); when it is absent, drawn faces
and synthetic voiced clips are used (``SimSource.meta`` says which).
"""
from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from app.errors import UserError
from app.sources.limits import CAMERAS, MAX_SIMULATED_S, MIN_SIMULATED_S
from app.sources.replay import ReplayStream
from sim.face_textures import FaceTexture, load_textures
from sim.render import Person, StereoSceneRenderer
from sim.audio import SimAudio, load_background, load_clip_bank, load_sentence_bank, render_audio
from sim.body_truth import interval_times, labelled_point_means, visible_moving_centres
from sim.depth import DepthRenderer
from sim.mouths import MouthTracks
from sim.rooms import ROOM_DURATION_S, make_room
from sim.scenario import (
    ClipBank,
    FrameTruth,
    Scenario,
    default_rig,
    make_scenario,
)

__all__ = ["CAMERAS", "SimSource", "load_clip_bank", "load_textures", "render_audio"]

log = logging.getLogger(__name__)

NOD_HZ = 2.0
GESTURE_M = 0.15  # how far a talker's hands swing (SimSource(bodies=True))
LISTENING_GESTURE_M = 0.03  # and a listener's: people with bodies are never quite still
GESTURE_RAMP_S = 0.25  # how long the hands take to go from one to the other


def check_simulated_duration(duration_s: float | None) -> None:
    """A :class:`UserError` naming ``--duration`` when the simulated room cannot run that long (or that short)."""
    if duration_s is not None and not MIN_SIMULATED_S <= duration_s <= MAX_SIMULATED_S:
        raise UserError(f"--duration {duration_s:g}: the simulated room runs between {MIN_SIMULATED_S:g} and "
                        f"{MAX_SIMULATED_S:g} s (it renders the whole scenario's audio in memory); for longer runs, "
                        "repeat or use a recording")


# ---------------------------------------------------------------------------------------------------------------
# the source


@dataclass
class _FrameCache:
    key: tuple | None = None
    left: np.ndarray | None = None
    right: np.ndarray | None = None


def _with_mouths_located(textures: list[FaceTexture]) -> list[FaceTexture]:
    """Each face's mouth drawn (``drawn_mouth``) where the face mesh finds it in its texture (the median place of
    :data:`sim.face_textures.MOUTH_IN_FACE_BOX` without the mesh's model, or where the mesh finds no face), so that drawn
    lips replace the photographed ones in their place."""
    from app.models import facemesh_model  # the simulator itself knows no model files
    from avcore.facemesh import LIP_CORNERS, LIP_INNER_LOWER, LIP_INNER_UPPER, FaceMesh

    try:
        mesh = FaceMesh(facemesh_model())
    except UserError:
        return [replace(tex, drawn_mouth=True) for tex in textures]
    out = []
    for tex in textures:
        marks = None if tex.source == "drawn" else mesh.run(tex.image, np.array([tex.face_box])).landmarks[0, :, :2]
        if marks is None or np.isnan(marks).any():
            out.append(replace(tex, drawn_mouth=True))
            continue
        bx, by, bw, bh = tex.face_box
        cx, cy = marks[[LIP_INNER_UPPER, LIP_INNER_LOWER]].mean(axis=0)
        width = float(np.linalg.norm(marks[LIP_CORNERS[1]] - marks[LIP_CORNERS[0]]))
        out.append(replace(tex, mouth_in_box=((cx - bx) / bw, (cy - by) / bh, width / bw), drawn_mouth=True))
    return out


class SimSource(ReplayStream):
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
                 noise_std: float = 1.5, audio: SimAudio | None = None, bodies: bool = False,
                 camera: str = "stereo", lips: bool = False,
                 progress: Callable[[str], None] | None = None) -> None:
        super().__init__()
        if camera not in CAMERAS:
            raise ValueError(f"camera must be one of {', '.join(CAMERAS)}, got {camera!r}")
        if not (np.isfinite(fps) and 1.0 <= fps <= 60.0):
            raise ValueError(f"fps must be between 1 and 60 frames per second, got {fps!r}")
        if isinstance(block_size, bool) or not isinstance(block_size, (int, np.integer)) or block_size < 1:
            raise ValueError(f"block_size must be a positive number of samples, got {block_size!r}")
        if noise_std < 0:
            raise ValueError(f"noise_std must be >= 0 grey levels, got {noise_std!r}")
        self.scenario = scenario
        self.bank = bank
        self.bodies = bool(bodies)
        # each talker's mouth opens with their speech, and listeners' now and then (sim.mouths)
        self.mouths = MouthTracks(scenario, bank) if lips else None
        faces_kind = "given"
        if textures is None:
            textures, faces_kind = load_textures(data_dir)
        if not textures:
            raise ValueError("textures is empty; give at least one face texture (or None for the defaults)")
        self.textures = _with_mouths_located(textures) if lips else textures
        # distinct faces for distinct people (as long as there are enough textures), chosen by the scenario's seeds
        order = np.random.default_rng([a.face for a in scenario.actors]).permutation(len(textures))
        self._face_of = [int(order[i % len(order)]) for i in range(len(scenario.actors))]
        self.stereo = scenario.rig
        self.mics = scenario.mics
        self.array = scenario.array
        self.fps = float(fps)
        self.samplerate_hz = scenario.room.samplerate_hz
        self.n_channels = len(self.array.positions)
        self.block_size = int(block_size)
        self.noise_std = float(noise_std)
        n_frames = int(np.floor(scenario.duration_s * self.fps - 1e-9)) + 1
        self.frame_stamps_s = np.arange(n_frames) / self.fps
        self.right_stamps_s = self.frame_stamps_s.copy()
        self.audio_start_s = 0.0
        self.audio = audio if audio is not None else render_audio(scenario, bank, progress=progress)
        expected = (round(scenario.duration_s * self.samplerate_hz), self.n_channels)
        if self.audio.samples.shape != expected:
            raise ValueError(f"audio holds {self.audio.samples.shape} samples, not the scenario's {expected}")
        self.n_samples = int(self.audio.samples.shape[0])
        self.meta = {"scenario": scenario.name, "seed": scenario.seed, "duration_s": scenario.duration_s,
                     "speech": bank.source, "faces": faces_kind, "measured_rt60_s": self.audio.measured_rt60_s,
                     "description": scenario.description}
        self._renderer = StereoSceneRenderer(self.stereo, [], room=scenario.visual_room, noise_std=0.0,
                                             seed=scenario.seed)
        self._cache = _FrameCache()
        self.camera = camera
        # an RGB-D camera: the left camera's colour and a depth image aligned to it (sim.depth, with its errors)
        self._depth_renderer = DepthRenderer(self._renderer, self.people, seed=scenario.seed) \
            if camera == "rgbd" else None
        rng = np.random.default_rng([scenario.seed, 23])
        w, h = self.stereo.image_size
        # sensor noise: a few precomputed fields, one drawn per image (cheap, deterministic)
        self._noise = [np.round(rng.normal(0.0, self.noise_std, (h, w, 3))).astype(np.int16) for _ in range(7)] \
            if self.noise_std > 0 else []

    @classmethod
    def from_preset(cls, name: str, *, duration_s: float | None = None, seed: int = 0, fps: float = 30.0,
                    data_dir: str | Path | None = None, block_size: int = 512, rt60_s: float = 0.4,
                    mics: str = "pair", bodies: bool = False, camera: str = "stereo", lips: bool = False,
                    progress: Callable[[str], None] | None = None) -> SimSource:
        """A preset of :data:`sim.scenario.PRESETS` with real faces and digits from ``data_dir`` (default
        ``../shared/data``; without it drawn faces and the digits avhear ships, :func:`sim.roomsim.data_path`),
        heard by the microphones ``mics``
        (:data:`avcore.geometry.ARRAY_PRESETS`)."""
        bank = load_clip_bank(16000, data_dir, seed=seed)
        scenario = make_scenario(name, clip_durations_s=bank.durations_s, duration_s=duration_s, seed=seed,
                                 rt60_s=rt60_s, mics=mics)
        return cls(scenario, bank, data_dir=data_dir, fps=fps, block_size=block_size, bodies=bodies,
                   camera=camera, lips=lips, progress=progress)

    @classmethod
    def from_room(cls, seed: int, *, duration_s: float | None = None, fps: float = 30.0,
                  data_dir: str | Path | None = None, block_size: int = 512, mics: str = "pair",
                  bodies: bool = False, camera: str = "stereo", lips: bool = False, image_scale: float = 1.0,
                  progress: Callable[[str], None] | None = None) -> SimSource:
        """A room of :mod:`sim.rooms` drawn from ``seed``, read sentences (the ARCTIC excerpts of ``data_dir``,
        synthetic utterances without them), its background noise (the kitchen, or pink noise), the faces' mouths
        moving with their speech with ``lips``; ``meta["room"]`` says what was drawn. ``image_scale`` 0.5 films
        the same view at 320 x 240 (faces 16-45 px wide, as far faces are: the lips' check)."""
        bank = load_sentence_bank(16000, data_dir, seed=seed)
        scenario, draw = make_room(seed, clip_durations_s=bank.durations_s, mics=mics,
                                   duration_s=ROOM_DURATION_S if duration_s is None else duration_s)
        if image_scale != 1.0:
            scenario = replace(scenario, rig=default_rig(image_scale))
        background = load_background(draw.noise_position_m, draw.noise_snr_db, 16000, data_dir, seed=seed)
        audio = render_audio(scenario, bank, background=background, progress=progress)
        source = cls(scenario, bank, data_dir=data_dir, fps=fps, block_size=block_size, bodies=bodies,
                     camera=camera, lips=lips, audio=audio, progress=progress)
        source.meta.update(room=dict(draw.as_dict(), image_size=list(scenario.rig.image_size)),
                           noise=background.source)
        return source

    # -------------------------------------------------------------- ReplayStream
    def people(self, t: float) -> list[Person]:
        """The renderer's people at ``t`` seconds: each actor's face texture at its path position, nodding while
        speaking; with bodies, gesturing while speaking (a little while listening), the seated behind a table."""
        pos = self.scenario.positions(t)
        nods = self.scenario.nod_amplitudes(t)
        b = self.bodies
        # the share of the last GESTURE_RAMP_S spent speaking: hands start and stop swinging smoothly, not at a jump
        talking = self.scenario.speaking_at(np.linspace(t - GESTURE_RAMP_S, t, 6)).mean(axis=0) if b else None

        def gesture(i: int) -> float:
            return LISTENING_GESTURE_M + (GESTURE_M - LISTENING_GESTURE_M) * talking[i] if b else 0.0

        m = self.mouths
        mouths = m.opening(t) if m is not None else np.zeros(len(pos))
        hands = m.covered(t) if m is not None else np.zeros(len(pos), bool)
        yaws = m.yaw_rad(t) if m is not None else np.zeros(len(pos))
        return [Person(face=self.textures[self._face_of[i]], position=tuple(p), shirt_bgr=a.shirt_bgr,
                       nod_rad=float(nod), nod_hz=NOD_HZ, phase=1.3 * i, arms=b, gesture_m=gesture(i),
                       table=b and a.posture == "seated", mouth_open=float(np.round(mouths[i], 2)),
                       hand_over_mouth=bool(hands[i]), yaw_rad=float(np.round(yaws[i], 3)))
                for i, (a, p, nod) in enumerate(zip(self.scenario.actors, pos, nods))]

    def body_centres(self, stamp_s: float, interval_s: float) -> np.ndarray:
        """(N, 3) metres: each actor's centre of the visible moving body over the interval of ``interval_s`` centred
        on ``stamp_s`` (:mod:`sim.body_truth`), the truth of a motion-guided result."""
        times = interval_times(stamp_s, interval_s)
        return visible_moving_centres(self.stereo, [self.people(float(t)) for t in times], times)

    def point_means(self, points: np.ndarray, stamp_s: float, interval_s: float) -> np.ndarray:
        """(N, 3) metres: the paper's truth of a motion-guided result, each actor's mean of the result's HM3D
        ``points`` that lie on them over its interval (:func:`sim.body_truth.labelled_point_means`; NaN: none)."""
        times = interval_times(stamp_s, interval_s)
        return labelled_point_means(points, [self.people(float(t)) for t in times], times)

    def prepare(self) -> None:
        """Render the first frame now (:class:`app.sources.open.StreamAdapter` calls this before a real-time run's
        clock starts): the renderers build the room's textures at their first frame, which takes several frame
        periods, and a clock started before it would skip the first frames as late."""
        self._depth(0, self._images(0)[0])

    def _images(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        t = float(self.frame_stamps_s[k])
        people = self.people(t)
        angles = [p.nod_rad * np.sin(2 * np.pi * p.nod_hz * t + p.phase) for p in people]
        moving_hands = [t if p.gesture_m > 0 else 0.0 for p in people]
        faces = [(p.mouth_open, p.hand_over_mouth, p.yaw_rad) for p in people]
        key = tuple(np.round(np.concatenate([np.ravel([p.position for p in people]), angles, moving_hands,
                                             np.ravel(faces)]), 5))
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
        return (left, right) if self.camera == "stereo" else (left, None)

    def _depth(self, k: int, colour: np.ndarray) -> np.ndarray | None:
        if self._depth_renderer is None:
            return None
        return self._depth_renderer.render(float(self.frame_stamps_s[k]), colour)

    def _samples(self, a: int, b: int) -> np.ndarray:
        return self.audio.samples[a:b].astype(np.float32) / np.float32(32768.0)

    def truth(self, k: int) -> FrameTruth:
        return self.scenario.truth(float(self.frame_stamps_s[k]))
