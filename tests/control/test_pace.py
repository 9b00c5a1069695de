"""The options for time to the goal: the objective's Pace terms (cost_to_go, path_align,
speed_weight) and the update's speed_mean, and the term for standing in a person's way
(way_weight); off by default."""

import numpy as np
import pytest

import dcmppi
from dcmppi.control.kernels.costs import OccupancyGrid
from dcmppi.control.objective import Objective, Pace
from dcmppi.control.planners.mppi import polar_means
from dcmppi.control.predictors import Prediction

GOAL = np.array([30.0, 0.0])
SMOOTH = {"agent": "holonomic", "preset": "smooth", "perturbation": "correlated"}


def drive(steps=30, controller="mppi", seed=3, **params):
    """The positions (steps + 1, 2) of `steps` steps towards an open goal 30 m ahead."""
    ctrl = dcmppi.make_controller(controller, K=200, N=30, seed=seed, **SMOOTH, **params)
    state, path = np.zeros(3), [np.zeros(2)]
    for _ in range(steps):
        state = ctrl.agent.step(state, ctrl.act(state, GOAL), ctrl.dt)
        path.append(state[:2].copy())
    return np.array(path)


def test_terms_by_hand():
    # two rollouts of 3 states from (0, 0) to a goal at (10, 0), dt 0.5, v_max 2
    x = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    y = np.array([[0.0, 0.0], [0.0, 0.5], [0.0, 1.0]])
    start, goal = np.zeros(2), np.array([10.0, 0.0])
    pace = Pace.of(2.0, 0.5, cost_to_go=1.0)
    np.testing.assert_allclose(pace(x, y, start, goal), [8.0, np.hypot(10.0, 1.0)])
    pace = Pace.of(2.0, 0.5, path_align=2.0)
    np.testing.assert_allclose(pace(x, y, start, goal), [0.0, 2.0 * 1.5])
    pace = Pace.of(2.0, 0.5, speed_weight=1.0)  # speeds 2, 2 and 1, 1
    np.testing.assert_allclose(pace(x, y, start, goal, cols=(1, 2)), [2.0])
    np.testing.assert_allclose(pace(x, y, start, goal), [0.0, 2.0])
    assert not Pace.of(2.0, 0.5).on and Pace.of(2.0, 0.5, speed_weight=0.1).on


def walker_ahead(speed=1.0, P=4, N=20, dt=0.1):
    """A Prediction of one walker of radius 0.3 from (2, 0) along +y at `speed`, P futures (two
    0.1 m/s slower, two faster: their mean is the walker's true path), N steps of dt."""
    t = dt * np.arange(N + 1)
    v = speed + np.array([-0.1, -0.1, 0.1, 0.1])[:P]
    futures = np.zeros((1, P, N + 1, 2))
    futures[0, :, :, 0], futures[0, :, :, 1] = 2.0, v[:, None] * t
    return Prediction(futures.reshape(P, N + 1, 2), np.full(P, 0.6), 100.0 / P, futures)


def test_the_way_term_counts_states_where_a_person_is_about_to_be():
    prediction, grid = walker_ahead(), OccupancyGrid(None, 0.3)
    goal = np.array([10.0, 0.0])
    # three robots: 0.45 s ahead of the walker on its line, 1 s behind it, and far off
    states = np.zeros((3, 21, 3))
    states[0, :, 0], states[0, :, 1] = 2.0, 0.1 * np.arange(21) + 0.45  # 0.45 s ahead of it
    states[1, :, 0], states[1, :, 1] = 2.0, 0.1 * np.arange(21) - 1.0  # 1 s behind it
    states[2, :, 0] = 8.0
    states = states.transpose(2, 1, 0)  # (3, N + 1, R)
    pace = Pace.of(1.5, 0.1, way_weight=2.0)
    off = Objective(goal, grid, 1e3, prediction)
    on = Objective(goal, grid, 1e3, prediction, pace, np.zeros(2))
    extra = on.moving(states) - off.moving(states)
    # ahead: each state against the walker's mean position 0.2, 0.4 .. 1.2 s later (held at the
    # futures' end), within 0.6 m: weight 2 per instant; behind and far off: none
    walker_y = 0.1 * np.minimum(np.arange(21)[:, None] + np.arange(2, 13, 2), 20)
    within = np.abs(states[1, :, 0][:, None] - walker_y) <= 0.6 + 1e-9
    assert extra[0] == 2.0 * within.sum() > 2.0 * 21
    assert extra[1] == 0.0 and extra[2] == 0.0
    J_off, J_on = off(states), on(states)
    np.testing.assert_allclose(J_on - J_off, extra)
    frozen = Prediction(prediction.tracks, prediction.distance, prediction.weight)  # no futures
    assert Objective(goal, grid, 1e3, frozen, pace, np.zeros(2)).way.empty
    shown = Prediction(prediction.tracks[:1], prediction.distance[:1], 100.0, prediction.futures)
    with pytest.raises(ValueError, match="way_weight needs a prediction whose futures"):
        Objective(goal, grid, 1e3, shown, pace, np.zeros(2))  # futures that are not its tracks


def test_polar_means_reach_the_top_speed():
    # samples at the top speed 45 degrees either side of +x, equal weights: the vector mean's
    # speed is cos 45 degrees of it, the polar mean's the top speed, along +x
    u = np.zeros((4, 3, 2))
    u[:, 0, :], u[:, 1, 0], u[:, 1, 1] = np.sqrt(0.5), np.sqrt(0.5), -np.sqrt(0.5)
    w = np.array([0.5, 0.5])
    vector = u @ w
    polar = polar_means(vector, u, w, (0, 1))
    np.testing.assert_allclose(polar, np.tile([1.0, 0.0, 0.0], (4, 1)), atol=1e-12)
    # per cluster: each of 2 clusters holds one sample, whose speed it keeps
    U = np.stack([u[:, :, 0], 0.5 * u[:, :, 1]])
    out = polar_means(U, u, np.ones(2), (0, 1), labels=np.array([0, 1]))
    np.testing.assert_allclose(np.hypot(out[..., 0], out[..., 1]), 1.0)
    np.testing.assert_allclose(out[1], u[:, :, 1])


@pytest.mark.parametrize("controller", ["mppi", "dc", "tube"])
def test_off_is_the_default(controller):
    off = {"cost_to_go": 0.0, "path_align": 0, "speed_weight": 0.0, "way_weight": 0.0,
           "speed_mean": "vector"}  # fmt: skip
    default = drive(10, controller)
    np.testing.assert_array_equal(drive(10, controller, **off), default)
    ctrl = dcmppi.make_controller(controller, **SMOOTH)
    assert ctrl.pace == Pace.of(ctrl.agent.max_speed, ctrl.dt) and ctrl.speed_mean == "vector"
    assert {"cost_to_go", "path_align", "speed_weight", "way_weight", "speed_mean"} <= set(
        ctrl.params
    )


def speed(path):
    """Mean speed [m/s] of a path at dt = 0.1 s."""
    return float(np.mean(np.hypot(*np.diff(path, axis=0).T)) / 0.1)


@pytest.mark.parametrize("controller", ["mppi", "dc"])
@pytest.mark.parametrize(
    "option", [{"speed_mean": "polar"}, {"speed_weight": 5.0}, {"cost_to_go": 50.0}]
)
def test_speed_options_raise_the_speed_to_an_open_goal(controller, option):
    base = speed(drive(controller=controller))
    faster = speed(drive(controller=controller, **option))
    assert base < faster <= 1.5 + 1e-9


@pytest.mark.parametrize("controller", ["mppi", "dc"])
def test_path_align_keeps_to_the_straight_line(controller):
    base, aligned = drive(controller=controller), drive(controller=controller, path_align=5.0)
    assert np.abs(aligned[:, 1]).mean() < np.abs(base[:, 1]).mean()


@pytest.mark.parametrize(
    ("params", "message"),
    [
        ({"path_align": -1.0}, "path_align"),
        ({"speed_mean": "median"}, "speed_mean must be one of"),
        ({"speed_mean": "polar", "agent": "dubins"}, "needs an agent with a norm-bounded"),
    ],
)
def test_bad_options_are_named(params, message):
    with pytest.raises(ValueError, match=message):
        dcmppi.make_controller("mppi", **params)


def test_a_preset_sets_the_options_and_gamma(monkeypatch):
    fast = {"speed_mean": "polar", "gamma": 0.1, "path_align": 1.0}
    monkeypatch.setitem(dcmppi.control.defaults.PRESETS, "fast", fast)
    ctrl = dcmppi.make_controller("dc", agent="holonomic", preset="fast")
    assert (ctrl.speed_mean, ctrl.gamma, ctrl.pace.path_align) == ("polar", 0.1, 1.0)
    given = dcmppi.make_controller("dc", agent="holonomic", preset="fast", gamma=1.0)
    assert given.gamma == 1.0


def test_the_crowds_preset_is_smooth_with_polar_speed_a_weak_importance_term_and_the_shield():
    ctrl = dcmppi.make_controller("dc", agent="holonomic", prediction="cv", preset="crowds")
    assert (ctrl.speed_mean, ctrl.gamma, ctrl.perturbation) == ("polar", 0.1, "correlated")
    assert ctrl.filter_window == 9 and ctrl.lambda_ == "auto" and ctrl.safety is not None
    assert ctrl.predictor.cv_std_still == 0.1 and ctrl.params["cv_std_still"] == 0.1
    assert ctrl.predictor.cv_std == 0.2 and (ctrl.beta, ctrl.way_weight) == (50.0, 1.0)
    off = dcmppi.make_controller(
        "dc", agent="holonomic", prediction="cv", preset="crowds", shield=False, cv_std_still=0.3
    )
    assert off.safety is None and off.predictor.cv_std_still == 0.3  # given options win
    social = dcmppi.make_controller("dc", agent="holonomic", prediction="social", preset="crowds")
    assert "cv_std_still" not in social.params  # only predictors that take it get it


def test_the_importance_term_drags_a_velocity_robot():
    # gamma lambda U0^T Sigma^-1 e is least for perturbations against the warm start: slower
    assert speed(drive(gamma=0.1)) > speed(drive()) + 0.1
