from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from avcore.geometry import MicPair


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


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"left": (0, 0, 0), "right": (0, 0, 0)}, "same position"),
        ({"left": (0, 0)}, "three finite coordinates"),
        ({"speed_of_sound": 0.0}, "speed_of_sound"),
        ({"c1": 0.0}, "c1"),
        ({"c0": float("nan")}, "c0"),
    ],
)
def test_bad_construction(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        MicPair(**kwargs)


def test_bad_points_shape() -> None:
    with pytest.raises(ValueError, match=r"\(\.\.\., 3\)"):
        MicPair().itd(np.zeros((4, 2)))
