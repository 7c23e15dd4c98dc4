from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from avcore.geometry import MicPair
from sim.synthetic import (
    SEQUENCES,
    Interval,
    SyntheticConfig,
    format_summaries,
    generate_sequence,
    summarize,
)

SEEDS = (0, 1, 2)


@pytest.fixture(scope="module")
def sequences() -> dict[tuple[str, int], list[Interval]]:
    """Every sequence type for a few seeds, generated once for the module (about 1 s each)."""
    return {(name, seed): generate_sequence(name, seed=seed) for name in SEQUENCES for seed in SEEDS}


def _azimuth_deg(xyz: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(xyz[..., 0], xyz[..., 2]))


def test_same_seed_same_sequence_and_different_seeds_differ() -> None:
    cfg = SyntheticConfig(n_intervals=8)
    for name in SEQUENCES:
        a = generate_sequence(name, seed=3, config=cfg)
        b = generate_sequence(name, seed=3, config=cfg)
        for x, y in zip(a, b):
            for f in ("points", "point_ids", "itds", "itd_ids", "truth_xyz", "truth_speaking", "hidden_xyz"):
                np.testing.assert_array_equal(getattr(x, f), getattr(y, f))
        c = generate_sequence(name, seed=4, config=cfg)
        assert not np.array_equal(a[0].points, c[0].points)
    # One seed, different sequence types: different draws.
    s0 = generate_sequence("StaCon", seed=3, config=cfg)[0].points
    s1 = generate_sequence("DynCon", seed=3, config=cfg)[0].points
    assert s0.shape != s1.shape or not np.allclose(s0, s1)


@pytest.mark.parametrize("name", SEQUENCES)
def test_shapes_and_dtypes(sequences: dict, name: str) -> None:
    seq = sequences[(name, SEEDS[0])]
    cfg = SyntheticConfig()
    assert len(seq) == cfg.n_intervals
    for k, iv in enumerate(seq):
        assert iv.index == k and iv.t_s == pytest.approx(k * 0.4) and iv.interval_s == 0.4
        m, g, h = len(iv.points), len(iv.truth_ids), len(iv.hidden_ids)
        assert iv.points.shape == (m, 3) and iv.points.dtype == np.float64
        assert iv.point_ids.shape == (m,) and iv.point_ids.dtype.kind == "i"
        assert iv.itds.ndim == 1 and iv.itds.dtype == np.float64 and iv.itd_ids.shape == iv.itds.shape
        assert iv.truth_xyz.shape == (g, 3) and iv.truth_speaking.shape == (g,) and iv.truth_speaking.dtype == bool
        assert iv.hidden_xyz.shape == (h, 3) and iv.hidden_speaking.shape == (h,) and iv.hidden_speaking.dtype == bool
        # Every person of the cast is either visible or hidden.
        assert sorted(np.concatenate([iv.truth_ids, iv.hidden_ids]).tolist()) == list(range(cfg.n_people))
        assert np.all(np.diff(iv.truth_ids) > 0)
        assert np.all(np.isfinite(iv.points)) and np.all(np.isfinite(iv.itds))
        # Points come only from visible people (or are outliers).
        assert set(np.unique(iv.point_ids)) <= set(iv.truth_ids.tolist()) | {-1}
        # ITDs come only from people who speak (visible or not) or are outliers.
        talkers = set(iv.truth_ids[iv.truth_speaking].tolist()) | set(iv.hidden_ids[iv.hidden_speaking].tolist())
        assert set(np.unique(iv.itd_ids)) <= talkers | {-1}


def test_interval_arrays_are_read_only(sequences: dict) -> None:
    iv = sequences[("StaCon", SEEDS[0])][0]
    with pytest.raises(ValueError, match="read-only"):
        iv.points[0, 0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        iv.itds = np.zeros(3)  # type: ignore[misc]


def test_paper_statistics(sequences: dict) -> None:
    # Section 7: about 2,000 HM3D points and 20 ITDs per interval of 0.4 s.
    for seed in SEEDS:
        for name in ("StaCon", "DynCon"):
            s = summarize(sequences[(name, seed)])
            assert 1900 < s.mean_points < 2100, (name, seed, s.mean_points)
            assert s.object_intervals == 408  # the paper's 3 x 136
        for name in SEQUENCES:
            s = summarize(sequences[(name, seed)])
            assert 15 < s.mean_itds < 25, (name, seed, s.mean_itds)
            assert 0.05 < s.point_outlier_share < 0.3
            assert 0.08 < s.itd_outlier_share < 0.3
    all_k = np.concatenate([[len(iv.itds) for iv in seq] for seq in sequences.values()])
    assert 18.5 < all_k.mean() < 21.5
    assert all_k.std() > 3  # K varies from interval to interval
    # Speaking about half of the time, pooled over sequences and seeds.
    speaking = np.concatenate([iv.truth_speaking for seq in sequences.values() for iv in seq])
    assert 0.4 < speaking.mean() < 0.6


def test_constant_sequences_keep_three_people_in_view(sequences: dict) -> None:
    for seed in SEEDS:
        for name in ("StaCon", "DynCon"):
            for iv in sequences[(name, seed)]:
                assert iv.truth_ids.tolist() == [0, 1, 2]
                assert iv.hidden_ids.size == 0


def test_varying_sequences_vary_between_one_and_three(sequences: dict) -> None:
    totals = []
    for seed in SEEDS:
        for name in ("StaVar", "DynVar"):
            counts = np.array([len(iv.truth_ids) for iv in sequences[(name, seed)]])
            assert counts.min() >= 1 and counts.max() <= 3
            assert len(np.unique(counts)) >= 2, (name, seed)
            assert any(iv.hidden_ids.size for iv in sequences[(name, seed)])
            totals.append(counts.sum())
    # The paper counts 229 objects in 136 intervals (1.68 per interval).
    assert 1.4 < np.mean(totals) / 136 < 2.2


def test_hidden_people_are_out_of_view_and_can_be_heard(sequences: dict) -> None:
    cfg = SyntheticConfig()
    mics = MicPair()
    deviations = []
    for seed in SEEDS:
        for name in ("StaVar", "DynVar"):
            for iv in sequences[(name, seed)]:
                assert np.all(np.abs(_azimuth_deg(iv.hidden_xyz)) > cfg.visible_azimuth_deg)
                assert np.all(np.abs(_azimuth_deg(iv.truth_xyz)) <= cfg.visible_azimuth_deg)
                for j, i in enumerate(iv.hidden_ids):
                    mine = iv.itds[iv.itd_ids == i]
                    assert iv.hidden_speaking[j] or mine.size == 0
                    deviations.extend(mine - mics.itd(iv.hidden_xyz[j]))
    deviations = np.asarray(deviations)
    assert deviations.size > 200  # people out of view are heard, often
    assert abs(np.mean(deviations)) < 4e-6 and np.std(deviations) < 40e-6


def test_static_sequences_do_not_move_and_dynamic_ones_walk(sequences: dict) -> None:
    for seed in SEEDS:
        for name in ("StaCon", "StaVar"):
            seq = sequences[(name, seed)]
            for pid in range(3):
                where = np.array([iv.truth_xyz[iv.truth_ids == pid][0] for iv in seq if pid in iv.truth_ids])
                if len(where):
                    np.testing.assert_allclose(where - where[0], 0.0, atol=1e-12)
            assert summarize(seq).mean_speed_mps == 0.0
        for name in ("DynCon", "DynVar"):
            speed = summarize(sequences[(name, seed)]).mean_speed_mps
            assert 0.2 < speed < 0.6, (name, seed, speed)


def test_static_people_are_separated_in_itd_space(sequences: dict) -> None:
    mics = MicPair()
    for seed in SEEDS:
        itd = np.sort(mics.itd(sequences[("StaCon", seed)][0].truth_xyz))
        assert np.all(np.diff(itd) > 60e-6)


def test_dynamic_people_sometimes_cross_in_itd_space(sequences: dict) -> None:
    mics = MicPair()
    close = [
        np.min(np.diff(np.sort(mics.itd(iv.truth_xyz)))) < 40e-6 for seed in SEEDS for iv in sequences[("DynCon", seed)]
    ]
    assert 0.02 < np.mean(close) < 0.5


def test_truth_is_the_centre_of_each_persons_points(sequences: dict) -> None:
    cfg = SyntheticConfig()
    for (name, seed), seq in sequences.items():
        for iv in seq[::5]:
            for g, pid in enumerate(iv.truth_ids):
                mine = iv.points[iv.point_ids == pid]
                assert 400 < len(mine) < 700
                assert np.linalg.norm(mine.mean(axis=0) - iv.truth_xyz[g]) < 0.06, (name, seed, iv.index, pid)
                spread = mine.std(axis=0)
                assert spread[0] < spread[1]  # taller than wide
                assert 0.08 < spread[0] < 0.3 and 0.15 < spread[1] < 0.35
            assert cfg.depth_m[0] - 0.1 < np.min(iv.truth_xyz[:, 2], initial=np.inf) or iv.truth_xyz.size == 0


def test_points_stay_in_the_field_of_view(sequences: dict) -> None:
    cfg = SyntheticConfig()
    tan_h = math.tan(math.radians(cfg.fov_deg[0] / 2))
    tan_v = math.tan(math.radians(cfg.fov_deg[1] / 2))
    for seq in sequences.values():
        pts = np.concatenate([iv.points for iv in seq])
        z = pts[:, 2]
        assert np.all(z >= cfg.outlier_depth_m[0])
        assert np.all(np.abs(pts[:, 0]) <= z * tan_h + 1e-12)
        assert np.all(np.abs(pts[:, 1]) <= z * tan_v + 1e-12)


def test_projected_outlier_points_are_not_uniform_in_itd_space(sequences: dict) -> None:
    # Section 7: 3D outliers uniform in the frustum do not project uniformly onto ITD space. They fill only the
    # ITDs of the field of view, and more densely near its edges: at each depth x is uniform, so the azimuth is
    # uniform in tan, and the ITD ~ sin(azimuth) packs the wide edge strips into fewer microseconds.
    mics = MicPair()
    pts = np.concatenate([iv.points[iv.point_ids < 0] for iv in sequences[("StaCon", SEEDS[0])]])
    itd = mics.itd(pts)
    lo, hi = mics.itd_interval()
    assert itd.min() > lo / 2 and itd.max() < hi / 2  # 30 degrees -> sin(30) = 0.5 of the interval
    hist, _ = np.histogram(itd, bins=8, range=(lo / 2, hi / 2))
    assert hist[[0, -1]].mean() > 1.1 * hist[3:5].mean()


def test_itds_lie_in_the_itd_interval_and_follow_their_speaker(sequences: dict) -> None:
    mics = MicPair()
    lo, hi = mics.itd_interval()
    deviations = []
    for seq in sequences.values():
        for iv in seq:
            assert np.all((iv.itds >= lo) & (iv.itds <= hi))
            for g, pid in enumerate(iv.truth_ids):
                mine = iv.itds[iv.itd_ids == pid]
                deviations.extend(mine - mics.itd(iv.truth_xyz[g]))
            if not (iv.truth_speaking.any() or iv.hidden_speaking.any()):
                assert np.all(iv.itd_ids == -1)
    deviations = np.asarray(deviations)
    assert abs(np.mean(deviations)) < 3e-6
    assert 18e-6 < np.std(deviations) < 40e-6  # 25 us plus the walk within the interval


def test_itd_sign_follows_the_speakers_side_and_the_mic_pair() -> None:
    cfg = SyntheticConfig(n_intervals=40, speaking_share=0.9, itd_outlier_fraction=0.0)
    seq = generate_sequence("StaCon", seed=5, config=cfg)
    rights = [
        iv.itds[iv.itd_ids == pid] for iv in seq for g, pid in enumerate(iv.truth_ids) if iv.truth_xyz[g, 0] > 0.3
    ]
    lefts = [
        iv.itds[iv.itd_ids == pid] for iv in seq for g, pid in enumerate(iv.truth_ids) if iv.truth_xyz[g, 0] < -0.3
    ]
    assert np.median(np.concatenate(rights)) > 0 > np.median(np.concatenate(lefts))
    # The generator uses the given microphones: an offset c0 shifts every speaker's ITDs.
    shifted = generate_sequence("StaCon", seed=5, config=cfg, mics=MicPair(c0=1e-4))
    a = np.concatenate([iv.itds for iv in seq])
    b = np.concatenate([iv.itds for iv in shifted])
    assert np.mean(b - a) == pytest.approx(1e-4, abs=1e-6)


def test_config_changes_the_statistics() -> None:
    cfg = SyntheticConfig(n_intervals=6, points_per_person=0.0, outlier_points=100.0, itds_when_speaking=0.0,
                          itds_when_silent=0.0)
    seq = generate_sequence("DynCon", seed=0, config=cfg)
    assert len(seq) == 6
    assert all(np.all(iv.point_ids == -1) for iv in seq)
    assert all(iv.itds.size == 0 for iv in seq)
    assert 60 < np.mean([len(iv.points) for iv in seq]) < 140


def test_summary_and_table(sequences: dict) -> None:
    s = summarize(sequences[("StaCon", SEEDS[0])], "StaCon")
    assert s.name == "StaCon" and s.n_intervals == 136
    assert (s.min_visible, s.max_visible) == (3, 3)
    table = format_summaries([summarize(sequences[(n, SEEDS[0])], n) for n in SEQUENCES])
    assert len(table.splitlines()) == 5 and "DynVar" in table
    with pytest.raises(ValueError, match="at least one Interval"):
        summarize([])


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_intervals": 0}, "n_intervals must be a positive integer, got 0"),
        ({"n_intervals": 2.5}, "n_intervals"),
        ({"interval_s": -0.4}, "interval_s must be a positive"),
        ({"speaking_share": 1.0}, "speaking_share must be a fraction"),
        ({"depth_m": (3.5, 1.5)}, "depth_m must be a tuple"),
        ({"body_sigma_m": (0.1, 0.2)}, "body_sigma_m"),
        ({"fov_deg": (200.0, 45.0)}, "fov_deg"),
        ({"visible_azimuth_deg": 40.0}, "visible_azimuth_deg"),
        ({"away_azimuth_deg": (20.0, 50.0)}, "away_azimuth_deg must start beyond"),
        ({"min_separation_deg": 30.0}, "do not fit"),
        ({"points_per_person": float("nan")}, "points_per_person"),
    ],
)
def test_bad_config_raises(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SyntheticConfig(**kwargs)


def test_bad_arguments_raise() -> None:
    with pytest.raises(ValueError, match="name must be one of StaCon, DynCon, StaVar, DynVar, got 'Static'"):
        generate_sequence("Static")
    with pytest.raises(ValueError, match="seed must be a non-negative integer, got -1"):
        generate_sequence("StaCon", seed=-1)
    with pytest.raises(TypeError, match="mics must be a MicPair"):
        generate_sequence("StaCon", mics=(0.12, 343.0))  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="config must be a SyntheticConfig"):
        generate_sequence("StaCon", config={"n_intervals": 3})  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="StaVar needs config.n_people >= 2"):
        generate_sequence("StaVar", config=SyntheticConfig(n_people=1))
