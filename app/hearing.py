"""The two ways of hearing as one object each, so that the pipeline holds no "if face": what vision yields from the
frames, which ITDs a result collects, the hearing that fits them, and where the people are for the tracker.

- :class:`FaceGuided` (Algorithm 2): the faces of every frame in 3D (F3D); a result per frame collects the ITDs of
  +- ``frame_window_s`` and the single frames' ITDs; its speaking states are voted over ``vote_frames`` results.
- :class:`MotionGuided` (Algorithm 1): the HM3D points of an interval of ``interval_s``; a result per interval
  collects the ITDs of the interval; no vote.
"""
from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import cv2
import numpy as np

from avcore.bin_spill import BinSpill
from avcore.depth import locate_faces_depth, motion_points_depth
from avcore.facemesh import N_LANDMARKS, eye_centres, mouth_opening
from avcore.faces import TrackingFaceDetector, locate_faces
from avcore.geometry import MicArray
from avcore.inference import FaceGuidedHearing, FaceGuidedParams, MotionGuidedHearing, MotionGuidedParams
from avcore.itd import gives_frame_itds
from avcore.lips import (
    HiddenLips,
    LipTracks,
    SoundEnvelope,
    choose_by_lips,
    lip_synchrony,
    lips_move_with_the_sound,
    lips_with_the_words,
    same_direction_groups,
    veto_still_lips,
    voice_without_lips,
)
from avcore.mono import locate_faces_mono
from avcore.motion import harris_motion_points
from avcore.own_itd import OwnItds
from avcore.selfcal import ArrayYawCalibration, SelfCalibration, SelfCalibrationFit, YawFit
from avcore.speaking import SpeakingVote
from avcore.sync import TimeFrame
from avcore.voices import VoiceTracks, unexplained_voice

log = logging.getLogger(__name__)

if TYPE_CHECKING:
    from app.events import StereoFrame
    from app.pipeline_config import PipelineConfig
    from avcore.faces import FaceDetector
    from avcore.geometry import MicPair
    from avcore.stereo import StereoRig

__all__ = ["FaceGuided", "LipReader", "MotionGuided", "Vision", "Voice", "detector_name", "face_detector",
           "faces_of_people", "hearing_mode"]


@dataclass(frozen=True, eq=False)
class Vision:
    """What vision yields for one result: its stamp, the frame it is shown on, the face boxes (None when
    motion-guided), the 3D points (the faces, or the HM3D points) and, with the lips' cue, each face's lip
    activity, its place in the face's own range, the face's track and its recent mouth openings
    (:class:`avcore.lips.LipTracks`); motion-guided with the lips' cue, ``face_xyz`` the faces of the interval's
    last frame in 3D (None otherwise); ``landmarks`` the face mesh's on the boxes when vision has run it already
    (one camera, whose faces the mesh's eyes place), for the lips' stage."""

    stamp_s: float
    frame: StereoFrame
    boxes: np.ndarray | None
    xyz: np.ndarray
    lip_activity: np.ndarray | None = None
    lip_relative: np.ndarray | None = None
    lip_ids: np.ndarray | None = None
    face_xyz: np.ndarray | None = None
    lip_series: list[np.ndarray] | None = None
    landmarks: np.ndarray | None = None


@dataclass(eq=False)
class LipReader:
    """The lips' cue on one video stream: the face mesh on each face (MediaPipe's, by ``runtime``), each face's
    lip activity along its track (:class:`avcore.lips.LipTracks`), whose still lips say nothing
    (:class:`avcore.lips.HiddenLips`) and the sound's envelope its lips are compared with
    (:class:`avcore.lips.SoundEnvelope`, fed by the pipeline's audio). The model is found (or a UserError says how
    to get it) when it is made."""

    runtime: str = "opencv"
    earn_trust: bool = True
    synced_s: float | None = None
    every: int = 1
    tracks: LipTracks = field(init=False, repr=False)
    hidden: HiddenLips = field(init=False, repr=False)
    envelope: SoundEnvelope = field(default_factory=SoundEnvelope, init=False, repr=False)
    _mesh: Any = field(default=None, init=False, repr=False)
    _frames: int = field(default=0, init=False, repr=False)

    def __post_init__(self) -> None:
        from app.models import facemesh_model
        from avcore.facemesh import FaceMesh

        self._mesh = FaceMesh(facemesh_model(), runtime=self.runtime)
        self.tracks = LipTracks(min_samples=max(2, LipTracks.min_samples // self.every))
        self.hidden = HiddenLips(earn_trust=self.earn_trust, synced_s=self.synced_s)

    def landmarks(self, image: np.ndarray, boxes: np.ndarray, eyes: np.ndarray | None = None) -> np.ndarray:
        """The mesh's landmarks (n, 468, 3) on ``boxes``, its crops levelled by ``eyes`` (the detector's) when given."""
        return self._mesh.run(image, np.asarray(boxes, dtype=np.float64).reshape(-1, 4), eyes).landmarks

    def read(self, stamp_s: float, image: np.ndarray, boxes: np.ndarray, landmarks: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[np.ndarray]]:
        """Each face's lip activity (NaN: no opinion), its place in its own range, its track's id and its recent
        mouth openings; the mesh runs on ``boxes`` unless their ``landmarks`` are given, and with ``every`` > 1
        only on every ``every``-th frame (the others follow the faces' tracks with no opening)."""
        self._frames += 1
        if landmarks is not None:
            openings = mouth_opening(landmarks)
        elif (self._frames - 1) % self.every == 0:
            openings = mouth_opening(self.landmarks(image, boxes))
        else:
            openings = np.full(np.asarray(boxes).reshape(-1, 4).shape[0], np.nan)
        activity = self.tracks.update(stamp_s, boxes, openings)
        return activity, self.tracks.relative, self.tracks.ids, self.tracks.series()

    def synchrony(self, series: list[np.ndarray]) -> np.ndarray:
        """Each face's lips against the sound (:func:`avcore.lips.lip_synchrony`)."""
        return lip_synchrony(series, self.envelope)

    def veto(self, stamp_s: float, ids: np.ndarray, output: Any, activity: np.ndarray, still_below: float,
             alone: np.ndarray | None = None, relative: np.ndarray | None = None,
             frame_s: tuple[float, float] | None = None, synchrony: np.ndarray | None = None) -> Any:
        """``output`` with the people whose lips are still (under ``still_below``, or with ``relative`` within
        their own still level) not speaking, but those whose lips have not earned trust (hidden: see
        :class:`avcore.lips.HiddenLips`; with ``relative`` and ``synchrony``, lips moving with the sound earn it),
        the one heard alone while the sound is loud through the result's time frame ``frame_s`` (start, end) and
        no lips in view move (:func:`avcore.lips.voice_without_lips`), and those not ``alone`` (a group the lips
        already chose within)."""
        moving = None if relative is None or synchrony is None else \
            lips_move_with_the_sound(activity, relative, synchrony)
        hidden = self.hidden.update(stamp_s, ids, output.speaking, activity, still_below, moving, synchrony)
        if frame_s is not None:
            hidden |= voice_without_lips(output.speaking, activity, still_below, self.envelope.loud_share(*frame_s))
        keep = ~hidden if alone is None else alone & ~hidden
        speaking, probability = veto_still_lips(output.speaking, output.probability, np.where(keep, activity, np.nan),
                                                still_below, relative)
        return replace(output, speaking=speaking, probability=probability)

    def join(self, output: Any, activity: np.ndarray, relative: np.ndarray, synchrony: np.ndarray,
             trusted: np.ndarray | None = None) -> Any:
        """``output`` with the faces whose lips move with the sound (``synchrony``: :meth:`synchrony`) speaking too
        while another is heard (:func:`avcore.lips.lips_with_the_words`), and a call of the speaking test's later
        looks on lips that move with the sound no longer a rescue (:class:`avcore.speaking.RescueContinuity`: the
        lips may start speech). Only lips that have earned trust (``trusted``, (N,) bool; None: all) add a talker:
        a face whose lips never moved with its own voice gives no opinion, here as in the veto."""
        joining = relative if trusted is None else np.where(np.asarray(trusted, dtype=bool), relative, np.nan)
        speaking, probability = lips_with_the_words(output.speaking, output.probability, activity, joining,
                                                    synchrony)
        rescued = getattr(output, "rescued", None)
        if rescued is not None:
            rescued = rescued & ~lips_move_with_the_sound(activity, relative, synchrony)
            return replace(output, speaking=speaking, probability=probability, rescued=rescued)
        return replace(output, speaking=speaking, probability=probability)


@dataclass(eq=False)
class FaceGuided:
    """Algorithm 2 (module docstring), each person heard where their voice is (``config.own_itds``:
    :mod:`avcore.own_itd`) and each talker's spill onto the neighbours' bins learned (``config.bin_spill``:
    :mod:`avcore.bin_spill`); with ``config.lips`` the face mesh on every face and the lips' veto
    (:mod:`avcore.lips`)."""

    config: PipelineConfig
    _lips: LipReader | None = field(default=None, init=False, repr=False)
    _voices: VoiceTracks = field(default_factory=VoiceTracks, init=False, repr=False)
    _unexplained: tuple = field(default=(None, None), init=False, repr=False)  # (stamp, VoiceDirection | None)
    _own: OwnItds | None = field(default=None, init=False, repr=False)
    _spill: BinSpill | None = field(default=None, init=False, repr=False)

    def __post_init__(self) -> None:
        if self.config.own_itds and self.config.face_variant != "paper":
            self._own = OwnItds()
        if self.config.bin_spill and self.config.face_variant != "paper":
            self._spill = BinSpill()
        if self.config.lips:  # the model is found (or a UserError says how to get it) before anything runs
            self._lips = LipReader(self.config.tflite_runtime, self.config.lip_earn_trust, self.config.lip_synced_s,
                                   self.config.lip_mesh_every)

    @property
    def frame_capacity(self) -> int:
        return self.config.frame_queue

    def time_frame(self) -> TimeFrame:
        """The ITDs of +- ``frame_window_s`` around each frame; with ``latency="low"`` as wide a frame that ends at
        the frame's stamp (the past only: a result waits for no later ITD)."""
        return _time_frame(self.config, self.config.frame_window_s)

    def vote(self) -> SpeakingVote:
        """The vote over ``vote_frames`` results centred on each one; trailing (at once) with ``latency="low"``."""
        return SpeakingVote(self.config.vote_frames, trailing=self.config.latency == "low")

    @property
    def frame_itds(self) -> bool:
        return self.config.frame_itds and gives_frame_itds(self.config.itd_method)

    @property
    def envelope(self) -> SoundEnvelope | None:
        """The sound's envelope the lips are compared with (the pipeline feeds it), or None without the lips."""
        return None if self._lips is None else self._lips.envelope

    def detector(self) -> FaceDetector:
        """The detector ``face_detector`` names (:func:`face_detector`)."""
        return face_detector(self.config)

    def hearing(self, mics: MicPair | MicArray) -> FaceGuidedHearing | SelfCalibrating:
        """Algorithm 2 on ``mics``. A calibrated mapping (section 5.3's c1, c0 on any pair) already says where the
        voices are heard, and each person's own ITD is not learned on top of it (docs/method.md)."""
        params = FaceGuidedParams.paper() if self.config.face_variant == "paper" else FaceGuidedParams.for_array(mics)
        hearing = FaceGuidedHearing(mics, replace(params, decision_window_s=self.config.decision_window_s))
        array = hearing.array
        if np.any(np.asarray(array.c1) != 1.0) or np.any(np.asarray(array.c0) != 0.0):
            self._own = None
        return SelfCalibrating(hearing) if self.config.self_calibrate else hearing

    @property
    def reads_lips(self) -> bool:
        """Whether :meth:`read_lips` has work to do (the pipeline gives it a thread of its own)."""
        return self._lips is not None

    def vision(self, frame: StereoFrame, rig: StereoRig, detector: FaceDetector) -> Vision | None:
        """The faces of this frame, from the stereo pair, an RGB-D camera's depth, or with one camera their size
        in the image (ValueError: a frame F3D cannot use); with the lips' cue and one camera, the face mesh's eyes
        place the faces and its landmarks go with them (:meth:`read_lips` reads the lips from them)."""
        lips, seen = self._lips, []
        if lips is None or frame.right is not None or frame.depth_m is not None:
            faces = _faces(frame, rig, detector)
            return Vision(frame.stamp_s, frame, faces.boxes, faces.points)

        def eyes_from(image: np.ndarray, boxes: np.ndarray, eyes: np.ndarray) -> np.ndarray:
            seen.append((np.asarray(boxes, dtype=np.float64).copy(), lips.landmarks(image, boxes, eyes)))
            return eye_centres(seen[-1][1])

        faces = _faces(frame, rig, detector, eyes_from)
        return Vision(frame.stamp_s, frame, faces.boxes, faces.points, landmarks=_landmarks_of(faces.boxes, seen))

    def read_lips(self, vision: Vision) -> Vision:
        """``vision`` with each face's lips read (:meth:`LipReader.read`; the mesh runs unless vision ran it);
        unchanged without the lips' cue. One thread at a time: the lips' tracks follow the frames in order."""
        if self._lips is None:
            return vision
        activity, relative, ids, series = self._lips.read(vision.stamp_s, vision.frame.left, vision.boxes,
                                                          vision.landmarks)
        return replace(vision, lip_activity=activity, lip_relative=relative, lip_ids=ids, lip_series=series,
                       landmarks=None)

    def step(self, hearing: Any, vision: Vision, itds: np.ndarray, times_s: np.ndarray,
             near: Callable[[], tuple]) -> Any:
        """The hearing's step on this result's faces and ITDs, with the single frames' ITDs near it (``near()``);
        with the lips' cue, faces that direction cannot tell apart (:func:`avcore.lips.same_direction_groups`,
        within ``lip_same_direction_s``) are one object for the hearing, whose words go to the face whose lips move
        (:func:`avcore.lips.choose_by_lips`), the faces whose lips are still are not speaking, and while one face
        is heard, another whose trusted lips move with the sound speaks too
        (:func:`avcore.lips.lips_with_the_words`).

        With several pairs, where the ITDs hold a voice that no visible face explains (:func:`unexplained_voice`),
        the bins' look is not taken for this result: a bin of that voice agrees best with whichever visible person
        lies nearest its direction (a small array tells directions 30 degrees apart poorly), and would claim them
        as speaking; the windows', frames' and bands' looks still decide."""
        frames, bands, bins = near()
        found = unexplained_voice(itds, hearing.array, vision.xyz) if hearing.array.n_pairs >= 2 else None
        self._unexplained = (vision.stamp_s, found)
        if vision.lip_activity is None:
            return self._heard(found is None, hearing, vision.xyz, itds, times_s - vision.stamp_s, frames, bands,
                               None if found else bins)
        xyz = np.asarray(vision.xyz, dtype=np.float64).reshape(-1, 3)
        itds_of_faces = hearing.array.itd(xyz).reshape(len(xyz), hearing.array.n_pairs)
        assert self._lips is not None
        # only lips that have earned trust choose within a group; a face whose lips have not is heard on its own
        trusted = self._lips.hidden.trusted(np.arange(len(xyz)) if vision.lip_ids is None else vision.lip_ids)
        groups = same_direction_groups(itds_of_faces, self.config.lip_same_direction_s, trusted)
        ones = np.array([g[np.argmin(xyz[g, 2])] for g in groups], dtype=int)  # each group heard from its nearest
        owner = np.empty(len(xyz), dtype=int)
        for k, g in enumerate(groups):
            owner[g] = k
        alone = np.bincount(owner, minlength=len(groups))[owner] == 1
        out = self._heard(found is None, hearing, xyz[ones], itds, times_s - vision.stamp_s, frames, bands,
                          None if found else bins)
        if len(ones) < len(xyz):
            out = replace(out, speaking=out.speaking[owner], probability=out.probability[owner],
                          itd_means=out.itd_means[owner], itd_counts=out.itd_counts[owner],
                          model=out.model.shared(owner),
                          pair_itd_means=None if out.pair_itd_means is None else out.pair_itd_means[owner],
                          rescued=None if out.rescued is None else out.rescued[owner],
                          bin_share=None if out.bin_share is None else out.bin_share[owner])
            speaking, probability = choose_by_lips(out.speaking, out.probability, vision.lip_relative, groups,
                                                   self.config.lip_both_above)
            out = replace(out, speaking=speaking, probability=probability)
        # a face in a group is not vetoed on its own: the sound says one of them speaks, and the lips chose who;
        # nor is one whose lips have stayed still through a second of its own voice, or that a voice no lips in
        # view make is heard from (hidden: no opinion)
        lips = np.asarray(vision.lip_activity, dtype=np.float64)
        ids = np.arange(len(lips)) if vision.lip_ids is None else vision.lip_ids
        before, after = _frame_span(self.config, self.config.frame_window_s)
        synchrony = None if vision.lip_series is None else self._lips.synchrony(vision.lip_series)
        out = self._lips.veto(vision.stamp_s, ids, out, lips, self.config.lip_still_below, alone, vision.lip_relative,
                              (vision.stamp_s - before, vision.stamp_s + after), synchrony)
        if vision.lip_relative is None or synchrony is None:
            return out
        return self._lips.join(out, lips, vision.lip_relative, synchrony, trusted)

    def _heard(self, learn: bool, hearing: Any, xyz: np.ndarray, itds: np.ndarray, *rest: Any) -> Any:
        """``hearing.step`` with each person where their voice is heard (:class:`avcore.own_itd.OwnItds`) and the
        bins' claims above the heard talkers' learned spill (:class:`avcore.bin_spill.BinSpill`); both then learn
        from what the windows' test heard alone, unless ``learn`` is False (the ITDs hold a voice no face explains,
        which could lie near the one person heard)."""
        n_pairs = hearing.array.n_pairs
        learner = self._spill if n_pairs >= 2 else None  # one pair's bins claim by their own rule (SpeakingTest)
        if self._own is None and learner is None:
            return hearing.step(xyz, itds, *rest)
        mapped = hearing.array.itd(np.asarray(xyz, dtype=np.float64).reshape(-1, 3)).reshape(-1, n_pairs)
        offsets = None if self._own is None else self._own.offsets(mapped)
        means = mapped if offsets is None else mapped + offsets
        spill = None if learner is None else learner.ratios(means)
        out = hearing.step(xyz, itds, *rest, mean_offsets_s=offsets, bin_spill=spill)
        if not learn:
            return out
        alone = out.speaking if out.rescued is None else out.speaking & ~out.rescued
        if self._own is not None:
            self._own.update(mapped, np.asarray(itds, dtype=np.float64).reshape(-1, n_pairs), alone)
        if learner is not None:
            learner.update(means, out.bin_share, alone)
        return out

    def people_xyz(self, vision: Vision, output: Any) -> np.ndarray:
        return vision.xyz

    def people_lips(self, vision: Vision, output: Any) -> np.ndarray | None:
        """Each person's lip activity (a person is a face), or None without the lips' cue."""
        return vision.lip_activity

    def voices(self, array: MicArray, vision: Vision, itds: np.ndarray,
               new_id: Callable[[], int] | None = None) -> tuple[Voice, ...] | None:
        """With several pairs, the voice out of view this result's ITDs hold, if any (:mod:`avcore.voices`), with
        its id (drawn by ``new_id``: the people's tracker, so that a voice and a person never share a number);
        None with one pair (it cannot tell a direction)."""
        if array.n_pairs < 2:
            return None
        stamp, found = self._unexplained  # the step's search on the same result
        if stamp != vision.stamp_s:
            found = unexplained_voice(itds, array, vision.xyz)
        vid = self._voices.update(vision.stamp_s, found, new_id)
        if vid is None or found is None:
            return ()
        return (Voice(vid, found.azimuth_rad, found.elevation_rad),)


@dataclass(frozen=True)
class Voice:
    """A voice that no visible person explains: its id (from the people's numbering, never a person's) and its
    direction (azimuth from straight ahead, positive to the right; elevation up, None where the array cannot tell);
    its distance is unknown."""

    id: int
    azimuth_rad: float
    elevation_rad: float | None


@dataclass(eq=False)
class MotionGuided:
    """Algorithm 1 (module docstring). Stateful: the frames of the interval being gathered."""

    config: PipelineConfig
    _interval: list = field(default_factory=list, init=False, repr=False)
    _lips: LipReader | None = field(default=None, init=False, repr=False)
    _last_faces: tuple = field(default=(None, None, None), init=False, repr=False)  # (xyz, activity, ids)
    _people_lips: tuple = field(default=(None, None), init=False, repr=False)  # (stamp, each person's activity)

    def __post_init__(self) -> None:
        if self.config.lips:
            self._lips = LipReader(self.config.tflite_runtime, self.config.lip_earn_trust, self.config.lip_synced_s,
                                   self.config.lip_mesh_every)

    @property
    def frame_capacity(self) -> int:
        """One interval at 60 FPS at least: the vision thread takes a whole interval at once."""
        return max(self.config.frame_queue, math.ceil(self.config.interval_s * 60.0))

    def time_frame(self) -> TimeFrame:
        """The ITDs of the interval (+- half of it around its centre); with ``latency="low"`` the past only."""
        return _time_frame(self.config, self.config.interval_s / 2)

    def vote(self) -> SpeakingVote:
        """No vote: each interval decides alone."""
        return SpeakingVote(1)

    @property
    def frame_itds(self) -> bool:
        return False

    @property
    def envelope(self) -> None:
        """No envelope: Algorithm 1's lips only veto."""
        return None

    def detector(self) -> FaceDetector | None:
        """No faces are looked for, but with the lips' cue (:func:`face_detector`)."""
        return face_detector(self.config) if self.config.lips else None

    def hearing(self, mics: MicPair | MicArray) -> MotionGuidedHearing:
        """avhear's Algorithm 1, or the paper's as written (``config.motion_variant``)."""
        paper = self.config.motion_variant == "paper"
        return MotionGuidedHearing(mics, MotionGuidedParams.paper() if paper else MotionGuidedParams())

    @property
    def reads_lips(self) -> bool:
        """False: the lips are read in :meth:`vision`, frame by frame through the interval."""
        return False

    def read_lips(self, vision: Vision) -> Vision:
        """``vision`` as it is (its lips were read with its frames)."""
        return vision

    def vision(self, frame: StereoFrame, rig: StereoRig, detector: FaceDetector | None) -> Vision | None:
        """The HM3D points once an interval is gathered (stamped at its centre, shown on its middle frame); with
        the lips' cue the faces of every frame are read, and the last frame's go with the interval."""
        interval = self._interval
        interval.append(frame)
        if self._lips is not None and detector is not None:
            faces = _faces(frame, rig, detector)
            activity, _, ids, _ = self._lips.read(frame.stamp_s, frame.left, faces.boxes)
            self._last_faces = (faces.points, activity, ids)
        if frame.stamp_s - interval[0].stamp_s + 1e-9 < self.config.interval_s:
            return None
        if interval[0].depth_m is None and interval[0].right is None:
            self._interval = []
            raise ValueError("Algorithm 1 needs depth for its moving points: one camera has none")
        if interval[0].depth_m is not None:  # an RGB-D camera: the points' depth is measured, not matched
            points = motion_points_depth([f.left for f in interval], [f.depth_m for f in interval], rig).points
        else:
            points = harris_motion_points([f.left for f in interval], [f.right for f in interval], rig).points
        self._interval = []
        face_xyz, activity, ids = self._last_faces
        return Vision(0.5 * (interval[0].stamp_s + interval[-1].stamp_s), interval[len(interval) // 2], None,
                      points, activity, None, ids, face_xyz)

    def step(self, hearing: Any, vision: Vision, itds: np.ndarray, times_s: np.ndarray,
             near: Callable[[], tuple]) -> Any:
        """The hearing's step on the interval's points and ITDs; with the lips' cue, a person whose face's lips
        are still is not speaking (their face: :func:`faces_of_people`)."""
        out = hearing.step(vision.xyz, itds)
        if self._lips is None or vision.face_xyz is None:
            return out
        face = faces_of_people(out.positions, vision.face_xyz, self.config.lip_face_within_m)
        # -1 (no face) picks the appended NaN; a person without a face gets an id of their own for the hidden lips
        activity = np.append(np.asarray(vision.lip_activity, dtype=np.float64).reshape(-1), np.nan)[face]
        ids = np.where(face >= 0, np.append(np.asarray(vision.lip_ids).reshape(-1), 0)[face], -1 - np.arange(len(face)))
        self._people_lips = (vision.stamp_s, activity)
        return self._lips.veto(vision.stamp_s, ids, out, activity, self.config.lip_still_below)

    def people_xyz(self, vision: Vision, output: Any) -> np.ndarray:
        return output.positions

    def people_lips(self, vision: Vision, output: Any) -> np.ndarray | None:
        """Each person's lip activity (their face's, NaN without one), or None without the lips' cue."""
        stamp, activity = self._people_lips
        return activity if stamp == vision.stamp_s else None

    def voices(self, array: MicArray, vision: Vision, itds: np.ndarray,
               new_id: Callable[[], int] | None = None) -> None:
        """Algorithm 1 gives every sound a cluster of its own: no voice is left over."""
        return None


def _faces(frame: StereoFrame, rig: StereoRig, detector: FaceDetector, eyes_from: Callable | None = None) -> Any:
    """The faces of a frame in 3D: from the stereo pair, an RGB-D camera's depth, or with one camera their size in
    the image (the eyes from ``eyes_from`` when given: the face mesh's)."""
    if frame.depth_m is not None:
        return locate_faces_depth(frame.left, frame.depth_m, rig, detector=detector)
    if frame.right is None:
        return locate_faces_mono(frame.left, rig, detector=detector, eyes_from=eyes_from)
    return locate_faces(frame.left, frame.right, rig, detector=detector)


def _landmarks_of(boxes: np.ndarray, seen: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray | None:
    """The landmarks of the mesh's run ``seen`` (boxes, landmarks) for each of ``boxes`` (some of the boxes it ran on,
    the faces placed), or None when a box is not among them (the lips' stage then runs the mesh)."""
    b = np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
    if not seen:
        return None if len(b) else np.zeros((0, N_LANDMARKS, 3))
    ran_on, landmarks = seen[-1]
    rows = [np.flatnonzero((ran_on == box).all(axis=1)) for box in b]
    return landmarks[[int(r[0]) for r in rows]] if all(len(r) for r in rows) else None


def faces_of_people(people_xyz: np.ndarray, faces_xyz: np.ndarray, within_m: float) -> np.ndarray:
    """(N,) the face of each person of Algorithm 1 (index into ``faces_xyz``, -1: none): a person's cluster is their
    moving body, whose face is above it, so faces and people are paired by their horizontal distance (x, z), the
    closest pairs first, one for one, within ``within_m``."""
    people = np.asarray(people_xyz, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(faces_xyz, dtype=np.float64).reshape(-1, 3)
    out = np.full(len(people), -1, dtype=int)
    if not len(people) or not len(faces):
        return out
    d = np.hypot(people[:, None, 0] - faces[None, :, 0], people[:, None, 2] - faces[None, :, 2])
    d[~np.isfinite(d)] = np.inf
    for flat in np.argsort(d, axis=None):
        i, j = np.unravel_index(flat, d.shape)
        if d[i, j] > within_m:
            break
        if out[i] < 0 and j not in out:
            out[i] = j
    return out


class SelfCalibrating:
    """A face-guided hearing whose correction is learned as it runs (:mod:`avcore.selfcal`); every ``every`` results
    the hearing is rebuilt with what is known (it holds no state from one result to the next).

    One pair: its c1, c0 (eq. itd_up) from :class:`SelfCalibration`. Several pairs (an array, whose geometry comes
    from its maker and whose placement from the rig file): the array's turn about the vertical and the ITDs' common
    scale (:class:`ArrayYawCalibration`), the scale becoming every pair's c1. Not a line per pair: a pair whose
    faces span little of its ITD range (NAO's front-back pair) gets one far from the truth (docs/method.md).
    ``state()`` says where each pair stands."""

    def __init__(self, hearing: FaceGuidedHearing, every: int = 30) -> None:
        self.hearing = hearing
        self.every = every
        self._given = hearing.array
        several = hearing.array.n_pairs > 1
        self._cals = [] if several else [SelfCalibration(hearing.array.pair(0))]
        self._fits: list[SelfCalibrationFit | None] = [None] * len(self._cals)
        self._yaw = ArrayYawCalibration(hearing.array) if several else None
        self._yaw_fit: YawFit | None = None
        self._n = 0

    @property
    def array(self) -> MicArray:
        return self.hearing.array

    def step(self, faces_xyz: np.ndarray, itds_s: np.ndarray, *rest: Any, **options: Any) -> Any:
        out = self.hearing.step(faces_xyz, itds_s, *rest, **options)
        for p, cal in enumerate(self._cals):
            cal.push(faces_xyz, itds_s[:, p])
        if self._yaw is not None:
            self._yaw.push(faces_xyz, itds_s)
        self._n += 1
        # an array's turn is looked for three times as often until found (until then the whole array hears wrong)
        searching = self._yaw is not None and self._yaw_fit is None
        if self._n % (max(1, self.every // 3) if searching else self.every) == 0:
            self._refit()
        return out

    def _refit(self) -> None:
        a = self._given
        c1, c0 = a.c1, a.c0
        if self._yaw is not None:
            self._yaw_fit = self._yaw.fit(self._yaw_fit.yaw_rad if self._yaw_fit else 0.0) or self._yaw_fit
            if self._yaw_fit is None:
                return
            a = a.turned(self._yaw_fit.yaw_rad)
            c1 = tuple(self._yaw_fit.scale * c for c in a.c1)  # type: ignore[union-attr]
        if self._cals:
            fits = [cal.fit() for cal in self._cals]
            self._fits = [f if f is not None else old for f, old in zip(fits, self._fits)]
            c1 = tuple(f.c1 if f is not None else c for f, c in zip(self._fits, c1))  # type: ignore[arg-type]
            c0 = tuple(f.c0 if f is not None else c for f, c in zip(self._fits, c0))  # type: ignore[arg-type]
        self.hearing = FaceGuidedHearing(MicArray(a.positions, a.pairs, a.speed_of_sound, c1, c0, a.channels),
                                         self.hearing.params)

    def state(self) -> list[dict[str, Any]]:
        """Per pair: c1, c0 in use, and the fit's inliers, observations and confidence (None: not fitted yet: the
        pair's own fit, or the array's); with several pairs also the array's learned turn, ``array_yaw_deg`` (None:
        not yet), the same in every pair."""
        a = self.hearing.array
        fits = self._fits if self._cals else [self._yaw_fit] * a.n_pairs
        kept = [len(c) for c in self._cals] if self._cals else [len(self._yaw)] * a.n_pairs  # type: ignore[arg-type]
        out = [{"c1": float(c1), "c0_s": float(c0), "inliers": f.inliers if f else 0, "observations": n,
                "confidence": f.confidence if f else None}
               for c1, c0, f, n in zip(a.c1, a.c0, fits, kept)]  # type: ignore[arg-type]
        if self._yaw is not None:
            yaw = None if self._yaw_fit is None else math.degrees(self._yaw_fit.yaw_rad)
            for d in out:
                d["array_yaw_deg"] = yaw
        return out


def detector_name(config: PipelineConfig) -> str:
    """The detector ``config.face_detector`` stands for: "auto" is BlazeFace when its model is installed, else Haar's
    cascade with a one-line notice; Haar asked of an OpenCV without cascades (OpenCV 5) is BlazeFace, with a notice.
    A UserError says how to get BlazeFace's model where nothing else can find faces."""
    from app.errors import UserError
    from app.models import INSTALL_HINT, blazeface_model, no_face_detector

    has_haar = hasattr(cv2, "CascadeClassifier")
    if config.face_detector == "blazeface" or (config.face_detector == "haar" and has_haar):
        return config.face_detector
    if config.face_detector == "auto" and config.face_model is not None:
        return "blazeface"  # a model given by name: a missing file is an error, never a fallback
    try:
        blazeface_model(config.face_model)
    except UserError:
        if not has_haar:
            raise no_face_detector(cv2.__version__) from None
        log.warning("BlazeFace's model is not installed (%s): the faces are found by Haar's cascade", INSTALL_HINT)
        return "haar"
    if config.face_detector == "haar":
        log.warning("OpenCV %s has no Haar cascades: the faces are found by BlazeFace", cv2.__version__)
    return "blazeface"


def face_detector(config: PipelineConfig) -> FaceDetector:
    """The detector :func:`detector_name` gives for ``config`` (a UserError when its model or runtime is missing or
    is not what it should be)."""
    from app.errors import UserError
    from app.models import blazeface_model

    if detector_name(config) == "haar":
        return TrackingFaceDetector()
    from avcore.blazeface import TrackingBlazeFace

    try:
        return TrackingBlazeFace.from_model(blazeface_model(config.face_model), runtime=config.tflite_runtime)
    except ValueError as exc:  # a file that is not the model
        raise UserError(f"--face-model: {exc}") from None
    except ImportError as exc:  # LiteRT asked for and not installed
        raise UserError(f"--tflite-runtime litert: {exc}") from None


def _frame_span(config: PipelineConfig, half_s: float) -> tuple[float, float]:
    """How far a result's time frame reaches (before, after) its stamp: the past only with ``latency="low"``."""
    return (2 * half_s, 0.0) if config.latency == "low" else (half_s, half_s)


def _time_frame(config: PipelineConfig, half_s: float) -> TimeFrame:
    before, after = _frame_span(config, half_s)
    return TimeFrame(before, after_s=after)


def hearing_mode(config: PipelineConfig) -> FaceGuided | MotionGuided:
    """The mode ``config.inference`` names."""
    return MotionGuided(config) if config.inference == "motion" else FaceGuided(config)
