"""The contract with robot software: topic names, frames and message types of what avhear publishes, in one place.

Topics are ROS 2 topic names relative to the namespace (``humans/voices/tracked``); :mod:`app.bus.ros2` makes them
Zenoh keys in either convention (rmw_zenoh's or zenoh-bridge-ros2dds's). Payloads are CDR exactly as ROS 2
serialises them (little-endian, 4-byte encapsulation header), built and read by rosbags' typestore (ROS 2 Jazzy's
definitions, no ROS installation needed), which also gives each type's REP-2011 hash.

ROS4HRI (REP-155) as avhear publishes it (every topic and its type: docs/architecture.md's table): faces, voices
(each voice's ``is_speaking``; with the voices on its ``audio``, the person's stream of :mod:`avcore.separation` as
``audio_common_msgs/AudioData``, 16 kHz mono S16LE chunks in order; with the words its ``speech``), persons (each
person's ``location_confidence``: 1 while seen, then down to 0 over :data:`PERSON_MEMORY_S`, REP-155's "Person
frame" case 2), ``humans/candidate_matches`` and TF frames on ``tf``. Topics REP-155 latches are sent with every
result instead. Where the camera's own frame is known, :data:`RIG_FRAME` is linked to it on ``tf_static``
(:meth:`Topics.rig_link`, sent again every second in place of a latched topic).

avhear's ids: a tracked person ``N`` (:class:`avcore.tracking.NearestTracker`; the results file's ``id``) is the
person ``pN`` with the face ``fN`` (face-guided runs) and the voice ``vN``, matched with confidence 1.0 (the voice is
the sound from that person's place); persons are anonymous (followed, not recognised). A voice out of view (several
microphone pairs: a person of the results without a position, its id from the same numbering) is the person ``pN``
with the voice ``vN`` and no face, its location unknown (``location_confidence`` 0, no person frame), and the frame
``voice_vN`` 1 m along its direction (:data:`UNSEEN_VOICE_RANGE_M`: its distance is unknown). Frames ``person_pN``
(at the face while seen, at the last place while remembered), ``face_fN`` and ``voice_vN`` are children of
:data:`RIG_FRAME`, the scene frame of docs/architecture.md, with identity rotation. Headers carry the result's
capture stamp on the source's clock, the JSON's ``stamp_s``.

Message definitions not in rosbags' ROS 2 Jazzy store are declared here from their sources:

- ``hri_msgs/msg/IdsList`` and ``hri_msgs/msg/IdsMatch``: github.com/ros4hri/hri_msgs, commit dd03e79c0670
  (2023-12-18), ``msg/IdsList.msg`` and ``msg/IdsMatch.msg`` (comments left out; ``Header`` written as
  ``std_msgs/Header``, which is what ROS 2 resolves it to);
- ``audio_common_msgs/msg/AudioData``, ``AudioDataStamped`` and ``AudioInfo``: github.com/ros-drivers/audio_common,
  branch ros2, commit 06c280a79859 (2024-03-07), ``audio_common_msgs/msg/*.msg`` (comments left out), what its
  ``audio_capture`` node publishes (``audio_stamped`` and ``audio_info``, the latter every 5 s);
- ``hri_msgs/msg/LiveSpeech``: github.com/ros4hri/hri_msgs, release 2.0.0 (commit 5d52c81, 2023-11-13),
  ``msg/LiveSpeech.msg`` (comments left out): each voice's ``speech``, incremental words while the person speaks
  and the final words (with their confidence) when the utterance ends (``avhear run --transcribe``);
- ``avhear_msgs/msg/AudioBlock``: avhear's own, for the sensor stream (see its definition below).
"""
from __future__ import annotations

import json
from functools import lru_cache
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from app.bus.drivers import RosTopics
from app.result import voice_id
from avcore.tracking import PERSON_MEMORY_S  # as long as the tracker keeps a person's id

__all__ = [
    "AUDIO_BLOCK", "AUDIO_INFO", "AUDIO_STAMPED", "CAMERA_INFO", "COMPRESSED_IMAGE", "FACE", "IMAGE", "RESULTS_KEY", "RosTopics", "RIG_FRAME", "VOICE", "Topics", "decode", "encode",
    "face_id", "make_header", "person_id", "typestore", "voice_id", "PERSON", "PERSON_MEMORY_S",
]

RIG_FRAME = "avhear_rig"
RESULTS_KEY = "avhear/results"  # the JSON of app.sinks.results_file, one message per result
PERSON, FACE, VOICE = 1, 2, 4  # hri_msgs/IdsMatch id types


IDS_LIST = "hri_msgs/msg/IdsList"
IDS_MATCH = "hri_msgs/msg/IdsMatch"
LIVE_SPEECH = "hri_msgs/msg/LiveSpeech"
AUDIO_BLOCK = "avhear_msgs/msg/AudioBlock"
AUDIO_DATA = "audio_common_msgs/msg/AudioData"
AUDIO_STAMPED = "audio_common_msgs/msg/AudioDataStamped"
AUDIO_INFO = "audio_common_msgs/msg/AudioInfo"
IMAGE = "sensor_msgs/msg/Image"
CAMERA_INFO = "sensor_msgs/msg/CameraInfo"
BOOL = "std_msgs/msg/Bool"
STRING = "std_msgs/msg/String"
FLOAT32 = "std_msgs/msg/Float32"
ROI = "sensor_msgs/msg/RegionOfInterest"
TF = "tf2_msgs/msg/TFMessage"
COMPRESSED_IMAGE = "sensor_msgs/msg/CompressedImage"

_DEFINITIONS = {
    IDS_LIST: "std_msgs/Header header\nstring[] ids\n",
    AUDIO_DATA: "uint8[] data\n",
    LIVE_SPEECH: "std_msgs/Header header\nstring incremental\nstring final\nfloat64 confidence\nstring language\n",
    AUDIO_STAMPED: "std_msgs/Header header\naudio_common_msgs/AudioData audio\n",
    AUDIO_INFO: "uint8 channels\nuint32 sample_rate\nstring sample_format\nuint32 bitrate\nstring coding_format\n",
    IDS_MATCH: ("int8 UNSET=0\nint8 PERSON=1\nint8 FACE=2\nint8 BODY=3\nint8 VOICE=4\n"
                "string id1\nint8 id1_type\nstring id2\nint8 id2_type\nfloat32 confidence\n"),
    # One block of multichannel audio. header.stamp: capture time of the block's first sample; first_sample: its
    # index since the stream started, so that a lost block shows as a jump; samples: interleaved frames of
    # n_channels float32 values in [-1, 1]. audio_common_msgs/AudioDataStamped carries bytes without their
    # format or sample index, so a receiver could neither decode nor detect a gap on its own.
    AUDIO_BLOCK: "std_msgs/Header header\nuint32 samplerate_hz\nuint16 n_channels\nuint64 first_sample\n"
                 "float32[] samples\n",
}


@lru_cache(maxsize=1)
def typestore() -> Any:
    """ROS 2 Jazzy's message types plus the definitions above."""
    store = get_typestore(Stores.ROS2_JAZZY)
    for name, text in _DEFINITIONS.items():
        store.register(get_types_from_msg(text, name))
    return store


def encode(message: Any, typename: str) -> bytes:
    """CDR bytes, little-endian, with the encapsulation header, as ROS 2 publishes them."""
    return bytes(typestore().serialize_cdr(message, typename))


def decode(payload: bytes, typename: str) -> Any:
    """The message of CDR bytes; raises ValueError when they do not decode as ``typename``."""
    try:
        return typestore().deserialize_cdr(payload, typename)
    except Exception as exc:  # noqa: BLE001 - rosbags raises several types for bad bytes
        raise ValueError(f"a {typename} payload of {len(payload)} bytes does not decode: {exc}") from exc


def make_header(stamp_s: float, frame_id: str = RIG_FRAME) -> Any:
    """A std_msgs/Header stamped ``stamp_s`` (seconds on the source's clock)."""
    t = typestore().types
    sec = int(np.floor(stamp_s))
    nanosec = min(int(round((stamp_s - sec) * 1e9)), 999_999_999)
    return t["std_msgs/msg/Header"](stamp=t["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec),
                                    frame_id=frame_id)


def person_id(person: int) -> str:
    return f"p{int(person)}"


def face_id(person: int) -> str:
    return f"f{int(person)}"


# a voice out of view has a direction and no distance: its voice_<id> frame is put this far along its ray, a unit
# distance that says "direction only" (REP-155 gives voices no distance field)
UNSEEN_VOICE_RANGE_M = 1.0


class Topics:
    """Builds the messages of one result: (topic relative to the namespace, ROS type, payload); the JSON line of the
    results file goes on :data:`RESULTS_KEY` with the type None (it is not a ROS message). Stateful: it remembers
    the persons no longer seen for :data:`PERSON_MEMORY_S` (one instance per stream of results)."""

    def __init__(self, memory_s: float = PERSON_MEMORY_S) -> None:
        self._t = typestore().types
        self.memory_s = float(memory_s)
        self._last_seen: dict[int, tuple[float, list[float], bool]] = {}  # id -> (stamp, position, has a face)

    def _transform(self, header: Any, child: str, xyz: list[float]) -> Any:
        t = self._t
        return t["geometry_msgs/msg/TransformStamped"](
            header=header, child_frame_id=child,
            transform=t["geometry_msgs/msg/Transform"](
                translation=t["geometry_msgs/msg/Vector3"](x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2])),
                rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)))

    def rig_link(self, stamp_s: float, camera_frame: str, rig_in_camera_m: tuple[float, float, float]
                 ) -> tuple[str, str, bytes]:
        """The static transform from the camera's optical frame (REP-103's x right, y down, z forward, as the scene
        frame's axes) to :data:`RIG_FRAME`, whose origin is ``rig_in_camera_m`` in it (the cyclopean point half a
        baseline to the right of a stereo rig's left camera; the camera itself for an RGB-D camera)."""
        header = make_header(stamp_s, camera_frame)
        transform = self._transform(header, RIG_FRAME, list(rig_in_camera_m))
        return "tf_static", TF, encode(self._t[TF](transforms=[transform]), TF)

    def voice_audio(self, person_id: int, samples: np.ndarray) -> tuple[str, str, bytes]:
        """A chunk of person ``person_id``'s voice (float samples in [-1, 1], 16 kHz) on its voice's ``audio``."""
        pcm = np.clip(np.round(np.asarray(samples, dtype=np.float64) * 32767.0), -32768, 32767).astype("<i2")
        message = self._t[AUDIO_DATA](data=np.frombuffer(pcm.tobytes(), dtype=np.uint8))
        return f"humans/voices/{voice_id(person_id)}/audio", AUDIO_DATA, encode(message, AUDIO_DATA)

    def speech(self, stamp_s: float, person_id: int, text: str, final: bool, confidence: float | None
               ) -> tuple[str, str, bytes]:
        """Person ``person_id``'s words on its voice's ``speech`` (hri_msgs/LiveSpeech, US English): ``incremental``
        while they speak, ``final`` with its confidence when the utterance ends; stamped at ``stamp_s``."""
        message = self._t[LIVE_SPEECH](header=make_header(stamp_s), incremental="" if final else text,
                                       final=text if final else "", confidence=float(confidence or 0.0),
                                       language="en-US")
        return f"humans/voices/{voice_id(person_id)}/speech", LIVE_SPEECH, encode(message, LIVE_SPEECH)

    def messages(self, record: dict[str, Any]) -> list[tuple[str, str | None, bytes]]:
        """Every message of one result, given as its :meth:`app.result.Result.as_dict`."""
        t = self._t
        header = make_header(record["stamp_s"])
        people = [p for p in record["people"] if p["position_m"] is not None]
        heard = [p for p in record["people"] if p["position_m"] is None]  # out of view: a direction, no face
        face = record["mode"] == "face"
        out: list[tuple[str, str | None, bytes]] = []

        def add(topic: str, typename: str, message: Any) -> None:
            out.append((topic, typename, encode(message, typename)))

        voices = [voice_id(p["id"]) for p in people]
        unseen = [voice_id(v["id"]) for v in heard]
        add("humans/voices/tracked", IDS_LIST, t[IDS_LIST](header=header, ids=voices + unseen))
        for p, vid in zip(people, voices):
            add(f"humans/voices/{vid}/is_speaking", BOOL, t[BOOL](data=bool(p["speaking"])))
        transforms = [self._transform(header, f"voice_{vid}", p["position_m"]) for p, vid in zip(people, voices)]
        for v, vid in zip(heard, unseen):  # heard now: speaking; its frame on its ray, at an unknown distance
            add(f"humans/voices/{vid}/is_speaking", BOOL, t[BOOL](data=True))
            az = np.radians(v["azimuth_deg"])
            transforms.append(self._transform(header, f"voice_{vid}", [UNSEEN_VOICE_RANGE_M * np.sin(az), 0.0,
                                                                        UNSEEN_VOICE_RANGE_M * np.cos(az)]))
        if face:
            faces = [face_id(p["id"]) for p in people]
            add("humans/faces/tracked", IDS_LIST, t[IDS_LIST](header=header, ids=faces))
            for p, fid, vid in zip(people, faces, voices):
                x, y, w, h = (max(int(v), 0) for v in p["box_px"])
                add(f"humans/faces/{fid}/roi", ROI,  # a box in the rectified image
                    t[ROI](x_offset=x, y_offset=y, height=h, width=w, do_rectify=False))
                if p.get("lip_activity") is not None:  # with the lips read: the face's visual speech evidence
                    add(f"humans/faces/{fid}/lip_activity", FLOAT32, t[FLOAT32](data=float(p["lip_activity"])))
                add("humans/candidate_matches", IDS_MATCH,
                    t[IDS_MATCH](id1=fid, id1_type=FACE, id2=vid, id2_type=VOICE, confidence=1.0))
                transforms.append(self._transform(header, f"face_{fid}", p["position_m"]))
        transforms += self._persons(float(record["stamp_s"]), face, people, heard, add, header)
        add("tf", TF, t[TF](transforms=transforms))
        out.append((RESULTS_KEY, None, json.dumps(record, separators=(",", ":")).encode()))
        return out

    def _persons(self, stamp: float, face: bool, people: list[dict[str, Any]], heard: list[dict[str, Any]],
                 add: Any, header: Any) -> list[Any]:
        """The persons' messages (module docstring): the people in view and remembered, then the voices out of
        view (a person with a voice only, its location unknown: confidence 0, no frame); returns the TF
        transforms."""
        t = self._t
        for p in people:
            self._last_seen[int(p["id"])] = (stamp, list(p["position_m"]), face)
        confidence = {n: 1.0 - max(stamp - seen, 0.0) / self.memory_s for n, (seen, _, _) in self._last_seen.items()}
        self._last_seen = {n: v for n, v in self._last_seen.items() if confidence[n] > 0}
        now = [int(p["id"]) for p in people]
        voiced = [int(p["id"]) for p in heard]
        add("humans/persons/tracked", IDS_LIST, t[IDS_LIST](header=header, ids=[person_id(n) for n in now + voiced]))
        add("humans/persons/known", IDS_LIST, t[IDS_LIST](header=header,
                                                           ids=[person_id(n) for n in sorted(self._last_seen)] +
                                                           [person_id(n) for n in voiced]))
        for n in voiced:
            pid = person_id(n)
            add(f"humans/persons/{pid}/anonymous", BOOL, t[BOOL](data=True))
            add(f"humans/persons/{pid}/voice_id", STRING, t[STRING](data=voice_id(n)))
            add(f"humans/persons/{pid}/location_confidence", FLOAT32, t[FLOAT32](data=0.0))
            add("humans/candidate_matches", IDS_MATCH,
                t[IDS_MATCH](id1=pid, id1_type=PERSON, id2=voice_id(n), id2_type=VOICE, confidence=1.0))
        transforms = []
        for n in sorted(self._last_seen):
            _, position, has_face = self._last_seen[n]
            pid, c = person_id(n), (1.0 if n in now else confidence[n])
            add(f"humans/persons/{pid}/anonymous", BOOL, t[BOOL](data=True))
            add(f"humans/persons/{pid}/voice_id", STRING, t[STRING](data=voice_id(n)))
            add(f"humans/persons/{pid}/location_confidence", FLOAT32, t[FLOAT32](data=float(c)))
            if has_face:
                add(f"humans/persons/{pid}/face_id", STRING, t[STRING](data=face_id(n)))
            if n in now:
                add("humans/candidate_matches", IDS_MATCH,
                    t[IDS_MATCH](id1=pid, id1_type=PERSON, id2=voice_id(n), id2_type=VOICE, confidence=1.0))
                if has_face:
                    add("humans/candidate_matches", IDS_MATCH,
                        t[IDS_MATCH](id1=pid, id1_type=PERSON, id2=face_id(n), id2_type=FACE, confidence=1.0))
            transforms.append(self._transform(header, f"person_{pid}", position))
        return transforms
