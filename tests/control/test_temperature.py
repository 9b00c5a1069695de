"""lambda_="auto" (dcmppi.control.planners.temperature): the ESS band on random costs and real
steps, the importance term against a brute-force reference, bad input."""

import math

import numpy as np
import pytest

import dcmppi
from dcmppi.control.planners.mppi import effective_sample_size, mppi_weights
from dcmppi.control.planners.temperature import ESS_BAND, _log_ess, choose_lambda

STATE, GOAL = np.array([0.0, 0.0, 0.3]), np.array([14.0, 3.0])
STATIC = np.array([[6.0, 1.5, 1.0]])
MOVING = np.array([[9.0, -4.0, np.pi / 2, 1.0]])
MODEL = np.array([1.0, 0.29, 0.0, 0.29])
HOLONOMIC = {"agent": "holonomic", "perturbation": "mixed", "Sigma": [1.0, 1.0, 0.1]}


def in_band(ess, target):
    """ESS within the search's band around target (at least 1 sample), rounding allowed."""
    target = max(target, 1.0)
    lo, hi = target / (1 + ESS_BAND), target * (1 + ESS_BAND)
    return lo * (1 - 1e-9) <= ess <= hi * (1 + 1e-9)


def random_costs(kind, K, rng):
    if kind == "exponential":
        return 1000.0 + rng.exponential(30.0, K)
    if kind == "lognormal":
        return rng.lognormal(2.0, 1.5, K)
    if kind == "collisions":  # goal distances plus alpha for each of 51 states in collision
        return rng.uniform(0.0, 50.0, K) + 1000.0 * rng.binomial(51, 0.05, K)
    return 10.0 * (rng.normal(size=(K, 3)) ** 2).sum(axis=1)  # quadratic bowl in 3 controls


@pytest.mark.parametrize("kind", ["exponential", "lognormal", "collisions", "bowl"])
@pytest.mark.parametrize("K", [50, 500, 2048])
@pytest.mark.parametrize("ess_target", [0.01, 0.05, 0.1, 0.3, 1.0])
def test_ess_of_random_costs_lies_in_the_band(kind, K, ess_target):
    rng = np.random.default_rng(K + int(100 * ess_target))
    S = random_costs(kind, K, rng)
    for guess in (None, 1e-9, 1e9, 3.0):
        lam = choose_lambda(S, ess_target, guess)
        ess = effective_sample_size(mppi_weights(S, lam))
        assert in_band(ess, ess_target * K), (guess, lam, ess)


def test_ties_of_the_least_cost_can_only_raise_the_ess():
    """60 ties and a target of 25: no lambda gives fewer than 60, the search ends near 60."""
    rng = np.random.default_rng(3)
    S = np.concatenate([np.full(60, 7.0), 7.0 + rng.uniform(1.0, 100.0, 440)])
    lam = choose_lambda(S, 0.05)
    assert 60.0 <= effective_sample_size(mppi_weights(S, lam)) < 60.5
    assert lam < 1.0 / 40


def test_largest_bounds_lambda():
    """5 free samples, 495 colliding: ESS 50 needs a lambda of the collision cost's order."""
    rng = np.random.default_rng(4)
    S = np.concatenate([rng.uniform(0.0, 10.0, 5), 1000.0 + rng.uniform(0.0, 10.0, 495)])
    assert choose_lambda(S, 0.1) > 100.0
    assert choose_lambda(S, 0.1, largest=100.0) == 100.0


def test_shifted_costs_give_the_same_lambda():
    rng = np.random.default_rng(5)
    S = rng.exponential(20.0, 500)
    assert math.isclose(choose_lambda(S + 12345.6, 0.1), choose_lambda(S, 0.1), rel_tol=1e-9)


def test_equal_costs_give_lambda_one():
    assert choose_lambda(np.full(20, 3.0), 0.1) == 1.0


@pytest.mark.parametrize("beta", [1e-3, 0.1, 3.0, 300.0])
def test_log_ess_and_slope_match_numpy(beta):
    """The search's own exp against numpy's, and its analytic slope d log ESS / d log lambda
    against a central difference."""
    rng = np.random.default_rng(6)
    S = 100.0 + rng.exponential(5.0, 700)
    low = S.min()

    def log_ess(b):
        return math.log(effective_sample_size(mppi_weights(S, 1.0 / b)))

    g, slope = _log_ess(S, low, beta)
    assert math.isclose(g, log_ess(beta), rel_tol=1e-9, abs_tol=1e-9)
    h = 1e-5  # t = log lambda = -log beta
    numeric = (log_ess(beta * math.exp(-h)) - log_ess(beta * math.exp(h))) / (2 * h)
    assert math.isclose(slope, numeric, rel_tol=1e-5, abs_tol=1e-8)


def controller(name, **params):
    return dcmppi.make_controller(name, K=500, N=30, seed=0, **{**HOLONOMIC, **params})


def steps(ctrl, n=3):
    for _ in range(n):
        ctrl.act(STATE, GOAL, STATIC, MOVING, MODEL)
    return ctrl.diagnostics


@pytest.mark.parametrize("name", ["mppi", "tube", "dc"])
def test_ess_of_a_real_step_lies_in_the_band(name):
    """mppi and tube weigh all samples; dc's fallback (no cluster: DBSCAN needs more samples
    than there are) too, at the step's lambda."""
    extra = {"dbscan_min_samples": 501} if name == "dc" else {}
    ctrl = controller(name, lambda_="auto", ess_target=0.05, **extra)
    for _ in range(4):
        d = steps(ctrl, 1)
        assert d.lambda_ < ctrl.alpha / 10  # the bound does not decide here
        assert in_band(d.ess, 0.05 * 500), (d.lambda_, d.ess)
        np.testing.assert_allclose(d.weights, mppi_weights(d.S, d.lambda_), rtol=1e-12)
    if name == "dc":
        assert d.chosen == -1


def test_clusters_share_the_steps_lambda():
    """Every cluster's weights are exp(-(S - its least S) / lambda) at the one lambda."""
    ctrl = controller("clustered", lambda_="auto")
    d = steps(ctrl)
    assert d.chosen >= 0
    member = d.labels == d.chosen
    np.testing.assert_allclose(d.weights[member], mppi_weights(d.S[member], d.lambda_), rtol=1e-12)


def test_alpha_bounds_the_chosen_lambda():
    ctrl = controller("mppi", lambda_="auto", alpha=1.0)  # lambda at most 0.1
    assert steps(ctrl).lambda_ == 0.1


@pytest.mark.parametrize("name", ["mppi", "clustered"])
def test_gamma_does_not_change_lambda_when_q_is_constant(name):
    """With the warm start U0 = 0 every q_k = sum_i u_i^T Sigma^-1 eps_ik is 0: gamma = 0 and
    gamma = 1 see the same J and choose the same lambda."""
    chosen = []
    for gamma in (0.0, 1.0):
        ctrl = controller(name, lambda_="auto", gamma=gamma)
        ctrl.U = np.zeros((ctrl.N, ctrl.nu))
        ctrl.act(STATE, GOAL, STATIC, MOVING, MODEL)
        d = ctrl.diagnostics
        np.testing.assert_array_equal(d.S, d.J)
        chosen.append((d.lambda_, d.J))
    assert chosen[0][0] == chosen[1][0]
    np.testing.assert_array_equal(chosen[0][1], chosen[1][1])


@pytest.mark.parametrize("agent", ["dubins", "unicycle", "holonomic"])
@pytest.mark.parametrize("lambda_", [2.5, "auto"])
def test_importance_term_matches_brute_force(agent, lambda_):
    """S_k = J_k + gamma lambda sum_i sum_j u_ij eps_kij / Sigma_j, by hand from the
    diagnostics, at lambda = 2.5 and gamma = 0.7 (with "auto": lambda = 1 inside S, the step's
    lambda in the weights)."""
    Sigma = {"dubins": [0.1], "unicycle": [0.3, 0.1], "holonomic": [1.0, 0.5, 0.1]}[agent]
    ctrl = dcmppi.make_controller(
        "mppi", agent=agent, Sigma=Sigma, gamma=0.7, lambda_=lambda_, K=300, N=20, seed=1,
        perturbation="mixed",
    )  # fmt: skip
    d = steps(ctrl)
    U0 = d.warm_start
    assert np.abs(U0).max() > 0.1  # a warm start that makes the term matter
    q = np.zeros(ctrl.K)
    for k in range(ctrl.K):
        for i in range(ctrl.N):
            for j in range(ctrl.nu):
                q[k] += U0[i, j] * d.eps[k, i, j] / Sigma[j]
    lam = 1.0 if lambda_ == "auto" else lambda_
    term = 0.7 * lam * q
    assert term.std() > 1.0
    np.testing.assert_allclose(d.S, d.J + term, rtol=0, atol=1e-9 * np.abs(d.S).max())
    if lambda_ != "auto":
        assert d.lambda_ == lambda_
    np.testing.assert_allclose(d.weights, mppi_weights(d.J + term, d.lambda_), rtol=1e-9)


@pytest.mark.parametrize("value", [0.0, -1.0, float("nan"), "Auto", "1", True, [1.0]])
def test_bad_lambda_is_named(value):
    with pytest.raises(ValueError, match="lambda_ must be a number > 0 or 'auto'"):
        dcmppi.make_controller("mppi", lambda_=value)


@pytest.mark.parametrize("value", [0.0, -0.1, 1.5, float("nan"), "0.1"])
def test_bad_ess_target_is_named(value):
    with pytest.raises(ValueError, match="ess_target"):
        dcmppi.make_controller("mppi", lambda_="auto", ess_target=value)


def test_choose_lambda_rejects_bad_costs():
    with pytest.raises(ValueError, match="finite"):
        choose_lambda(np.array([1.0, np.nan, 2.0]), 0.1)
    with pytest.raises(ValueError, match=r"shape \(K,\)"):
        choose_lambda(np.ones((2, 3)), 0.1)


def test_auto_is_recorded_in_params():
    params = dcmppi.make_controller("dc", lambda_="auto", ess_target=0.2).params
    assert params["lambda_"] == "auto" and params["ess_target"] == 0.2
