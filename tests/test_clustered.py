"""Algorithm 2: the two-valley case, a controller facing a blocking cylinder."""

import numpy as np

import dcmppi
from dcmppi.clustered import cluster_features, cluster_labels, cluster_updates
from dcmppi.dynamics import rollout
from dcmppi.mppi import mppi_update


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
