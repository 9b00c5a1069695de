"""DC-MPPI: sampled obstacle futures in the cost, brute-force equality, skipping the unreachable."""

import numpy as np

import dcmppi
from dcmppi.control import Objective, Prediction
from dcmppi.control.kernels.costs import OccupancyGrid, TrackIndex, valid_cylinders
from dcmppi.control.kernels.dynamics import obstacle_futures, rollout_time_major
from dcmppi.control.predictors.prior import sample_speeds

MODEL = np.array([1.0, 0.05, 0.0, 0.02])  # v_mean, v_std, omega_mean, omega_std


def straight_cost(moving, seed=0, **params):
    """DC cost of the straight rollout, and of the same with no moving obstacle: the step's
    Objective built from the dc predictor's Prediction, called on one rollout."""
    ctrl = dcmppi.make_controller("dc", seed=seed, **params)
    state, goal = np.array([0.0, 0.0, 0.0]), np.array([10.0, 0.0])
    grid = OccupancyGrid(None, ctrl.robot_radius)
    states = ctrl.agent.rollout(state, np.zeros((ctrl.N, 1, 1)), ctrl.dt)
    J = []
    for obstacles in (valid_cylinders(moving, "m", 4), np.zeros((0, 4))):
        prediction = ctrl.predictor.predict(state, obstacles, MODEL, ctrl.rng)
        assert isinstance(prediction, Prediction)
        J.append(Objective(goal, grid, ctrl.alpha, prediction)(states)[0])
    return J[0], J[1], ctrl


def test_crossing_obstacle_raises_straight_cost_receding_does_not():
    crossing = np.array([[3.0, -3.0, np.pi / 2, 1.0]])  # meets the path at x = 3 after 3 s
    receding = np.array([[3.0, -3.0, -np.pi / 2, 1.0]])
    J, J0, _ = straight_cost(crossing)
    assert J > J0 + 1.0
    J, J0, _ = straight_cost(receding)
    assert J == J0


def test_cost_equals_brute_force_reference():
    rng = np.random.default_rng(5)
    ctrl = dcmppi.make_controller("dc", K=20, N=15, P=4, seed=1)
    state, goal = np.array([0.0, 0.0, 0.3]), np.array([8.0, 2.0])
    moving = np.column_stack([rng.uniform(-3, 5, (6, 2)), rng.uniform(0, 6, 6), np.full(6, 1.0)])
    ctrl.act(state, goal, None, moving, MODEL)
    d = ctrl.diagnostics
    futures = d.prediction.futures
    states = d.states  # (K, N + 1, 3)
    radius = ctrl.robot_radius + 1.0
    brute = np.zeros(ctrl.K)
    for k in range(ctrl.K):
        for i in range(ctrl.N + 1):
            brute[k] += np.hypot(states[k, i, 0] - goal[0], states[k, i, 1] - goal[1])
            for l in range(len(futures)):
                for p in range(ctrl.P):
                    o = futures[l, p, i]
                    hit = np.hypot(states[k, i, 0] - o[0], states[k, i, 1] - o[1]) <= radius
                    brute[k] += ctrl.beta / ctrl.P * hit
    assert (brute > brute.min() + 1.0).any()  # some rollouts do hit sampled futures
    np.testing.assert_allclose(d.J, brute, rtol=1e-12)


def test_unreachable_obstacles_are_skipped_exactly():
    ctrl = dcmppi.make_controller("dc", seed=0)
    state, goal = np.array([10.0, 10.0, 0.0]), np.array([20.0, 10.0])
    far = np.array([[60.0, 40.0, 0.0, 1.0]])
    ctrl.act(state, goal, None, far, MODEL)
    assert ctrl.diagnostics.prediction.futures.shape[0] == 0
    near = np.array([[13.0, 10.0, np.pi, 1.0]])
    ctrl.act(state, goal, None, near, MODEL)
    fut = ctrl.diagnostics.prediction.futures
    assert fut.shape == (1, ctrl.P, ctrl.N + 1, 2)
    # Skipping is exact: the far obstacle's own futures would hit no rollout.
    x = rollout_time_major(state, np.full((ctrl.N, 3), [-1.0, 0.0, 1.0]), ctrl.agent.v, ctrl.dt)
    far_track = np.broadcast_to(far[:, None, :2], (1, ctrl.N + 1, 2))
    assert TrackIndex(far_track, np.array([1.5])).count(x[0], x[1]).sum() == 0


def test_dc_needs_obstacle_model():
    ctrl = dcmppi.make_controller("dc")
    try:
        ctrl.act(np.zeros(3), np.ones(2), None, np.array([[1.0, 1.0, 0.0, 1.0]]), None)
    except ValueError as e:
        assert "obstacle_model" in str(e)
    else:
        raise AssertionError("no ValueError")


def test_prior_futures_come_from_the_known_gaussian_and_the_observed_pose():
    """prediction="prior" draws speeds and turn rates first (the paper's stream, unchanged by the
    ekf option) and starts every future at the observed pose."""
    ctrl = dcmppi.make_controller("dc", K=8, N=10, P=6, seed=3)
    moving = np.array([[2.0, 1.0, 0.4, 1.0], [-1.0, 1.5, 2.0, 0.5]])
    ctrl.act(np.zeros(3), np.array([5.0, 0.0]), None, moving, MODEL)
    speed, turn = sample_speeds(np.random.default_rng(3), MODEL, 2, 6)
    expected = obstacle_futures(moving, speed, turn, 10, ctrl.dt)
    np.testing.assert_array_equal(ctrl.diagnostics.prediction.futures, expected)


def test_prior_with_unobserved_headings_draws_them_uniformly():
    ctrl = dcmppi.make_controller("dc", K=8, N=30, P=4000, seed=0)
    moving = np.array([[2.0, 1.0, np.nan, 1.0]])
    ctrl.act(np.zeros(3), np.array([5.0, 0.0]), None, moving, MODEL)
    ends = ctrl.diagnostics.prediction.futures[0, :, -1] - moving[0, :2]  # (P, 2) after 3 s
    heading = np.arctan2(ends[:, 1], ends[:, 0])
    counts = np.histogram(heading, bins=8, range=(-np.pi, np.pi))[0]
    assert counts.min() > 0.8 * 500 and counts.max() < 1.2 * 500
    np.testing.assert_allclose(np.hypot(*ends.T).mean(), 3.0, rtol=0.05)  # v_mean 1 m/s, 3 s
