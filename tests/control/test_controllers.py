"""Registry, parameters, determinism, diagnostics, analytic closed loop: every controller with
every agent."""

import functools

import numpy as np
import pytest

import dcmppi
from dcmppi.control.agents import make_agent

NAMES = ["mppi", "clustered", "dc", "tube"]
AGENTS = ["dubins", "unicycle", "holonomic"]
PERTURBATIONS = ["constant", "time_varying", "mixed", "correlated"]
MODEL = np.array([1.0, 0.29, 0.0, 0.29])


def test_registry_lists_names():
    classical = {"orca", "hrvo", "hl", "social_force", "dwa"}  # tests/control/test_classical.py
    assert set(dcmppi.controller_names()) == {*NAMES, *classical}
    with pytest.raises(ValueError, match="valid names: clustered, dc, dwa, hl, hrvo, mppi, orca, "):
        dcmppi.make_controller("nope")


@pytest.mark.parametrize(
    "params, word",
    [
        ({"K": 0}, "K"),
        ({"K": 2.5}, "K"),
        ({"N": 0}, "N"),
        ({"lambda_": 0.0}, "lambda_"),
        ({"Sigma": -1.0}, "Sigma"),
        ({"Sigma": "big"}, "Sigma must hold numbers"),
        ({"Sigma": 1e-320}, "Sigma of omega must be at least 1e-308"),  # 1 / Sigma overflows
        ({"Sigma": [0.1, 0.1]}, "one variance per control"),  # dubins has one control
        ({"v": 0}, "v"),
        ({"dt": float("nan")}, "dt"),
        ({"P": 0}, "P"),
        ({"alpha": -1}, "alpha"),
        ({"perturbation": "wiggly"}, "perturbation"),
        ({"gamma": -1.0}, "gamma"),
        ({"obstacle_margin": -0.1}, "obstacle_margin"),
        ({"agent": "tank"}, "unknown agent 'tank'; valid names: dubins, holonomic, unicycle"),
        ({"v_max": 2.0}, "v_max"),  # a holonomic parameter given to the (default) dubins agent
        ({"agent": "holonomic", "v_max": float("inf")}, "v_max"),
        ({"agent": "holonomic", "Sigma": 1.0}, "one variance per control"),
        ({"agent": "unicycle", "omega_max": 0.0}, "omega_max"),
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
    words = ("state", "goal", "static", "moving", "obstacle_model", "bounds")
    for i, word in enumerate(words):  # not numbers: named, not numpy's conversion error
        args = [np.zeros(3), np.ones(2), None, [[2.0, 0.0, 0.0, 0.3]], np.ones(4), None]
        args[i] = "abc"
        with pytest.raises(ValueError, match=f"^{word} must hold numbers; got 'abc'$"):
            dcmppi.make_controller("dc").act(*args)


@pytest.mark.parametrize("seed", [-1, 2.5, "0"])
def test_a_bad_seed_is_named(seed):
    with pytest.raises(ValueError, match="seed must be None, an int >= 0 or a np.random"):
        dcmppi.make_controller("mppi", seed=seed)


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
    assert np.isfinite(ctrl.act(state, goal, static.tolist(), moving, model)).all()
    assert np.isfinite(ctrl.act(state, goal, static.tolist(), moving, model)).all()  # grid reused


def test_cost_map_too_large_names_resolution():
    ctrl = dcmppi.make_controller("mppi")
    with pytest.raises(ValueError, match="coarser resolution"):
        ctrl.act(np.zeros(3), np.ones(2), np.array([[0.0, 0.0, 1.0], [1e5, 1e5, 1.0]]))


def scene():
    static = np.array([[6.0, 0.2, 1.0], [0.0, 0.0, 0.0]])  # one cylinder and a padding row
    moving = np.array([[9.0, -4.0, np.pi / 2, 1.0]])
    return np.array([0.0, 0.0, 0.0]), np.array([14.0, 0.0]), static, moving


@pytest.mark.parametrize("agent", AGENTS)
@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("perturbation", PERTURBATIONS)
def test_same_seed_bit_identical_actions(agent, name, perturbation):
    state, goal, static, moving = scene()
    runs = []
    for _ in range(2):
        ctrl = dcmppi.make_controller(
            name, agent=agent, seed=7, K=100, N=20, perturbation=perturbation
        )
        s, acts = state.copy(), []
        for _ in range(3):
            acts.append(ctrl.act(s, goal, static, moving, MODEL))
            s = ctrl.agent.step(s, acts[-1], 0.1)
        runs.append(np.array(acts))
    np.testing.assert_array_equal(runs[0], runs[1])
    ctrl.reset(seed=8)
    assert (ctrl.act(state, goal, static, moving, MODEL) != runs[0][0]).any()


@pytest.mark.parametrize("agent", AGENTS)
@pytest.mark.parametrize("name", NAMES)
def test_diagnostics_shapes_and_bounds(agent, name):
    state, goal, static, moving = scene()
    ctrl = dcmppi.make_controller(name, agent=agent, seed=0, K=64, N=20)
    nu = ctrl.agent.nu
    u = ctrl.act(state, goal, static, moving, MODEL)
    d = ctrl.diagnostics
    assert u.shape == (nu,) and np.array_equal(d.action, u)
    assert d.eps.shape == (64, 20, nu) and d.states.shape == (64, 21, 3)
    assert d.J.shape == d.S.shape == d.weights.shape == (64,)
    assert np.isclose(d.weights.sum(), 1.0) and 1.0 <= d.ess <= 64
    assert d.plan.shape == (20, nu)
    agent_model = ctrl.agent
    for controls in (u[None], d.plan):
        assert np.all(controls >= agent_model.lower - 1e-12)
        assert np.all(controls <= agent_model.upper + 1e-12)
    assert set(ctrl.params) >= {"agent", "K", "N", "lambda_", "Sigma", "gamma", "seed"}
    assert set(ctrl.params) >= set(agent_model.param_names)


@pytest.mark.parametrize("agent", AGENTS)
@pytest.mark.parametrize("perturbation", PERTURBATIONS)
def test_every_sampled_control_respects_the_bounds(agent, perturbation):
    """Large perturbations around a warm start at the bounds: every rolled-out control sequence
    is inside the box and, for the holonomic agent, inside the speed disc."""
    ctrl = dcmppi.make_controller(
        "mppi", agent=agent, seed=3, K=400, N=15, perturbation=perturbation,
        Sigma=[4.0] * len(make_agent(agent).controls),
    )  # fmt: skip
    ctrl.act(np.zeros(3), np.array([10.0, 3.0]))
    a = ctrl.agent
    U0 = a.project(np.tile(a.upper, (15, 1)), axis=1)  # pinned at a corner of the bounds
    ctrl.U = U0
    r = ctrl.perturbed_rollouts(np.zeros(3))
    u, eps = r.u, r.e
    assert u.shape == (15, a.nu, 400)
    assert (u >= a.lower[None, :, None]).all() and (u <= a.upper[None, :, None]).all()
    if a.norm_axes is not None:
        assert (np.hypot(u[:, 0], u[:, 1]) <= a.norm_limit * (1 + 1e-12)).all()
    np.testing.assert_allclose(u, U0[:, :, None] + eps, rtol=0, atol=1e-12)
    clipped = (u == a.lower[None, :, None]) | (u == a.upper[None, :, None])
    assert clipped.mean() > 0.1  # the test did push samples beyond the bounds


@pytest.mark.parametrize("agent", AGENTS)
@pytest.mark.parametrize("name", NAMES)
def test_closed_loop_reaches_goal_around_cylinder(agent, name):
    state, goal, static, _ = scene()
    ctrl = dcmppi.make_controller(name, agent=agent, seed=0, K=200)
    for _ in range(250):
        u = ctrl.act(state, goal, static)
        state = ctrl.agent.step(state, u, ctrl.dt)
        clearance = np.hypot(state[0] - 6.0, state[1] - 0.2) - 1.0 - ctrl.robot_radius
        assert clearance > 0
        if np.hypot(*(state[:2] - goal)) < 1.0:
            break
    assert np.hypot(*(state[:2] - goal)) < 1.0


def test_agent_instance_and_margin():
    """An Agent instance plans as its name does; obstacle_margin widens the frozen obstacles."""
    state, goal, static, moving = scene()
    by_name = dcmppi.make_controller("mppi", agent="holonomic", v_max=1.2, seed=1, K=64)
    by_instance = dcmppi.make_controller(
        "mppi", agent=make_agent("holonomic", v_max=1.2), seed=1, K=64
    )
    np.testing.assert_array_equal(
        by_name.act(state, goal, static, moving), by_instance.act(state, goal, static, moving)
    )
    with pytest.raises(ValueError, match="v_max"):  # set on the instance, not here
        dcmppi.make_controller("mppi", agent=make_agent("holonomic"), v_max=1.0)
    # a moving obstacle right on the straight path; with a margin more rollouts touch it
    moving = np.array([[3.0, 0.6, 0.0, 0.3]])
    hits = []
    for margin in (0.0, 0.5):
        ctrl = dcmppi.make_controller("mppi", seed=1, K=200, obstacle_margin=margin)
        ctrl.act(state, goal, None, moving)
        hits.append((ctrl.diagnostics.J >= ctrl.alpha).sum())
    assert hits[1] > hits[0]


@pytest.mark.parametrize("perturbation", PERTURBATIONS)
def test_every_perturbation_kind_has_the_per_step_variance_sigma(perturbation):
    """The importance term assumes eps_i ~ N(0, Sigma) at every step: constant, time-varying,
    mixed (half of the variance constant, half per step) and correlated (AR(1), correlation
    a^5 five steps apart) samples all have it."""
    ctrl = dcmppi.make_controller(
        "mppi", agent="holonomic", seed=0, K=20000, N=10, perturbation=perturbation
    )
    eps = np.asarray(ctrl.sample())  # (N, 3, K)
    np.testing.assert_allclose(eps.var(axis=2), np.broadcast_to(ctrl.Sigma, (10, 3)), rtol=0.05)
    lag = (eps[0] * eps[5]).mean(axis=1) / ctrl.Sigma  # correlation between two steps
    expected = {"constant": 1.0, "time_varying": 0.0, "mixed": 0.5, "correlated": 0.9**5}
    expected = expected[perturbation]
    np.testing.assert_allclose(lag, expected, atol=0.03)
    next_step = (eps[3] * eps[4]).mean(axis=1) / ctrl.Sigma
    if perturbation == "correlated":
        np.testing.assert_allclose(next_step, ctrl.correlation, atol=0.03)


def test_correlation_is_checked_and_belongs_to_its_kind():
    """correlation: in [0, 1), the default 0.9 for "correlated", refused with another kind; the
    smooth preset draws correlated perturbations unless another kind is given."""
    make = functools.partial(dcmppi.make_controller, "mppi", agent="holonomic")
    assert make(perturbation="correlated").correlation == 0.9
    assert make(perturbation="correlated", correlation=0.5).correlation == 0.5
    assert make().correlation == 0.0
    with pytest.raises(ValueError, match="correlation applies to perturbation='correlated'"):
        make(correlation=0.5)
    for bad in (1.0, -0.1, "x"):
        with pytest.raises(ValueError, match="correlation"):
            make(perturbation="correlated", correlation=bad)
    assert make(preset="smooth").perturbation == "correlated"
    assert make(preset="smooth", perturbation="mixed").perturbation == "mixed"
