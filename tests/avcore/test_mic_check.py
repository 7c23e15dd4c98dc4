"""The rig's microphones checked against what they hear (avcore.mic_check), on ITDs made from the geometry."""
from __future__ import annotations

import math

import numpy as np

from avcore.geometry import MicArray
from avcore.mic_check import MicCheck

FACES = np.array([[-0.30, -0.18, 1.44], [0.31, -0.12, 1.83], [0.95, -0.15, 2.38]])  # three seated, in view
PULL = 0.92  # the room's reverberation pulls every ITD towards zero (section 5.3's c1)


def _scaled(array: MicArray, factor: float) -> MicArray:
    return MicArray(tuple(tuple(factor * np.asarray(p)) for p in array.positions), array.pairs,
                    channels=array.channels)


def _frame(heard: MicArray, source: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A time frame's ITDs (10, P) of one source as the microphones really placed (``heard``) give them."""
    tau = PULL * heard.raw_itd(source[None]).reshape(1, heard.n_pairs)
    return tau + rng.normal(0.0, 3e-6, (10, heard.n_pairs))


def _check(declared: MicArray, heard: MicArray, *, noise_behind: bool) -> list:
    """Three people take turns (200 one-source frames); with ``noise_behind`` a kitchen behind the robot is the
    one source of every other frame (no face is there)."""
    rng = np.random.default_rng(0)
    check = MicCheck(declared)
    behind = np.array([1.2 * math.sin(math.radians(160)), 0.0, 1.2 * math.cos(math.radians(160))])
    for k in range(400):
        source = behind if noise_behind and k % 2 else FACES[(k // 20) % 3]
        check.push(FACES, _frame(heard, source, rng))
    return check.findings()


def test_a_noise_behind_the_robot_is_no_face_turned_round() -> None:
    """The noise behind gives one-source frames whose ITD vector is about minus a face's: scaled freely, a face in
    view "explains" them with a negative scale (a ReSpeaker in a drawn room was told its microphones were -1.0 to
    1.7 times their spacing). A face must fit them clearly better than the others at a plausible scale: nothing
    said of the right geometry, with or without the noise."""
    array = MicArray.preset("respeaker4")
    assert _check(array, array, noise_behind=True) == []
    assert _check(array, array, noise_behind=False) == []


def test_a_preset_larger_than_the_array_is_said_on_each_pair() -> None:
    """The ReSpeaker 4-mic preset (radius 40.5 mm) declared for microphones on radius 32 mm: the talkers' ITDs are
    0.79 of the geometry's (times the room's pull), said on the pairs with about the real spacing, noise or not."""
    declared = MicArray.preset("respeaker4")
    heard = _scaled(declared, 32.0 / 40.5)
    for noise in (False, True):
        said = _check(declared, heard, noise_behind=noise)
        assert said and all(f.kind == "scale" for f in said)
        assert {f.pair for f in said} >= {0, 1}  # at least the two widest pairs
        for f in said:
            assert abs(f.value - PULL * 32.0 / 40.5) < 0.03
            assert f.implied_m < 0.85 * f.declared_m


def test_one_face_in_view_is_not_taken_for_a_voice_from_elsewhere() -> None:
    """One pair, one face found; another person, whom the camera misses, talks more than it: their ITDs are about
    -2 times the face's, no spacing at all. Only plausible ratios count: nothing said of the right pair, and a
    pair twice as wide as declared is still said."""
    pair = MicArray.preset("pair")
    missed = np.array([[0.7, -0.1, 1.5]])  # 25 degrees to the right; FACES[0] is 12 degrees to the left
    for factor, expected in ((1.0, None), (2.0, 2.0 * PULL)):
        heard = _scaled(pair, factor)
        rng = np.random.default_rng(1)
        check = MicCheck(pair)
        for k in range(300):
            check.push(FACES[:1], _frame(heard, missed[0] if k % 5 < 3 else FACES[0], rng))
        said = check.findings()
        if expected is None:
            assert said == []
        else:
            assert len(said) == 1 and said[0].kind == "scale" and abs(said[0].value - expected) < 0.05


def test_a_pair_that_points_at_its_talkers_is_judged_on_a_share_of_its_own() -> None:
    """A flat ReSpeaker 4 with the people ahead: its front-back pairs hear them at about their reach (times the
    room's pull), and the measurement's spread (20 us) puts 12 % of those ITDs past 1.05 times it; the right
    geometry is said nothing. Microphones 1.27 times as far apart as declared put most of them there (those the
    extractor's search, 1.2 times the reach, does not hold are lost): said on those pairs."""
    ahead = np.array([[-0.10, -0.10, 1.5], [0.05, -0.12, 2.0], [0.20, -0.10, 2.5]])
    declared = MicArray.preset("respeaker4")
    reach = np.array([declared.pair(k).max_itd_s for k in range(declared.n_pairs)])
    along = {k for k in range(declared.n_pairs) if np.all(np.abs(declared.raw_itd(ahead)).reshape(3, -1)[:, k]
                                                           > 0.9 * reach[k])}
    assert len(along) == 2  # the two front-back pairs
    for factor, said_on in ((1.0, set()), (40.5 / 32.0, along)):
        heard = _scaled(declared, factor)
        rng = np.random.default_rng(2)
        check = MicCheck(declared)
        for k in range(400):
            tau = PULL * heard.raw_itd(ahead[(k // 20) % 3][None]).reshape(1, -1) + rng.normal(0.0, 20e-6, (10, 6))
            check.push(ahead, np.where(np.abs(tau) <= 1.2 * reach, tau, np.nan))
        said = check.findings()
        assert {f.pair for f in said} == said_on, [f.message() for f in said]
        assert all(f.kind == "beyond" and f.implied_m > 1.1 * f.declared_m for f in said)


def test_results_with_no_face_in_view_count_as_if_a_face_were_on_the_axis() -> None:
    """A front-back pair hears its talker at the reach itself; in results where vision found no face (a camera that
    starts late, a frame without depth) nothing says the sound comes from the axis, so those results are counted
    with the lenient share too: right microphones are not said wrong, and microphones a third farther apart still
    are."""
    ahead = np.array([[-0.10, -0.10, 1.5], [0.05, -0.12, 2.0], [0.20, -0.10, 2.5]])
    declared = MicArray.preset("respeaker4")
    reach = np.array([declared.pair(k).max_itd_s for k in range(declared.n_pairs)])
    for factor, said in ((1.0, False), (40.5 / 32.0, True)):
        heard = _scaled(declared, factor)
        rng = np.random.default_rng(3)
        check = MicCheck(declared)
        for k in range(400):
            tau = PULL * heard.raw_itd(ahead[(k // 20) % 3][None]).reshape(1, -1) + rng.normal(0.0, 20e-6, (10, 6))
            check.push(ahead if k % 2 else np.zeros((0, 3)), np.where(np.abs(tau) <= 1.2 * reach, tau, np.nan))
        assert bool(check.findings()) is said, [f.message() for f in check.findings()]
