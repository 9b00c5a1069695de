"""The smoothness options and the `smooth` preset: the change cost, the Savitzky-Golay filter,
candidates without single samples, hysteresis in the choice of cluster; off by default."""

import numpy as np
import pytest
from scipy.signal import savgol_coeffs

import dcmppi
from dcmppi.control.agents import make_agent
from dcmppi.control.defaults import PRESETS
from dcmppi.control.kernels.projection import bound_rows
from dcmppi.control.planners.clustered import with_hysteresis, without_singletons
from dcmppi.control.planners.controller import shifted
from dcmppi.control.planners.smoothing import (
    change_costs,
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


@pytest.mark.parametrize("name", ["mppi", "dc", "tube"])
def test_guard_applies_the_plan_where_the_filtered_one_costs_more(name):
    """With filter_guard, the filtered plan unless the plan as optimised is cheaper by more than
    the margin; a filter that lags behind a turn away from the cylinder meets it."""
    ctrl = dcmppi.make_controller(
        name, agent="holonomic", seed=0, K=64, filter_window=9, filter_guard=0.0
    )
    state = np.array([4.45, 0.0, 0.0])  # 0.05 m from touching the cylinder ahead
    list(head_on(ctrl, 2))
    ctrl._applied.extend([np.array([1.5, 0.0, 0.0])] * 4)  # straight at the cylinder
    swerve = np.tile([0.0, 1.5, 0.0], (ctrl.N, 1))  # away from it, at once
    straight_on = np.tile([1.5, 0.0, 0.0], (ctrl.N, 1))
    _, J = ctrl.rollout_costs(state, np.stack([swerve, straight_on], axis=2))
    assert J[0] < J[1]
    assert ctrl.smoothed(swerve, state) is swerve and ctrl.diagnostics.guarded
    ctrl.filter_guard = float(J[1] - J[0]) + 1.0  # the filtered plan is within the margin
    kept = ctrl.smoothed(swerve, state)
    assert not ctrl.diagnostics.guarded and not np.array_equal(kept, swerve)
    unguarded = dcmppi.make_controller(name, agent="holonomic", seed=0, K=64, filter_window=9)
    list(head_on(unguarded, 2))
    unguarded._applied.extend([np.array([1.5, 0.0, 0.0])] * 4)
    np.testing.assert_array_equal(unguarded.smoothed(swerve, state), kept)


def test_change_cost_charges_a_jagged_sequence():
    N = 20
    smooth = np.full((N, 1), 0.5)
    jagged = 0.5 + 0.3 * np.tile([[1.0], [-1.0]], (N // 2, 1))
    u = np.stack([smooth, jagged], axis=2)  # (N, 1, 2)
    cost = change_costs(u, np.zeros(0), np.array([2.0]), 0, 2)
    assert cost[0] == 0.0 and cost[1] == pytest.approx(2.0 * (N - 1) * 0.6**2)
    cost = change_costs(u, np.array([0.0]), np.array([2.0]), 0, 2)  # and from the last control
    assert cost[0] == pytest.approx(2.0 * 0.25)
    # in a controller: J of the jagged sequence rises by its change cost, the smooth one's not
    base = dcmppi.make_controller("mppi", seed=0, K=32, N=N)
    charged = dcmppi.make_controller("mppi", seed=0, K=32, N=N, change_cost=2.0)
    for ctrl in (base, charged):
        ctrl.act(np.zeros(3), GOAL)
    x0 = np.zeros(3)
    _, J0 = base.rollout_costs(x0, u)
    _, J1 = charged.rollout_costs(x0, u)
    applied = charged.diagnostics.action[0]
    expected = 2.0 * ((u[0, 0] - applied) ** 2 + np.sum(np.diff(u[:, 0], axis=0) ** 2, axis=0))
    np.testing.assert_allclose(J1 - J0, expected, rtol=1e-9)
    assert J1[1] - J0[1] > J1[0] - J0[0]


def test_without_singletons_relabels_small_clusters():
    labels = np.array([0, 0, 1, -1, 2, 2, 2, 3])
    np.testing.assert_array_equal(without_singletons(labels), [0, 0, -1, -1, 1, 1, 1, -1])
    kept = np.array([0, 0, 1, 1, -1])
    assert without_singletons(kept) is kept


@pytest.mark.parametrize("name", ["clustered", "dc"])
def test_no_single_sample_candidates(name):
    ctrl = dcmppi.make_controller(
        name, agent="holonomic", seed=1, K=128, best_sample_cluster=False, dbscan_min_samples=1
    )
    for c in head_on(ctrl, 12):
        d = c.diagnostics
        clustered = d.labels[d.labels >= 0]
        if len(clustered):
            assert np.bincount(clustered).min() >= 2
            assert len(d.cluster_controls) == clustered.max() + 1
        assert np.count_nonzero(d.weights) >= 2


def test_hysteresis_keeps_the_continuing_cluster_within_the_margin():
    U0 = np.zeros((5, 2))
    U = np.stack([np.full((5, 2), 1.0), np.full((5, 2), 0.1)])  # candidate 1 continues U0
    Sigma = np.array([1.0, 1.0])
    assert continuing(U, U0, Sigma) == 1
    J = np.array([100.0, 120.0])
    assert with_hysteresis(J, U, U0, Sigma, 30.0) == (1, 1)  # within the margin: kept
    assert with_hysteresis(J, U, U0, Sigma, 10.0) == (0, 1)  # better by more: switch
    ctrl = dcmppi.make_controller("dc", agent="holonomic", seed=2, K=128, hysteresis=1e9)
    for c in head_on(ctrl, 8):
        d = c.diagnostics
        assert d.chosen == d.continued or d.chosen == -1


def test_smooth_preset_sets_its_options_and_explicit_values_win():
    smooth = PRESETS["smooth"]
    ctrl = dcmppi.make_controller("dc", agent="holonomic", preset="smooth")
    assert ctrl.preset == "smooth" and ctrl.lambda_ == smooth["lambda_"] == "auto"
    assert ctrl.ess_target == smooth["ess_target"]
    assert not ctrl.change_cost.any()  # tried and left out of the preset
    assert (ctrl.filter_window, ctrl.filter_order) == (
        smooth["filter_window"],
        smooth["filter_order"],
    )
    assert ctrl.best_sample_cluster  # the least-cost sample's cluster stays
    assert ctrl.hysteresis == smooth["hysteresis"] > 0
    assert ctrl.filter_guard is None and "filter_guard" not in smooth  # no guard: only jerk
    assert ctrl.perturbation == smooth["perturbation"] == "correlated"
    assert ctrl.correlation == 0.9
    params = ctrl.params
    assert params["preset"] == "smooth" and params["change_cost"] == ctrl.change_cost.tolist()
    own = dcmppi.make_controller(
        "dc", agent="holonomic", preset="smooth", lambda_=1.0, filter_window=0, hysteresis=0.0
    )
    assert (own.lambda_, own.filter_window, own.hysteresis) == (1.0, 0, 0.0)
    assert dcmppi.make_controller("dc", preset="smooth", change_cost=0.5).change_cost == [0.5]
    for name in ("mppi", "tube"):  # the planners without clusters take the rest
        ctrl = dcmppi.make_controller(name, agent="holonomic", preset="smooth", seed=0, K=64)
        assert ctrl.filter_window == 9 and ctrl.lambda_ == "auto"
        assert ctrl.perturbation == "correlated" and not ctrl.has_guard
        list(head_on(ctrl, 3))


def test_unknown_preset_is_one_line_naming_the_valid_ones():
    with pytest.raises(ValueError) as error:
        dcmppi.make_controller("mppi", preset="silky")
    message = str(error.value)
    assert "\n" not in message
    assert message == "preset must be one of paper, smooth; got 'silky'"


@pytest.mark.parametrize(
    "params, match",
    [
        ({"filter_window": 4}, "filter_window must be 0"),
        ({"filter_window": 5, "filter_order": 5}, "filter_order must be below"),
        ({"change_cost": -1.0}, "change_cost must be >= 0"),
        ({"change_cost": [1.0, 2.0]}, "one per control"),
        ({"hysteresis": -1.0}, "hysteresis must be >= 0"),
        ({"filter_guard": -1.0}, "filter_guard must be >= 0"),
        ({"best_sample_cluster": "no"}, "best_sample_cluster must be true or false"),
    ],
)
def test_bad_smoothness_parameters_are_named(params, match):
    with pytest.raises(ValueError, match=match):
        dcmppi.make_controller("dc", **params)


@pytest.mark.parametrize("name", ["mppi", "clustered", "dc", "tube"])
def test_defaults_are_the_papers(name):
    ctrl = dcmppi.make_controller(name, agent="holonomic", lambda_=None, ess_target=None)
    assert ctrl.preset == "paper" and ctrl.lambda_ == 1.0 and ctrl.ess_target == 0.1
    assert not ctrl.change_cost.any() and ctrl.filter_window == 0 and ctrl.filter_guard is None
    if name in ("clustered", "dc"):
        assert ctrl.best_sample_cluster is True and ctrl.hysteresis == 0.0
