"""Algorithm 2: exact DBSCAN, the two-valley case, a controller facing a blocking cylinder."""

import numpy as np
import pytest
from sklearn.cluster import DBSCAN

import dcmppi
from dcmppi.clustered import cluster_features, cluster_labels, cluster_updates
from dcmppi.dbscan import dbscan
from dcmppi.dynamics import rollout
from dcmppi.mppi import mppi_update


@pytest.mark.parametrize("seed", range(4))
def test_dbscan_labels_identical_to_sklearn(seed):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        n, d = int(rng.integers(1, 300)), int(rng.integers(1, 5))
        X = rng.standard_normal((n, d)) * rng.uniform(0.2, 3.0)
        if rng.random() < 0.3:
            X = np.round(X, 1)  # duplicates and ties on the band edge
        eps, ms = rng.uniform(0.05, 1.0), int(rng.integers(1, 10))
        expected = DBSCAN(eps=eps, min_samples=ms).fit(X).labels_
        np.testing.assert_array_equal(dbscan(X, eps, ms), expected)


@pytest.mark.parametrize("seed", range(3))
def test_dbscan_levels_identical_to_sklearn(seed):
    """Clustered MPPI's features: most points share the clipped cost exactly (1-D levels)."""
    rng = np.random.default_rng(seed)
    for _ in range(60):
        n = int(rng.integers(1, 400))
        X = rng.standard_normal((n, 2))
        X[:, 1] = np.minimum(np.abs(X[:, 1]) * rng.uniform(1, 8), rng.uniform(0.2, 3.0))
        if rng.random() < 0.3:
            X = np.round(X, 1)  # several levels, duplicates, ties at eps
        eps, ms = rng.uniform(0.05, 1.0), int(rng.integers(1, 10))
        expected = DBSCAN(eps=eps, min_samples=ms).fit(X).labels_
        np.testing.assert_array_equal(dbscan(X, eps, ms), expected)


@pytest.mark.parametrize("seed", range(3))
def test_dbscan_level_edge_cases_identical_to_sklearn(seed):
    """The level path: sizes around MIN_LEVEL, large min_samples (wide windows), one level only,
    integer grids (exact ties at eps), and free points just below the level."""
    rng = np.random.default_rng(10 + seed)
    for _ in range(80):
        n = int(rng.integers(1, 120))
        X = np.column_stack([rng.standard_normal(n), rng.uniform(0.0, 1.0, n)])
        top = rng.uniform(0.5, 1.0)
        X[rng.random(n) < rng.uniform(0.0, 1.0), 1] = top  # the level, possibly below MIN_LEVEL
        X[:, 1] = np.minimum(X[:, 1], top)
        kind = rng.integers(4)
        if kind == 1:
            X[:, 0] = rng.integers(-8, 8, n) * 0.1  # ties exactly at eps = 0.1 * k
        elif kind == 2:
            X[:, 1] = top  # everything on the level
        elif kind == 3:
            X[:, 1] = np.where(X[:, 1] < top, top - rng.uniform(0, 0.3, n), top)  # near the level
        eps = float(rng.choice([0.1, 0.2, rng.uniform(0.05, 0.6)]))
        ms = int(rng.integers(1, 30))
        expected = DBSCAN(eps=eps, min_samples=ms).fit(X).labels_
        np.testing.assert_array_equal(dbscan(X, eps, ms), expected)


def two_valley(eps):
    """Paper Fig. 2: good modes at +-0.5, a ridge of high cost at the mean 0."""
    return 1.0 * np.minimum((eps - 0.5) ** 2, (eps + 0.5) ** 2) * 20 + 50.0 * (np.abs(eps) < 0.25)


def test_two_valley_mppi_on_ridge_clustered_in_a_mode():
    rng = np.random.default_rng(3)
    K, sigma, lam = 500, np.sqrt(0.1) * 2, 5.0
    raw = rng.normal(0, sigma, K)
    eps = raw[None, :]  # N = 1
    S = two_valley(raw)
    U, _ = mppi_update(np.zeros(1), eps, S, lam)
    assert abs(U[0]) < 0.25  # the weighted average lands on the ridge
    labels = cluster_labels(cluster_features(eps, S, lam, sigma, raw=raw))
    Uc, W = cluster_updates(np.zeros(1), eps, S, lam, labels)
    np.testing.assert_allclose(W.sum(axis=1), 1.0)
    best = Uc[np.argmin(two_valley(Uc[:, 0])), 0]
    assert 0.3 < abs(best) < 0.7  # inside one mode


def test_noise_points_belong_to_no_cluster():
    labels = np.array([0, -1, 0, 1, 1, -1])
    S = np.arange(6.0)
    _, W = cluster_updates(np.zeros(2), np.ones((2, 6)), S, 1.0, labels)
    assert np.all(W[:, labels == -1] == 0)
    assert W.shape == (2, 6)


def blocked_step(name, **params):
    """One step with a cylinder straight ahead between the robot and the goal."""
    ctrl = dcmppi.make_controller(name, seed=0, **params)
    state, goal = np.array([0.0, 0.0, 0.0]), np.array([15.0, 0.0])
    static = np.array([[3.0, 0.0, 1.0]])
    ctrl.act(state, goal, static)
    return ctrl, rollout(state, ctrl.diagnostics.plan, ctrl.v, ctrl.dt)


def test_clustered_plan_avoids_blocking_cylinder():
    ctrl, states = blocked_step("clustered")
    d = ctrl.diagnostics
    assert d.labels.shape == (ctrl.K,) and d.chosen >= 0
    assert d.cluster_costs[d.chosen] == d.cluster_costs.min()
    assert np.hypot(states[:, 0] - 3.0, states[:, 1]).min() > 1.5
