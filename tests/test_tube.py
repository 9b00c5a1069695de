"""Tube-MPPI: nominal resets, LQR tracking on the analytic model."""

import numpy as np

import dcmppi
from dcmppi.dynamics import dubins_step, rollout, wrap_angle
from dcmppi.tube import linearize, tvlqr_gains

GOAL = np.array([20.0, 0.0])


def step_with_nominal(nominal, real, threshold):
    ctrl = dcmppi.make_controller("tube", seed=0, reset_threshold=threshold, max_deviation=100.0)
    ctrl.nominal = np.array(nominal, dtype=float)
    ctrl.act(np.array(real, dtype=float), GOAL)
    return ctrl.diagnostics


def test_nominal_resets_when_real_state_is_better():
    d = step_with_nominal([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], threshold=0.0)  # real closer to goal
    assert d.nominal_reset and np.array_equal(d.nominal_state, [2.0, 0.0, 0.0])


def test_nominal_kept_when_real_state_is_worse():
    d = step_with_nominal([2.0, 0.0, 0.0], [0.0, 0.0, 0.0], threshold=0.0)
    assert not d.nominal_reset and np.array_equal(d.nominal_state, [2.0, 0.0, 0.0])
    # A threshold above the cost gap resets it again.
    assert step_with_nominal([2.0, 0.0, 0.0], [0.0, 0.0, 0.0], threshold=1e4).nominal_reset


def test_lqr_feedback_reduces_tracking_error():
    v, dt, N = 1.0, 0.1, 60
    U = 0.3 * np.sin(np.linspace(0, 3, N))
    nominal = rollout(np.zeros(3), U, v, dt)
    A, B = linearize(nominal, U, v, dt)
    K = tvlqr_gains(A, B, np.diag([1.0, 1.0, 1.0]), 1.0, np.diag([1.0, 1.0, 1.0]))
    start = np.array([0.0, 0.6, -0.3])  # lateral and heading error
    open_loop, closed = start.copy(), start.copy()
    for i in range(N):
        open_loop = dubins_step(open_loop, U[i], v, dt)
        e = closed - nominal[i]
        e[2] = wrap_angle(e[2])
        closed = dubins_step(closed, np.clip(U[i] - K[i] @ e, -1, 1), v, dt)
    err = lambda s: np.hypot(*(s[:2] - nominal[-1, :2]))  # noqa: E731
    assert err(closed) < 0.5 * err(open_loop)
    assert err(closed) < 0.3


def test_nominal_propagates_once_per_step():
    ctrl = dcmppi.make_controller("tube", seed=0)
    state = np.zeros(3)
    ctrl.act(state, GOAL)
    z = ctrl.diagnostics.nominal_state
    np.testing.assert_allclose(ctrl.nominal, dubins_step(z, ctrl.diagnostics.plan[0], 1.0, 0.1))
