"""Algorithm 2: the two-valley case, a controller facing a blocking cylinder."""

import numpy as np
import pytest

import dcmppi
from dcmppi.control.clustered import cluster_features, cluster_labels, cluster_updates
from dcmppi.control.mppi import mppi_update


def two_valley(eps):
    """Paper Fig. 2: good modes at +-0.5, a ridge of high cost at the mean 0."""
    return 1.0 * np.minimum((eps - 0.5) ** 2, (eps + 0.5) ** 2) * 20 + 50.0 * (np.abs(eps) < 0.25)


def test_two_valley_mppi_on_ridge_clustered_in_a_mode():
    rng = np.random.default_rng(3)
    K, sigma, lam = 500, np.sqrt(0.1) * 2, 5.0
    raw = rng.normal(0, sigma, K)
    eps = raw[None, None, :]  # N = 1, one control
    S = two_valley(raw)
    U, _ = mppi_update(np.zeros((1, 1)), eps, S, lam)
    assert abs(U[0, 0]) < 0.25  # the weighted average lands on the ridge
    labels = cluster_labels(cluster_features(eps, S, lam, [sigma], raw=raw[None]))
    Uc, w = cluster_updates(np.zeros((1, 1)), eps, S, lam, labels)
    np.testing.assert_allclose(np.bincount(labels[labels >= 0], w[labels >= 0]), 1.0)
    best = Uc[np.argmin(two_valley(Uc[:, 0, 0])), 0, 0]
    assert 0.3 < abs(best) < 0.7  # inside one mode


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
    for args in (
        (np.zeros((3, 1)), eps, S, 1.0, labels),
        (np.zeros((4, 1)), eps, S[:5], 1.0, labels),
    ):
        with pytest.raises(ValueError, match="cluster_updates needs"):
            cluster_updates(*args)
    with pytest.raises(ValueError, match="raw"):
        cluster_updates(np.zeros((4, 1)), eps, S, 1.0, labels, raw=np.zeros(5), bound=1.0)


def blocked_step(name, **params):
    """One step with a cylinder straight ahead between the robot and the goal."""
    ctrl = dcmppi.make_controller(name, seed=0, **params)
    state, goal = np.array([0.0, 0.0, 0.0]), np.array([15.0, 0.0])
    static = np.array([[3.0, 0.0, 1.0]])
    ctrl.act(state, goal, static)
    return ctrl, ctrl.agent.rollout_one(state, ctrl.diagnostics.plan, ctrl.dt)


def test_clustered_plan_avoids_blocking_cylinder():
    ctrl, states = blocked_step("clustered")
    d = ctrl.diagnostics
    assert d.labels.shape == (ctrl.K,) and d.chosen >= 0
    assert d.cluster_costs[d.chosen] == d.cluster_costs.min()
    assert np.hypot(states[:, 0] - 3.0, states[:, 1]).min() > 1.5
