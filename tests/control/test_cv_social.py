"""The velocity-aware predictors: "cv" (constant velocity) and "social" (social-force futures
pushed by the robot's plan), and the inputs a controller gives a predictor (velocity,
robot_plan)."""

import numpy as np
import pytest

import dcmppi
from dcmppi.control import Prediction, Predictor, make_predictor, register_predictor
from dcmppi.control.kernels.social import FORCE_CUTOFF, B
from dcmppi.control.predictors import base

NAMES = ["mppi", "clustered", "dc", "tube"]
SHARED = dict(N=20, dt=0.1, robot_radius=0.5, max_speed=1.0, alpha=1000.0, beta=100.0, P=5,
              obstacle_margin=0.1)  # fmt: skip
CROSSING = np.array([[3.0, -2.0, np.pi / 2, 0.5]])  # walks across the robot's straight path
CROSSING_VELOCITY = np.array([[0.0, 1.0]])
NEEDS = "prediction '{}' needs the moving obstacles' velocities \\(moving_velocity\\)"


def test_cv_futures_are_the_constant_velocity_formula():
    cv = make_predictor("cv", cv_std=0.4, **SHARED)
    moving = np.array([[1.0, 2.0, 0.0, 0.3], [-2.0, 0.5, np.nan, 0.6]])
    velocity = np.array([[1.0, -0.5], [0.0, 0.8]])
    p = cv.predict(np.zeros(3), moving, None, np.random.default_rng(7), velocity=velocity)
    dv = 0.4 * np.random.default_rng(7).standard_normal((2, 5, 2))
    t = 0.1 * np.arange(21)
    expected = moving[:, None, None, :2] + (velocity[:, None, None] + dv[:, :, None]) * t[:, None]
    np.testing.assert_allclose(p.futures, expected, rtol=0, atol=1e-14)
    np.testing.assert_array_equal(p.tracks, p.futures.reshape(10, 21, 2))  # obstacle-major
    np.testing.assert_allclose(p.distance, np.repeat([0.9, 1.2], 5))  # r + margin + robot
    assert p.weight == 100.0 / 5 and p.unit == 100.0


def test_cv_std_still_ramps_the_spread_from_standing_to_walking():
    """sigma_l = still + (cv_std - still) min(|v_l| / STILL_SPEED, 1): standing people spread
    by cv_std_still, people at STILL_SPEED and above by cv_std, linearly between."""
    from dcmppi.control.predictors.cv import STILL_SPEED

    cv = make_predictor("cv", cv_std=0.4, cv_std_still=0.1, **SHARED)
    moving = np.array([[1.0, 2.0, 0.0, 0.3], [-2.0, 0.5, 0.0, 0.3], [0.0, -3.0, 0.0, 0.3]])
    velocity = np.array([[0.0, 0.0], [0.5 * STILL_SPEED, 0.0], [0.0, 1.2]])
    p = cv.predict(np.zeros(3), moving, None, np.random.default_rng(7), velocity=velocity)
    noise = np.random.default_rng(7).standard_normal((3, 5, 2))
    sigma = np.array([0.1, 0.25, 0.4])
    dv = sigma[:, None, None] * noise
    t = 0.1 * np.arange(21)
    expected = moving[:, None, None, :2] + (velocity[:, None, None] + dv[:, :, None]) * t[:, None]
    np.testing.assert_allclose(p.futures, expected, rtol=0, atol=1e-14)
    same = make_predictor("cv", cv_std=0.4, **SHARED)  # None: cv_std for everyone
    q = same.predict(np.zeros(3), moving, None, np.random.default_rng(7), velocity=velocity)
    np.testing.assert_allclose(
        q.futures[:, :, -1] - p.futures[:, :, -1],
        ((0.4 - sigma)[:, None, None] * noise) * 2.0,
        atol=1e-12,
    )
    with pytest.raises(ValueError, match="cv_std_still"):
        make_predictor("cv", cv_std_still=-0.1, **SHARED)


def test_cv_skips_exactly_the_obstacles_no_future_can_reach():
    """Left out iff |p_0 - o| > (v_max + |v + dv_p|) N dt + robot_radius + r + margin for
    every future p: an obstacle on that reach is kept, one a micrometre beyond is not."""
    cv = make_predictor("cv", **SHARED)
    velocity = np.array([[0.6, 0.8], [0.6, 0.8]])  # walking away: the rule uses speed only
    dv = 0.3 * np.random.default_rng(3).standard_normal((2, 5, 2))
    speed = np.hypot(*(velocity[:, None] + dv).transpose(2, 0, 1)).max(axis=1)  # (2,)
    reach = (1.0 + speed) * 20 * 0.1 + 0.5 + 0.4 + 0.1
    moving = np.array([[reach[0], 0.0, 0.0, 0.4], [0.0, -reach[1] - 1e-6, 0.0, 0.4]])
    p = cv.predict(np.zeros(3), moving, None, np.random.default_rng(3), velocity=velocity)
    assert p.futures.shape == (1, 5, 21, 2)
    np.testing.assert_array_equal(p.futures[0, :, 0], np.broadcast_to(moving[0, :2], (5, 2)))
    far = cv.predict(np.zeros(3), moving + [1e-6, 0, 0, 0], None, np.random.default_rng(3),
                     velocity=velocity)  # fmt: skip
    assert far.futures.shape == (0, 5, 21, 2) and far.tracks.shape == (0, 21, 2)


@pytest.mark.parametrize("prediction", ["cv", "social"])
def test_velocity_predictors_name_the_fix_without_velocities(prediction):
    ctrl = dcmppi.make_controller("dc", prediction=prediction, K=16, N=10, seed=0)
    goal = np.array([6.0, 0.0])
    with pytest.raises(ValueError, match=NEEDS.format(prediction) + ".*prediction='ekf'"):
        ctrl.act(np.zeros(3), goal, None, CROSSING)
    two = np.vstack([CROSSING, [[4.0, 1.0, 0.0, 0.5]]])
    with pytest.raises(ValueError, match=NEEDS.format(prediction)):
        ctrl.act(np.zeros(3), goal, None, two, moving_velocity=[[0.0, 1.0], [np.nan, np.nan]])
    # nothing moving, nothing to predict: no velocities needed
    ctrl.act(np.zeros(3), goal, None, None)
    assert ctrl.diagnostics.prediction.futures.shape == (0, ctrl.P, 11, 2)


def test_social_without_interactions_is_cv_with_the_same_draws():
    """Two pedestrians and the robot's plan farther apart than the force's reach all along: the
    social futures are cv's (desired velocity = the future's velocity, nothing pushes)."""
    shared = {**SHARED, "N": 50}
    moving = np.array([[0.0, 9.0, 0.0, 0.3], [0.0, -9.0, np.nan, 0.4]])
    velocity = np.array([[1.0, 0.0], [-0.8, -0.3]])
    plan = np.zeros((51, 3))
    plan[:, 0] = np.linspace(0.0, 2.0, 51)
    rngs = np.random.default_rng(11), np.random.default_rng(11)
    cv = make_predictor("cv", **shared).predict(np.zeros(3), moving, None, rngs[0],
                                                velocity=velocity)  # fmt: skip
    social = make_predictor("social", **shared).predict(
        np.zeros(3), moving, None, rngs[1], velocity=velocity, robot_plan=plan
    )
    assert cv.futures.shape == (2, 5, 51, 2)
    reach = B * np.log(1 / FORCE_CUTOFF) + 0.3 + 0.5  # the kernel skips pairs beyond
    assert np.hypot(*(cv.futures - plan[:, :2]).transpose(3, 0, 1, 2)).min() > reach
    np.testing.assert_allclose(social.futures, cv.futures, rtol=0, atol=1e-12)
    np.testing.assert_allclose(social.tracks, cv.tracks, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(social.distance, cv.distance)
    assert (social.weight, social.unit) == (cv.weight, cv.unit)
    assert rngs[0].random() == rngs[1].random()  # the same draws taken


def test_social_pedestrian_steps_aside_from_the_robot_plan():
    """A pedestrian walking head-on (slightly off the robot's line) toward the robot's plan:
    cv walks it through the robot, social deflects it sideways, away from the plan."""
    shared = {**SHARED, "N": 40, "obstacle_margin": 0.0}
    moving = np.array([[4.0, 0.2, np.pi, 0.3]])
    velocity = np.array([[-1.0, 0.0]])
    plan = np.zeros((41, 3))
    plan[:, 0] = 0.1 * np.arange(41)  # the robot drives +x at 1 m/s
    args = (np.zeros(3), moving, None)
    cv = make_predictor("cv", cv_std=0.0, **shared).predict(
        *args, np.random.default_rng(0), velocity=velocity
    )
    social = make_predictor("social", cv_std=0.0, **shared)
    pushed = social.predict(*args, np.random.default_rng(0), velocity=velocity, robot_plan=plan)
    alone = social.predict(*args, np.random.default_rng(0), velocity=velocity)
    np.testing.assert_allclose(alone.futures, cv.futures, atol=1e-12)  # no plan: nothing pushes

    def gap(futures):  # closest centre distance to the robot along the plan, per future
        return np.hypot(*(futures[0] - plan[:, :2]).transpose(2, 0, 1)).min(axis=1)

    assert (gap(cv.futures) < 0.25).all()  # straight through the robot's disc
    assert (gap(pushed.futures) > 0.35).all()  # pushed off (a soft force: discs still touch)
    assert (pushed.futures[0, :, -1, 1] > 1.0).all()  # to +y, away from the robot's line


@pytest.mark.parametrize("prediction", ["cv", "social"])
@pytest.mark.parametrize("name", NAMES)
def test_every_planner_plans_with_cv_and_social(name, prediction):
    ctrl = dcmppi.make_controller(name, prediction=prediction, cv_std=0.2, K=32, N=20, P=5, seed=0)
    assert ctrl.params["cv_std"] == 0.2 and ctrl.params["prediction"] == prediction
    state, goal = np.zeros(3), np.array([6.0, 0.0])
    moving = CROSSING.copy()
    for _ in range(3):
        moving[:, :2] += 0.1 * CROSSING_VELOCITY
        u = ctrl.act(state, goal, None, moving, None, moving_velocity=CROSSING_VELOCITY)
        assert u.shape == (ctrl.nu,) and np.isfinite(u).all()
        state = ctrl.agent.step(state, u, ctrl.dt)
    p = ctrl.diagnostics.prediction
    assert p.futures.shape == (1, 5, 21, 2) and p.weight == 20.0 and p.unit == ctrl.beta
    np.testing.assert_array_equal(p.futures[0, :, 0], np.broadcast_to(moving[0, :2], (5, 2)))


def test_the_controller_gives_the_inputs_a_predictor_names():
    """velocity: the rows of moving_velocity whose moving rows are not padding (radius 0);
    robot_plan: the warm start rolled out from the state; a predictor without inputs gets the
    four arguments alone."""
    seen = []

    @register_predictor("recording")
    class Recording(Predictor):
        inputs = ("velocity", "robot_plan")

        def predict(self, state, moving, obstacle_model, rng, velocity=None, robot_plan=None):
            seen.append((moving, velocity, robot_plan))
            return self.none()

    @register_predictor("plain")
    class Plain(Predictor):
        def predict(self, state, moving, obstacle_model, rng):
            return Prediction(np.zeros((0, self.N + 1, 2)), np.zeros(0), self.alpha)

    moving = np.array([[3.0, 1.0, 0.0, 0.5], [0.0, 0.0, 0.0, 0.0], [5.0, -1.0, np.nan, 0.4]])
    velocity = np.array([[1.0, 0.0], [np.nan, np.nan], [0.0, -1.0]])
    state, goal = np.array([0.5, 0.2, 0.3]), np.array([6.0, 0.0])
    try:
        ctrl = dcmppi.make_controller("mppi", prediction="recording", K=16, N=10, seed=0)
        ctrl.act(state, goal, None, moving, moving_velocity=velocity)
        U = ctrl.U  # the next step's warm start
        ctrl.act(state, goal, None, moving, moving_velocity=velocity)
        rows, v, plan = seen[-1]
        np.testing.assert_array_equal(rows, moving[[0, 2]])
        np.testing.assert_array_equal(v, velocity[[0, 2]])
        np.testing.assert_array_equal(plan, ctrl.agent.rollout_one(state, U, ctrl.dt))
        assert plan.shape == (11, 3)
        ctrl.act(state, goal, None, moving)
        assert seen[-1][1] is None
        with pytest.raises(ValueError, match=r"moving_velocity must have shape \(3, 2\)"):
            ctrl.act(state, goal, None, moving, moving_velocity=velocity[:2])
        with pytest.raises(ValueError, match="infinite rows \\[2\\]"):
            ctrl.act(state, goal, None, moving, moving_velocity=velocity + [[0], [0], [np.inf]])
        plain = dcmppi.make_controller("mppi", prediction="plain", K=16, N=10, seed=0)
        plain.act(state, goal, None, moving, moving_velocity=velocity)
        Recording.inputs = ("velocity", "lidar")
        with pytest.raises(ValueError, match="inputs \\['lidar'\\].*valid inputs: velocity"):
            dcmppi.make_controller("mppi", prediction="recording")
    finally:
        base.PREDICTORS.unregister("recording")
        base.PREDICTORS.unregister("plain")


def test_cv_std_must_not_be_negative():
    with pytest.raises(ValueError, match="cv_std"):
        dcmppi.make_controller("dc", prediction="cv", cv_std=-0.1)


def test_social_blind_to_the_robot_is_cv_with_pedestrians_only():
    """reactive=False: the robot's plan pushes nobody; one lone pedestrian's futures are then
    exactly cv's for the same draws, even with the plan driving through it."""
    state = np.zeros(3)
    moving = np.array([[2.0, 0.0, np.pi, 0.3]])
    velocity = np.array([[-1.0, 0.0]])
    plan = np.column_stack([np.linspace(0, 5, 21), np.zeros(21), np.zeros(21)])
    shared = dict(N=20, dt=0.1, robot_radius=0.3, max_speed=1.5, alpha=1000.0, beta=100.0, P=4,
                  obstacle_margin=0.0)  # fmt: skip
    blind = make_predictor("social", reactive=False, **shared)
    seen = make_predictor("social", **shared)
    cv = make_predictor("cv", **shared)
    rng = lambda: np.random.default_rng(3)  # noqa: E731
    a = blind.predict(state, moving, None, rng(), velocity=velocity, robot_plan=plan)
    b = cv.predict(state, moving, None, rng(), velocity=velocity)
    c = seen.predict(state, moving, None, rng(), velocity=velocity, robot_plan=plan)
    np.testing.assert_allclose(a.futures, b.futures, atol=1e-9)
    assert np.abs(c.futures - b.futures).max() > 0.1  # the plan pushes the reactive ones
    with pytest.raises(ValueError, match="reactive must be true or false"):
        make_predictor("social", reactive="no", **shared)
