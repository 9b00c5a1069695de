"""Registry, parameters, determinism, diagnostics, analytic closed loop: all controllers."""

import numpy as np
import pytest

import dcmppi
from dcmppi.control.dynamics import dubins_step

NAMES = ["mppi", "clustered", "dc", "tube"]
MODEL = np.array([1.0, 0.29, 0.0, 0.29])


def test_registry_lists_names():
    assert set(dcmppi.controller_names()) == set(NAMES)
    with pytest.raises(ValueError, match="valid names: clustered, dc, mppi, tube"):
        dcmppi.make_controller("nope")


@pytest.mark.parametrize(
    "params, word",
    [
        ({"K": 0}, "K"),
        ({"K": 2.5}, "K"),
        ({"N": 0}, "N"),
        ({"lambda_": 0.0}, "lambda_"),
        ({"Sigma": -1.0}, "Sigma"),
        ({"v": 0}, "v"),
        ({"dt": float("nan")}, "dt"),
        ({"P": 0}, "P"),
        ({"alpha": -1}, "alpha"),
        ({"perturbation": "wiggly"}, "perturbation"),
        ({"gamma": 1}, "gamma"),
    ],
)
def test_bad_parameters_name_the_parameter(params, word):
    with pytest.raises(ValueError, match=word):
        dcmppi.make_controller("dc", **params)


def test_bad_inputs():
    ctrl = dcmppi.make_controller("mppi")
    with pytest.raises(ValueError, match="state"):
        ctrl.act(np.zeros(2), np.ones(2))
    with pytest.raises(ValueError, match="static"):
        ctrl.act(np.zeros(3), np.ones(2), np.zeros((3, 2)))


@pytest.mark.parametrize("name", NAMES)
def test_non_finite_inputs_are_named(name):
    """NaN or far-off poses and obstacles get a ValueError naming them, not a crash (the numba
    kernels do not check bounds) or a silently ignored obstacle; the controller still works."""
    ctrl = dcmppi.make_controller(name, K=50, N=10, seed=0)
    state, goal, static, moving = scene()
    model = np.array([1.0, 0.2, 0.0, 0.1])
    bad = [
        ("state", (np.array([np.nan, 0.0, 0.0]), goal, static, moving, model)),
        ("goal", (state, np.array([1e300, 0.0]), static, moving, model)),
        ("static", (state, goal, np.array([[6.0, np.nan, 1.0]]), moving, model)),
        ("static", (state, goal, np.array([[6.0, 0.2, -1.0]]), moving, model)),
        ("moving", (state, goal, static, np.array([[9.0, np.inf, 0.0, 1.0]]), model)),
    ]
    if name == "dc":
        bad.append(("obstacle_model", (state, goal, static, moving, model * np.nan)))
    for word, args in bad:
        with pytest.raises(ValueError, match=word):
            ctrl.act(*args)
    assert np.isfinite(ctrl.act(state, goal, static.tolist(), moving, model))
    assert np.isfinite(ctrl.act(state, goal, static.tolist(), moving, model))  # list, grid reused


def test_cost_map_too_large_names_resolution():
    ctrl = dcmppi.make_controller("mppi")
    with pytest.raises(ValueError, match="coarser resolution"):
        ctrl.act(np.zeros(3), np.ones(2), np.array([[0.0, 0.0, 1.0], [1e5, 1e5, 1.0]]))


def scene():
    static = np.array([[6.0, 0.2, 1.0], [0.0, 0.0, 0.0]])  # one cylinder and a padding row
    moving = np.array([[9.0, -4.0, np.pi / 2, 1.0]])
    return np.array([0.0, 0.0, 0.0]), np.array([14.0, 0.0]), static, moving


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("perturbation", ["constant", "time_varying"])
def test_same_seed_bit_identical_actions(name, perturbation):
    state, goal, static, moving = scene()
    runs = []
    for _ in range(2):
        ctrl = dcmppi.make_controller(name, seed=7, K=100, perturbation=perturbation)
        s, acts = state.copy(), []
        for _ in range(4):
            acts.append(ctrl.act(s, goal, static, moving, MODEL))
            s = dubins_step(s, acts[-1], 1.0, 0.1)
        runs.append(acts)
    assert runs[0] == runs[1]
    ctrl.reset(seed=8)
    assert ctrl.act(state, goal, static, moving, MODEL) != runs[0][0]


@pytest.mark.parametrize("name", NAMES)
def test_diagnostics_shapes_and_bounds(name):
    state, goal, static, moving = scene()
    ctrl = dcmppi.make_controller(name, seed=0, K=64, N=20)
    omega = ctrl.act(state, goal, static, moving, MODEL)
    d = ctrl.diagnostics
    assert abs(omega) <= 1.0 and d.action == omega
    assert d.eps.shape == (64, 20) and d.states.shape == (64, 21, 3)
    assert d.J.shape == d.S.shape == d.weights.shape == (64,)
    assert np.isclose(d.weights.sum(), 1.0) and 1.0 <= d.ess <= 64
    assert d.plan.shape == (20,) and np.all(np.abs(d.plan) <= 1.0)
    assert set(ctrl.params) >= {"K", "N", "lambda_", "Sigma", "alpha", "beta", "P", "seed"}


@pytest.mark.parametrize("name", NAMES)
def test_closed_loop_reaches_goal_around_cylinder(name):
    state, goal, static, _ = scene()
    ctrl = dcmppi.make_controller(name, seed=0, K=200)
    for _ in range(250):
        omega = ctrl.act(state, goal, static)
        state = dubins_step(state, omega, ctrl.v, ctrl.dt)
        clearance = np.hypot(state[0] - 6.0, state[1] - 0.2) - 1.0 - ctrl.robot_radius
        assert clearance > 0
        if np.hypot(*(state[:2] - goal)) < 1.0:
            break
    assert np.hypot(*(state[:2] - goal)) < 1.0
