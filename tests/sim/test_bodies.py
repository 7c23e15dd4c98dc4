"""sim.bodies: people with bodies for Algorithm 1 (issue 18)."""
from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from avcore.geometry import MicPair
from sim.bodies import FAMILIES, generate_bodies


@lru_cache(maxsize=None)
def _bodies(family: str, seed: int) -> tuple:
    """60 intervals of a family, drawn once for the module's tests that read them."""
    return tuple(generate_bodies(family, seed=seed, n_intervals=60))


def _person_points(iv, i):  # noqa: ANN001, ANN202
    return iv.points[iv.point_ids == i]


def test_a_seed_gives_the_same_sequence_and_families_differ() -> None:
    a = generate_bodies("seated", seed=3, n_intervals=3)
    b = generate_bodies("seated", seed=3, n_intervals=3)
    c = generate_bodies("standing", seed=3, n_intervals=3)
    assert all(np.array_equal(x.points, y.points) and np.array_equal(x.itds, y.itds) for x, y in zip(a, b))
    assert not np.array_equal(a[0].points, c[0].points)
    with pytest.raises(ValueError, match="family"):
        generate_bodies("dancing")


def test_the_truth_is_the_centre_of_the_visible_moving_body() -> None:
    """Static families: the mean of a person's (noisy) points lies within a few centimetres of the truth; the points
    are spread over a body (head to hands), not a blob around it."""
    for family in ("seated", "standing"):
        for iv in generate_bodies(family, seed=1, n_intervals=4):
            assert iv.truth_xyz.shape == (3, 3)
            for g, i in enumerate(iv.truth_ids):
                pts = _person_points(iv, i)
                assert np.linalg.norm(pts.mean(axis=0) - iv.truth_xyz[g]) < 0.05
                spread = np.linalg.norm(pts - iv.truth_xyz[g], axis=1)
                assert np.quantile(spread, 0.9) > 0.25  # hands and head far from the centre


def test_a_table_hides_the_seated_and_walkers_show_their_legs() -> None:
    seated = generate_bodies("seated", seed=2, n_intervals=3)[1]
    walking = generate_bodies("walking", seed=2, n_intervals=3)[1]
    for iv, below_max in ((seated, 0.45), (walking, None)):
        for g, i in enumerate(iv.truth_ids):
            pts = _person_points(iv, i)
            top = np.quantile(pts[:, 1], 0.01)  # y is down: the top of the head
            reach = np.quantile(pts[:, 1], 0.99) - top
            if below_max is not None:
                assert reach < 0.75  # nothing below the table
            else:
                assert reach > 1.2  # legs down to the floor


def test_people_at_the_edge_and_behind_others_lose_points() -> None:
    edge = generate_bodies("edge", seed=0, n_intervals=3)[0]
    counts = [int((edge.point_ids == i).sum()) for i in range(3)]
    assert counts[2] < 0.8 * min(counts[:2])  # the third stands at the edge of the view
    crossing = _bodies("crossing", 0)
    behind = [int((iv.point_ids == 1).sum()) for iv in crossing]
    assert min(behind) < 0.5 * max(behind)  # hidden while the one in front covers them


@pytest.mark.parametrize("family", ["walking", "crossing"])
def test_walkers_pass_each_other_without_walking_through(family: str) -> None:
    """People keep 0.6 m apart; walkers go to and fro across the room, so they keep to lanes of their own depth."""
    for seed in (0, 1, 2):
        for iv in _bodies(family, seed)[::3]:
            centres = np.concatenate([iv.truth_xyz, iv.hidden_xyz])
            gaps = np.linalg.norm(centres[:, None] - centres[None], axis=2)[np.triu_indices(3, 1)]
            assert gaps.min() > 0.45, (seed, iv.index)


def test_a_person_too_hidden_for_the_truth_is_listed_as_hidden() -> None:
    crossing = _bodies("crossing", 0)
    listed = [iv for iv in crossing if iv.hidden_xyz.shape[0]]
    assert listed, "the walker behind is never hidden enough"
    checked = 0
    for iv in listed:
        assert iv.hidden_xyz.shape == (iv.hidden_ids.size, 3) and iv.hidden_speaking.shape == iv.hidden_ids.shape
        assert set(iv.hidden_ids).isdisjoint(iv.truth_ids) and iv.truth_ids.size + iv.hidden_ids.size == 3
        for i, centre in zip(iv.hidden_ids, iv.hidden_xyz):
            seen = _person_points(iv, i)
            if seen.shape[0] >= 20:  # what is seen of them lies around their listed centre
                assert np.linalg.norm(seen.mean(axis=0) - centre) < 0.2
                checked += 1
    assert checked >= 3  # the centre check ran, not only the shapes


def test_talkers_itds_come_from_their_mouths() -> None:
    mics = MicPair()
    checked = 0
    for iv in generate_bodies("standing", seed=4, n_intervals=20, mics=mics):
        for g, i in enumerate(iv.truth_ids):
            own = iv.itds[iv.itd_ids == i]
            if iv.truth_speaking[g] and own.size >= 5:
                # the delay at the person's place from the distances to the two microphones (not MicPair.itd)
                head_ish = (np.linalg.norm(iv.truth_xyz[g] - mics.left) - np.linalg.norm(iv.truth_xyz[g] - mics.right)) / 343.0
                assert abs(np.median(own) - head_ish) < 60e-6
                checked += 1
    assert checked >= 5  # talkers were heard and compared
    assert set(FAMILIES) >= {"seated", "walking", "crossing", "edge", "close", "gesturing", "standing"}
