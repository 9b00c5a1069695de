"""The "given" predictor: the caller's futures of the moving obstacles, and its bad input."""

import numpy as np
import pytest

import dcmppi

GOAL = np.array([8.0, 0.0])


def crossing(steps, N=50, dt=0.1, speed=1.2, y0=4.0):
    """A disc crossing the robot's straight way downwards: (1, 4) now and (1, 1, N + 1, 2) its
    exact future, `steps` control steps after the start."""
    t = dt * (steps + np.arange(N + 1))
    future = np.stack([np.full_like(t, 4.0), y0 - speed * t], axis=-1)
    now = np.array([[*future[0], -np.pi / 2, 0.5]])
    return now, future[None, None]


def drive(prediction):
    """12 s toward GOAL past the crossing disc; the smallest centre distance [m]."""
    ctrl = dcmppi.make_controller("mppi", agent="holonomic", prediction=prediction, seed=0)
    state, closest = np.zeros(3), np.inf
    for k in range(120):
        moving, future = crossing(k)
        extra = {"moving_futures": future} if prediction == "given" else {}
        u = ctrl.act(state, GOAL, None, moving, None, **extra)
        state = ctrl.agent.step(state, u, 0.1)
        closest = min(closest, np.hypot(*(state[:2] - crossing(k + 1)[0][0, :2])))
    return closest


def test_true_futures_keep_the_robot_clear_where_frozen_ones_do_not():
    touching = 0.5 + 0.5
    assert drive("given") > touching > drive("frozen")


def test_the_futures_are_the_tracks_with_weight_beta_per_future():
    ctrl = dcmppi.make_controller("dc", agent="holonomic", prediction="given", seed=0)
    moving, future = crossing(0)
    two = np.concatenate([future, future + 1.0], axis=1)  # (1, 2, N + 1, 2)
    ctrl.act(np.zeros(3), GOAL, None, moving, None, moving_futures=two)
    p = ctrl.diagnostics.prediction
    np.testing.assert_array_equal(p.tracks, two[0])
    assert p.weight == ctrl.beta / 2 and p.collision_cost == ctrl.beta
    np.testing.assert_array_equal(p.distance, [0.5 + ctrl.robot_radius] * 2)


def test_obstacles_out_of_reach_are_left_out_and_change_nothing():
    """A parked obstacle 2 km away (which would spread the step's track cells over 2 km) is left
    out; one that comes within reach only at the horizon's end is kept; the plan is the same."""
    moving, future = crossing(0)
    N = future.shape[2] - 1
    far = np.full((1, 1, N + 1, 2), 2000.0)
    late = np.stack([np.full(N + 1, 6.0), np.linspace(40.0, 0.0, N + 1)], axis=-1)[None, None]
    late_now = np.array([[6.0, 40.0, -np.pi / 2, 0.5]])  # 40 m away now, at the robot's reach
    rows = np.vstack([moving, [[2000.0, 2000.0, 0.0, 0.5]], late_now])
    futures = np.concatenate([future, far, late])
    plans = []
    for state_rows, state_futures in ((rows, futures), (rows[[0, 2]], futures[[0, 2]])):
        ctrl = dcmppi.make_controller("dc", agent="holonomic", prediction="given", seed=0)
        plans.append(
            ctrl.act(np.zeros(3), GOAL, None, state_rows, None, moving_futures=state_futures)
        )
        np.testing.assert_array_equal(ctrl.diagnostics.prediction.futures, futures[[0, 2]])
    assert np.array_equal(plans[0], plans[1])


def test_padding_rows_drop_their_futures_too():
    ctrl = dcmppi.make_controller("mppi", agent="holonomic", prediction="given", seed=0)
    moving, future = crossing(0)
    padded = np.vstack([moving, np.zeros(4)])
    futures = np.concatenate([future, np.full_like(future, np.nan)])  # the padding row's: unused
    ctrl.act(np.zeros(3), GOAL, None, padded, None, moving_futures=futures)
    np.testing.assert_array_equal(ctrl.diagnostics.prediction.tracks, future[0])


@pytest.mark.parametrize(
    "futures, message",
    [
        (None, "needs the moving obstacles' futures"),
        (np.zeros((1, 1, 10, 2)), r"must have shape \(1, F, 51, 2\)"),
        (np.zeros((2, 1, 51, 2)), "one row per row of moving"),
        (np.full((1, 1, 51, 2), np.nan), "all finite"),
    ],
)
def test_bad_futures_are_named(futures, message):
    ctrl = dcmppi.make_controller("mppi", agent="holonomic", prediction="given", seed=0)
    moving, _ = crossing(0)
    with pytest.raises(ValueError, match=message):
        ctrl.act(np.zeros(3), GOAL, None, moving, None, moving_futures=futures)
