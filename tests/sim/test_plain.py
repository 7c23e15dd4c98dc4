"""sim.plain: people in plain clothes, and Algorithm 1 holding each of them in every interval."""
from __future__ import annotations

import numpy as np
import pytest

from avcore.evaluation import match_clusters
from avcore.geometry import MicPair
from avcore.inference import MotionGuidedHearing, MotionGuidedParams
from sim.plain import PlainConfig, generate_plain


def test_plain_people_are_what_the_docstring_says() -> None:
    mics = MicPair()
    ivs = generate_plain("static", seed=3, config=PlainConfig(n_intervals=20))
    again = generate_plain("static", seed=3, config=PlainConfig(n_intervals=20))
    assert all(np.array_equal(a.points, b.points) and np.array_equal(a.itds, b.itds) for a, b in zip(ivs, again))
    talks, heard = 0, []
    for iv in ivs:
        counts = np.bincount(iv.point_ids + 1, minlength=4)  # outliers, then the three people
        assert all(450 < c < 750 for c in counts[1:])
        assert counts[0] / counts.sum() == pytest.approx(0.12, abs=0.01)
        for g, i in enumerate(iv.truth_ids):  # the paper's truth: the mean of the person's own points
            np.testing.assert_allclose(iv.truth_xyz[g], iv.points[iv.point_ids == i].mean(axis=0))
        azimuth = np.degrees(np.arctan2(iv.truth_xyz[:, 0], iv.truth_xyz[:, 2]))
        assert np.all(np.abs(azimuth) <= 50) and np.all((iv.truth_xyz[:, 2] > 1.1) & (iv.truth_xyz[:, 2] < 3.3))
        assert iv.truth_speaking.sum() <= 1
        for g in np.flatnonzero(iv.truth_speaking):
            talks += 1
            own = iv.itds[iv.itd_ids == g]
            if own.size:
                heard.append(abs(np.median(own) - float(mics.itd(iv.truth_xyz[g]))))
    assert 0.1 < talks / (3 * 20) < 0.4  # each person silent most of the time (speaks in about one interval in 4)
    assert heard and np.median(heard) < 60e-6  # a talker's ITDs come from its place
    with pytest.raises(ValueError, match="unknown family"):
        generate_plain("dancing")


@pytest.mark.parametrize("family", ["static", "moving"])
def test_algorithm_1_holds_every_plain_person_in_every_interval(family: str) -> None:
    """Issue 28's failure, on people of this generator: a person present in every interval must be found in every
    interval (the default lost one in five on another generator's untextured people), with no one invented."""
    hearing = MotionGuidedHearing(MicPair())
    found, false = [], 0
    for iv in generate_plain(family, seed=5, config=PlainConfig(n_intervals=30)):
        out = hearing.step(iv.points, iv.itds)
        match = match_clusters(out.positions, iv.truth_xyz, detected_speaking=out.speaking,
                               truth_speaking=iv.truth_speaking)
        found.append(match.tp)
        false += match.fp
    assert found == [3] * 30 and false <= 1


def test_a_person_lost_for_an_interval_is_held_where_few_points_and_many_outliers_make_the_groups_falter() -> None:
    """40 points a person and 25 % outliers: each interval alone loses a person now and then and finds them in the
    next; holding the previous interval's people where their bodies still are finds every one in every interval."""
    config = PlainConfig(n_intervals=40, points_per_person=40, outlier_share=0.25)
    for seed in (1, 2, 5):
        ivs = generate_plain("static", seed=seed, config=config)
        missed = {}
        for name, params in (("alone", MotionGuidedParams(hold_radius_m=None)), ("held", MotionGuidedParams())):
            hearing = MotionGuidedHearing(MicPair(), params)
            missed[name], false = 0, 0
            for iv in ivs:
                match = match_clusters(hearing.step(iv.points, iv.itds).positions, iv.truth_xyz)
                missed[name] += match.fn
                false += match.fp
            assert false == 0
        assert missed["alone"] >= 2 and missed["held"] == 0, (seed, missed)
