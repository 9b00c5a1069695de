"""The objective and its obstacle predictors: every planner with every predictor, the registry,
what each predictor gives, and the Objective a planner calls, checked against brute force."""

import numpy as np
import pytest

import dcmppi
from dcmppi.control import Objective, Prediction, Predictor, make_predictor, register_predictor
from dcmppi.control.kernels.costs import OccupancyGrid
from dcmppi.control.predictors import base, predictor_names

NAMES = ["mppi", "clustered", "dc", "tube"]
PREDICTORS = ["frozen", "prior", "ekf"]
MODEL = np.array([1.0, 0.1, 0.0, 0.1])  # v_mean, v_std, omega_mean, omega_std
SHARED = dict(N=20, dt=0.1, robot_radius=0.5, max_speed=1.0, alpha=1000.0, beta=100.0, P=5,
              obstacle_margin=0.0)  # fmt: skip
CROSSING = np.array([[3.0, -2.0, np.pi / 2, 0.5]])  # walks across the robot's straight path


@pytest.mark.parametrize("prediction", PREDICTORS)
@pytest.mark.parametrize("name", NAMES)
def test_every_planner_takes_every_predictor(name, prediction):
    ctrl = dcmppi.make_controller(name, prediction=prediction, K=32, N=20, P=5, seed=0)
    assert ctrl.prediction == prediction and ctrl.params["prediction"] == prediction
    state, goal = np.zeros(3), np.array([6.0, 0.0])
    for _ in range(3):
        u = ctrl.act(state, goal, None, CROSSING, MODEL)
        state = ctrl.agent.step(state, u, ctrl.dt)
    p = ctrl.diagnostics.prediction
    assert isinstance(p, Prediction) and p.tracks.shape[1:] == (21, 2)
    assert p.weight == (1000.0 if prediction == "frozen" else 100.0 / 5)
    assert (p.futures is None) == (prediction == "frozen")


def test_dc_is_clustered_with_the_prior():
    """Paper Alg. 3 is Alg. 2 with sampled futures: the same draws, the same plans."""
    actions = {}
    for name, params in (("dc", {}), ("clustered", {"prediction": "prior"})):
        ctrl = dcmppi.make_controller(name, K=64, N=20, P=5, seed=4, **params)
        state, out = np.zeros(3), []
        for _ in range(5):
            out.append(ctrl.act(state, np.array([6.0, 0.0]), None, CROSSING, MODEL))
            state = ctrl.agent.step(state, out[-1], ctrl.dt)
        actions[name] = np.array(out)
    np.testing.assert_array_equal(actions["dc"], actions["clustered"])
    assert dcmppi.make_controller("dc").prediction == "prior"
    assert dcmppi.make_controller("clustered").prediction == "frozen"


def test_frozen_predictor_keeps_obstacles_in_place_and_skips_unreachable_ones():
    frozen = make_predictor("frozen", **SHARED)
    # reach: max_speed N dt + robot radius + obstacle radius = 3 m; the second is 3.01 m away
    moving = np.array([[2.0, 1.0, 0.0, 0.5], [3.01, 0.0, 0.0, 0.5]])
    p = frozen.predict(np.zeros(3), moving, None, np.random.default_rng(0))
    assert p.tracks.shape == (1, 21, 2) and (p.tracks == [2.0, 1.0]).all()
    np.testing.assert_array_equal(p.distance, [1.0])
    assert p.weight == 1000.0 and p.futures is None
    margin = make_predictor("frozen", **{**SHARED, "obstacle_margin": 0.3})
    p = margin.predict(np.zeros(3), moving, None, np.random.default_rng(0))
    np.testing.assert_allclose(p.distance, [1.3, 1.3])  # the margin brings the second in reach


def test_prior_predictor_needs_the_obstacle_model_and_draws_from_the_rng():
    prior = make_predictor("prior", **SHARED)
    with pytest.raises(ValueError, match="prediction 'prior' needs obstacle_model"):
        prior.predict(np.zeros(3), CROSSING, None, np.random.default_rng(0))
    a = prior.predict(np.zeros(3), CROSSING, MODEL, np.random.default_rng(1))
    b = prior.predict(np.zeros(3), CROSSING, MODEL, np.random.default_rng(1))
    c = prior.predict(np.zeros(3), CROSSING, MODEL, np.random.default_rng(2))
    np.testing.assert_array_equal(a.tracks, b.tracks)
    assert not np.array_equal(a.tracks, c.tracks)
    assert a.futures.shape == (1, 5, 21, 2) and a.weight == pytest.approx(20.0)


def test_ekf_predictor_forgets_on_reset():
    ctrl = dcmppi.make_controller("mppi", prediction="ekf", measurement_std=0.2, K=16, N=10)
    assert ctrl.params["measurement_std"] == 0.2
    two = np.array([[3.0, 1.0, np.nan, 0.5], [5.0, -1.0, np.nan, 0.5]])
    ctrl.act(np.zeros(3), np.array([6.0, 0.0]), None, two, MODEL)
    with pytest.raises(ValueError, match="number and order"):
        ctrl.act(np.zeros(3), np.array([6.0, 0.0]), None, two[:1], MODEL)
    ctrl.reset()
    ctrl.act(np.zeros(3), np.array([6.0, 0.0]), None, two[:1], MODEL)
    assert ctrl.diagnostics.prediction.posterior[0].shape == (1, 5)


def test_objective_equals_brute_force():
    """J of each rollout = sum over its states of the goal distance, alpha per state in the
    static map and the prediction's weight per (state, track) pair within the track's distance."""
    rng = np.random.default_rng(3)
    ctrl = dcmppi.make_controller("mppi", agent="holonomic", N=12, K=40, seed=0)
    static = np.array([[0.9, 0.5, 0.1]])
    grid = OccupancyGrid(static, ctrl.robot_radius, 0.1)
    tracks = rng.uniform(0.2, 1.2, (3, 13, 2))
    prediction = Prediction(tracks, np.array([0.3, 0.4, 0.5]), 7.0)
    goal = np.array([4.0, 1.0])
    objective = Objective(goal, grid, 1000.0, prediction)
    u = rng.uniform(-1, 1, (12, 3, 40))
    states = ctrl.agent.rollout(np.zeros(3), ctrl.agent.project(u), 0.1)
    x, y = states[0], states[1]
    brute = np.hypot(x - goal[0], y - goal[1]).sum(axis=0)
    brute += 1000.0 * grid.count(x, y)
    hits = np.hypot(x[None] - tracks[:, :, 0, None], y[None] - tracks[:, :, 1, None])
    moving = 7.0 * (hits <= np.array([0.3, 0.4, 0.5])[:, None, None]).sum(axis=(0, 1))
    assert (grid.count(x, y) > 0).any() and (grid.count(x, y) == 0).any()
    assert (moving > 0).any() and (moving == 0).any()
    np.testing.assert_allclose(objective(states), brute + moving, rtol=1e-12)
    np.testing.assert_array_equal(objective.moving(states), moving)


def test_planner_cost_is_its_objective():
    ctrl = dcmppi.make_controller("dc", K=32, N=20, P=5, seed=1)
    ctrl.act(np.zeros(3), np.array([6.0, 0.0]), None, CROSSING, MODEL)
    d = ctrl.diagnostics
    np.testing.assert_array_equal(ctrl.objective(d.states.transpose(2, 1, 0)), d.J)
    assert ctrl.objective.prediction is d.prediction


def test_a_registered_predictor_plans_and_bad_ones_are_named():
    @register_predictor("ahead")
    class Ahead(Predictor):
        """Each obstacle one metre ahead of where it is, still."""

        own_params = ("gap",)

        def __init__(self, *, gap=1.0, **shared):
            super().__init__(**shared)
            self.gap = gap

        def predict(self, state, moving, obstacle_model, rng):
            ahead = moving[:, :2] + self.gap * np.stack(
                [np.cos(moving[:, 2]), np.sin(moving[:, 2])], axis=-1
            )
            tracks = np.repeat(ahead[:, None], self.N + 1, axis=1)
            return Prediction(tracks, moving[:, 3] + self.robot_radius, self.alpha)

    try:
        assert "ahead" in predictor_names()
        ctrl = dcmppi.make_controller("mppi", prediction="ahead", gap=2.0, K=16, N=20, seed=0)
        assert ctrl.params["gap"] == 2.0
        ctrl.act(np.zeros(3), np.array([6.0, 0.0]), None, CROSSING, MODEL)
        np.testing.assert_array_equal(ctrl.diagnostics.prediction.tracks[0, 0], [3.0, 0.0])
        with pytest.raises(ValueError, match="unknown parameter.*gap.*prediction 'frozen'"):
            dcmppi.make_controller("mppi", gap=2.0)
    finally:
        base.PREDICTORS.unregister("ahead")
    with pytest.raises(ValueError, match="unknown predictor 'crystal'; valid names: cv, ekf"):
        dcmppi.make_controller("dc", prediction="crystal")
    with pytest.raises(ValueError, match="no_such_module"):
        dcmppi.make_controller("dc", prediction="no_such_module:Thing")
    with pytest.raises(TypeError, match="subclass of Predictor"):
        register_predictor("bad")(object)

    class Lazy(Predictor):
        def predict(self, state, moving, obstacle_model, rng):
            return moving

    register_predictor("lazy")(Lazy)
    try:
        ctrl = dcmppi.make_controller("mppi", prediction="lazy", K=16, N=10)
        with pytest.raises(TypeError, match="must return a dcmppi.control.Prediction"):
            ctrl.act(np.zeros(3), np.array([6.0, 0.0]), None, CROSSING, MODEL)
    finally:
        base.PREDICTORS.unregister("lazy")


@pytest.mark.parametrize("prediction", ["frozen", "prior"])
def test_clustered_measures_the_moving_term_in_the_predictions_collision_cost(prediction):
    """The cost feature is ((S - M) / alpha + M / collision_cost) x gap x radius (up to its
    minimum): a state certainly inside a moving obstacle moves a sample as far as a static
    collision; frozen obstacles (collision_cost alpha) keep the plain (S - min S) scale."""
    ctrl = dcmppi.make_controller("clustered", prediction=prediction, K=200, N=20, P=5, seed=2)
    ctrl.act(np.zeros(3), np.array([6.0, 0.0]), None, np.array([[2.5, 0.3, np.pi, 0.5]]), MODEL)
    d = ctrl.diagnostics
    M = ctrl.objective.moving(d.states.transpose(2, 1, 0))
    assert (M > 0).any() and M.max() > M.min()
    unit = {"frozen": ctrl.alpha, "prior": ctrl.beta}[prediction]
    assert d.prediction.unit == unit
    cost = (d.S - M) / ctrl.alpha + M / unit
    expected = (cost - cost.min()) * ctrl.collision_gap * ctrl.dbscan_eps
    np.testing.assert_allclose(d.features[:, -1], expected, rtol=1e-9, atol=1e-9)


def test_objective_without_tracks_has_no_moving_term():
    grid = OccupancyGrid(None, 0.5)
    objective = Objective(np.zeros(2), grid, 1000.0, make_predictor("frozen", **SHARED).none())
    states = np.zeros((3, 21, 4))
    np.testing.assert_array_equal(objective.moving(states), np.zeros(4))
    J, term = objective(states, moving=True)
    assert term is None and J.shape == (4,)
