from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from avcore.geometry import ARRAY_PRESETS, MicArray, MicPair


def test_itd_hand_computed() -> None:
    mics = MicPair(left=(-0.06, 0.0, 0.0), right=(0.06, 0.0, 0.0), speed_of_sound=343.0)
    # A source 1 m to the right on the microphone axis: |S - M_L| = 1.06, |S - M_R| = 0.94.
    assert mics.itd([1.0, 0.0, 0.0]) == pytest.approx(0.12 / 343.0, rel=1e-12)
    # (3, 0, 4): |S - M_L| = sqrt(3.06^2 + 16), |S - M_R| = sqrt(2.94^2 + 16)
    expected = (np.sqrt(3.06**2 + 16) - np.sqrt(2.94**2 + 16)) / 343.0
    assert mics.itd([3.0, 0.0, 4.0]) == pytest.approx(expected, rel=1e-12)
    # Straight ahead: zero.
    assert mics.itd([0.0, 0.3, 2.0]) == pytest.approx(0.0, abs=1e-15)


def test_sign_convention_right_is_positive() -> None:
    mics = MicPair()
    right = mics.itd([0.5, 0.0, 1.5])
    left = mics.itd([-0.5, 0.0, 1.5])
    assert right > 0 > left
    assert right == pytest.approx(-left)
    # Swapping the microphones negates the mapping.
    swapped = MicPair(left=mics.right, right=mics.left)
    assert swapped.itd([0.5, 0.0, 1.5]) == pytest.approx(-right)


def test_affine_correction_and_interval() -> None:
    mics = MicPair(c1=1.2, c0=-1e-5)
    pts = np.array([[0.3, 0.1, 2.0], [-1.0, 0.0, 1.0]])
    raw = MicPair().itd(pts)
    np.testing.assert_allclose(mics.itd(pts), 1.2 * raw - 1e-5)
    lo, hi = mics.itd_interval()
    assert lo == pytest.approx(-1e-5 - 1.2 * 0.12 / 343.0)
    assert hi == pytest.approx(-1e-5 + 1.2 * 0.12 / 343.0)
    # Negative c1 still gives an ordered interval.
    lo, hi = MicPair(c1=-1.0).itd_interval()
    assert lo < hi


@given(st.lists(st.tuples(*[st.floats(-20, 20)] * 3), min_size=1, max_size=20))
def test_mapping_stays_inside_interval(points: list[tuple[float, float, float]]) -> None:
    mics = MicPair(c1=0.9, c0=2e-5)
    lo, hi = mics.itd_interval()
    itds = mics.itd(np.array(points))
    assert np.all(itds >= lo - 1e-12) and np.all(itds <= hi + 1e-12)


def test_vectorised_over_leading_axes() -> None:
    mics = MicPair()
    pts = np.random.default_rng(0).normal(size=(4, 5, 3))
    out = mics.itd(pts)
    assert out.shape == (4, 5)
    np.testing.assert_allclose(out[2, 3], mics.itd(pts[2, 3]))


def test_bad_points_shape() -> None:
    with pytest.raises(ValueError, match=r"\(\.\.\., 3\)"):
        MicPair().itd(np.zeros((4, 2)))


# -- several microphone pairs -------------------------------------------------------------------------------------


def test_one_pair_array_is_the_pair() -> None:
    mics = MicPair(left=(-0.07, 0.01, 0.0), right=(0.05, 0.0, 0.02), c1=0.9, c0=3e-6)
    array = MicArray.from_pair(mics)
    pts = np.random.default_rng(0).uniform(-2, 2, (50, 3)) + [0, 0, 3]
    np.testing.assert_allclose(array.itd(pts)[:, 0], mics.itd(pts))
    assert array.n_pairs == 1 and array.itd(pts).shape == (50, 1)


def test_array_itds_follow_the_geometry_both_ways() -> None:
    """t_i - t_j from the path lengths, for every pair; a source on the right of a (left, right) pair gives a
    positive ITD, and swapping the pair negates it."""
    array = MicArray.preset("nao")
    rng = np.random.default_rng(1)
    pts = rng.uniform(-3, 3, (40, 3))
    pos = np.asarray(array.positions)
    expected = np.stack([(np.linalg.norm(pts - pos[i], axis=1) - np.linalg.norm(pts - pos[j], axis=1)) / 343.0
                         for i, j in array.pairs], axis=1)
    np.testing.assert_allclose(array.itd(pts), expected, atol=1e-15)
    lr = array.pairs.index((2, 3))  # NAO's left and right microphones
    right_of_robot = np.array([[1.0, 0.0, 2.0]])
    assert array.itd(right_of_robot)[0, lr] > 0
    swapped = MicArray(array.positions, [(j, i) for i, j in array.pairs])
    np.testing.assert_allclose(swapped.itd(pts), -array.itd(pts))


def test_nao_head_frame_becomes_the_scene_frame() -> None:
    """NAO's left microphone (head y = +6 cm, left) is at scene x = -6 cm; its front one is in front (z > 0) and
    above the head's origin (y < 0, since y points down)."""
    nao = MicArray.preset("nao")
    front, rear, left, right = np.asarray(nao.positions)
    assert left[0] == pytest.approx(-0.0606) and right[0] == pytest.approx(0.0606)
    assert front[2] > 0 > rear[2] and front[1] < 0
    # front/back, which the left-right pair cannot tell apart: mirrored sources, same left-right ITD
    ahead, behind = np.array([0.8, 0.0, 2.0]), np.array([0.8, 0.0, -2.0])
    lr, fr = nao.pairs.index((2, 3)), nao.pairs.index((1, 0))
    itds = nao.itd(np.stack([ahead, behind]))
    assert abs(itds[0, lr] - itds[1, lr]) < 15e-6  # the left-right pair hears them alike (the head is not flat)
    assert itds[0, fr] > 1e-4 and itds[1, fr] < -1e-4  # the rear-front pair does not


@pytest.mark.parametrize("name, n_mics", [("pair", 2), ("nao", 4), ("respeaker4", 4), ("respeaker-usb", 4),
                                          ("respeaker6", 6), ("ps3eye", 4), ("uma8", 7)])
def test_presets(name: str, n_mics: int) -> None:
    array = MicArray.preset(name)
    assert len(array.positions) == n_mics and array.n_pairs == n_mics * (n_mics - 1) // 2
    assert array.itd_intervals().shape == (array.n_pairs, 2)
    assert name in ARRAY_PRESETS


def test_respeaker_usb_uses_the_raw_channels() -> None:
    assert MicArray.preset("respeaker-usb").channels == (1, 2, 3, 4)


def test_an_array_placed_on_the_rig() -> None:
    turn = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # 90 degrees about y
    moved = MicArray.preset("ps3eye").placed(turn, [0.0, -0.1, 0.05])
    np.testing.assert_allclose(np.asarray(moved.positions)[0], [0.0, -0.1, 0.05 + 0.03], atol=1e-12)
    with pytest.raises(ValueError, match="rotation"):
        MicArray.preset("ps3eye").placed(np.diag([1.0, 1.0, -1.0]), [0, 0, 0])


@pytest.mark.parametrize(("name", "radius_m", "n_ring", "centre"), [
    ("respeaker4", 0.0405, 4, False), ("respeaker-usb", 0.032, 4, False), ("respeaker6", 0.0463, 6, False),
    ("uma8", 0.043, 6, True)])
def test_the_ring_presets_have_the_makers_geometry(name: str, radius_m: float, n_ring: int, centre: bool) -> None:
    """The makers' figures (radius, count, a centre microphone), written here: every ring microphone at the radius in
    the horizontal plane (y = 0), neighbours 360 / n degrees apart (so at 2 r sin(180 / n) from each other)."""
    pos = np.asarray(MicArray.preset(name).positions)
    ring = pos[1:] if centre else pos
    if centre:
        np.testing.assert_allclose(pos[0], [0.0, 0.0, 0.0], atol=1e-12)
    assert ring.shape == (n_ring, 3)
    np.testing.assert_allclose(ring[:, 1], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.hypot(ring[:, 0], ring[:, 2]), radius_m, rtol=1e-9)
    angles = np.sort(np.degrees(np.arctan2(ring[:, 2], ring[:, 0])) % 360)
    np.testing.assert_allclose(np.diff(np.append(angles, angles[0] + 360)), 360 / n_ring, atol=1e-6)
    chord = 2 * radius_m * np.sin(np.pi / n_ring)
    nearest = [np.sort(np.linalg.norm(ring - p, axis=1))[1] for p in ring]
    np.testing.assert_allclose(nearest, chord, rtol=1e-9)


def test_the_line_presets_and_the_square_s_orientation() -> None:
    """The PS3 Eye: four microphones on x at -30, -10, 10, 30 mm; the ReSpeaker 4-Mic HAT's square sits at 45
    degrees (its microphones on the diagonals: x = +-28.6 mm); the paper's pair 12 cm apart on x."""
    np.testing.assert_allclose(np.asarray(MicArray.preset("ps3eye").positions),
                               [[-0.03, 0, 0], [-0.01, 0, 0], [0.01, 0, 0], [0.03, 0, 0]], atol=1e-12)
    square = np.asarray(MicArray.preset("respeaker4").positions)
    np.testing.assert_allclose(np.abs(square[:, [0, 2]]), 0.0405 / np.sqrt(2), rtol=1e-9)
    np.testing.assert_allclose(np.asarray(MicArray.preset("pair").positions), [[-0.06, 0, 0], [0.06, 0, 0]])


def test_pairs_are_left_to_right_and_widest_first() -> None:
    """Each pair (i, j) has i the more-left microphone (a tie: the one further back), so that a source on the right
    gives a positive ITD; the widest left-right pair comes first."""
    for name in ARRAY_PRESETS:
        array = MicArray.preset(name)
        pos = np.asarray(array.positions)
        spreads = [pos[j, 0] - pos[i, 0] for i, j in array.pairs]
        assert all(s >= -1e-12 for s in spreads), name
        for (i, j), s in zip(array.pairs, spreads):
            if abs(s) < 1e-12:
                assert pos[i, 2] <= pos[j, 2], name  # a tie in x: the one further back is "left"
        assert spreads[0] == pytest.approx(max(spreads)), name
        assert np.all(np.diff(np.round(spreads, 9)) <= 0), name  # by decreasing left-right spread
        right = np.array([1.0, 0.0, 2.0])
        assert array.itd(right)[0] > 0, name


def test_a_placed_array_moves_every_microphone_and_keeps_its_pairs() -> None:
    turn = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])  # 90 degrees about y
    array = MicArray.preset("respeaker6")
    moved = array.placed(turn, [0.1, -0.2, 0.3])
    np.testing.assert_allclose(np.asarray(moved.positions), np.asarray(array.positions) @ turn.T + [0.1, -0.2, 0.3],
                               atol=1e-12)
    assert moved.pairs == array.pairs and moved.channels == array.channels and moved.c1 == array.c1
    same = MicArray.preset("respeaker6", rotation=turn, translation_m=[0.1, -0.2, 0.3])
    np.testing.assert_allclose(np.asarray(same.positions), np.asarray(moved.positions), atol=1e-12)
    with pytest.raises(ValueError, match="translation_m"):
        array.placed(np.eye(3), [0.0, np.inf, 0.0])


def test_a_turned_array_turns_about_the_vertical_through_its_centre() -> None:
    """turned(yaw): every microphone keeps its height and its distance to the microphones' centroid, which stays;
    a quarter turn takes the front (+z) to the right (+x) and the right to the back (written out by hand)."""
    array = MicArray(((-0.05, 0.0, 1.0), (0.05, 0.0, 1.0), (0.0, 0.02, 1.1)), c1=(0.9, 1.0, 1.1))
    centre = np.mean(np.asarray(array.positions), axis=0)
    quarter = array.turned(np.pi / 2)
    # (x, y, z) -> (z, y, -x) about the centre: a quarter turn with the front going right
    offsets = np.asarray(array.positions) - centre
    by_hand = centre + np.c_[offsets[:, 2], offsets[:, 1], -offsets[:, 0]]
    np.testing.assert_allclose(np.asarray(quarter.positions), by_hand, atol=1e-12)
    assert by_hand[2, 0] > centre[0] and by_hand[1, 2] < centre[2]  # front to the right, right to the back
    assert quarter.pairs == array.pairs and quarter.c1 == array.c1 and quarter.channels == array.channels
    back = quarter.turned(-np.pi / 2)
    np.testing.assert_allclose(np.asarray(back.positions), np.asarray(array.positions), atol=1e-12)
    with pytest.raises(ValueError, match="yaw_rad"):
        array.turned(float("nan"))


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"left": (0, 0, 0), "right": (0, 0, 0)},
     "left and right microphones are at the same position; give their two positions"),
    ({"left": (0, 0)}, r"left must be three finite coordinates in metres, got \(0, 0\)"),
    ({"right": (0, 0, float("inf"))}, r"right must be three finite coordinates in metres, got \(0, 0, inf\)"),
    ({"speed_of_sound": 0.0}, "speed_of_sound must be a positive number of m/s, got 0.0"),
    ({"speed_of_sound": float("inf")}, "speed_of_sound must be a positive number of m/s, got inf"),
    ({"c1": 0.0}, "c1 must be a finite non-zero scale, got 0.0"),
    ({"c1": float("nan")}, "c1 must be a finite non-zero scale, got nan"),
    ({"c0": float("nan")}, "c0 must be a finite offset in seconds, got nan"),
])
def test_a_pair_names_what_is_wrong(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=f"^{message}$"):
        MicPair(**kwargs)


def test_a_pair_accepts_a_negative_scale_and_stores_float_positions() -> None:
    flipped = MicPair(left=[0, 0, 0], right=np.array([1, 0, 0]), c1=-1.0, c0=1e-5)
    assert flipped.left == (0.0, 0.0, 0.0) and type(flipped.right[0]) is float and flipped.c1 == -1.0
    assert MicPair(speed_of_sound=0.5).max_itd_s == pytest.approx(0.24)  # any positive speed (here a slow one)


TWO = ((0.0, 0.0, 0.0), (0.1, 0.0, 0.0))


@pytest.mark.parametrize(("args", "kwargs", "message"), [
    ((((0, 0, 0),),), {}, "a microphone array needs at least 2 positions, got 1"),
    ((TWO,), {"pairs": []}, r"pairs must name at least one pair \(i, j\) of microphones"),
    ((TWO,), {"pairs": [(0, 0)]}, r"each pair must be two different microphone numbers below 2, got \(0, 0\)"),
    ((TWO,), {"pairs": [(0, 2)]}, r"each pair must be two different microphone numbers below 2, got \(0, 2\)"),
    ((TWO,), {"pairs": [(-1, 1)]}, r"each pair must be two different microphone numbers below 2, got \(-1, 1\)"),
    ((TWO,), {"pairs": [(2, 0)]}, r"each pair must be two different microphone numbers below 2, got \(2, 0\)"),
    (((TWO[0], TWO[0]),), {}, r"pair \(0, 1\) has both microphones at \(0.0, 0.0, 0.0\)"),
    ((TWO,), {"c1": (1.0, 1.0)}, r"c1 must give one value per pair \(1\), got 2"),
    ((TWO,), {"c0": ()}, r"c0 must give one value per pair \(1\), got 0"),
    ((TWO,), {"channels": (0,)}, r"channels must give 2 different channel numbers >= 0, got \(0,\)"),
    ((TWO,), {"channels": (1, 1)}, r"channels must give 2 different channel numbers >= 0, got \(1, 1\)"),
    ((TWO,), {"channels": (-1, 0)}, r"channels must give 2 different channel numbers >= 0, got \(-1, 0\)"),
    (((TWO[0], (0, 0, float("nan"))),), {}, r"positions\[1\] must be three finite coordinates in metres, got "),
])
def test_an_array_names_what_is_wrong(args: tuple, kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=f"^{message}"):
        MicArray(*args, **kwargs)


def test_an_array_at_its_limits_is_accepted() -> None:
    two = MicArray(TWO, channels=(5, 0))
    assert two.pairs == ((0, 1),) and two.channels == (5, 0) and two.c1 == (1.0,) and two.c0 == (0.0,)
    assert MicArray(TWO, pairs=[(1, 0)], c1=[2], c0=[0]).pair(0).left == TWO[1]
    with pytest.raises(ValueError, match="^unknown microphone array 'nope'; choose one of pair, laptop, nao, "):
        MicArray.preset("nope")
    with pytest.raises(ValueError, match=r"^rotation must be a \(3, 3\) rotation matrix, got "):
        two.placed(np.eye(2), np.zeros(3))
    with pytest.raises(ValueError, match=r"^translation_m must be three finite coordinates in metres, got \[0, 0\]$"):
        two.placed(np.eye(3), [0, 0])
    with pytest.raises(ValueError, match="^yaw_rad must be a finite angle in radians, got nan$"):
        two.turned(float("nan"))
    assert two.placed(np.eye(3), [0.0, 0.0, 0.5]).positions[1] == (0.1, 0.0, 0.5)


def test_an_arrays_raw_itds_are_each_pairs_distances_written_out() -> None:
    """Eq. (itd) for every pair, without the correction: (|S - M_i| - |S - M_j|) / nu, and the corrected ITDs are
    c1 times that plus c0, pair by pair."""
    mics = ((-0.1, 0.0, 0.0), (0.1, 0.0, 0.0), (0.0, -0.05, 0.02))
    array = MicArray(mics, pairs=[(0, 1), (2, 0), (1, 2)], speed_of_sound=340.0, c1=(1.1, 0.9, 1.0),
                     c0=(1e-5, 0.0, -2e-5))
    s = np.array([[0.7, -0.2, 1.5], [-1.0, 0.3, 2.0]])
    want = np.array([[(np.linalg.norm(p - np.array(mics[i])) - np.linalg.norm(p - np.array(mics[j]))) / 340.0
                      for i, j in ((0, 1), (2, 0), (1, 2))] for p in s])
    np.testing.assert_allclose(array.raw_itd(s), want, rtol=1e-12)
    np.testing.assert_allclose(array.itd(s), want * [1.1, 0.9, 1.0] + [1e-5, 0.0, -2e-5], rtol=1e-12, atol=1e-18)
    assert array.raw_itd(s[0]).shape == (3,)


def test_a_placed_array_keeps_its_corrections_channels_and_speed_of_sound() -> None:
    array = MicArray(((-0.1, 0.0, 0.0), (0.1, 0.0, 0.0)), c1=(1.2,), c0=(3e-5,), channels=(4, 2), speed_of_sound=330.0)
    moved = array.placed(np.eye(3), [0.0, 0.0, 0.1])
    assert moved.c1 == (1.2,) and moved.c0 == (3e-5,) and moved.channels == (4, 2) and moved.speed_of_sound == 330.0
    preset = MicArray.preset("respeaker4", speed_of_sound=330.0)
    assert preset.speed_of_sound == 330.0 and preset.pair(0).speed_of_sound == 330.0
    turned = MicArray.preset("respeaker4", rotation=[[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    assert not np.allclose(np.asarray(turned.positions), np.asarray(MicArray.preset("respeaker4").positions))
    lifted = MicArray.preset("respeaker4", translation_m=[0.0, -0.2, 0.0])
    np.testing.assert_allclose(np.asarray(lifted.positions)[:, 1], -0.2)


def test_a_rotation_within_a_millionth_of_orthonormal_is_one_and_a_scaling_is_not() -> None:
    array = MicArray.preset("ps3eye")
    c, s = np.cos(0.3), np.sin(0.3)
    nearly = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]) + np.array([[0, 4e-7, 0], [0, 0, 0], [0, 0, 0]])
    assert array.placed(nearly, np.zeros(3)).n_pairs == array.n_pairs
    with pytest.raises(ValueError, match="^rotation must be a"):
        array.placed(np.diag([1.2, 1.0, 1.0]), np.zeros(3))


def test_a_pairs_array_keeps_its_left_first_even_when_it_is_on_the_right() -> None:
    flipped = MicPair(left=(0.06, 0.0, 0.0), right=(-0.06, 0.0, 0.0))
    array = MicArray.from_pair(flipped)
    assert array.pairs == ((0, 1),)
    s = np.array([0.5, 0.0, 1.0])
    assert array.itd(s)[0] == pytest.approx(flipped.itd(s), rel=1e-12) and flipped.itd(s) < 0  # its left is nearer


def test_an_array_stores_float_positions_and_gives_each_pair_its_correction() -> None:
    array = MicArray([[0, 0, 0], [1, 0, 0]], c1=(1.1,), c0=(2e-5,))
    assert array.positions == ((0.0, 0.0, 0.0), (1.0, 0.0, 0.0)) and type(array.positions[1][0]) is float
    assert (array.pair(0).c1, array.pair(0).c0) == (1.1, 2e-5)
    with pytest.raises(ValueError, match=r"^points must be an array of shape \(\.\.\., 3\) in metres, got shape \(2,\)$"):
        array.itd(np.zeros(2))


def test_an_array_knows_its_preset_wherever_the_rig_places_it() -> None:
    turn = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
    for name in ARRAY_PRESETS:
        assert MicArray.preset(name).preset_name == name
        assert MicArray.preset(name, rotation=turn, translation_m=(0.1, -0.3, 0.05)).turned(0.4).preset_name == name
    nao = np.array(MicArray.preset("nao").positions)
    nao[2, 0] += 0.005  # one microphone 5 mm off: an array of its own
    assert MicArray(tuple(map(tuple, nao))).preset_name is None
    assert MicArray(((-0.1, 0.0, 0.0), (0.1, 0.0, 0.0))).preset_name is None
