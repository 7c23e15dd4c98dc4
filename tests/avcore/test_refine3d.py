from __future__ import annotations

import numpy as np
import pytest

from avcore.refine3d import (
    GAUSS_PEAKEDNESS,
    UNIFORM_PEAKEDNESS,
    compact_groups,
    group_from_members,
    held_bodies,
    merge_close,
    merge_scores,
    merge_within_width,
)

BODY = np.array([0.12, 0.25, 0.08])


def _blob(rng: np.random.Generator, centre: list[float], n: int = 500) -> np.ndarray:
    return np.asarray(centre) + rng.normal(0, BODY, (n, 3))


def test_peakedness_constants() -> None:
    assert GAUSS_PEAKEDNESS > 0.2 > 0.04 > UNIFORM_PEAKEDNESS


def test_two_people_side_by_side_are_two_groups() -> None:
    rng = np.random.default_rng(0)
    centres = [[0.1, 0.0, 2.3], [0.55, 0.0, 2.25]]  # 45 cm apart, as when people cross in ITD space
    pts = np.concatenate([_blob(rng, c) for c in centres])
    groups = compact_groups(pts, np.ones(len(pts)))
    assert len(groups) == 2
    found = sorted(g.mean[0] for g in groups)
    np.testing.assert_allclose(found, [0.1, 0.55], atol=0.03)
    for g in groups:
        assert 400 < g.mass < 600
        assert np.all(np.sqrt(np.diag(g.cov)) < 2 * BODY + 0.05)
    assert sum(g.mass for g in groups) <= len(pts) + 1e-6


def test_outliers_do_not_pull_the_position() -> None:
    rng = np.random.default_rng(1)
    person = _blob(rng, [0.3, 0.0, 2.0])
    z = rng.uniform(0.8, 6, 150)
    outliers = np.c_[0.15 * z + rng.normal(0, 0.05, 150), rng.uniform(-1, 1, 150) * 0.4 * z, z]  # on a bearing
    pts = np.concatenate([person, outliers])
    (group,) = compact_groups(pts, np.ones(len(pts)))
    assert np.linalg.norm(group.mean - [0.3, 0.0, 2.0]) < 0.03
    naive = pts.mean(axis=0)
    assert np.linalg.norm(naive - [0.3, 0.0, 2.0]) > 0.2


def test_diffuse_points_make_no_group() -> None:
    rng = np.random.default_rng(2)
    z = rng.uniform(0.8, 6, 400)
    pts = np.c_[rng.uniform(-1, 1, 400) * 0.577 * z, rng.uniform(-1, 1, 400) * 0.4 * z, z]
    assert compact_groups(pts, np.ones(len(pts))) == []


def test_weights_select_the_cluster() -> None:
    rng = np.random.default_rng(3)
    a, b = _blob(rng, [-0.5, 0, 2]), _blob(rng, [0.5, 0, 2])
    pts = np.concatenate([a, b])
    w = np.r_[np.ones(500), np.zeros(500)]
    (g,) = compact_groups(pts, w)
    assert g.mean[0] < -0.4 and g.members[500:].sum() == 0


def test_merge_close_groups() -> None:
    rng = np.random.default_rng(4)
    pts = _blob(rng, [0, 0, 2], 600)
    left = group_from_members(pts, (pts[:, 0] < 0).astype(float))
    right = group_from_members(pts, (pts[:, 0] >= 0).astype(float))
    far = group_from_members(pts + [1.0, 0, 0], np.ones(600))
    assert sorted(map(sorted, merge_close([left, right, far], pts, 0.3))) == [[0, 1], [2]]


def test_merge_close_stacks_a_bodys_parts_but_not_people_side_by_side() -> None:
    """A head 0.6 m above a hand is one person with vertical_m 1.2; two heads 0.6 m apart side by side are two."""
    rng = np.random.default_rng(5)
    head = group_from_members(_blob(rng, [0, -0.3, 2], 200), np.ones(200))
    hand = group_from_members(_blob(rng, [0.1, 0.3, 2], 200), np.ones(200))
    other = group_from_members(_blob(rng, [0.6, -0.3, 2], 200), np.ones(200))
    pts = np.zeros((200, 3))
    assert sorted(map(sorted, merge_close([head, hand, other], pts, 0.3, 1.2))) == [[0, 1], [2]]
    assert sorted(map(sorted, merge_close([head, hand, other], pts, 0.3))) == [[0], [1], [2]]
    with pytest.raises(ValueError, match="vertical_m"):
        merge_close([head, hand], pts, 0.3, 0.0)


def test_a_hand_out_to_the_side_and_below_its_head_is_one_person_a_neighbour_is_not() -> None:
    """An arm reaches out and down: a hand 0.34 m beside its head and 0.25 m below it is merged with reach_per_m 0.3
    (0.29 + 0.3 x 0.25 = 0.37 m), not without it (0.29 m); a neighbour's head 0.34 m away at the same height is
    not merged either way, and the merge is greedy from the deepest pair."""
    rng = np.random.default_rng(6)
    head = group_from_members(_blob(rng, [0, -0.3, 2], 200), np.ones(200))
    hand = group_from_members(_blob(rng, [0.34, -0.05, 2], 200), np.ones(200))
    neighbour = group_from_members(_blob(rng, [-0.34, -0.3, 2], 200), np.ones(200))
    pts = np.zeros((200, 3))
    groups = [head, hand, neighbour]
    assert sorted(map(sorted, merge_close(groups, pts, 0.3, 1.2, 0.3))) == [[0, 1], [2]]
    assert sorted(map(sorted, merge_close(groups, pts, 0.3, 1.2))) == [[0], [1], [2]]
    with pytest.raises(ValueError, match="reach_per_m"):
        merge_close(groups, pts, 0.3, 1.2, -0.1)


def test_the_refinements_body_parameters_are_checked() -> None:
    from avcore.inference import MotionGuidedParams

    with pytest.raises(ValueError, match="body_radius_m"):
        MotionGuidedParams(body_radius_m=0.0)
    with pytest.raises(ValueError, match="merge_vertical_m"):
        MotionGuidedParams(merge_vertical_m=-1.0)
    with pytest.raises(ValueError, match="merge_reach_per_m"):
        MotionGuidedParams(merge_reach_per_m=-0.1)
    assert MotionGuidedParams(body_radius_m=None).body_radius_m is None


def test_a_body_keeps_its_groups_parts_outside_the_cylinder() -> None:
    """A head and a hand held out to the side (one merged group) and a sparse torso no group takes: the body's
    centre is the mean of all three, the hand outside the 0.3 m cylinder around the group included."""
    from avcore.geometry import MicPair
    from avcore.inference import MotionGuidedHearing, MotionGuidedParams

    rng = np.random.default_rng(7)
    head = [0.0, -0.3, 2.0] + rng.normal(0, [0.06, 0.08, 0.05], (150, 3))
    hand = [0.5, 0.1, 2.0] + rng.normal(0, 0.03, (60, 3))
    torso = rng.uniform([-0.17, -0.15, 1.95], [0.17, 0.35, 2.05], (120, 3))
    pts = np.concatenate([head, hand, torso])
    group = group_from_members(pts, np.r_[np.ones(210), np.zeros(120)])
    assert np.hypot(*(hand.mean(axis=0) - group.mean)[::2]) > 0.3  # the hand is outside the cylinder
    centre = MotionGuidedHearing(MicPair(), MotionGuidedParams())._body(pts, np.ones(len(pts)), group).mean
    assert np.linalg.norm(centre - pts.mean(axis=0)) < 0.01
    with pytest.raises(TypeError, match="body_keeps_groups"):
        MotionGuidedParams(body_keeps_groups=1)  # type: ignore[arg-type]


def _strip(rng: np.random.Generator, x: float, n: int = 300, half_width: float = 0.04) -> np.ndarray:
    """Moving points along one vertical edge of a body 2 m away: a strip ``2 half_width`` wide, 0.5 m tall."""
    return np.c_[x + rng.uniform(-half_width, half_width, n), rng.uniform(-0.1, 0.4, n), 2.0 + rng.normal(0, 0.02, n)]


def test_a_body_moving_at_both_sides_is_one_person_its_neighbour_is_not() -> None:
    """A torso swaying gives its two edges, strips 0.33 m apart spanning 0.41 m: one person at width 0.6 m (not
    merged by distance alone, 0.3 m). A neighbour whose moving points fill a body 0.4 m wide, centred 0.55 m away,
    stays apart: the narrowest pair (the two strips) goes first, then the three together span 0.9 m. A strip 0.3 m
    higher is not at one height (merge_close's work)."""
    rng = np.random.default_rng(7)
    neighbour = np.c_[rng.uniform(0.35, 0.75, 300), rng.uniform(-0.1, 0.4, 300), 2.0 + rng.normal(0, 0.02, 300)]
    pts = np.concatenate([_strip(rng, -0.165), _strip(rng, 0.165), neighbour])
    groups = [group_from_members(pts, np.repeat(np.eye(3)[k], 300)) for k in range(3)]
    apart = merge_close(groups, pts, 0.3)
    assert sorted(map(sorted, apart)) == [[0], [1], [2]]
    assert sorted(map(sorted, merge_within_width(groups, pts, apart, 0.6))) == [[0, 1], [2]]
    assert sorted(map(sorted, merge_within_width(groups, pts, apart, 0.35))) == [[0], [1], [2]]
    raised = np.concatenate([pts[:300], pts[300:600] + [0.0, 0.3, 0.0]])
    pair = [group_from_members(raised, np.repeat(np.eye(2)[k], 300)) for k in range(2)]
    assert sorted(map(sorted, merge_within_width(pair, raised, [[0], [1]], 0.6))) == [[0], [1]]
    with pytest.raises(ValueError, match="width_m"):
        merge_within_width(groups, pts, apart, 0.0)


HOLD = dict(radius_m=0.3, half_height_m=1.2, match_m=0.6, min_points=15.0, min_share=0.5, min_contrast=5.0)


def _room(rng: np.random.Generator, n: int) -> np.ndarray:
    z = rng.uniform(0.8, 6, n)
    return np.c_[rng.uniform(-1, 1, n) * 0.577 * z, rng.uniform(-1, 1, n) * 0.4 * z, z]


def test_a_person_the_groups_lost_is_held_where_their_body_still_is() -> None:
    rng = np.random.default_rng(20)
    a, b = _blob(rng, [-0.5, 0.0, 2.0], 300), _blob(rng, [0.6, 0.1, 2.5], 300)
    pts = np.concatenate([a, b, _room(rng, 80)])
    previous = np.array([[-0.5, 0.0, 2.0], [0.55, 0.05, 2.45]])  # b moved 7 cm since
    ((index, mask),) = held_bodies(pts, previous, np.array([300.0, 300.0]), np.array([[-0.49, 0.01, 2.0]]), **HOLD)
    assert index == 1
    assert mask[300:600].mean() > 0.9 and not mask[:300].any()  # b's points, none of a's
    assert mask[600:].sum() <= 3  # the room's outliers a 0.3 m cylinder happens to cross
    np.testing.assert_allclose(pts[mask].mean(axis=0), b.mean(axis=0), atol=0.02)


def test_nobody_is_held_who_left_was_found_or_drifted_away() -> None:
    rng = np.random.default_rng(21)
    a = _blob(rng, [-0.5, 0.0, 2.0], 300)
    room = _room(rng, 80)
    mass = np.array([300.0])
    # left: the cylinder holds the room's few outliers
    assert held_bodies(np.concatenate([a, room]), [[0.6, 0.1, 2.5]], mass, [[-0.5, 0.0, 2.0]], **HOLD) == []
    # found: a current person 0.5 m away horizontally (and 0.9 m below) stands for them
    assert held_bodies(a, [[-0.5, 0.0, 2.0]], mass, [[-0.1, 0.9, 2.3]], **HOLD) == []
    # one current person stands for one previous person: of two side by side, the other is looked for
    two = np.concatenate([a, _blob(rng, [0.0, 0.0, 2.0], 300)])
    ((index, _),) = held_bodies(two, [[-0.5, 0.0, 2.0], [0.0, 0.0, 2.0]], [300.0, 300.0], [[-0.45, 0.0, 2.0]], **HOLD)
    assert index == 1
    # too few points for the mass they had: 40 left of 300
    assert held_bodies(a[:40], [[-0.5, 0.0, 2.0]], mass, np.empty((0, 3)), **HOLD) == []
    assert len(held_bodies(a[:40], [[-0.5, 0.0, 2.0]], [60.0], np.empty((0, 3)), **HOLD)) == 1
    # fewer than min_points whatever the mass
    assert held_bodies(a[:14], [[-0.5, 0.0, 2.0]], [10.0], np.empty((0, 3)), **HOLD) == []


def test_a_held_person_does_not_take_a_current_persons_points_or_wander_off() -> None:
    rng = np.random.default_rng(22)
    q = np.array([0.0, 0.2, 3.0])
    beside = q + [0.7, 0.0, 0.0] + rng.normal(0, [0.2, 0.1, 0.1], (300, 3))  # someone else, 0.7 m away
    # re-centring walks from the first point in reach onto the other body: too far to be the same person
    assert held_bodies(beside, [q], [60.0], np.empty((0, 3)), **HOLD) == []
    assert len(held_bodies(beside, [q], [60.0], np.empty((0, 3)), **{**HOLD, "match_m": 1.0})) == 1
    # found as a current person 0.7 m away, so not standing for q: their points are still not q's
    assert held_bodies(beside, [q], [60.0], [q + [0.7, 0.0, 0.0]], **{**HOLD, "match_m": 0.5}) == []


def test_a_false_person_made_of_outliers_is_not_carried_on() -> None:
    rng = np.random.default_rng(23)
    q = np.array([0.4, 0.0, 3.0])
    field = q + rng.uniform(-1, 1, (1500, 3)) * [0.8, 1.0, 0.8]  # outliers as dense as a crowd's, all around q
    inside = np.hypot(*(field - q)[:, [0, 2]].T) < 0.3
    assert inside.sum() > 30  # enough points, and half of the 30 the false person had
    assert held_bodies(field, [q], [30.0], np.empty((0, 3)), **HOLD) == []
    assert len(held_bodies(field, [q], [30.0], np.empty((0, 3)), **{**HOLD, "min_contrast": 0.0})) == 1
    body = _blob(rng, q, 200)
    assert len(held_bodies(np.concatenate([body, field[::10]]), [q], [150.0], np.empty((0, 3)), **HOLD)) == 1


def test_a_held_person_that_would_be_a_part_of_a_current_one_is_not_held() -> None:
    rng = np.random.default_rng(24)
    walker = np.array([0.35, 0.2, 3.1])
    legs = walker + [-0.05, 0.8, 0.4] + rng.normal(0, [0.08, 0.15, 0.04], (60, 3))  # below and behind the torso
    previous = [walker - [0.1, 0, 0], walker + [-0.05, 0.75, 0.35]]  # the legs were taken for a person
    mass = [300.0, 50.0]
    merge = (0.3, 1.2, 0.3)  # MotionGuidedParams' merge_distance_m, merge_vertical_m, merge_reach_per_m
    assert merge_scores(legs.mean(axis=0), walker, *merge)[0, 0] < 1
    ((index, _),) = held_bodies(legs, previous, mass, [walker], **HOLD)
    assert index == 1
    assert held_bodies(legs, previous, mass, [walker], **HOLD, merge=merge) == []
    # the same legs 1.5 m to the side of the walker are somebody of their own
    beside = [walker + [1.5, 0, 0]]
    assert [i for i, _ in held_bodies(legs, previous, mass, beside, **HOLD, merge=merge)] == [1]
    # and so is a person 0.45 m beside the walker at one height (a merge score of 1.5)
    neighbour = walker + [0.45, 0.0, 0.0] + rng.normal(0, [0.03, 0.1, 0.03], (60, 3))
    assert merge_scores(neighbour.mean(axis=0), walker, *merge)[0, 0] == pytest.approx(1.5, abs=0.1)
    found = held_bodies(neighbour, [walker - [0.1, 0, 0], walker + [0.45, 0, 0]], mass, [walker], **HOLD, merge=merge)
    assert [i for i, _ in found] == [1]


def test_people_side_by_side_lost_together_are_both_held() -> None:
    """Their neighbours' bodies fill each other's ring; a person of the previous interval is not background."""
    rng = np.random.default_rng(25)
    centres = np.array([[-0.55, 0.0, 2.0], [0.0, 0.0, 2.0], [0.55, 0.0, 2.0]])
    pts = np.concatenate([c + rng.uniform(-1, 1, (600, 3)) * [0.21, 0.4, 0.1] for c in centres])
    held = held_bodies(pts, centres, [500.0] * 3, centres[2:], **HOLD)
    assert [i for i, _ in held] == [0, 1]
    for i, mask in held:
        np.testing.assert_allclose(pts[mask].mean(axis=0), centres[i], atol=0.03)


def _disc(n: int, centre: list[float], radius: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` points on a horizontal circle of ``radius`` around ``centre`` (evenly spaced: their mean is the centre)."""
    a = 2 * np.pi * (np.arange(n) + rng.random()) / n
    return np.asarray(centre) + np.c_[radius * np.cos(a), np.zeros(n), radius * np.sin(a)]


@pytest.mark.parametrize(("n_body", "n_ring", "held"), [(50, 30, True), (55, 30, True), (45, 30, False)])
def test_the_density_contrast_at_its_edge(n_body: int, n_ring: int, held: bool) -> None:
    """Held when the cylinder's count is at least 5 times the ring's per cylinder area (the ring is 3 of them)."""
    rng = np.random.default_rng(26)
    q = [0.0, 0.0, 2.0]
    pts = np.concatenate([_disc(n_body, q, 0.05, rng), _disc(n_ring, q, 0.45, rng),
                          _disc(40, q, 0.75, rng)])  # beyond the ring (twice the radius): not counted
    found = held_bodies(pts, [q], [2.0 * n_body], np.empty((0, 3)), **{**HOLD, "min_contrast": 5.0})
    assert len(found) == int(held)
    default = {k: v for k, v in HOLD.items() if k != "min_contrast"}
    assert len(held_bodies(pts, [q], [2.0 * n_body], np.empty((0, 3)), **default)) == int(held)


def test_the_counts_at_their_edges() -> None:
    rng = np.random.default_rng(27)
    q = [0.0, 0.0, 2.0]
    fifteen = _disc(15, q, 0.05, rng)
    assert len(held_bodies(fifteen, [q], [30.0], np.empty((0, 3)), **HOLD)) == 1  # 15 points, half of 30
    assert held_bodies(fifteen, [q], [30.1], np.empty((0, 3)), **HOLD) == []
    assert held_bodies(fifteen[:14], [q], [1.0], np.empty((0, 3)), **HOLD) == []
    # no current person at all: nobody stands for q, and nobody makes it a part
    assert len(held_bodies(fifteen, [q], [30.0], np.empty((0, 3)), **HOLD, merge=(0.3, 1.2, 0.3))) == 1


def test_every_current_person_keeps_their_points_and_so_does_each_person_held() -> None:
    """A lost person 0.45 m behind a person found (whose previous self the found one stands for) would take the found
    one's points if they were free; they are not, before and after another person is held."""
    rng = np.random.default_rng(28)
    a, c = np.array([-1.0, 0.0, 2.0]), np.array([1.0, 0.0, 2.0])
    r = 0.25 * np.sqrt(rng.random(200))
    t = rng.uniform(0, 2 * np.pi, 200)
    crowd = c + np.c_[r * np.cos(t), np.zeros(200), r * np.sin(t)]  # the found person's points
    behind = c + [0.0, 0.0, 0.45]
    hold = {**HOLD, "min_contrast": 0.0}
    # the found person first or last among the current ones
    for current in ([c, a + [0, 0, 3.0]], [a + [0, 0, 3.0], c]):
        assert held_bodies(crowd, [c, behind], [200.0, 20.0], current, **hold) == []
    lone = _disc(40, a, 0.05, rng)  # somebody lost where nobody was found: held first
    held = held_bodies(np.concatenate([lone, crowd]), [a, behind, c], [40.0, 20.0, 200.0], [c], **hold)
    assert [i for i, _ in held] == [0]


def test_current_people_stand_for_the_previous_ones_closest_pairs_first() -> None:
    rng = np.random.default_rng(29)
    previous = np.array([[0.0, 0.0, 2.0], [0.5, 0.0, 2.0]])
    pts = np.concatenate([_disc(60, p, 0.03, rng) for p in previous])
    small = {**HOLD, "radius_m": 0.1, "match_m": 0.35, "min_contrast": 0.0}
    # one person found 0.3 m from the first and 0.2 m from the second stands for the second
    assert [i for i, _ in held_bodies(pts, previous, [60.0, 60.0], [[0.3, 0.0, 2.0]], **small)] == [0]
    # two found, each closest to another previous person than the first pair in the list
    current = np.array([[0.45, 0.0, 2.0], [0.05, 0.0, 2.0]])
    assert held_bodies(pts, previous, [60.0, 60.0], current, **small) == []


def test_the_ring_is_measured_around_where_the_person_is_now() -> None:
    """Re-centred 0.25 m from where they were, the ring around the new centre counts the points by the old one."""
    rng = np.random.default_rng(30)
    q = np.array([0.0, 0.0, 2.0])
    pts = np.concatenate([_disc(50, q + [0.25, 0, 0], 0.02, rng), _disc(36, q - [0.29, 0, 0], 0.005, rng)])
    assert held_bodies(pts, [q], [50.0], np.empty((0, 3)), **HOLD) == []  # 50 < 5 * 36 / 3
    ((_, mask),) = held_bodies(pts[:50], [q], [50.0], np.empty((0, 3)), **HOLD)
    np.testing.assert_allclose(pts[:50][mask].mean(axis=0), q + [0.25, 0, 0], atol=0.01)


def test_merge_scores_follow_merge_closes_ellipse_and_reach() -> None:
    a = np.array([[0.0, 0.0, 2.0]])
    b = np.array([[0.27, 0.6, 2.0], [0.0, 1.2, 2.0], [0.2, 0.0, 2.0]])
    s = merge_scores(a, b, 0.3, 1.2, 0.0)
    np.testing.assert_allclose(s[0, 0], 0.27 / np.sqrt(0.3**2 - (0.6 * 0.3 / 1.2) ** 2))
    assert s[0, 0] > 1 and s[0, 1] == np.inf and s[0, 2] == pytest.approx(0.2 / 0.3)
    np.testing.assert_allclose(merge_scores(a, b, 0.3, 1.2, 0.3)[0, 0],
                               0.27 / (np.sqrt(0.3**2 - (0.6 * 0.3 / 1.2) ** 2) + 0.3 * 0.6))
