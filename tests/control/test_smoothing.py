"""The smoothness options and the `smooth` preset: the Savitzky-Golay filter of the plan and
hysteresis in the choice of cluster; off by default."""

import numpy as np
import pytest
from scipy.signal import savgol_coeffs

import dcmppi
from dcmppi.control.agents import make_agent
from dcmppi.control.defaults import PRESETS
from dcmppi.control.kernels.projection import bound_rows
from dcmppi.control.planners.controller import shifted
from dcmppi.control.planners.smoothing import (
    Hysteresis,
    PlanFilter,
    continuing,
    filter_coefficients,
    savitzky_golay,
)

GOAL = np.array([30.0, 0.0])
MODEL = np.array([1.0, 0.29, 0.0, 0.29])
BOUNDS = np.array([-5.0, -10.0, 40.0, 10.0])


def head_on(ctrl, steps):
    """`steps` steps towards a cylinder and a walker crossing the way; yields each step's
    controller after its act."""
    state = np.zeros(3)
    for t in range(steps):
        walker = np.array([[12.0 - 0.5 * t * 0.1, 0.3, np.pi, 0.5]])
        u = ctrl.act(state, GOAL, np.array([[6.0, 0.0, 1.0]]), walker, MODEL, BOUNDS)
        state = ctrl.agent.step(state, u, ctrl.dt)
        yield ctrl


def test_filter_keeps_a_quadratic_and_damps_alternation():
    c = filter_coefficients(9, 2)
    np.testing.assert_allclose(c * 231, [-21, 14, 39, 54, 59, 54, 39, 14, -21], atol=1e-9)
    for window, order in ((5, 0), (11, 4), (7, 6)):
        expected = savgol_coeffs(window, order)
        np.testing.assert_allclose(filter_coefficients(window, order), expected, atol=1e-12)
    t = np.arange(-4, 20, dtype=float)
    signal = np.column_stack([0.3 * t**2 - t + 2.0, 0.01 * t**2])
    history, plan = signal[:4], signal[4:]
    out = savitzky_golay(plan, history, c)
    # a quadratic passes unchanged wherever the window holds it (all but the last 4 rows,
    # whose window runs past the end over the last row repeated)
    np.testing.assert_allclose(out[:-4], plan[:-4], atol=1e-9)
    jagged = np.tile([[1.0], [-1.0]], (10, 1))
    smooth = savitzky_golay(jagged, jagged[:0], c)
    # the window's gain at alternation: |sum (-1)^j c_j| = 41 / 231
    np.testing.assert_allclose(np.abs(smooth[4:-4]), 41 / 231, rtol=1e-12)
    # too little history: the oldest (or the first row) repeats
    np.testing.assert_allclose(savitzky_golay(np.ones((6, 1)), np.zeros((0, 1)), c), 1.0)


@pytest.mark.parametrize("agent", ["holonomic", "unicycle", "dubins"])
def test_bounded_plan_is_the_agents_projection(agent):
    model = make_agent(agent)
    plan = np.random.default_rng(0).normal(0.0, 2.0, (50, model.nu))
    np.testing.assert_array_equal(bound_rows(model, plan), model.project(plan, axis=1))


def test_filtered_plan_is_applied_and_warm_starts():
    ctrl = dcmppi.make_controller("mppi", agent="holonomic", seed=0, K=64, filter_window=9)
    for c in head_on(ctrl, 5):
        d = c.diagnostics
        np.testing.assert_array_equal(c.U, shifted(d.plan))
        np.testing.assert_allclose(d.action, d.plan[0], atol=1e-12)
        assert np.all(np.hypot(d.plan[:, 0], d.plan[:, 1]) <= 1.5 + 1e-9)  # still in bounds
        assert c.plan_filter.applied[-1] is d.action  # the next step's window reaches it


def test_plan_filter_reaches_back_over_the_last_applied_controls():
    agent = make_agent("holonomic")
    plan_filter = PlanFilter(agent, 9, 2)
    applied = [np.array([0.2 * i, 0.0, 0.0]) for i in range(6)]
    for u in applied:
        plan_filter.record(u)
    plan = np.tile([1.2, 0.0, 0.0], (20, 1))
    history = np.array(applied[-4:])  # the window's half before the plan: the last 4
    expected = bound_rows(agent, savitzky_golay(plan, history, filter_coefficients(9, 2)))
    np.testing.assert_array_equal(plan_filter(plan), expected)
    assert expected[0, 0] < 1.2  # the slower controls before the plan pull its start down
    plan_filter.reset()  # a new episode: the plan's first row stands for the history
    np.testing.assert_allclose(plan_filter(plan), plan, atol=1e-12)
    assert PlanFilter(agent, 0, 2)(plan) is plan  # no filter


def test_hysteresis_keeps_the_continuing_cluster_within_the_margin():
    U0 = np.zeros((5, 2))
    U = np.stack([np.full((5, 2), 1.0), np.full((5, 2), 0.1)])  # candidate 1 continues U0
    Sigma = np.array([1.0, 1.0])
    assert continuing(U, U0, Sigma) == 1
    J = np.array([100.0, 120.0])
    assert Hysteresis(30.0, Sigma)(J, U, U0) == (1, 1)  # within the margin: kept
    assert Hysteresis(10.0, Sigma)(J, U, U0) == (0, 1)  # better by more: switch
    assert Hysteresis(0.0, Sigma)(J, U, U0) == (0, -1)  # none: the least J
    ctrl = dcmppi.make_controller("dc", agent="holonomic", seed=2, K=128, hysteresis=1e9)
    for c in head_on(ctrl, 8):
        d = c.diagnostics
        assert d.chosen == d.continued or d.chosen == -1


def test_smooth_preset_sets_its_options_and_explicit_values_win():
    smooth = PRESETS["smooth"]
    ctrl = dcmppi.make_controller("dc", agent="holonomic", preset="smooth")
    assert ctrl.preset == "smooth" and ctrl.lambda_ == smooth["lambda_"] == "auto"
    assert ctrl.ess_target == smooth["ess_target"]
    assert (ctrl.filter_window, ctrl.filter_order) == (
        smooth["filter_window"],
        smooth["filter_order"],
    )
    assert ctrl.hysteresis == smooth["hysteresis"] > 0
    assert ctrl.perturbation == smooth["perturbation"] == "correlated"
    assert ctrl.correlation == 0.9
    params = ctrl.params
    assert params["preset"] == "smooth" and params["filter_window"] == smooth["filter_window"]
    own = dcmppi.make_controller(
        "dc", agent="holonomic", preset="smooth", lambda_=1.0, filter_window=0, hysteresis=0.0
    )
    assert (own.lambda_, own.filter_window, own.hysteresis) == (1.0, 0, 0.0)
    for name in ("mppi", "tube"):  # the planners without clusters take the rest
        ctrl = dcmppi.make_controller(name, agent="holonomic", preset="smooth", seed=0, K=64)
        assert ctrl.filter_window == 9 and ctrl.lambda_ == "auto"
        assert ctrl.perturbation == "correlated"
        list(head_on(ctrl, 3))


def test_unknown_preset_is_one_line_naming_the_valid_ones():
    with pytest.raises(ValueError) as error:
        dcmppi.make_controller("mppi", preset="silky")
    message = str(error.value)
    assert "\n" not in message
    assert message == "preset must be one of paper, smooth, crowds; got 'silky'"


@pytest.mark.parametrize(
    "params, match",
    [
        ({"filter_window": 4}, "filter_window must be 0"),
        ({"filter_window": 5, "filter_order": 5}, "filter_order must be below"),
        ({"hysteresis": -1.0}, "hysteresis must be >= 0"),
    ],
)
def test_bad_smoothness_parameters_are_named(params, match):
    with pytest.raises(ValueError, match=match):
        dcmppi.make_controller("dc", **params)


@pytest.mark.parametrize("name", ["mppi", "clustered", "dc", "tube"])
def test_defaults_are_the_papers(name):
    ctrl = dcmppi.make_controller(name, agent="holonomic", lambda_=None, ess_target=None)
    assert ctrl.preset == "paper" and ctrl.lambda_ == 1.0 and ctrl.ess_target == 0.1
    assert ctrl.filter_window == 0
    if name in ("clustered", "dc"):
        assert ctrl.hysteresis == 0.0
