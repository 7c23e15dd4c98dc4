"""The lips' cue in the application: --read-lips runs the face mesh on every face, each person carries a lip
activity to the results file, and a face the ITDs call speaking whose lips are still is not speaking."""
from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest

from app.cli import main
from app.hearing import FaceGuided, Vision
from app.pipeline import PipelineConfig
from avcore.geometry import MicArray, MicPair
from avcore.mixture import Mixture1D


def _needs_the_face_mesh() -> None:
    """Skip, saying how to install it, when the face mesh's model is not installed."""
    from app.errors import UserError
    from app.models import facemesh_model

    try:
        facemesh_model()
    except UserError as exc:
        pytest.skip(str(exc))


@dataclass(frozen=True)
class _Output:  # the fields of FaceGuidedOutput the veto, the own ITDs and the bins' spill read and replace
    speaking: np.ndarray
    probability: np.ndarray
    rescued: np.ndarray | None = None
    bin_share: np.ndarray | None = None


class _Hearing:
    array = MicArray.from_pair(MicPair())  # one pair: no voice out of view is looked for

    def __init__(self, speaking: tuple[bool, ...] = (True, True, False)) -> None:
        self.speaking = np.array(speaking)

    def step(self, *args: object, **options: object) -> _Output:
        return _Output(self.speaking.copy(), np.array([0.9, 0.8, 0.1]))


def test_still_lips_silence_a_face_the_itds_call_speaking(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("app.models.facemesh_model", lambda: Path(__file__))  # no mesh runs in this test
    monkeypatch.setattr("avcore.facemesh.FaceMesh.__post_init__", lambda self: None)
    mode = FaceGuided(PipelineConfig(lips=True, lip_still_below=0.012, lip_earn_trust=False))
    apart = np.array([[-0.8, 0.0, 2.0], [0.0, 0.0, 2.0], [0.8, 0.0, 2.0]])  # directions the ITDs tell apart
    vision = Vision(1.0, None, np.zeros((3, 4)), apart, np.array([0.004, 0.05, 0.004]))
    out = mode.step(_Hearing(), vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    assert out.speaking.tolist() == [False, True, False]
    assert out.probability.tolist() == [0.5, 0.8, 0.1]
    # earning trust (the default): lips never seen moving with their own voice say nothing yet
    trusting = FaceGuided(PipelineConfig(lips=True, lip_still_below=0.012))
    out = trusting.step(_Hearing(), vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    assert out.speaking.tolist() == [True, True, False]
    # face 0 heard alone for a second with its lips moving: trusted; then its still lips silence the spill on it
    vision_ids = np.array([0, 1, 2])
    for t in np.arange(0.0, 1.06, 0.05):
        moving = Vision(float(t), None, np.zeros((3, 4)), apart, np.array([0.05, 0.004, 0.004]), lip_ids=vision_ids)
        trusting.step(_Hearing((True, False, False)), moving, np.zeros((0, 1)), np.zeros(0),
                      lambda: (None, None, None))
    still = Vision(1.2, None, np.zeros((3, 4)), apart, np.array([0.004, 0.05, 0.004]), lip_ids=vision_ids)
    out = trusting.step(_Hearing(), still, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    assert out.speaking.tolist() == [False, True, False]
    # without the cue the hearing's answer stands
    plain = FaceGuided(PipelineConfig()).step(_Hearing(), Vision(1.0, None, np.zeros((3, 4)), np.zeros((3, 3))),
                                              np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    assert plain.speaking.tolist() == [True, True, False]


def test_lips_still_through_a_second_of_their_own_voice_give_no_opinion(monkeypatch: pytest.MonkeyPatch) -> None:
    """A hand over a talker's mouth: the mesh reads a closed mouth jittering about the veto's threshold while the
    ITDs keep calling the face speaking, alone. The veto holds for a moment (a listener's brief false alarm looks the
    same) and lets go once the face has been heard for a second with near-still lips; the faces beside it, not
    heard, stay silent whatever their lips do, and a listener heard for 0.4 s is still vetoed."""
    monkeypatch.setattr("app.models.facemesh_model", lambda: Path(__file__))
    monkeypatch.setattr("avcore.facemesh.FaceMesh.__post_init__", lambda self: None)
    mode = FaceGuided(PipelineConfig(lips=True, lip_still_below=0.012, lip_earn_trust=False))
    apart = np.array([[-0.8, 0.0, 2.0], [0.0, 0.0, 2.0], [0.8, 0.0, 2.0]])
    said = []
    for k, t in enumerate(np.arange(0.0, 1.6, 1 / 30)):
        hand = 0.009 + 0.002 * (k % 2)  # just under the threshold, as a hand's mesh reads
        vision = Vision(float(t), None, np.zeros((3, 4)), apart, np.array([hand, 0.05, 0.004]), None,
                        np.array([7, 8, 9]))
        out = mode.step(_Hearing((True, False, False)), vision, np.zeros((0, 1)), np.zeros(0),
                        lambda: (None, None, None))
        said.append(out.speaking)
    said = np.array(said)
    t = np.arange(0.0, 1.6, 1 / 30)
    assert not said[(t > 0.1) & (t < 0.95), 0].any() and said[t > 1.05, 0].all()
    assert not said[:, 1:].any()  # moving lips alone make no speaker
    # a listener heard for 0.4 s with still lips: vetoed throughout
    fresh = FaceGuided(PipelineConfig(lips=True, lip_still_below=0.012, lip_earn_trust=False))
    for t in np.arange(0.0, 0.4, 1 / 30):
        vision = Vision(float(t), None, np.zeros((3, 4)), apart, np.array([0.004, 0.05, 0.004]), None,
                        np.array([1, 2, 3]))
        out = fresh.step(_Hearing(), vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
        assert out.speaking.tolist() == [False, True, False]


def test_a_hand_over_a_lone_talkers_mouth_gives_no_opinion_at_once_while_a_voice_is_heard(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The hand from the number's first moment: the one face heard, the sound loud through the result's time frame
    and no lips in view moving, the still lips say nothing (it speaks at once, not after a second). Lips moving in
    view, a clap's short sound, or a frame that ends before the voice (``--latency low``) keep the veto."""
    monkeypatch.setattr("app.models.facemesh_model", lambda: Path(__file__))
    monkeypatch.setattr("avcore.facemesh.FaceMesh.__post_init__", lambda self: None)
    apart = np.array([[-0.8, 0.0, 2.0], [0.0, 0.0, 2.0], [0.8, 0.0, 2.0]])
    frames = np.arange(0.005, 2.0, 0.01)

    def said(loud: tuple[float, float], others: float, latency: str = "default") -> np.ndarray:
        mode = FaceGuided(PipelineConfig(lips=True, lip_still_below=0.012, latency=latency,
                                         lip_earn_trust=False))
        assert mode.envelope is not None
        mode.envelope.push(frames, np.where((frames > loud[0]) & (frames < loud[1]), 1e-3, 1e-6))
        out = []
        for k, t in enumerate(np.arange(1.0, 1.5, 1 / 30)):
            hand = 0.009 + 0.002 * (k % 2)
            vision = Vision(float(t), None, np.zeros((3, 4)), apart, np.array([hand, others, 0.004]), None,
                            np.array([7, 8, 9]))
            out.append(mode.step(_Hearing((True, False, False)), vision, np.zeros((0, 1)), np.zeros(0),
                                 lambda: (None, None, None)).speaking)
        return np.array(out)

    assert said((1.0, 1.6), 0.004)[:, 0].all() and not said((1.0, 1.6), 0.004)[:, 1:].any()
    assert not said((1.0, 1.6), 0.05)[:, 0].any()  # another face's lips move: they may be the talker's
    assert not said((1.2, 1.28), 0.004)[:, 0].any()  # a clap: loud for a fifth of the frame
    low = said((1.0, 1.6), 0.004, latency="low")[:, 0]  # the frame is the 0.4 s before each result
    assert not low[0] and low[-1]


@dataclass(frozen=True)
class _GroupOutput:  # the fields of FaceGuidedOutput that follow each face
    speaking: np.ndarray
    probability: np.ndarray
    itd_means: np.ndarray
    itd_counts: np.ndarray
    pair_itd_means: np.ndarray
    model: Mixture1D
    rescued: np.ndarray | None = None
    bin_share: np.ndarray | None = None


class _EveryoneSpeaks:
    array = MicArray.from_pair(MicPair())

    def __init__(self) -> None:
        self.heard: list[np.ndarray] = []

    def step(self, xyz: np.ndarray, *args: object, **options: object) -> _GroupOutput:
        self.heard.append(xyz)
        n = len(xyz)
        model = Mixture1D(np.full(n + 1, 1 / (n + 1)), np.arange(n) * 1e-4, np.full(n, 1e-9), (-8e-4, 8e-4))
        return _GroupOutput(np.ones(n, bool), np.full(n, 0.9), np.arange(n) * 1e-4, np.full(n, 5.0),
                            np.arange(n)[:, None] * 1e-4, model, np.arange(n) == 1)


def test_faces_in_one_direction_are_heard_as_one_whose_words_go_to_the_moving_lips(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr("app.models.facemesh_model", lambda: Path(__file__))
    monkeypatch.setattr("avcore.facemesh.FaceMesh.__post_init__", lambda self: None)
    mode = FaceGuided(PipelineConfig(lips=True, lip_earn_trust=False))
    # one behind the other on one ray from the microphones (the same ITD), and a third 0.8 m to the left
    xyz = np.array([[0.3, 0.0, 1.3], [0.6, 0.0, 2.6], [-0.8, 0.0, 2.0]])
    hearing = _EveryoneSpeaks()
    lips = np.array([0.02, 0.02, 0.02])  # no still lips: the absolute veto stays out of this
    vision = Vision(1.0, None, np.zeros((3, 4)), xyz, lips, np.array([0.1, 0.9, 0.5]))
    out = mode.step(hearing, vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    np.testing.assert_array_equal(hearing.heard[0], xyz[[0, 2]])  # the group heard from its nearest face
    assert out.speaking.tolist() == [False, True, True]  # the far face's lips move: the words are its
    assert out.probability.tolist() == [0.5, 0.9, 0.9]
    assert out.itd_means.tolist() == [0.0, 0.0, 1e-4] and out.pair_itd_means.shape == (3, 1)
    assert out.rescued.tolist() == [False, False, True]  # each face takes its object's: the third's was rescued
    # the model too, one component a face (what the console draws), the group's weight shared by its faces
    assert out.model.means.tolist() == [0.0, 0.0, 1e-4]
    np.testing.assert_allclose(out.model.weights, [1 / 6, 1 / 6, 1 / 3, 1 / 3])
    both = Vision(1.0, None, np.zeros((3, 4)), xyz, lips, np.array([0.7, 0.9, 0.5]))
    assert mode.step(hearing, both, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None)).speaking.all()
    # a still mouth in a group is not vetoed on its own: the sound says one of the group speaks
    still = Vision(1.0, None, np.zeros((3, 4)), xyz, np.array([0.004, 0.004, 0.02]), np.array([0.9, 0.1, 0.5]))
    out = mode.step(hearing, still, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    assert out.speaking.tolist() == [True, False, True]
    # a frame without faces: nothing to group, nobody to decide
    empty = Vision(1.0, None, np.zeros((0, 4)), np.zeros((0, 3)), np.zeros(0), np.zeros(0))
    assert mode.step(hearing, empty, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None)).speaking.size == 0


def test_faces_in_one_direction_are_heard_apart_until_their_lips_earn_trust(monkeypatch: pytest.MonkeyPatch) -> None:
    """Earning trust (the default): two faces on one ray whose lips have not shown they move with their voice (a
    photograph's mesh jitters) are heard each on its own, as without the lips, so the jitter never hands one's
    words to the other; once both are trusted they are one object whose words go to the moving lips."""
    monkeypatch.setattr("app.models.facemesh_model", lambda: Path(__file__))
    monkeypatch.setattr("avcore.facemesh.FaceMesh.__post_init__", lambda self: None)
    mode = FaceGuided(PipelineConfig(lips=True))
    xyz = np.array([[0.3, 0.0, 1.3], [0.6, 0.0, 2.6], [-0.8, 0.0, 2.0]])
    hearing = _EveryoneSpeaks()
    lips = np.array([0.02, 0.02, 0.02])
    vision = Vision(1.0, None, np.zeros((3, 4)), xyz, lips, np.array([0.1, 0.9, 0.5]))
    out = mode.step(hearing, vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    np.testing.assert_array_equal(hearing.heard[-1], xyz)  # three objects: nobody's lips chose
    assert out.speaking.tolist() == [True, True, True]
    hidden = mode._lips.hidden
    for face in (0, 1):  # each heard alone for a second, its lips moving
        for t in np.arange(2.0 + 2 * face, 3.12 + 2 * face, 0.05):
            hidden.update(float(t), np.arange(3), np.arange(3) == face, np.array([0.08, 0.08, 0.08]), 0.012)
    assert hidden.trusted(np.arange(3)).tolist() == [True, True, False]
    out = mode.step(hearing, replace(vision, stamp_s=6.0), np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    np.testing.assert_array_equal(hearing.heard[-1], xyz[[0, 2]])  # the trusted pair heard as one
    assert out.speaking.tolist() == [False, True, True]  # the far face's lips move: the words are its


def test_read_lips_puts_each_persons_lip_activity_in_the_results(tmp_path: Path) -> None:
    pytest.importorskip("pyroomacoustics")
    _needs_the_face_mesh()
    out = tmp_path / "r.jsonl"
    # the lips are read by default where the face mesh is installed; --no-read-lips turns them off
    assert main(["demo", "--duration", "2", "--fast", "--headless", "--results-jsonl", str(out)]) == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    values = [p["lip_activity"] for r in rows for p in r["people"]]
    assert all("lip_activity" in p for r in rows for p in r["people"])
    assert values[0] is None  # no opinion until a face has been seen for a while
    assert sum(v is not None for v in values) > 0.5 * len(values)
    assert all(v is None or 0.0 <= v < 1.0 for v in values)
    plain = tmp_path / "plain.jsonl"
    assert main(["demo", "--duration", "1", "--fast", "--headless", "--no-read-lips", "--results-jsonl",
                 str(plain)]) == 0
    assert not any("lip_activity" in p for line in plain.read_text().splitlines() for p in json.loads(line)["people"])


@dataclass(frozen=True)
class _MotionOutput:  # the fields of MotionGuidedOutput the veto reads and replaces
    positions: np.ndarray
    speaking: np.ndarray
    probability: np.ndarray


class _MotionHearing:
    """Algorithm 1's people: three bodies, the first two heard speaking."""

    def step(self, *args: object) -> _MotionOutput:
        return _MotionOutput(np.array([[-0.8, 0.3, 2.0], [0.0, 0.35, 2.5], [0.8, 0.3, 2.0]]),
                             np.array([True, True, False]), np.array([0.9, 0.8, 0.1]))


def test_faces_go_to_the_bodies_below_them_one_for_one() -> None:
    from app.hearing import faces_of_people

    people = np.array([[-0.8, 0.3, 2.0], [0.0, 0.35, 2.5], [0.8, 0.3, 2.0]])
    faces = np.array([[0.05, -0.2, 2.6], [-0.75, -0.3, 2.1], [2.0, -0.2, 2.0], [0.3, -0.2, 2.5]])
    # a face half a metre above a body and 11 cm from it horizontally is its face; a body within reach of two faces
    # takes the closer; a face past within_m is nobody's; one face goes to one body, the closer
    assert faces_of_people(people, faces, 0.35).tolist() == [1, 0, -1]
    assert faces_of_people(people, faces[[3, 0]], 0.35).tolist() == [-1, 1, -1]
    assert faces_of_people(people[[1, 1]] + [[0.0, 0, 0], [0.3, 0, 0]], faces[[3]], 0.35).tolist() == [-1, 0]
    assert faces_of_people(people, faces, 0.1).tolist() == [-1, -1, -1]
    assert faces_of_people(people, np.zeros((0, 3)), 0.35).tolist() == [-1, -1, -1]
    assert faces_of_people(np.zeros((0, 3)), faces, 0.35).tolist() == []
    assert faces_of_people(people, np.array([[np.nan, 0.0, 2.0]]), 0.35).tolist() == [-1, -1, -1]


def test_algorithm_1_silences_a_person_whose_face_s_lips_are_still(monkeypatch: pytest.MonkeyPatch) -> None:
    from app.hearing import MotionGuided

    monkeypatch.setattr("app.models.facemesh_model", lambda: Path(__file__))  # no mesh runs in this test
    monkeypatch.setattr("avcore.facemesh.FaceMesh.__post_init__", lambda self: None)
    mode = MotionGuided(PipelineConfig(inference="motion", lips=True, lip_still_below=0.012,
                                      lip_earn_trust=False))
    faces = np.array([[-0.8, -0.2, 2.0], [0.05, -0.2, 2.5]])  # above the first two bodies
    for still, expected in ((0.004, [False, True, False]), (0.05, [True, True, False])):
        vision = Vision(1.0, None, None, np.zeros((0, 3)), np.array([still, 0.05]), None, np.array([7, 8]), faces)
        out = mode.step(_MotionHearing(), vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
        assert out.speaking.tolist() == expected
        np.testing.assert_allclose(mode.people_lips(vision, out), [still, 0.05, np.nan])
    # a body with no face above it keeps the hearing's answer; so does every body without faces in the interval
    vision = Vision(2.0, None, None, np.zeros((0, 3)), np.array([0.004]), None, np.array([9]), faces[[1]])
    out = mode.step(_MotionHearing(), vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    assert out.speaking.tolist() == [True, False, False]  # the still lips are the second body's now
    vision = Vision(3.0, None, None, np.zeros((0, 3)))
    out = mode.step(_MotionHearing(), vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
    assert out.speaking.tolist() == [True, True, False] and mode.people_lips(vision, out) is None


def test_read_lips_with_motion_gives_each_person_their_face_s_lips(tmp_path: Path) -> None:
    _needs_the_face_mesh()
    out = tmp_path / "r.jsonl"
    assert main(["demo", "--duration", "3", "--fast", "--headless", "--motion", "--read-lips",
                 "--results-jsonl", str(out)]) == 0
    rows = [json.loads(line) for line in out.read_text().splitlines()]
    values = [p["lip_activity"] for r in rows for p in r["people"]]
    assert rows and all("lip_activity" in p for r in rows for p in r["people"])
    assert sum(v is not None for v in values) > 0.5 * len(values)  # most people have a face above them
    assert all(v is None or 0.0 <= v < 1.0 for v in values)


def test_moving_mouths_are_the_simulated_rooms(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    assert main(["run", "--source", f"replay:{tmp_path}", "--lips", "--headless"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--lips" in err[0] and "real ones" in err[0]


@pytest.mark.parametrize("bad", [0.0, -0.01, 1.0, float("nan")])
def test_the_still_lips_threshold_is_checked(bad: float) -> None:
    with pytest.raises(ValueError, match="lip_still_below"):
        PipelineConfig(lip_still_below=bad)
    with pytest.raises(ValueError, match="^lip_face_within_m must be a horizontal distance in"):
        PipelineConfig(lip_face_within_m=bad if bad != 1.0 else 2.0)


@pytest.mark.parametrize(("name", "bad"), [("lip_same_direction_s", -1e-6), ("lip_same_direction_s", 1e-3),
                                           ("lip_same_direction_s", float("nan")), ("lip_both_above", 0.0),
                                           ("lip_both_above", 1.5), ("lip_synced_s", 0.0),
                                           ("lip_synced_s", 4.0), ("lip_synced_s", float("nan"))])
def test_the_same_direction_settings_are_checked(name: str, bad: float) -> None:
    with pytest.raises(ValueError, match=name):
        PipelineConfig(**{name: bad})


def test_a_missing_face_mesh_is_one_line_before_any_preparation(monkeypatch: pytest.MonkeyPatch,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setenv("AVHEAR_FACEMESH", "/nonexistent/face_landmark.tflite")
    assert main(["demo", "--duration", "2", "--headless", "--read-lips"]) == 2
    captured = capsys.readouterr()
    assert captured.err.strip().splitlines() == ["avhear: error: AVHEAR_FACEMESH=/nonexistent/face_landmark.tflite: "
                                                 "no such file; give the path of face_landmark.tflite"]
    assert "preparing" not in captured.out + captured.err  # refused before the simulated room is made


@pytest.mark.parametrize("earned", [True, False], ids=["trusted lips", "lips yet to earn trust"])
def test_a_face_whose_lips_move_with_the_sound_speaks_beside_the_one_heard(monkeypatch: pytest.MonkeyPatch,
                                                                           earned: bool) -> None:
    """Two talking at once, the direction giving the words to one: the other face, with some ITD support and lips
    that open with the sound 75 ms before it, speaks too; the same lips out of step with the sound do not; nor do
    lips that have not yet moved with their own voice (new faces, where trust is to be earned: no opinion)."""
    monkeypatch.setattr("app.models.facemesh_model", lambda: Path(__file__))
    monkeypatch.setattr("avcore.facemesh.FaceMesh.__post_init__", lambda self: None)
    mode = FaceGuided(PipelineConfig(lips=True, lip_earn_trust=not earned))  # without earning: every face trusted
    assert mode.envelope is not None and FaceGuided(PipelineConfig()).envelope is None
    frames = np.arange(0.005, 3.0, 0.01)
    mode.envelope.push(frames, 1e-3 * (0.05 + 0.5 + 0.5 * np.sin(2 * np.pi * 4.0 * frames)) ** 2)
    video = np.arange(2.4, 3.0, 1 / 30)
    with_sound = np.stack([video, 0.2 + 0.1 * np.sin(2 * np.pi * 4.0 * (video + 0.075))], axis=1)
    against = np.stack([video, 0.2 - 0.1 * np.sin(2 * np.pi * 4.0 * (video + 0.075))], axis=1)
    apart = np.array([[-0.8, 0.0, 2.0], [0.0, 0.0, 2.0], [0.8, 0.0, 2.0]])
    lips, relative = np.array([0.06, 0.07, 0.004]), np.array([0.9, 0.8, 0.0])

    def step(series: list[np.ndarray]) -> np.ndarray:
        vision = Vision(2.95, None, np.zeros((3, 4)), apart, lips, relative, np.array([1, 2, 3]), lip_series=series)
        hearing = _Hearing((True, False, False))  # the second face's probability: 0.8, its ITDs agree
        return mode.step(hearing, vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None)).speaking

    assert step([with_sound, with_sound, against]).tolist() == [True, earned, False]
    assert step([with_sound, against, against]).tolist() == [True, False, False]


@dataclass(frozen=True)
class _RescuedOutput:
    speaking: np.ndarray
    probability: np.ndarray
    rescued: np.ndarray
    bin_share: np.ndarray | None = None


def test_lips_that_move_with_the_sound_make_a_rescued_call_one_that_may_start_speech(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The second face is called by the speaking test's later looks alone (rescued): with lips that open with the
    sound it is no longer a rescue (the continuity will not drop it); with lips out of step it still is."""
    monkeypatch.setattr("app.models.facemesh_model", lambda: Path(__file__))
    monkeypatch.setattr("avcore.facemesh.FaceMesh.__post_init__", lambda self: None)
    mode = FaceGuided(PipelineConfig(lips=True))
    frames = np.arange(0.005, 3.0, 0.01)
    mode.envelope.push(frames, 1e-3 * (0.05 + 0.5 + 0.5 * np.sin(2 * np.pi * 4.0 * frames)) ** 2)
    video = np.arange(2.4, 3.0, 1 / 30)
    with_sound = np.stack([video, 0.2 + 0.1 * np.sin(2 * np.pi * 4.0 * (video + 0.075))], axis=1)
    against = np.stack([video, 0.2 - 0.1 * np.sin(2 * np.pi * 4.0 * (video + 0.075))], axis=1)
    apart = np.array([[-0.8, 0.0, 2.0], [0.8, 0.0, 2.0]])

    class Rescuing:
        array = MicArray.from_pair(MicPair())

        def step(self, *args: object, **options: object) -> _RescuedOutput:
            return _RescuedOutput(np.array([True, True]), np.array([0.9, 0.7]), np.array([False, True]))

    def rescued(series: list[np.ndarray]) -> list[bool]:
        vision = Vision(2.95, None, np.zeros((2, 4)), apart, np.array([0.06, 0.07]), np.array([0.9, 0.8]),
                        np.array([1, 2]), lip_series=series)
        out = mode.step(Rescuing(), vision, np.zeros((0, 1)), np.zeros(0), lambda: (None, None, None))
        assert out.speaking.tolist() == [True, True]
        return out.rescued.tolist()

    assert rescued([with_sound, with_sound]) == [False, False]
    assert rescued([with_sound, against]) == [False, True]


def test_the_pipeline_feeds_the_lips_the_sound_it_hears(monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("pyroomacoustics")
    from avcore.lips import SoundEnvelope

    _needs_the_face_mesh()
    heard: list[tuple[np.ndarray, np.ndarray]] = []
    push = SoundEnvelope.push
    monkeypatch.setattr(SoundEnvelope, "push", lambda self, t, p: (heard.append((t, p)), push(self, t, p))[1])
    assert main(["demo", "--duration", "2", "--fast", "--headless", "--read-lips"]) == 0
    times = np.concatenate([t for t, _ in heard])
    powers = np.concatenate([p for _, p in heard])
    assert np.all(np.diff(times) > 0) and times[0] < 0.1 and times[-1] > 1.9  # the whole run, in order
    np.testing.assert_allclose(np.diff(times)[:-1], 0.01, atol=1.5e-3)  # every 10 ms or so (the last block short)
    assert powers.min() >= 0 and powers.max() > 1e-6  # the room's speech is heard


def test_the_console_draws_faces_heard_as_one(tmp_path: Path) -> None:
    """S6: one face behind the other, heard as one object; the console still gets one Gaussian a face."""
    pytest.importorskip("pyroomacoustics")
    _needs_the_face_mesh()
    rrd = tmp_path / "s6.rrd"
    assert main(["run", "--source", "sim:S6", "--duration", "3", "--lips", "--read-lips", "--fast",
                 "--save", str(rrd)]) == 0
    assert rrd.stat().st_size > 0


def test_one_camera_reading_the_lips_places_faces_by_the_meshs_eyes_with_one_mesh_a_frame(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """With one camera and --read-lips the mesh runs once a frame: its eyes place the faces, its lips are read."""
    from app.events import StereoFrame
    from avcore.blazeface import FaceDetections
    from avcore.facemesh import (LEFT_EYE_CORNERS, LIP_CORNERS, LIP_INNER_LOWER, LIP_INNER_UPPER, N_LANDMARKS,
                                 RIGHT_EYE_CORNERS, FaceMeshResult)
    from sim.render import default_scene

    monkeypatch.setattr("app.models.facemesh_model", lambda: Path(__file__))
    monkeypatch.setattr("avcore.facemesh.FaceMesh.__post_init__", lambda self: None)
    runs = []

    def run(self: object, image: np.ndarray, boxes: np.ndarray, eyes: np.ndarray | None = None) -> FaceMeshResult:
        runs.append(len(boxes))
        marks = np.zeros((len(boxes), N_LANDMARKS, 3))
        for i, (x, y, w, _) in enumerate(boxes):  # eyes 0.5 of the box apart (the detector says 0.25)
            marks[i, list(RIGHT_EYE_CORNERS), :2] = [x + 0.2 * w, y + 0.4 * w], [x + 0.3 * w, y + 0.4 * w]
            marks[i, list(LEFT_EYE_CORNERS), :2] = [x + 0.7 * w, y + 0.4 * w], [x + 0.8 * w, y + 0.4 * w]
            marks[i, [LIP_CORNERS[0], LIP_CORNERS[1]], :2] = [x + 0.3 * w, y + 0.8 * w], [x + 0.7 * w, y + 0.8 * w]
            marks[i, [LIP_INNER_UPPER, LIP_INNER_LOWER], :2] = [x + 0.5 * w, y + 0.78 * w], [x + 0.5 * w, y + 0.82 * w]
        return FaceMeshResult(marks, np.ones(len(boxes)))

    monkeypatch.setattr("avcore.facemesh.FaceMesh.run", run)
    boxes = np.array([[100.0, 100.0, 40.0, 40.0], [400.0, 100.0, 40.0, 40.0]])
    keypoints = np.zeros((2, 6, 2))
    keypoints[:, 0], keypoints[:, 1] = boxes[:, :2] + [15.0, 16.0], boxes[:, :2] + [25.0, 16.0]

    class _Finder:
        def detect_faces(self, image: np.ndarray) -> FaceDetections:
            return FaceDetections(boxes.copy(), keypoints.copy(), np.ones(2))

    scene = default_scene()
    image = scene.render(0.0).left
    frame = StereoFrame(0, 0.0, image, None, 0.0)
    mode = FaceGuided(PipelineConfig(lips=True))
    with_lips = mode.read_lips(mode.vision(frame, scene.rig, _Finder()))  # type: ignore[arg-type]
    plain = FaceGuided(PipelineConfig()).vision(frame, scene.rig, _Finder())  # type: ignore[arg-type]
    assert runs == [2]  # one mesh for the eyes and the lips
    np.testing.assert_allclose(with_lips.xyz[:, 2], plain.xyz[:, 2] / 2)  # eyes twice as far apart: half as far
    assert with_lips.lip_activity is not None and len(with_lips.lip_activity) == 2


def test_the_lips_are_read_by_default_where_the_face_mesh_is(monkeypatch: pytest.MonkeyPatch) -> None:
    """Face-guided runs read the lips unless --no-read-lips; motion-guided ones only with --read-lips. Without the
    face mesh's package the default leaves them unread (no error), and --read-lips is one line that says how."""
    import app.models
    from app.cli import build_parser
    from app.commands.options import pipeline_config, wants_read_lips
    from app.errors import UserError

    parse = build_parser().parse_args
    assert wants_read_lips(parse(["run"])) is True
    assert wants_read_lips(parse(["run", "--no-read-lips"])) is False
    assert wants_read_lips(parse(["run", "--motion"])) is False
    assert wants_read_lips(parse(["run", "--motion", "--read-lips"])) is True

    def missing() -> None:
        raise UserError("the face mesh's model (the lips) is not installed")

    monkeypatch.setattr(app.models, "facemesh_model", missing)
    assert wants_read_lips(parse(["run"])) is False
    with pytest.raises(UserError, match="not installed"):
        pipeline_config(parse(["run", "--read-lips", "--face-detector", "blazeface"]))
