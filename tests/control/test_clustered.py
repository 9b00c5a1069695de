"""Algorithm 2: the features, the two-valley case (paper Fig. 2) on recorded steps, cluster
updates."""

import numpy as np
import pytest

import dcmppi
from dcmppi.bench.episodes.runner import Episode, EpisodeSpec
from dcmppi.control.kernels.costs import goal_distance
from dcmppi.control.planners.clustered import (
    cluster_features,
    cluster_labels,
    cluster_updates,
    dbscan_radius,
    features_of_sums,
    mean_std,
)
from dcmppi.control.planners.mppi import mppi_update
from dcmppi.control.planners.rollouts import Rollouts


def two_valley(eps):
    """Paper Fig. 2: good modes at +-0.5, a ridge of high cost (a collision) around the mean 0."""
    return 20.0 * np.minimum((eps - 0.5) ** 2, (eps + 0.5) ** 2) + 1000.0 * (np.abs(eps) < 0.25)


def test_two_valley_mppi_on_ridge_clustered_in_a_mode():
    rng = np.random.default_rng(3)
    K, sigma, lam = 500, np.sqrt(0.1) * 2, 5.0
    raw = rng.normal(0, sigma, K)
    eps = raw[None, None, :]  # N = 1, one control
    S = two_valley(raw)
    U, _ = mppi_update(np.zeros((1, 1)), eps, S, lam)
    assert abs(U[0, 0]) < 0.25  # the weighted average lands on the ridge
    radius = dbscan_radius(1)
    labels = cluster_labels(cluster_features(eps, S, [sigma], 5 * radius / 1000.0), radius)
    Uc, w = cluster_updates(np.zeros((1, 1)), eps, S, lam, labels)
    np.testing.assert_allclose(np.bincount(labels[labels >= 0], w[labels >= 0]), 1.0)
    best = Uc[np.argmin(two_valley(Uc[:, 0, 0])), 0, 0]
    assert 0.3 < abs(best) < 0.7  # inside one mode
    left, right = labels[np.argmin(np.where(raw < 0, S, np.inf))], labels[np.argmin(S)]
    assert min(left, right) >= 0 and left != right  # each valley of the cost is a cluster
    ridge = np.abs(raw) < 0.25
    assert not np.isin(labels[ridge], [left, right]).any()


def test_features_are_horizon_means_in_std_units_and_scaled_costs():
    rng = np.random.default_rng(4)
    eps, S = rng.normal(size=(6, 2, 30)), rng.uniform(10, 20, 30)
    scale = np.array([0.5, 2.0])
    F = cluster_features(eps, S, scale, 0.01)
    np.testing.assert_allclose(F[:, :2], eps.mean(axis=0).T / scale, rtol=1e-13)
    np.testing.assert_allclose(F[:, 2], (S - S.min()) * 0.01, rtol=1e-13)
    with pytest.raises(ValueError, match="cluster_features needs"):
        cluster_features(eps, S, [1.0], 0.01)
    # the default radius and the std of a horizon mean for every perturbation kind
    assert dbscan_radius(1) == pytest.approx(0.2019, abs=1e-4)
    assert dbscan_radius(3) == pytest.approx(0.9162, abs=1e-4)
    sigma = np.array([1.0, 0.3])
    np.testing.assert_allclose(mean_std(sigma, "constant", 50), sigma)
    np.testing.assert_allclose(mean_std(sigma, "time_varying", 50), sigma / np.sqrt(50))
    np.testing.assert_allclose(mean_std(sigma, "mixed", 50), sigma * np.sqrt(0.51))
    np.testing.assert_allclose(mean_std(sigma, "correlated", 50, 0.0), sigma / np.sqrt(50))
    steps = np.arange(50)  # the mean of a^|i - j| over the pairs of steps
    pairs = np.mean(0.9 ** np.abs(steps[:, None] - steps[None]))
    np.testing.assert_allclose(mean_std(sigma, "correlated", 50, 0.9), sigma * np.sqrt(pairs))


@pytest.mark.parametrize("perturbation", ["constant", "time_varying", "mixed", "correlated"])
def test_features_of_unprojected_samples_are_standard_normal(perturbation):
    ctrl = dcmppi.make_controller(
        "clustered", agent="holonomic", seed=0, K=4000, perturbation=perturbation
    )
    eps = np.asarray(ctrl.sample())  # before projection
    F = cluster_features(eps, np.zeros(ctrl.K), ctrl._feature_scale, 1.0)[:, :3]
    np.testing.assert_allclose(F.mean(axis=0), 0, atol=0.06)
    np.testing.assert_allclose(F.std(axis=0), 1, atol=0.05)


@pytest.mark.parametrize("agent", ["dubins", "unicycle", "holonomic"])
@pytest.mark.parametrize("perturbation", ["constant", "time_varying", "mixed", "correlated"])
def test_projection_pass_gives_the_features_and_reads_constant_perturbations_alike(
    agent, perturbation
):
    """controls() with sums: the same controls for sample()'s perturbations (a constant view, a
    Draw) as for them laid out in full, and horizon sums that make exactly cluster_features'
    values (the clustered step uses them)."""
    ctrl = dcmppi.make_controller("clustered", agent=agent, seed=1, perturbation=perturbation)
    U0 = ctrl.agent.project(
        np.random.default_rng(2).normal(0, 0.7, (ctrl.N, ctrl.nu)) + ctrl.agent.upper / 2, axis=1
    )  # some samples land on the bounds
    eps = ctrl.sample()
    r = Rollouts.allocate(U0, eps, np.zeros(3), sums=True)
    full = Rollouts.allocate(U0, np.ascontiguousarray(eps), np.zeros(3))
    for each in (r, full):
        ctrl.controls(each, (0, ctrl.K))
    u, e, sums = r.u, r.e, r.sums
    np.testing.assert_array_equal(u, full.u)
    np.testing.assert_array_equal(e, full.e)
    np.testing.assert_array_equal(r.products, full.products)
    assert (u == ctrl.agent.upper[:, None]).any() or (u == ctrl.agent.lower[:, None]).any()
    S = np.random.default_rng(3).uniform(0, 100, ctrl.K)
    inv = 1.0 / (ctrl.N * ctrl._feature_scale)
    expected = cluster_features(e, S, ctrl._feature_scale, 0.5)
    np.testing.assert_array_equal(features_of_sums(sums, S, inv, 0.5), expected)


def recorded_two_valley_steps(task, controller, seeds, **task_params):
    """Run episodes and yield (diagnostics, peaks, ridges) at every step where two
    runs of >= 20 collision-free samples (in the order of the first perturbation feature) are
    separated by colliding samples spanning at least one DBSCAN radius: the two-valley case.
    peaks: the lowest-cost sample of each run; ridges: the colliding samples between runs."""
    for seed in seeds:
        episode = Episode(EpisodeSpec(task, controller, seed=seed, task_params=task_params))
        while not episode.done:
            episode.step()
            ctrl, d = episode.controller, episode.controller.diagnostics
            states = d.states.transpose(1, 2, 0)
            colliding = (
                d.J - goal_distance(states[:, 0], states[:, 1], ctrl.objective.goal) >= ctrl.alpha
            )
            f = d.features[:, 0]
            order = np.argsort(f, kind="stable")
            runs, current = [], []
            for k in order:
                if colliding[k]:
                    runs.append(current)
                    current = []
                else:
                    current.append(k)
            runs.append(current)
            runs = [np.array(r) for r in runs if len(r) >= 20]
            gap = ctrl.dbscan_eps
            pairs = [
                (a, b)
                for a, b in zip(runs, runs[1:], strict=False)
                if f[b].min() - f[a].max() >= gap
            ]
            if pairs:
                peaks = [r[np.argmin(d.S[r])] for pair in pairs for r in pair]
                ridges = [colliding & (f > f[a].max()) & (f < f[b].min()) for a, b in pairs]
                yield d, peaks, ridges


@pytest.mark.parametrize(
    "task, controller, params",
    [
        ("blocked", "clustered", {"lateral_jitter": 1.0}),
        ("blocked", "dc", {"lateral_jitter": 1.0}),
        ("crossing", "clustered", {}),  # the moving obstacle seen frozen: a static ridge
    ],
)
def test_value_peaks_are_clusters_on_recorded_two_valley_steps(task, controller, params):
    """Paper Fig. 2: each value peak lies in a cluster with its flanks, the ridge through the
    obstacle in neither, the best sample is never a noise point, and the applied perturbation
    lies among the samples of a peak's cluster."""
    steps = 0
    for d, peaks, ridges in recorded_two_valley_steps(task, controller, (0, 1), **params):
        steps += 1
        best = np.argmin(d.S)
        assert d.labels[best] >= 0
        labels = d.labels[peaks]
        assert (labels >= 0).all() and len(set(labels)) == len(labels)
        for ridge in ridges:
            assert not np.isin(d.labels[ridge], labels).any()
        assert d.chosen in labels
        members = d.eps[d.labels == d.chosen, 0, 0]
        applied = d.plan[0, 0] - d.warm_start[0, 0]
        assert members.min() - 1e-12 <= applied <= members.max() + 1e-12
        for ridge in ridges:  # not on the ridge between the peaks
            assert not d.eps[ridge, 0, 0].min() < applied < d.eps[ridge, 0, 0].max()
    assert steps >= 10  # the episodes did meet the two-valley case


def test_noise_points_belong_to_no_cluster():
    labels = np.array([0, -1, 0, 1, 1, -1])
    S = np.arange(6.0)
    eps = np.array([[1.0, 50.0, 3.0, -2.0, 4.0, 70.0], [0.5, 90.0, 0.5, 1.0, 1.0, -80.0]])
    eps = eps[:, None, :]  # N = 2 steps, one control
    U, w = cluster_updates(np.array([[0.1], [-0.1]]), eps, S, 1.0, labels)
    assert np.all(w[labels == -1] == 0) and U.shape == (2, 2, 1)
    for c in (0, 1):  # a weighted mean of the cluster's own perturbations, not the noise's
        member = eps[:, 0, labels == c]
        assert np.all(U[c, :, 0] >= member.min(axis=1) + [0.1, -0.1] - 1e-12)
        assert np.all(U[c, :, 0] <= member.max(axis=1) + [0.1, -0.1] + 1e-12)


def test_cluster_updates_are_alg1_on_each_cluster():
    rng = np.random.default_rng(0)
    K, N, lam = 300, 7, 0.7
    U0, eps, S = rng.normal(size=(N, 2)), rng.normal(size=(N, 2, K)), rng.uniform(0, 20, K)
    labels = rng.integers(-1, 4, K)
    U, w = cluster_updates(U0, eps, S, lam, labels)
    for c in range(4):
        member = labels == c
        Uc, wc = mppi_update(U0, eps[:, :, member], S[member], lam)
        np.testing.assert_allclose(U[c], Uc, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(w[member], wc, rtol=1e-12)
    assert np.all(w[labels == -1] == 0)


def test_constant_perturbation_updates_recompute_eps_exactly():
    """With the scalar samples and the bound, the update recomputes the clipped perturbations:
    bit-identical to reading them from eps, clipping at the bound included."""
    rng = np.random.default_rng(1)
    K, N, bound = 400, 30, 0.8
    U0, raw = rng.uniform(-bound, bound, (N, 1)), rng.normal(0, 1.0, K)
    eps = (np.clip(U0 + raw, -bound, bound) - U0)[:, None, :]
    assert (np.abs(U0 + raw) > bound).mean() > 0.2  # many samples clipped
    S, labels = rng.uniform(0, 30, K), rng.integers(-1, 5, K)
    U, w = cluster_updates(U0, eps, S, 0.7, labels)
    Ur, wr = cluster_updates(U0, eps, S, 0.7, labels, raw, bound)
    np.testing.assert_array_equal(Ur, U)
    np.testing.assert_array_equal(wr, w)


def test_cluster_updates_check_shapes():
    eps, S, labels = np.zeros((4, 1, 6)), np.zeros(6), np.zeros(6, dtype=int)
    for U0, s in ((np.zeros((3, 1)), S), (np.zeros((4, 1)), S[:5])):
        with pytest.raises(ValueError, match="cluster_updates needs"):
            cluster_updates(U0, eps, s, 1.0, labels)
    with pytest.raises(ValueError, match="raw"):
        cluster_updates(np.zeros((4, 1)), eps, S, 1.0, labels, raw=np.zeros(5), bound=1.0)


def test_clustered_plan_avoids_blocking_cylinder():
    ctrl = dcmppi.make_controller("clustered", seed=0)
    state, goal = np.array([0.0, 0.0, 0.0]), np.array([15.0, 0.0])
    ctrl.act(state, goal, np.array([[3.0, 0.0, 1.0]]))
    states = ctrl.agent.rollout_one(state, ctrl.diagnostics.plan, ctrl.dt)
    d = ctrl.diagnostics
    assert d.labels.shape == (ctrl.K,) and d.chosen >= 0
    assert d.cluster_costs[d.chosen] == d.cluster_costs.min()
    assert np.hypot(states[:, 0] - 3.0, states[:, 1]).min() > 1.5


def test_bad_cluster_parameters_are_named():
    for params, word in (
        ({"dbscan_eps": 0.0}, "dbscan_eps"),
        ({"dbscan_min_samples": 1.5}, "dbscan_min_samples"),
        ({"collision_gap": -1.0}, "collision_gap"),
        ({"alpha": 0.0}, "cost_unit"),
    ):
        with pytest.raises(ValueError, match=word):
            dcmppi.make_controller("clustered", **params)


@pytest.mark.parametrize(
    "name, params", [("clustered", {"alpha": 0.0, "cost_unit": 1.0}), ("dc", {"beta": 0.0})]
)
def test_a_moving_obstacle_term_of_weight_zero_adds_nothing_to_the_features(name, params):
    """With the moving obstacles' weight 0 (alpha for frozen ones, beta for futures) their term
    is 0, in any unit: the features are those of the costs S."""
    ctrl = dcmppi.make_controller(name, K=64, N=10, seed=0, **params)
    moving = np.array([[1.0, 0.0, np.pi, 0.3]])  # in reach
    u = ctrl.act([0.0, 0.0, 0.0], [5.0, 0.0], None, moving, [1.0, 0.1, 0.0, 0.1])
    assert np.isfinite(u).all() and ctrl.objective.weight == 0.0
    plain = dcmppi.make_controller(name, K=64, N=10, seed=0, **params)
    plain.act([0.0, 0.0, 0.0], [5.0, 0.0], None, None, [1.0, 0.1, 0.0, 0.1])
    assert np.array_equal(ctrl.diagnostics.features, plain.diagnostics.features)
