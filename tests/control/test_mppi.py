"""Algorithm 1: known-answer update, normalised weights, numerical robustness."""

import numpy as np

from dcmppi.control.planners.mppi import mppi_update, mppi_weights


def test_update_moves_towards_quadratic_optimum():
    rng = np.random.default_rng(0)
    N, K, target = 5, 20000, 0.4
    U0 = np.zeros((N, 1))
    eps = rng.normal(0, 0.3, (N, 1, K))
    S = ((U0[:, :, None] + eps - target) ** 2).sum(axis=(0, 1)) * 10.0
    U, w = mppi_update(U0, eps, S, lambda_=1.0)
    assert np.all(np.abs(U - target) < np.abs(U0 - target))
    # Known answer: weights exp(-S / lambda) times the N(0, 0.09) sampling density give a
    # Gaussian with precision 2 * 10 + 1 / 0.09 and mean 20 target / that precision.
    np.testing.assert_allclose(U, 20 * target / (20 + 1 / 0.09), atol=0.02)
    assert np.isclose(w.sum(), 1.0)


def test_weights_finite_with_huge_costs():
    rng = np.random.default_rng(1)
    S = rng.uniform(1e3, 1e6, 500)
    w = mppi_weights(S, 1.0)
    assert np.all(np.isfinite(w)) and np.isclose(w.sum(), 1.0)
    assert w.argmax() == S.argmin()
    U, _ = mppi_update(np.zeros((3, 2)), rng.normal(size=(3, 2, 500)), S, 0.01)
    assert np.all(np.isfinite(U))


def test_smaller_lambda_concentrates_weights():
    S = np.linspace(0.0, 5.0, 50)
    assert mppi_weights(S, 0.1).max() > mppi_weights(S, 10.0).max()


def test_update_of_several_controls_is_per_control():
    """With nu controls, Alg. 1 updates each control by its own weighted perturbations."""
    rng = np.random.default_rng(2)
    U0 = rng.normal(size=(4, 3))
    eps = rng.normal(size=(4, 3, 50))
    S = rng.uniform(0, 5, 50)
    U, w = mppi_update(U0, eps, S, 1.0)
    for j in range(3):
        np.testing.assert_allclose(U[:, j], U0[:, j] + eps[:, j] @ w, rtol=1e-13)
