"""Algorithm 1: known-answer update, normalised weights, numerical robustness."""

import numpy as np

from dcmppi.control.mppi import mppi_update, mppi_weights


def test_update_moves_towards_quadratic_optimum():
    rng = np.random.default_rng(0)
    N, K, target = 5, 20000, 0.4
    U0 = np.zeros(N)
    eps = rng.normal(0, 0.3, (N, K))
    S = ((U0[:, None] + eps - target) ** 2).sum(axis=0) * 10.0
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
    U, _ = mppi_update(np.zeros(3), rng.normal(size=(3, 500)), S, 0.01)
    assert np.all(np.isfinite(U))


def test_smaller_lambda_concentrates_weights():
    S = np.linspace(0.0, 5.0, 50)
    assert mppi_weights(S, 0.1).max() > mppi_weights(S, 10.0).max()
