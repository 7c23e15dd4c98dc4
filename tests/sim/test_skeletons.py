"""The body families of sim/skeletons.py: geometry, visibility, ground truth and determinism."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from avcore.inference import MotionGuidedParams
from sim.skeletons import FAMILIES, BodyConfig, generate_family
from app.eval.synthetic import score_intervals

SHORT = BodyConfig(n_intervals=4)


@pytest.fixture(scope="module")
def seqs() -> dict[str, list]:
    return {f: generate_family(f, seed=3, config=SHORT) for f in FAMILIES}


def test_same_seed_same_sequence() -> None:
    a = generate_family("close", seed=5, config=SHORT)
    b = generate_family("close", seed=5, config=SHORT)
    c = generate_family("close", seed=6, config=SHORT)
    assert all(np.array_equal(x.points, y.points) and np.array_equal(x.itds, y.itds) for x, y in zip(a, b))
    assert not np.array_equal(a[0].points, c[0].points)


def test_intervals_are_well_formed(seqs: dict[str, list]) -> None:
    for fam, seq in seqs.items():
        assert len(seq) == SHORT.n_intervals, fam
        for it in seq:
            assert it.points.shape[1] == 3 and len(it.point_ids) == len(it.points)
            assert np.all(it.points[:, 2] >= SHORT.outlier_depth_m[0])
            assert len(it.truth_xyz) + len(it.hidden_xyz) == 3
            assert len(it.truth_speaking) == len(it.truth_xyz)


def test_points_are_not_a_blob_around_the_truth() -> None:
    """Seated people's points sit on the head and the hands, above the table, few around the chest (the visible
    body's centre)."""
    table_y = SHORT.camera_height_m - 0.75
    dy = []
    for it in generate_family("seated", seed=3, config=BodyConfig(n_intervals=4, truth_point="body")):
        for g, pid in enumerate(it.truth_ids):
            pts = it.points[it.point_ids == pid]
            good = np.abs(pts[:, 2] - it.truth_xyz[g, 2]) < 0.5  # leave out the wrong stereo matches
            assert np.quantile(pts[good, 1], 0.98) < table_y + 0.05  # nothing below the table top
            dy.extend(pts[good, 1] - it.truth_xyz[g, 1])
    dy = np.array(dy)
    assert (dy < -0.15).mean() > 0.3  # the head, 0.15-0.4 m above the visible body's centre
    assert (dy > 0.1).mean() > 0.15  # the hands on the table
    # a Gaussian of the same vertical spread would put 18 % within 5 cm of its centre
    assert (np.abs(dy) < 0.05).mean() < 0.12


def test_gesturing_hands_move_more_than_the_head() -> None:
    """Hands are farther from the head's points than the head's own spread: points spread over the arms' reach."""
    seq = generate_family("gesturing", seed=1, config=SHORT)
    spans = []
    for it in seq:
        for pid in it.truth_ids:
            pts = it.points[it.point_ids == pid]
            spans.append(np.ptp(np.quantile(pts[:, 0], [0.05, 0.95])))
    assert np.median(spans) > 0.35  # wider than a head or a torso: the hands reach out


def test_truth_is_the_centre_of_the_visible_moving_body_the_visible_body_or_the_head() -> None:
    def first(truth_point: str, family: str = "seated", seed: int = 2) -> np.ndarray:
        return generate_family(family, seed=seed, config=BodyConfig(n_intervals=4, truth_point=truth_point))[0]

    body, head = first("body").truth_xyz, first("head").truth_xyz
    dy = head[:, 1] - body[:, 1]
    # seated behind a table: the visible body's centre is at the chest, 0.15-0.4 m below the head's centre
    assert np.all((dy < -0.15) & (dy > -0.4)), dy
    assert np.allclose(head[:, [0, 2]], body[:, [0, 2]], atol=0.12)
    # the same features whatever the truth: only the truth changes
    assert np.array_equal(first("moving").points, first("body").points)
    # standing still at the edge: the legs are visible but do not move, so the moving body's centre is higher
    # (smaller y, y points down) than the visible body's, and the default
    moving, still = first("moving", "edge", 0), first("body", "edge", 0)
    assert np.all(moving.truth_xyz[:, 1] < still.truth_xyz[:, 1] - 0.1)
    assert np.array_equal(generate_family("edge", seed=0, config=SHORT)[0].truth_xyz, moving.truth_xyz)


def test_the_points_truth_is_the_mean_of_the_persons_feature_distribution() -> None:
    """truth_point="points" (the paper's ground-truth cluster mean) is where a person's own points lie on average;
    the default, texture-free truth lies below them (the points crowd on the hair and the face)."""
    cfg = BodyConfig(n_intervals=10, truth_point="points")
    offsets = {"points": [], "moving": []}
    for it, ref in zip(generate_family("seated", seed=0, config=cfg),
                       generate_family("seated", seed=0, config=replace(cfg, truth_point="moving"))):
        assert np.array_equal(it.points, ref.points)
        for g, pid in enumerate(it.truth_ids):
            own = it.points[it.point_ids == pid].mean(axis=0)
            offsets["points"].append(own - it.truth_xyz[g])
            offsets["moving"].append(own - ref.truth_xyz[g])
    points, moving = np.mean(offsets["points"], axis=0), np.mean(offsets["moving"], axis=0)
    assert np.all(np.abs(points) < 0.015), points
    assert moving[1] < -0.03, moving  # y points down: the points sit above the texture-free truth


def test_a_person_half_outside_the_image_has_a_truth_inside_it() -> None:
    seq = generate_family("edge", seed=0, config=SHORT)
    tan_h = np.tan(np.radians(SHORT.fov_deg[0] / 2))
    for it in seq:
        assert np.all(np.abs(it.truth_xyz[:, 0]) <= it.truth_xyz[:, 2] * tan_h + 1e-9)


def test_the_walker_behind_is_hidden_some_of_the_time() -> None:
    seq = generate_family("behind", seed=0, config=BodyConfig(n_intervals=40))
    counts = [len(it.truth_xyz) for it in seq]
    assert min(counts) == 2 and max(counts) == 3


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match="family"):
        generate_family("dancing")
    with pytest.raises(ValueError, match="seed"):
        generate_family("seated", seed=-1)
    with pytest.raises(ValueError, match="truth_point"):
        BodyConfig(truth_point="feet")
    with pytest.raises(ValueError, match="n_people"):
        BodyConfig(n_people=2)


def test_scoring_runs_on_a_family(seqs: dict[str, list]) -> None:
    score = score_intervals("seated", [(3, seqs["seated"])], MotionGuidedParams(), variant="avhear")
    assert score.totals.n_intervals == SHORT.n_intervals
    assert score.totals.n_truth == sum(len(it.truth_xyz) for it in seqs["seated"])


def test_default_finds_each_body_once_where_the_papers_moments_do_not() -> None:
    """On seated people (few points on heads and hands, outliers in the room) the default's groups are merged into
    one object per body; the paper's alpha-weighted moments are pulled off by the outliers."""
    seq = [(7, generate_family("seated", seed=7, config=BodyConfig(n_intervals=12)))]
    ours = score_intervals("seated", seq, MotionGuidedParams()).totals
    paper = score_intervals("seated", seq, MotionGuidedParams.paper()).totals
    assert ours.visual_tp_rate >= 0.9, ours.as_dict()
    assert ours.fp <= 3, ours.as_dict()
    assert ours.visual_tp_rate > paper.visual_tp_rate and ours.fp < paper.fp
