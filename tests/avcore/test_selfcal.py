"""Self-calibration: c1, c0 of eq. (itd_up) from people talking alone in view, without a loudspeaker session."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.geometry import MicPair
from avcore.selfcal import SelfCalibration

MICS = MicPair()
FACES = np.array([[-0.9, 0.0, 2.2], [0.0, 0.05, 2.6], [0.8, -0.05, 2.0]])
C1, C0 = 0.81, 6e-6


def _frame(rng: np.random.Generator, talker: int | None, *, k: int = 12, spread_s: float = 4e-6,
           second: int | None = None, source_xyz: np.ndarray | None = None) -> np.ndarray:
    """A time frame's ITDs: the talker's (or an unseen source's) corrected ITD plus noise, and a second talker's
    half of them when two talk at once."""
    where = source_xyz if source_xyz is not None else FACES[talker]
    itds = C1 * MICS.raw_itd(where) + C0 + rng.normal(0, spread_s, k)
    if second is not None:
        itds[k // 2:] = C1 * MICS.raw_itd(FACES[second]) + C0 + rng.normal(0, spread_s, k - k // 2)
    return itds


def test_people_talking_in_turns_give_the_correction() -> None:
    """Three faces, each talking alone in turn: the line through the one-source time frames is c1, c0 within a
    microsecond over the view, whatever the correction the run started with (the fit does not use it)."""
    rng = np.random.default_rng(0)
    cal = SelfCalibration(MICS)
    assert cal.fit() is None
    for n in range(300):
        assert cal.push(FACES, _frame(rng, (n // 20) % 3))
    fit = cal.fit()
    assert fit is not None and fit.inliers >= 250 and fit.confidence > 0.8
    x = np.linspace(-175e-6, 175e-6, 15)
    assert np.max(np.abs(fit.c1 * x + fit.c0 - (C1 * x + C0))) < 1e-6


def test_two_at_once_and_a_voice_out_of_view_do_not_move_it() -> None:
    """Time frames where two talk at once are not one source and are not kept; a talker out of view pairs only with
    the wrong faces and stays off the line; the fit moves by less than 2 us."""
    rng = np.random.default_rng(1)
    cal = SelfCalibration(MICS)
    for n in range(300):
        cal.push(FACES, _frame(rng, (n // 20) % 3))
    before = cal.fit()
    assert not cal.push(FACES, _frame(rng, 0, second=2))  # two at once: their ITDs spread
    unseen = np.array([2.0, 0.0, 0.3])  # beside the robot, out of the cameras' view
    for _ in range(150):
        cal.push(FACES, _frame(rng, None, source_xyz=unseen))
    after = cal.fit()
    assert before is not None and after is not None
    x = np.linspace(-175e-6, 175e-6, 15)
    assert np.max(np.abs((after.c1 - before.c1) * x + after.c0 - before.c0)) < 2e-6


def test_one_face_that_never_moves_tells_no_scale() -> None:
    """A line needs faces spread across the view: one still face fixes a point, not c1 (no fit, not a guess)."""
    rng = np.random.default_rng(2)
    cal = SelfCalibration(MICS)
    for _ in range(200):
        cal.push(FACES[1:2], _frame(rng, 1))
    assert len(cal) == 200 and cal.fit() is None
    assert not cal.push(np.zeros((0, 3)), _frame(rng, 1))  # nobody in view
    with pytest.raises(ValueError, match="seconds"):
        SelfCalibration(MICS, tolerance_s=0.0)
