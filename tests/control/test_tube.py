"""Tube-MPPI: nominal resets, LQR tracking on the analytic model."""

import numpy as np
import pytest

import dcmppi
from dcmppi.control.agents import make_agent
from dcmppi.control.agents.dubins import jacobian_terms
from dcmppi.control.kernels.dynamics import dubins_step, rollout, wrap_angle
from dcmppi.control.planners.tube import dubins_lqr_gain, tvlqr_gains

GOAL = np.array([20.0, 0.0])


def step_with_nominal(nominal, real, threshold):
    ctrl = dcmppi.make_controller("tube", seed=0, reset_threshold=threshold, max_deviation=100.0)
    ctrl.nominal = np.array(nominal, dtype=float)
    ctrl.act(np.array(real, dtype=float), GOAL)
    return ctrl.diagnostics


def test_nominal_resets_when_real_state_is_better():
    d = step_with_nominal([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], threshold=0.0)  # real closer to goal
    assert d.nominal_reset and np.array_equal(d.nominal_state, [2.0, 0.0, 0.0])


def test_reset_threshold_takes_any_real_number_and_names_a_bad_one():
    """A numpy scalar threshold acts as the float; nan or a string is named."""
    for threshold in (np.float32(1e4), np.int64(10000)):
        assert step_with_nominal([2.0, 0.0, 0.0], [0.0, 0.0, 0.0], threshold).nominal_reset
    for bad in (float("nan"), "1", True):
        with pytest.raises(ValueError, match="reset_threshold must be a finite number"):
            dcmppi.make_controller("tube", reset_threshold=bad)


def test_nominal_kept_when_real_state_is_worse():
    d = step_with_nominal([2.0, 0.0, 0.0], [0.0, 0.0, 0.0], threshold=0.0)
    assert not d.nominal_reset and np.array_equal(d.nominal_state, [2.0, 0.0, 0.0])
    # A threshold above the cost gap resets it again.
    assert step_with_nominal([2.0, 0.0, 0.0], [0.0, 0.0, 0.0], threshold=1e4).nominal_reset


def test_lqr_feedback_reduces_tracking_error():
    v, dt, N = 1.0, 0.1, 60
    U = 0.3 * np.sin(np.linspace(0, 3, N))
    nominal = rollout(np.zeros(3), U, v, dt)
    A, B = make_agent("dubins").jacobians(nominal, U[:, None], dt)
    K = tvlqr_gains(A, B, np.diag([1.0, 1.0, 1.0]), 1.0, np.diag([1.0, 1.0, 1.0]))[:, 0]
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
    np.testing.assert_allclose(ctrl.nominal, dubins_step(z, ctrl.diagnostics.plan[0, 0], 1.0, 0.1))


def test_scalar_riccati_equals_matrix_riccati():
    rng = np.random.default_rng(0)
    v, dt, N = 1.0, 0.1, 50
    U = rng.uniform(-1.0, 1.0, N)
    nominal = rollout(np.array([1.0, 2.0, 3.0]), U, v, dt)
    A, B = make_agent("dubins").jacobians(nominal, U[:, None], dt)
    c0, c1, b0, b1 = jacobian_terms(nominal[:, 2], U, v, dt)
    for q_pos, q_theta, r in [(1.0, 1.0, 1.0), (2.0, 0.5, 0.3), (0.0, 1.0, 4.0)]:
        Q = np.diag([q_pos, q_pos, q_theta])
        expected = tvlqr_gains(A, B, Q, r, Q)[0, 0]
        got = dubins_lqr_gain(c0, c1, b0, b1, dt, q_pos, q_theta, r)
        np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-14)


def test_nominal_kept_runs_lqr_feedback():
    """Real state pushed back (worse): the nominal is kept and the applied control differs from
    the plan by the LQR feedback, which steers back towards the nominal's lateral offset."""
    d = step_with_nominal([0.0, 0.5, 0.0], [-0.5, 0.0, 0.0], threshold=0.0)
    assert not d.nominal_reset
    assert d.action[0] != d.plan[0, 0]
    assert d.action[0] > d.plan[0, 0]  # the nominal lies to the left: turn left (anticlockwise)


def test_two_start_batch_equals_separate_rollouts():
    ctrl = dcmppi.make_controller("tube", seed=0, K=64)
    ctrl.act(np.zeros(3), GOAL)  # sets the goal and the cost map
    u = ctrl.perturbed_rollouts(np.zeros(3)).u
    z, x = np.array([0.0, 0.0, 0.1]), np.array([0.2, -0.1, 7.0])
    states, J = ctrl.rollout_costs(np.column_stack([z, x]), u, starts=2)
    for i, start in enumerate([z, x]):
        s1, J1 = ctrl.rollout_costs(start, u)
        np.testing.assert_array_equal(states[:, :, i * 64 : (i + 1) * 64], s1)
        np.testing.assert_array_equal(J[i * 64 : (i + 1) * 64], J1)


def test_timing_push_keeps_the_nominal_in_some_steps():
    """dcmppi timing's forest+push row exercises both solves and the LQR feedback."""
    from dcmppi.bench.timing import forest, push, pushed

    static, state, goal = forest()
    ctrl = dcmppi.make_controller("tube", seed=0, reset_threshold=0.0)  # as the timing loop
    offsets = push(20)
    np.testing.assert_array_equal(offsets, push(20))  # deterministic
    kept = 0
    for offset in offsets:
        u = ctrl.act(state, goal, static)
        kept += not ctrl.diagnostics.nominal_reset
        state = pushed(ctrl.agent.step(state, u, ctrl.dt), offset)
    assert 5 <= kept < 20


def test_lqr_keeps_the_real_robot_near_the_nominal_in_a_noisy_corridor(tmp_path):
    """Control noise (Sigma = 0.1 on the applied turn rate) in a straight corridor, with the
    nominal never reset by cost (only beyond max_deviation): the Bryson-weighted TV-LQR alone
    holds the real robot within 5 cm (half a cost-map cell) of the nominal at every step, well
    under the clearance of the nominal plans (>= 0.13 m here). Q = I, R = 1 (tracking errors of
    1 m and 1 rad) let it stray 0.10-0.17 m."""
    import json

    from dcmppi.bench.episodes.runner import Episode, EpisodeSpec

    walls = [[x, y, 0.5] for x in np.arange(-2.0, 24.0, 0.8) for y in (-2.6, 2.6)]
    path = tmp_path / "corridor.json"
    layout = {
        "cylinders": walls,
        "start": [0, 0, 0],
        "goal": [22, 0],
        "map_bounds": [-5, -8, 27, 8],
    }
    path.write_text(json.dumps(layout))
    walls = np.array(walls)
    for seed in (0, 1):
        spec = EpisodeSpec(
            "layout", "tube", noise="control", seed=seed, task_params={"path": str(path)},
            controller_params={"reset_threshold": -1e9, "K": 200},
        )  # fmt: skip
        episode = Episode(spec)
        deviation, clearance = [], []
        while not episode.done:
            episode.step()
            d = episode.controller.diagnostics
            deviation.append(d.nominal_deviation)
            plan = episode.controller.agent.rollout_one(d.nominal_state, d.plan, 0.1)
            gaps = np.hypot(plan[:, None, 0] - walls[:, 0], plan[:, None, 1] - walls[:, 1]) - 1.0
            clearance.append(gaps.min())
        assert episode.env.task.outcome == "goal"
        assert max(deviation) < 0.05, f"seed {seed}: deviation up to {max(deviation):.3f} m"
        assert max(deviation) < 0.5 * min(clearance)
