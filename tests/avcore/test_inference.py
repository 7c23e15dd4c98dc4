from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from avcore.geometry import MicArray, MicPair
from avcore.inference import (
    FaceGuidedHearing,
    FaceGuidedParams,
    MotionGuidedHearing,
    MotionGuidedParams,
    speaking_threshold,
)
from avcore.mixture import ConvergenceWarning, EMSettings, Mixture1D
from avcore.speaking import SpeakingTest

MICS = MicPair()
PEOPLE = np.array([[-0.8, 0.0, 2.0], [0.0, 0.1, 2.5], [0.9, -0.1, 2.2]])


def _interval(rng: np.random.Generator, people: np.ndarray = PEOPLE, speaker: int | None = 0, n_per: int = 550,
              n_out: int = 250, n_itd: int = 16, n_itd_out: int = 4) -> tuple[np.ndarray, np.ndarray]:
    pts = [p + rng.normal(0, [0.12, 0.25, 0.07], (n_per, 3)) for p in people]
    z = rng.uniform(0.8, 6, n_out)
    x = rng.uniform(-1, 1, n_out) * z * np.tan(np.radians(30))
    y = rng.uniform(-1, 1, n_out) * z * np.tan(np.radians(22))
    pts.append(np.c_[x, y, z])
    itds = [rng.uniform(-350e-6, 350e-6, n_itd_out)]
    if speaker is not None:
        itds.append(rng.normal(MICS.itd(people[speaker]), 25e-6, n_itd))
    return np.concatenate(pts), np.concatenate(itds)


def _nearest(found: np.ndarray, truth: np.ndarray) -> np.ndarray:
    return np.linalg.norm(found[:, None] - truth[None], axis=2).min(axis=0)


@pytest.mark.parametrize("params", [MotionGuidedParams(), MotionGuidedParams.paper()], ids=["avhear", "paper"])
def test_motion_guided_finds_three_people_and_the_speaker(params: MotionGuidedParams) -> None:
    rng = np.random.default_rng(0)
    mg = MotionGuidedHearing(MICS, params)
    for _ in range(3):
        out = mg.step(*_interval(rng))
    assert out.n == 3
    errors = _nearest(out.positions, PEOPLE)
    assert np.all(errors < (0.05 if params.refine_3d else 0.35))  # paper: within tau_loc
    order = np.argsort(out.positions[:, 0])
    assert out.speaking[order].tolist() == [True, False, False]
    assert out.probability[order][0] > 0.5 > out.probability[order][1]
    assert out.covariances.shape == (3, 3, 3)
    assert out.bic.shape == (params.n_max + 1,) and out.n_selected == int(np.argmax(out.bic))
    assert mg.previous_ is not None and mg.previous_.n_components == 3


def test_refinement_removes_outlier_bias_of_the_paper_estimate() -> None:
    errs = {}
    for name, params in [("avhear", MotionGuidedParams()), ("paper", MotionGuidedParams.paper())]:
        rng = np.random.default_rng(1)
        mg = MotionGuidedHearing(MICS, params)
        e = []
        for _ in range(4):
            out = mg.step(*_interval(rng))
            e.extend(_nearest(out.positions, PEOPLE))
        errs[name] = np.mean(e)
    assert errs["avhear"] < 0.03
    assert errs["avhear"] < errs["paper"] / 2


def test_people_crossing_in_itd_space_are_split_in_3d() -> None:
    # two people on the same bearing, one behind the other: one cluster in ITD space
    people = np.array([[0.3, 0.0, 1.5], [0.6, 0.0, 3.0]])
    assert abs(MICS.itd(people[0]) - MICS.itd(people[1])) < 2e-6
    rng = np.random.default_rng(2)
    pts, itds = _interval(rng, people, speaker=None)
    ours = MotionGuidedHearing(MICS).step(pts, itds)
    assert ours.n == 2 and np.all(_nearest(ours.positions, people) < 0.05)
    # the paper's moments (eq. hat_svect) average the two people into one position
    paper = MotionGuidedHearing(MICS, MotionGuidedParams.paper()).step(pts, itds)
    assert np.count_nonzero(_nearest(paper.positions, people) < 0.1) <= 1


def test_nobody_speaking_with_outlier_itds() -> None:
    rng = np.random.default_rng(3)
    fires = {"avhear": 0, "paper": 0}
    for name, params in [("avhear", MotionGuidedParams()), ("paper", MotionGuidedParams.paper())]:
        mg = MotionGuidedHearing(MICS, params)
        for _ in range(10):
            out = mg.step(*_interval(rng, speaker=None, n_itd_out=5))
            fires[name] += int(out.speaking.sum())
    assert fires["avhear"] == 0
    assert fires["avhear"] <= fires["paper"]


def test_motion_guided_degenerate_inputs() -> None:
    mg = MotionGuidedHearing(MICS)
    out = mg.step(np.empty((0, 3)), np.array([1e-4, 2e-4]))
    assert out.n == 0 and out.positions.shape == (0, 3) and out.covariances.shape == (0, 3, 3)
    rng = np.random.default_rng(4)
    pts, _ = _interval(rng)
    out = mg.step(pts, np.empty(0))  # no ITDs: people found, nobody speaks
    assert out.n == 3 and not out.speaking.any()
    # only outliers (as many as a busy interval's outliers): no person
    z = rng.uniform(0.8, 6, 500)
    only_out = np.c_[rng.uniform(-1, 1, 500) * z * 0.577, rng.uniform(-1, 1, 500) * z * 0.4, z]
    out = MotionGuidedHearing(MICS).step(only_out, np.empty(0))
    assert out.n == 0
    # duplicates: many identical points make one tight person, no NaN
    dup = np.repeat([[0.2, 0.0, 2.0]], 300, axis=0)
    out = MotionGuidedHearing(MICS).step(dup, np.empty(0))
    assert out.n == 1 and np.allclose(out.positions[0], [0.2, 0.0, 2.0])


def test_motion_guided_bad_inputs() -> None:
    mg = MotionGuidedHearing(MICS)
    with pytest.raises(ValueError, match=r"points_xyz must be an \(n, 3\) array"):
        mg.step(np.zeros((5, 2)), np.zeros(2))
    with pytest.raises(ValueError, match="NaN"):
        mg.step(np.array([[0.0, 0.0, np.nan]]), np.zeros(2))
    with pytest.raises(ValueError, match=r"itds_s must have one column per pair \(1\)"):
        mg.step(np.zeros((5, 3)), np.zeros((3, 2)))
    with pytest.raises(TypeError, match="MicPair"):
        MotionGuidedHearing("mics")  # type: ignore[arg-type]


def test_face_guided_speaker_and_threshold() -> None:
    rng = np.random.default_rng(5)
    fg = FaceGuidedHearing(MICS)
    _, itds = _interval(rng, speaker=2)
    out = fg.step(PEOPLE, itds)
    assert out.speaking.tolist() == [False, False, True]
    assert out.probability[2] > 0.5 and np.all(out.probability[:2] < 0.5)
    assert np.all((out.probability >= 0) & (out.probability <= 1))
    assert out.tau_a == pytest.approx(itds.size / 5)
    assert speaking_threshold(20, 3) == pytest.approx(4.0)
    # anchored means stay at the faces
    np.testing.assert_allclose(out.itd_means, MICS.itd(PEOPLE))


def test_face_guided_anchoring_resists_an_unseen_talker() -> None:
    # the only talker is outside the field of view, 60 us to the right of the rightmost face
    rng = np.random.default_rng(6)
    faces = PEOPLE[:2]
    itds = rng.normal(MICS.itd(faces[1]) + 70e-6, 10e-6, 18)
    anchored = FaceGuidedHearing(MICS).step(faces, itds)
    free = FaceGuidedHearing(MICS, FaceGuidedParams.paper()).step(faces, itds)
    assert not anchored.speaking[1]
    assert free.speaking[1]  # free means walk to the unseen talker
    assert abs(free.itd_means[1] - MICS.itd(faces[1])) > 40e-6


def test_face_guided_degenerate_and_bad_inputs() -> None:
    fg = FaceGuidedHearing(MICS)
    out = fg.step(PEOPLE, np.empty(0))
    assert out.speaking.tolist() == [False] * 3 and np.all(out.probability == 0)
    out = fg.step(np.empty((0, 3)), np.array([1e-4]))
    assert out.speaking.shape == (0,) and out.probability.shape == (0,)
    with pytest.raises(ValueError, match="faces_xyz"):
        fg.step(np.zeros(3), np.zeros(1))
    with pytest.raises(ValueError, match="NaN"):
        fg.step(PEOPLE, np.array([np.nan]))


def test_face_guided_decides_on_the_itds_near_the_frame() -> None:
    """The ITDs of the whole time frame fit the model; only those near the frame's instant decide (the talker
    stopped 0.15 s before this frame: the paper's way still calls them speaking)."""
    rng = np.random.default_rng(7)
    assert FaceGuidedParams().decision_window_s is None  # the paper's way by default
    fg = FaceGuidedHearing(MICS, FaceGuidedParams(decision_window_s=0.1))
    itds = rng.normal(MICS.itd(PEOPLE[0]), 10e-6, 8)
    before = np.linspace(-0.2, -0.15, itds.size)  # window centres relative to the frame's stamp
    assert fg.step(PEOPLE, itds).speaking.tolist() == [True, False, False]  # no times: every ITD decides
    late = fg.step(PEOPLE, itds, before)
    assert late.speaking.tolist() == [False, False, False]
    np.testing.assert_allclose(late.itd_counts, fg.step(PEOPLE, itds).itd_counts)  # the same fit
    assert fg.step(PEOPLE, itds, before + 0.1).speaking.tolist() == [True, False, False]
    paper = FaceGuidedHearing(MICS, FaceGuidedParams.paper())
    assert paper.params.decision_window_s is None and paper.step(PEOPLE, itds, before).speaking[0]
    with pytest.raises(ValueError, match="one time per ITD"):
        fg.step(PEOPLE, itds, before[:3])
    with pytest.raises(ValueError, match="decision_window_s"):
        FaceGuidedParams(decision_window_s=0.0)


@pytest.mark.parametrize("seed", [0, 3])
def test_face_guided_counts_each_itd_for_the_nearest_face(seed: int) -> None:
    """Two faces 20 us apart in ITD, both talking: EM hands most of the weight, and so of the posteriors, to one of
    them; counted by posterior the other is silent, counted for the nearest face both speak."""
    faces = np.array([[0.3, 0.0, 2.0], [0.42, 0.0, 2.0], [-0.8, 0.0, 2.0]])
    mu = MICS.itd(faces)
    assert 15e-6 < mu[1] - mu[0] < 25e-6
    rng = np.random.default_rng(seed)
    itds = np.concatenate([rng.normal(mu[0], 8e-6, 9), rng.normal(mu[1], 8e-6, 7)])
    posterior = FaceGuidedParams(speaking=SpeakingTest(count_by="posterior"))
    by_posterior = FaceGuidedHearing(MICS, posterior).step(faces, itds)
    assert by_posterior.model.weights[1] < 0.2 and by_posterior.speaking.tolist() == [True, False, False]
    nearest = FaceGuidedHearing(MICS).step(faces, itds)
    assert nearest.speaking.tolist() == [True, True, False]
    with pytest.raises(ValueError, match="count_by"):
        SpeakingTest(count_by="loudest")


def test_face_guided_em_warns_when_it_does_not_converge_and_reports_its_final_model() -> None:
    """Algorithm 2's EM is the shared engine: a run cut at max_iter warns, and the ITD counts are the posteriors of
    the model it returns (eq. beta_kn), not of the iteration before."""
    from avcore.mixture import ConvergenceWarning, EMSettings

    mics = MicPair()
    rng = np.random.default_rng(5)
    faces = np.array([[-0.6, 0.0, 2.0], [0.5, 0.0, 2.0]])
    itds = np.concatenate([rng.normal(mics.itd(faces[0]), 40e-6, 30), rng.uniform(-5e-4, 5e-4, 30)])
    short = replace(FaceGuidedParams.paper(), em=EMSettings(max_iter=2, tol=1e-12))
    with pytest.warns(ConvergenceWarning, match="face-guided EM"):
        out = FaceGuidedHearing(mics, short).step(faces, itds)
    assert out.n_iter == 2
    assert out.itd_counts == pytest.approx(out.model.responsibilities(itds)[:, :-1].sum(axis=0), rel=1e-9)
    assert not np.allclose(out.itd_means, mics.itd(faces))  # the paper's means move with EM
    anchored = FaceGuidedHearing(mics).step(faces, itds)
    assert np.array_equal(anchored.itd_means, mics.itd(faces))


# ---------------------------------------------------------------------------------------------------------------
# several microphone pairs

FOUR_MICS = MicArray(((-0.06, 0.0, 0.0), (0.06, 0.0, 0.0), (0.0, 0.0, 0.05), (0.0, 0.0, -0.05)),
                     pairs=((0, 1), (3, 2)))  # left-right, and back-front


def test_two_pairs_tell_a_talker_behind_the_robot_from_the_face_in_front() -> None:
    """A talker behind the robot, unseen, on the left: the left-right pair alone gives the same ITD as the face in
    front on that side (front/back ambiguity), so one pair judges that face speaking; the back-front pair tells
    them apart."""
    rng = np.random.default_rng(7)
    faces = np.array([[-1.0, 0.0, 1.0], [1.0, 0.0, 1.5]])
    behind = np.array([-1.0, 0.0, -1.0])
    itds = FOUR_MICS.itd(behind) + rng.normal(0.0, 10e-6, (25, 2))
    one = FaceGuidedHearing(FOUR_MICS.pair(0)).step(faces, itds[:, 0])
    assert one.speaking[0], "the left-right pair alone cannot tell front from back"
    both = FaceGuidedHearing(FOUR_MICS).step(faces, itds)
    assert not both.speaking.any()
    assert both.pair_itd_means.shape == (2, 2)
    assert np.allclose(both.pair_itd_means, FOUR_MICS.itd(faces))
    # the face in front that really talks is found with both pairs
    front = FOUR_MICS.itd(faces[0]) + rng.normal(0.0, 10e-6, (25, 2))
    assert FaceGuidedHearing(FOUR_MICS).step(faces, front).speaking.tolist() == [True, False]


def test_pairs_accept_unaligned_itds_and_missing_pairs() -> None:
    """A sequence of P arrays (not aligned across pairs) counts each value on its own pair; NaN marks a pair a
    window has no ITD for; the wrong number of pairs is a ValueError naming the argument."""
    faces = np.array([[-1.0, 0.0, 1.0], [1.0, 0.0, 1.5]])
    rng = np.random.default_rng(8)
    mu = FOUR_MICS.itd(faces[1])
    fg = FaceGuidedHearing(FOUR_MICS)
    out = fg.step(faces, [mu[0] + rng.normal(0, 1e-5, 20), mu[1] + rng.normal(0, 1e-5, 12)])
    assert out.speaking.tolist() == [False, True]
    vectors = mu + rng.normal(0, 1e-5, (20, 2))
    vectors[::2, 1] = np.nan
    assert fg.step(faces, vectors).speaking.tolist() == [False, True]
    with pytest.raises(ValueError, match="itds_s"):
        fg.step(faces, np.zeros((4, 3)))


def test_one_pair_array_is_the_pair() -> None:
    """A MicArray of one pair gives exactly what its MicPair gives."""
    rng = np.random.default_rng(9)
    itds = np.concatenate([rng.normal(MICS.itd(PEOPLE[0]), 25e-6, 16), rng.uniform(-3e-4, 3e-4, 6)])
    a = FaceGuidedHearing(MicArray.from_pair(MICS)).step(PEOPLE, itds)
    b = FaceGuidedHearing(MICS).step(PEOPLE, itds)
    assert np.array_equal(a.speaking, b.speaking) and np.array_equal(a.probability, b.probability)


def test_motion_guided_with_two_pairs_tells_a_talker_behind_from_a_person_in_front() -> None:
    """Algorithm 1 finds the people on the first pair; with the array, who speaks is decided on every pair, so the
    talker behind the robot no longer makes the person in front on that side speak."""
    rng = np.random.default_rng(11)
    people = np.array([[-1.0, 0.0, 1.0], [1.0, 0.0, 1.5]])
    points = np.concatenate([p + rng.normal(0.0, [0.08, 0.15, 0.06], (700, 3)) for p in people])
    behind = FOUR_MICS.itd(np.array([-1.0, 0.0, -1.0])) + rng.normal(0.0, 10e-6, (25, 2))
    one = MotionGuidedHearing(FOUR_MICS.pair(0)).step(points, behind[:, 0])
    both = MotionGuidedHearing(FOUR_MICS).step(points, behind)
    assert one.positions.shape[0] == both.positions.shape[0] == 2
    np.testing.assert_allclose(both.positions, one.positions)
    left = int(np.argmin(one.positions[:, 0]))
    assert one.speaking[left] and not both.speaking.any()


@pytest.mark.parametrize("params", [MotionGuidedParams(), MotionGuidedParams.paper()], ids=["avhear", "paper"])
def test_algorithm_1_selects_n_by_the_papers_bic(params: MotionGuidedParams, monkeypatch: pytest.MonkeyPatch) -> None:
    """Eq. (criteria): BIC_N = L_N - D_N log(M + K) / 2 with D_N = 3 N. The log-likelihoods the algorithm scores are
    taken where it scores them; its BIC and its choice of N must be that formula's, written out here (a penalty of
    1.0 or 3.0 instead of 1.5 changes the chosen N on these intervals)."""
    import avcore.inference as inference

    seen: list[tuple[np.ndarray, np.ndarray, int]] = []
    real = inference.bic_score

    def spy(ll, n, m):  # noqa: ANN001, ANN202
        seen.append((np.array(ll, dtype=float), np.array(n), int(m)))
        return real(ll, n, m)

    monkeypatch.setattr(inference, "bic_score", spy)
    for seed in (1, 3):
        pts, itds = _interval(np.random.default_rng(seed), n_per=150)
        out = MotionGuidedHearing(MICS, params).step(pts, itds)
        ll, n, m = seen[-1]
        assert m == pts.shape[0] + itds.size  # M + K: every point and every ITD of the interval
        width = MICS.itd_interval()[1] - MICS.itd_interval()[0]
        assert ll[0] == pytest.approx(m * np.log(1.0 / width), rel=1e-12)  # N = 0: all outliers, 1/s densities
        np.testing.assert_array_equal(n, np.arange(params.n_max + 1))
        expected = ll - 3 * n * np.log(pts.shape[0] + itds.size) / 2
        np.testing.assert_allclose(out.bic, expected, rtol=0, atol=1e-9)
        assert out.n_selected == int(np.argmax(expected))


def test_the_clusters_moments_are_the_alpha_weighted_mean_and_covariance() -> None:
    """Eq. (hat_svect): each cluster's mean and covariance weighted by the points' posteriors, against numpy's own
    weighted average and (population) covariance; a cluster with no weight gets zeros, not a division by zero."""
    from avcore.inference import _weighted_moments

    rng = np.random.default_rng(5)
    points = rng.normal(0.0, 1.0, (40, 3)) * [0.3, 0.5, 0.2] + [0.1, -0.2, 2.0]
    alpha = np.column_stack([rng.uniform(0, 1, 40), rng.uniform(0, 1, 40) ** 3, np.zeros(40),
                             np.r_[0.3, 0.2, np.zeros(38)]])  # the last: half a point in all
    means, cov, abar = _weighted_moments(points, alpha)
    np.testing.assert_allclose(abar, alpha.sum(axis=0))
    for n in (0, 1, 3):
        np.testing.assert_allclose(means[n], np.average(points, axis=0, weights=alpha[:, n]), rtol=1e-12)
        np.testing.assert_allclose(cov[n], np.cov(points.T, aweights=alpha[:, n], bias=True), rtol=1e-10, atol=1e-14)
    assert np.all(means[2] == 0) and np.all(cov[2] == 0)


def test_the_papers_methods_are_the_papers() -> None:
    """The evaluations compare avcore's defaults with these (the "paper's method" columns): Algorithm 1 with the
    moments of eq. (hat_svect) alone (no 3D refinement), candidates started afresh, the plain threshold test
    tau_A = K / (N + 2); Algorithm 2 with free means and adapting variances and the plain test. Each differs from
    the default in what the docs say the default adds."""
    motion, motion_default = MotionGuidedParams.paper(), MotionGuidedParams()
    assert motion.refine_3d is False and motion.warm_start_candidates is False
    assert motion.speaking.outlier_aware is False
    assert (motion_default.refine_3d, motion_default.warm_start_candidates,
            motion_default.speaking.outlier_aware) == (True, True, True)
    face = FaceGuidedParams.paper()
    assert face.anchor_means is False and face.update_variances is True and face.speaking.outlier_aware is False
    assert face.var_max_s2 == 1.0 and face.var_min_s2 == EMSettings().var_floor_s2


def test_an_interval_without_moving_points_has_nobody_in_it() -> None:
    """No HM3D points: no audio-visual object can be formed (the model is vision-guided): zero people in arrays of
    the right shapes and types, the outliers-only model, every candidate's BIC 0 and N = 0 chosen, and the paper's
    threshold for the interval's ITDs with no person (K / 2)."""
    hearing = MotionGuidedHearing(MicPair())
    out = hearing.step(np.zeros((0, 3)), np.array([1e-4, -2e-4, 3e-5, 5e-5]))
    assert out.n == 0 and out.positions.shape == (0, 3) and out.covariances.shape == (0, 3, 3)
    assert out.speaking.dtype == bool and out.speaking.shape == (0,)
    for name in ("probability", "itd_means", "itd_counts", "point_counts"):
        assert getattr(out, name).shape == (0,), name
    assert out.model.n_components == 0 and out.model.weights.tolist() == [1.0]
    assert out.bic.tolist() == [0.0] * (hearing.params.n_max + 1) and out.n_selected == 0
    assert out.tau_a == pytest.approx(4 / 2)


def _blob(rng: np.random.Generator, centre: list[float], n: int, sd: tuple[float, float, float]) -> np.ndarray:
    return np.asarray(centre) + rng.normal(0.0, 1.0, (n, 3)) * sd


def test_one_cluster_holding_two_people_becomes_two_objects_with_their_share_of_it() -> None:
    """Two people on one bearing (one ITD cluster) at 1.5 and 3 m: each becomes an object at its own points, with
    the cluster's weight in proportion to its mass, the ITDs' posterior shared by the people's own 1-D densities
    (mass / sd x their Gaussian), and its own component (its points' ITD moments) for the next interval."""
    rng = np.random.default_rng(21)
    near, far = _blob(rng, [0.3, 0.0, 1.5], 300, (0.06, 0.12, 0.04)), _blob(rng, [0.6, 0.0, 3.0], 200, (0.06, 0.12, 0.04))
    pts = np.concatenate([near, far])
    v = MICS.itd(pts)
    a = MICS.itd(near[:8])  # ITDs from the near person's direction
    alpha = np.ones((pts.shape[0], 1))
    beta = np.linspace(0.5, 0.9, a.size)[:, None]
    model = Mixture1D(np.array([0.7, 0.3]), [float(v.mean())], [float(v.var())], MICS.itd_interval())
    mg = MotionGuidedHearing(MICS)
    positions, cov, mass, betas, new = mg._refine(pts, v, a, alpha, beta, model)
    assert positions.shape == (2, 3) and cov.shape == (2, 3, 3) and betas.shape == (a.size, 2)
    order = np.argsort(positions[:, 2])
    positions, mass, betas = positions[order], mass[order], betas[:, order]
    means, variances = new.means[order], new.variances[order]
    for j, blob in enumerate((near, far)):
        assert np.linalg.norm(positions[j] - blob.mean(axis=0)) < 0.01
        assert mass[j] == pytest.approx(blob.shape[0], rel=0.05)  # the kernel truncates a few outer points
        itds = MICS.itd(blob)
        assert means[j] == pytest.approx(itds.mean(), abs=0.5e-6)
        assert variances[j] == pytest.approx(itds.var(), rel=0.15)  # less the truncated outer points
    assert new.weights[order] == pytest.approx(0.7 * mass / pts.shape[0], rel=1e-12)
    assert new.weights[-1] == pytest.approx(1.0 - new.weights[:-1].sum(), rel=1e-12)
    np.testing.assert_allclose(betas.sum(axis=1), beta[:, 0], rtol=1e-12)
    dens = mass / np.sqrt(variances) * np.exp(-0.5 * (a[:, None] - means) ** 2 / variances)
    np.testing.assert_allclose(betas / beta, dens / dens.sum(axis=1, keepdims=True), rtol=1e-9)
    assert variances[0] > variances[1]  # the nearer person spans more ITD


def test_a_head_and_a_body_in_two_clusters_are_one_person_with_both_shares() -> None:
    """Two clusters whose groups are stacked (a head above a torso, within merge_vertical_m): one object, placed at
    the body's centre, with the sum of the clusters' ITD posteriors and weights."""
    rng = np.random.default_rng(22)
    head, torso = _blob(rng, [0.2, -0.45, 2.0], 150, (0.05, 0.05, 0.04)), _blob(rng, [0.2, 0.0, 2.0], 250,
                                                                                (0.08, 0.15, 0.05))
    pts = np.concatenate([head, torso])
    v = MICS.itd(pts)
    alpha = np.zeros((pts.shape[0], 2))
    alpha[:150, 0], alpha[150:, 1] = 1.0, 1.0
    a = MICS.itd(head[:6])
    beta = np.column_stack([np.full(a.size, 0.6), np.full(a.size, 0.3)])
    model = Mixture1D(np.array([0.3, 0.5, 0.2]), [float(v[:150].mean()), float(v[150:].mean())],
                      [float(v[:150].var()) + 1e-12, float(v[150:].var()) + 1e-12], MICS.itd_interval())
    positions, _, mass, betas, new = MotionGuidedHearing(MICS)._refine(pts, v, a, alpha, beta, model)
    assert positions.shape == (1, 3) and new.n_components == 1
    assert np.linalg.norm(positions[0] - pts.mean(axis=0)) < 0.02  # both parts' points: the body's centre
    assert mass[0] == pytest.approx(400, rel=0.05)
    np.testing.assert_allclose(betas[:, 0], 0.9, rtol=1e-12)
    assert new.weights[0] == pytest.approx(0.8, rel=0.05) and new.weights[1] == pytest.approx(1 - new.weights[0])
    nothing = MotionGuidedHearing(MICS)._refine(pts, v, a, np.zeros_like(alpha), beta, model)
    assert [x.shape for x in nothing[:4]] == [(0, 3), (0, 3, 3), (0,), (a.size, 0)]
    assert nothing[4].n_components == 0 and nothing[4].support == MICS.itd_interval()


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"n_max": -1}, "n_max must be in 0..50, got -1"),
    ({"n_max": 51}, "n_max must be in 0..50, got 51"),
    ({"bin_width_s": 0.0}, "bin_width_s must be > 0 seconds, got 0.0"),
    ({"merge_distance_m": 0.0}, "merge_distance_m and merge_vertical_m must be > 0 metres, got 0.0, 1.2"),
    ({"merge_vertical_m": -1.0}, "merge_distance_m and merge_vertical_m must be > 0 metres, got 0.3, -1.0"),
    ({"merge_reach_per_m": -0.1}, "merge_reach_per_m must be >= 0, got -0.1"),
    ({"body_width_m": 0.0}, "body_width_m must be None or > 0 metres, got 0.0"),
    ({"body_radius_m": -0.3}, "body_radius_m must be None or > 0 metres, got -0.3"),
    ({"hold_radius_m": 0.0}, "hold_radius_m must be None or > 0 metres, got 0.0"),
    ({"hold_share": 1.5}, r"hold_share must be in \[0, 1\], got 1.5"),
    ({"hold_share": -0.1}, r"hold_share must be in \[0, 1\], got -0.1"),
])
def test_motion_guided_params_name_what_is_wrong(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=f"^{message}$"):
        MotionGuidedParams(**kwargs)


def test_motion_guided_params_at_their_limits_are_accepted() -> None:
    p = MotionGuidedParams(n_max=0, merge_reach_per_m=0.0, body_width_m=None, body_radius_m=None, hold_radius_m=None,
                           hold_share=0.0)
    assert (p.n_max, p.body_width_m, p.body_radius_m, p.hold_radius_m) == (0, None, None, None)
    assert MotionGuidedParams(hold_share=1.0).hold_share == 1.0
    assert MotionGuidedParams(n_max=50).n_max == 50
    with pytest.raises(TypeError, match="^body_keeps_groups must be a bool, got int$"):
        MotionGuidedParams(body_keeps_groups=1)  # type: ignore[arg-type]


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"decision_window_s": 0.0}, "decision_window_s must be > 0 s or None, got 0.0"),
    ({"sigma2_init_s2": 0.0}, r"sigma2_init_s2 must be > 0 s\^2, got 0.0"),
    ({"var_min_s2": 0.0}, "need 0 < var_min_s2 <= var_max_s2"),
    ({"var_min_s2": 5e-9}, "need 0 < var_min_s2 <= var_max_s2"),
    ({"init_outlier_weight": 1.0}, r"init_outlier_weight must be in \(0, 1\), got 1.0"),
    ({"init_outlier_weight": 0.0}, r"init_outlier_weight must be in \(0, 1\), got 0.0"),
])
def test_face_guided_params_name_what_is_wrong(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=f"^{message}$"):
        FaceGuidedParams(**kwargs)


def test_face_guided_params_at_their_limits_and_defaults() -> None:
    p = FaceGuidedParams(var_min_s2=4e-9, var_max_s2=4e-9, decision_window_s=1e-3)
    assert p.var_min_s2 == p.var_max_s2 and p.decision_window_s == 1e-3
    d = FaceGuidedParams()
    assert (d.sigma2_init_s2, d.anchor_means, d.update_variances, d.var_min_s2, d.var_max_s2,
            d.init_outlier_weight) == (1e-9, True, False, 1e-10, 4e-9, 0.2)
    assert (d.em.max_iter, d.em.tol) == (50, 1e-4) and d.speaking.count_by == "nearest"


def test_itds_given_per_pair_are_stacked_and_wrong_ones_are_named() -> None:
    from avcore.inference import _itd_vectors

    out = _itd_vectors([np.array([1e-4, 2e-4]), np.array([3e-4])], 2, "itds_s")
    np.testing.assert_array_equal(out, [[1e-4, np.nan], [2e-4, np.nan], [np.nan, 3e-4]])
    assert out.dtype == np.float64
    ints = _itd_vectors(np.array([[1, 2], [3, 4]]), 2, "itds_s")
    assert ints.dtype == np.float64 and ints.tolist() == [[1.0, 2.0], [3.0, 4.0]]
    assert _itd_vectors([1e-4, 2e-4], 1, "x").shape == (2, 1)
    three = _itd_vectors([np.array([1.0, 2.0]), np.array([3.0]), np.array([4.0])], 3, "itds_s")
    np.testing.assert_array_equal(three, [[1, np.nan, np.nan], [2, np.nan, np.nan], [np.nan, 3, np.nan],
                                          [np.nan, np.nan, 4]])
    with pytest.raises(ValueError, match=r"^itds_s must have one column per pair \(2\), got shape \(2, 3\)$"):
        _itd_vectors(np.zeros((2, 3)), 2, "itds_s")
    with pytest.raises(ValueError, match="^itds_s must give 2 arrays, one per pair, got 3$"):
        _itd_vectors([np.zeros(1)] * 3, 2, "itds_s")
    with pytest.raises(ValueError, match=r"^frame_itds_s must be finite or NaN \(a pair without an ITD\)$"):
        _itd_vectors(np.array([[0.0, np.inf]]), 2, "frame_itds_s")
    with pytest.raises(ValueError, match=r"^itds_s\[1\] holds 1 NaN"):
        _itd_vectors([np.zeros(1), np.array([np.nan])], 2, "itds_s")
    with pytest.raises(TypeError, match="^mics must be a MicPair or a MicArray, got str$"):
        FaceGuidedHearing("mics")  # type: ignore[arg-type]


def test_face_guided_step_reports_the_em_it_ran_from_the_faces() -> None:
    """Algorithm 2's start (section 5.1): one component per face at its mapped ITD, sigma^2 = 1e-9 s^2, the
    outlier prior 0.2 and the rest shared equally; the output's counts are the posteriors' sums of that EM."""
    from avcore.mixture import fit_pairs_em

    rng = np.random.default_rng(23)
    itds = np.concatenate([rng.normal(MICS.itd(PEOPLE[0]), 20e-6, 14), rng.uniform(-3e-4, 3e-4, 5)])
    fg = FaceGuidedHearing(MICS)
    out = fg.step(PEOPLE, itds)
    means = MICS.itd(PEOPLE)[:, None]
    fit = fit_pairs_em(itds[:, None], np.array([0.8 / 3] * 3 + [0.2]), means, np.full((3, 1), 1e-9),
                       np.array([MICS.itd_interval()]), settings=EMSettings(max_iter=50, tol=1e-4, var_floor_s2=1e-10),
                       update_means=False, update_variances=False, max_variance_s2=4e-9)
    np.testing.assert_array_equal(out.itd_means, means[:, 0])
    np.testing.assert_array_equal(out.pair_itd_means, fit.means)
    np.testing.assert_allclose(out.itd_counts, fit.beta[:, :-1].sum(axis=0), rtol=1e-12)
    np.testing.assert_allclose(out.model.weights, fit.weights, rtol=1e-12)
    assert out.model.variances.tolist() == [1e-9] * 3 and out.model.support == MICS.itd_interval()
    assert out.n_iter == fit.n_iter and out.tau_a == pytest.approx(itds.size / 5)
    assert out.speaking.tolist() == [True, False, False]
    nobody = fg.step(np.empty((0, 3)), itds)
    assert nobody.itd_counts.shape == (0,) and nobody.model.weights.tolist() == [1.0]


def test_warm_started_candidates_take_last_intervals_fit_only_where_it_explains_the_data_better(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Per N, the start is the better (on the new data) of the paper's initialisation and the previous interval's
    fit with N components; the choice is per model of the batch."""
    from avcore._packed_em import Packed
    from avcore.inference import _choose

    a = Packed(np.array([1, 2]), np.array([0.9, 0.4, 0.5]), np.array([1.0, 2.0, 3.0]), np.array([4.0, 5.0, 6.0]),
               np.array([0.1, 0.1]))
    b = Packed(np.array([1, 2]), np.array([0.8, 0.3, 0.6]), np.array([7.0, 8.0, 9.0]), np.array([10.0, 11.0, 12.0]),
               np.array([0.2, 0.1]))
    c = _choose(a, b, np.array([False, True]))
    assert c.sizes.tolist() == [1, 2] and c.sizes is not a.sizes
    assert c.wg.tolist() == [0.9, 0.3, 0.6] and c.mu.tolist() == [1.0, 8.0, 9.0] and c.var.tolist() == [4.0, 11.0, 12.0]
    assert c.wo.tolist() == [0.1, 0.1]
    assert _choose(a, b, np.array([True, False])).wo.tolist() == [0.2, 0.1]
    # through the algorithm: each candidate of the second interval starts where the data are likelier
    from avcore import inference
    from avcore._packed_em import log_likelihoods
    from avcore.mixture import BinnedSamples, initial_models, pack

    rng = np.random.default_rng(24)
    mg = MotionGuidedHearing(MICS)
    mg.step(*_interval(rng))
    previous, candidates = mg.previous_, mg._candidates.copy()
    pts, itds = _interval(rng, PEOPLE[:2])  # one of the three left: last interval's fits are better for some N only
    starts = []
    real = inference.run_em
    monkeypatch.setattr(inference, "run_em", lambda x, stats, p, *args, **kw: starts.append(p) or real(x, stats, p,
                                                                                                          *args, **kw))
    vis, fused, bic = mg.fit_candidates(MICS.itd(pts), itds)
    assert [m.n_components for m in vis] == list(range(11)) and bic.shape == (11,)
    assert [m.n_components for m in fused] == list(range(11))
    assert all(m.support == MICS.itd_interval() for m in vis + fused)
    data = BinnedSamples.from_samples(MICS.itd(pts), 2e-6)
    paper = pack(initial_models(previous, 10, MICS.itd_interval(), data, outlier_weight=0.1)[1:])
    u = 1.0 / ((MICS.itd_interval()[1] - MICS.itd_interval()[0]) * 1e6)
    better = log_likelihoods(data.x_us, data.stats[:, 0], candidates, u) > log_likelihoods(
        data.x_us, data.stats[:, 0], paper, u)
    assert 0 < better.sum() < 10  # some of each
    want = _choose(paper, candidates, better)
    np.testing.assert_array_equal(starts[0].mu, want.mu)
    np.testing.assert_array_equal(starts[0].wo, want.wo)
    # one moving point is data too
    previous, candidates = mg.previous_, mg._candidates.copy()
    one = BinnedSamples.from_samples(MICS.itd(pts[:1]), 2e-6)
    mg.fit_candidates(MICS.itd(pts[:1]), itds)
    paper = pack(initial_models(previous, 10, MICS.itd_interval(), one, outlier_weight=0.1)[1:])
    better = log_likelihoods(one.x_us, one.stats[:, 0], candidates, u) > log_likelihoods(one.x_us, one.stats[:, 0],
                                                                                          paper, u)
    assert better.any()
    np.testing.assert_array_equal(starts[-1].mu, _choose(paper, candidates, better).mu)


def test_dropped_clusters_give_their_weight_to_the_outliers() -> None:
    model = Mixture1D(np.array([0.5, 0.2, 0.2, 0.1]), [-1e-4, 0.0, 1e-4], [1e-9] * 3, MICS.itd_interval())
    kept = MotionGuidedHearing(MICS)._keep(model, np.array([True, False, True]))
    assert kept.weights.tolist() == pytest.approx([0.5, 0.2, 0.3]) and kept.means.tolist() == [-1e-4, 1e-4]
    assert kept.support == MICS.itd_interval()


def _refined(blobs: list[np.ndarray], params: MotionGuidedParams | None = None, alpha: np.ndarray | None = None,
             a: np.ndarray | None = None) -> tuple:
    """``_refine`` of one ITD cluster holding ``blobs`` (alpha 1 unless given), ITDs from the first blob's
    direction unless given, each with the cluster's posterior 0.8."""
    pts = np.concatenate(blobs)
    v = MICS.itd(pts)
    alpha = np.ones((pts.shape[0], 1)) if alpha is None else alpha
    a = MICS.itd(blobs[0][:5]) if a is None else a
    model = Mixture1D(np.array([0.8, 0.2]), [float(v.mean())], [float(v.var())], MICS.itd_interval())
    return MotionGuidedHearing(MICS, params)._refine(pts, v, a, alpha, np.full((a.size, 1), 0.8), model)


def test_a_hand_low_at_the_side_and_two_strips_a_torso_apart_are_one_person() -> None:
    """A hand 0.6 m below the head and 0.35 m to its side is within reach (merge_reach_per_m); two strips 0.44 m
    apart at one height are one body's width (body_width_m); without those settings each is two objects. With
    neither a body radius nor a width the groups alone are the objects."""
    rng = np.random.default_rng(25)
    sd = (0.04, 0.06, 0.04)
    head, hand = _blob(rng, [0.0, -0.5, 2.0], 150, sd), _blob(rng, [0.35, 0.1, 2.0], 100, sd)
    assert _refined([head, hand])[0].shape == (1, 3)
    assert _refined([head, hand], replace(MotionGuidedParams(), merge_reach_per_m=0.0))[0].shape == (2, 3)
    left, right = (_blob(rng, [x, 0.0, 2.0], 150, (0.03, 0.1, 0.04)) for x in (-0.22, 0.22))
    positions = _refined([left, right])[0]
    assert positions.shape == (1, 3) and abs(positions[0, 0]) < 0.02
    assert _refined([left, right], replace(MotionGuidedParams(), body_width_m=None))[0].shape == (2, 3)
    bare = replace(MotionGuidedParams(), body_width_m=None, body_radius_m=None)
    positions, _, mass, _, _ = _refined([head, hand], bare)
    assert positions.shape == (1, 3) and mass[0] == pytest.approx(250, rel=0.05)


def test_itds_far_from_every_group_are_still_shared_in_full() -> None:
    """The cluster's posterior of an ITD is divided among its groups whatever its distance from them: the shares
    are normalised even where every group's density is small."""
    rng = np.random.default_rng(26)
    near, far = _blob(rng, [0.3, 0.0, 1.5], 300, (0.06, 0.12, 0.04)), _blob(rng, [0.6, 0.0, 3.0], 200, (0.06, 0.12, 0.04))
    a = MICS.itd(np.array([[0.3, 0.0, 1.5]])) + np.array([-150e-6, -120e-6, 0.0, 130e-6])
    betas = _refined([near, far], a=a)[3]
    assert betas.shape == (4, 2)
    np.testing.assert_allclose(betas.sum(axis=1), 0.8, rtol=1e-12)


def test_a_body_is_placed_by_its_own_clusters_points_only() -> None:
    """Points in the body's cylinder that belong to another cluster (too few to be a group of their own) do not
    move the body's centre: the cylinder's weights are the object's clusters' posteriors."""
    rng = np.random.default_rng(27)
    person = _blob(rng, [0.0, 0.0, 2.0], 250, (0.06, 0.12, 0.04))
    stray = _blob(rng, [0.2, 0.0, 2.0], 30, (0.02, 0.05, 0.02))  # beside it, another cluster's (alpha 0.3 each)
    alpha = np.zeros((280, 2))
    alpha[:250, 0], alpha[250:, 1] = 1.0, 0.3
    pts = np.concatenate([person, stray])
    v = MICS.itd(pts)
    a = MICS.itd(person[:5])
    model = Mixture1D(np.array([0.5, 0.3, 0.2]), [float(v[:250].mean()), float(v[250:].mean())],
                      [float(v[:250].var()), float(v[250:].var())], MICS.itd_interval())
    positions = MotionGuidedHearing(MICS)._refine(pts, v, a, alpha, np.full((5, 2), 0.4), model)[0]
    assert positions.shape == (1, 3)
    assert np.linalg.norm(positions[0] - person.mean(axis=0)) < 0.01


def test_parts_whose_bodies_come_together_are_merged_once_more(monkeypatch: pytest.MonkeyPatch) -> None:
    """A head and a hand half a metre apart both ways, and the arm between them: the parts stay two, but the bodies
    around them (each part with the cluster's points in its cylinder) are closer than the merge distance, so the
    second merge, on the bodies, makes them one person."""
    from avcore import inference

    seen = []
    real = inference.merge_close
    monkeypatch.setattr(inference, "merge_close", lambda parts, *a, **k: seen.append(real(parts, *a, **k)) or seen[-1])
    for seed in (0, 1):
        rng = np.random.default_rng(seed)
        head = _blob(rng, [0.0, -0.5, 2.0], 150, (0.04, 0.06, 0.04))
        hand = _blob(rng, [0.5, 0.0, 2.0], 120, (0.04, 0.06, 0.04))
        arm = np.c_[rng.uniform(0.05, 0.45, 60), rng.uniform(-0.5, 0.0, 60), rng.normal(2.0, 0.03, 60)]
        seen.clear()
        positions = _refined([head, hand, arm])[0]
        assert len(seen) == 2 and len(seen[0]) == 2 and len(seen[1]) == 1  # the parts: two; their bodies: one
        all_points = np.concatenate([head, hand, arm]).mean(axis=0)
        assert positions.shape == (1, 3) and np.linalg.norm(positions[0] - all_points) < 0.01  # the whole body's


def test_with_n_max_zero_everybody_is_an_outlier() -> None:
    rng = np.random.default_rng(28)
    pts, itds = _interval(rng)
    out = MotionGuidedHearing(MICS, MotionGuidedParams(n_max=0)).step(pts, itds)
    width = MICS.itd_interval()[1] - MICS.itd_interval()[0]
    assert out.n == 0 and out.n_selected == 0 and out.model.n_components == 0
    assert out.bic.tolist() == pytest.approx([(pts.shape[0] + itds.size) * np.log(1.0 / width)], rel=1e-12)


def test_the_batched_candidates_are_the_one_model_fits() -> None:
    """Steps (b) and (c) of Algorithm 1 for every N at once equal the public one-model EM and fusion EM (the visual
    points in bins of 1 ns: one each), and each BIC is eq. (criteria) of the fused model on both modalities."""
    from avcore.mixture import BinnedSamples, bic_score, fit_em, fit_fusion_em, initial_models

    rng = np.random.default_rng(29)
    pts, itds = _interval(rng, n_per=60, n_out=30)
    params = MotionGuidedParams(bin_width_s=1e-9, n_max=3)
    v = MICS.itd(pts)
    vis, fused, bic = MotionGuidedHearing(MICS, params).fit_candidates(v, itds)
    inits = initial_models(None, 3, MICS.itd_interval(), BinnedSamples.from_samples(v, 1e-9), outlier_weight=0.1)
    for n in range(1, 4):
        one = fit_em(v, inits[n], settings=params.em).model_  # exact, one value at a time
        np.testing.assert_allclose(vis[n].means, one.means, rtol=1e-7)
        np.testing.assert_allclose(vis[n].variances, one.variances, rtol=1e-6)
        fusion = fit_fusion_em(v, vis[n].responsibilities(v), itds, vis[n], settings=params.em).model_
        np.testing.assert_allclose(fused[n].means, fusion.means, rtol=1e-7)
        np.testing.assert_allclose(fused[n].variances, fusion.variances, rtol=1e-6)
        ll = fused[n].log_likelihood(v) + fused[n].log_likelihood(itds)
        assert bic[n] == pytest.approx(bic_score(ll, n, v.size + itds.size), rel=1e-9)


def test_identical_points_hold_a_candidates_variance_at_its_floor() -> None:
    v = np.full(300, MICS.itd(np.array([0.2, 0.0, 2.0])))
    vis, fused, _ = MotionGuidedHearing(MICS).fit_candidates(v, np.empty(0))
    floor = EMSettings().var_floor_s2
    assert vis[1].variances[0] == pytest.approx(floor, rel=1e-9) and fused[1].variances[0] == pytest.approx(floor,
                                                                                                          rel=1e-9)


def test_points_more_than_merge_vertical_m_below_do_not_place_the_body() -> None:
    """The body's cylinder reaches ``merge_vertical_m`` (1.2 m) up and down: a few points of the same cluster 1.5 m
    below (too few for a group) are not part of it."""
    rng = np.random.default_rng(30)
    person = _blob(rng, [0.0, 0.0, 2.0], 250, (0.06, 0.12, 0.04))
    feet = _blob(rng, [0.05, 1.5, 2.0], 10, (0.02, 0.02, 0.02))
    positions = _refined([person, feet])[0]
    assert positions.shape == (1, 3) and np.linalg.norm(positions[0] - person.mean(axis=0)) < 0.01


@pytest.mark.parametrize("n_people", [1, 2])
def test_with_an_array_every_pair_decides_for_one_person_or_more(n_people: int) -> None:
    """The speaking states and probabilities of Algorithm 1 on an array are Algorithm 2's on every pair at the found
    positions, with Algorithm 1's speaking test (here the paper's)."""
    rng = np.random.default_rng(31)
    people = np.array([[-1.0, 0.0, 1.0], [1.0, 0.0, 1.5]])[:n_people]
    points = np.concatenate([p + rng.normal(0.0, [0.08, 0.15, 0.06], (700, 3)) for p in people])
    behind = FOUR_MICS.itd(np.array([-1.0, 0.0, -1.0])) + rng.normal(0.0, 10e-6, (25, 2))
    params = MotionGuidedParams.paper()
    both = MotionGuidedHearing(FOUR_MICS, params).step(points, behind)
    one = MotionGuidedHearing(FOUR_MICS.pair(0), params).step(points, behind[:, 0])
    assert both.positions.shape[0] == n_people and one.speaking[np.argmin(one.positions[:, 0])]
    pairs = FaceGuidedHearing(FOUR_MICS, FaceGuidedParams(speaking=params.speaking)).step(both.positions, behind)
    assert not both.speaking.any() and np.array_equal(both.probability, pairs.probability)
    assert MotionGuidedHearing(FOUR_MICS, params)._pairs.params.speaking == params.speaking


def test_motion_guided_output_counts_points_and_itds_per_person() -> None:
    """point_counts: each person's alpha_bar (their points' posteriors); itd_counts: their beta_bar, the posteriors
    of the interval's ITDs (the talker's near their count, the others near none); the model has one component a
    person, tau_a the speaking test's threshold."""
    rng = np.random.default_rng(32)
    pts, itds = _interval(rng, n_itd=16, n_itd_out=4)
    out = MotionGuidedHearing(MICS).step(pts, itds)
    order = np.argsort(out.positions[:, 0])
    assert out.n == 3 and out.model.n_components == 3 and out.itd_means.shape == (3,)
    assert out.point_counts.shape == (3,) and np.all(out.point_counts[order] > 400)
    assert out.itd_counts.shape == (3,) and out.itd_counts[order][0] > 12 and np.all(out.itd_counts[order][1:] < 2)
    assert out.itd_counts.sum() <= itds.size and isinstance(out.tau_a, float) and out.tau_a > 0


def test_the_papers_determinant_test_drops_a_sheet_of_identical_points() -> None:
    dup = np.repeat([[0.2, 0.0, 2.0]], 300, axis=0)
    out = MotionGuidedHearing(MICS, MotionGuidedParams.paper()).step(dup, np.empty(0))
    assert out.n_selected == 1 and out.n == 0 and out.model.n_components == 0 and out.model.weights.tolist() == [1.0]


def test_face_guided_inputs_are_named_when_wrong() -> None:
    fg = FaceGuidedHearing(MICS)
    with pytest.raises(ValueError, match="^faces_xyz must be"):
        fg.step(np.zeros(3), np.zeros(1))
    with pytest.raises(ValueError, match="^itds_s holds 1 NaN"):
        fg.step(PEOPLE, np.array([np.nan]))
    with pytest.raises(ValueError, match=r"^merge_distance_m and merge_vertical_m must be > 0 metres, got 0.3, 0.0$"):
        MotionGuidedParams(merge_vertical_m=0.0)
    assert MotionGuidedParams(merge_vertical_m=0.5).merge_vertical_m == 0.5


@pytest.mark.parametrize("n_faces, paper", [(1, False), (2, True)])
def test_face_guided_step_runs_the_em_its_settings_name(n_faces: int, paper: bool) -> None:
    """One face, or the paper's Algorithm 2 (means free, variances adapting up to var_max_s2): the EM the step runs
    is fit_pairs_em from the faces with those settings."""
    from avcore.mixture import fit_pairs_em

    rng = np.random.default_rng(33)
    faces = PEOPLE[:n_faces]
    itds = np.concatenate([rng.normal(MICS.itd(faces[0]) + 15e-6, 30e-6, 14), rng.uniform(-3e-4, 3e-4, 5)])
    params = FaceGuidedParams.paper() if paper else FaceGuidedParams()
    out = FaceGuidedHearing(MICS, params).step(faces, itds)
    start = np.append(np.full(n_faces, 0.8 / n_faces), 0.2)
    fit = fit_pairs_em(itds[:, None], start, MICS.itd(faces)[:, None], np.full((n_faces, 1), 1e-9),
                       np.array([MICS.itd_interval()]),
                       settings=EMSettings(max_iter=50, tol=1e-4, var_floor_s2=params.var_min_s2),
                       update_means=paper, update_variances=paper, max_variance_s2=params.var_max_s2)
    np.testing.assert_allclose(out.model.weights, fit.weights, rtol=1e-12)
    np.testing.assert_allclose(out.model.variances, fit.variances[:, 0], rtol=1e-12)
    np.testing.assert_allclose(out.itd_means, fit.means[:, 0], rtol=1e-12)
    assert (out.model.variances != 1e-9).all() == paper


def test_face_guided_decision_window_includes_its_edge_and_names_a_wrong_length() -> None:
    """An ITD centred exactly decision_window_s from the frame decides; offsets may come as a column."""
    itds = np.full(8, MICS.itd(PEOPLE[0]))
    fg = FaceGuidedHearing(MICS, FaceGuidedParams(decision_window_s=0.25))
    at_edge = fg.step(PEOPLE, itds, itd_offsets_s=np.full((8, 1), 0.25))
    beyond = fg.step(PEOPLE, itds, itd_offsets_s=np.full(8, 0.375))
    assert at_edge.speaking[0] and not beyond.speaking.any()
    with pytest.raises(ValueError, match="^itd_offsets_s must give one time per ITD: 3 times for 8 ITDs$"):
        fg.step(PEOPLE, itds, itd_offsets_s=np.zeros(3))


def test_face_guided_step_passes_its_later_looks_on() -> None:
    """Band peaks at a quiet face (the third look) and bins whose phases agree with a face on every pair (the
    fourth) make it speak with no window ITD at all; a wrong argument among them is named."""
    from avcore.itd.pairs import FrameBins

    fg = FaceGuidedHearing(MICS)
    quiet = np.empty(0)
    bands = np.full(12, MICS.itd(PEOPLE[1]))
    assert fg.step(PEOPLE, quiet, band_itds_s=bands).speaking.tolist() == [False, True, False]
    freqs = np.linspace(200.0, 4000.0, 20)
    phases = np.exp(-2j * np.pi * freqs * MICS.itd(PEOPLE[2]))  # every bin at the third face's ITD
    bins = FrameBins(np.arange(10) * 0.032, np.broadcast_to(phases, (10, 1, 20)).astype(np.complex64), freqs)
    assert fg.step(PEOPLE, quiet, frame_bins=bins).speaking.tolist() == [False, False, True]
    for name in ("frame_itds_s", "band_itds_s"):
        with pytest.raises(ValueError, match=rf"^{name} must be finite or NaN \(a pair without an ITD\)$"):
            fg.step(PEOPLE, quiet, **{name: np.array([[np.inf]])})
    two = FrameBins(bins.times_s, np.concatenate([bins.bins, bins.bins], axis=1), freqs)
    with pytest.raises(ValueError, match="^frame_bins must hold the array's 1 pairs, got 2$"):
        fg.step(PEOPLE, quiet, frame_bins=two)
    with pytest.warns(ConvergenceWarning, match="^the face-guided EM did not converge in 1 iterations"):
        FaceGuidedHearing(MICS, FaceGuidedParams(em=EMSettings(max_iter=1, tol=1e-15), anchor_means=False)).step(
            PEOPLE, np.random.default_rng(34).normal(MICS.itd(PEOPLE[0]), 30e-6, 20))


def test_face_guided_variances_adapt_up_to_their_ceiling() -> None:
    """update_variances: a talker's ITDs spread 80 us wide give a variance above var_max_s2 = (63 us)^2; it is held
    there."""
    itds = np.random.default_rng(35).normal(MICS.itd(PEOPLE[0]), 80e-6, 60)
    out = FaceGuidedHearing(MICS, FaceGuidedParams(update_variances=True)).step(PEOPLE[:1], itds)
    assert out.model.variances[0] == pytest.approx(4e-9, rel=1e-9)


def test_the_ridgeline_merge_runs_on_two_clusters_or_more_unless_switched_off(monkeypatch: pytest.MonkeyPatch) -> None:
    from avcore import inference

    calls = []
    real = inference.ridgeline_merge
    monkeypatch.setattr(inference, "ridgeline_merge", lambda model: calls.append(model.n_components) or real(model))
    rng = np.random.default_rng(36)
    out = MotionGuidedHearing(MICS).step(*_interval(rng, PEOPLE[:1]))  # one person taken for two by BIC
    assert out.n_selected == 2 and calls == [2] and out.n == 1
    calls.clear()
    out = MotionGuidedHearing(MICS, MotionGuidedParams(merge_ridgeline=False)).step(*_interval(rng))
    assert out.n_selected > 1 and calls == []


def test_face_guided_variances_adapt_down_to_their_floor() -> None:
    """var_min_s2 is the adapting variances' floor (not the EM settings' own)."""
    itds = np.full(30, MICS.itd(PEOPLE[0]))
    out = FaceGuidedHearing(MICS, FaceGuidedParams(update_variances=True)).step(PEOPLE[:1], itds)
    assert out.model.variances[0] == pytest.approx(1e-10, rel=1e-9)



def test_a_person_the_groups_lose_for_an_interval_is_held_and_heard(monkeypatch: pytest.MonkeyPatch) -> None:
    """The second interval's groups lose the middle person (as when their points fall into a neighbour's
    cluster); the hold keeps them where their points are, with a 1-D component that hears their ITDs."""
    import avcore.inference as inference

    real = inference.compact_groups
    losing = {"on": False}

    def groups(pts: np.ndarray, w: np.ndarray, **kw: object) -> list:
        found = real(pts, w, **kw)
        return [g for g in found if not (losing["on"] and np.linalg.norm(g.mean - PEOPLE[1]) < 0.4)]

    monkeypatch.setattr(inference, "compact_groups", groups)
    masks = []

    def held(*args: object, **kw: object) -> list:
        masks[:] = inference_held(*args, **kw)
        return list(masks)

    inference_held = inference.held_bodies
    monkeypatch.setattr(inference, "held_bodies", held)
    rng = np.random.default_rng(30)
    first, second = _interval(rng, speaker=None), _interval(rng, speaker=1)
    for hold in (None, 0.3):
        mg = MotionGuidedHearing(MICS, MotionGuidedParams(hold_radius_m=hold))
        losing["on"] = False
        assert mg.step(*first).n == 3
        losing["on"] = True
        out = mg.step(*second)
        errors = _nearest(out.positions, PEOPLE)
        if hold is None:
            assert out.n == 2 and errors[1] > 0.5
            continue
        assert out.n == 3 and np.all(errors < 0.05)
        middle = int(np.argmin(np.linalg.norm(out.positions - PEOPLE[1], axis=1)))
        assert list(out.speaking) == [i == middle for i in range(3)]
        assert out.model.n_components == 3
        assert abs(out.itd_means[middle] - MICS.itd(PEOPLE[1])) < 10e-6
        assert out.point_counts[middle] > 500  # its body's points, not its group's
        ((_, mask),) = masks  # placed at its cylinder's points, with their covariance as it is
        np.testing.assert_allclose(out.positions[middle], second[0][mask].mean(axis=0))
        np.testing.assert_allclose(out.covariances[middle], np.cov(second[0][mask].T, bias=True))
        losing["on"] = False
        assert mg.step(*_interval(rng, speaker=None)).n == 3  # found again by its groups: not held twice


def test_a_held_person_fading_away_is_let_go(monkeypatch: pytest.MonkeyPatch) -> None:
    """Held against the mass they had when last found, not the last hold's: 60 % of the points are held, then 35 %
    (over half of 60 %) are not."""
    import avcore.inference as inference

    real = inference.compact_groups
    monkeypatch.setattr(inference, "compact_groups", lambda pts, w, **kw: [
        g for g in real(pts, w, **kw) if not (losing and np.linalg.norm(g.mean - PEOPLE[1]) < 0.4)])
    rng = np.random.default_rng(31)
    mg = MotionGuidedHearing(MICS)
    losing = False
    assert mg.step(*_interval(rng, speaker=None)).n == 3
    losing = True
    counts = []
    for share in (0.6, 0.35):
        pts, itds = _interval(rng, speaker=None)
        middle = np.arange(pts.shape[0]) // 550 == 1
        keep = ~middle | (rng.random(pts.shape[0]) < share)
        counts.append(mg.step(pts[keep], itds).n)
    assert counts == [3, 2]
