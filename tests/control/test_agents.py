"""Agent models: rollouts against brute-force loops, Jacobians, projection, registry, bad input."""

import math

import numpy as np
import pytest

import dcmppi
from dcmppi.control.agents import Agent, agent_names, make_agent, register_agent
from dcmppi.control.kernels.projection import bound

AGENTS = ["dubins", "unicycle", "holonomic"]
DT = 0.1


def brute_step(agent, state, u):
    """One control period written out with math, independent of the agents' code."""
    x, y, th = state
    if agent.name == "holonomic":
        return [x + DT * u[0], y + DT * u[1], th + DT * u[2]]
    v, w = (agent.v, u[0]) if agent.name == "dubins" else (u[0], u[1])
    if w == 0.0:
        return [x + v * DT * math.cos(th), y + v * DT * math.sin(th), th]
    r = v / w  # exact arc: centre to the left of the heading
    return [
        x + r * (math.sin(th + w * DT) - math.sin(th)),
        y - r * (math.cos(th + w * DT) - math.cos(th)),
        th + w * DT,
    ]


def random_controls(agent, rng, n, k):
    u = rng.uniform(agent.lower[None, :, None], agent.upper[None, :, None], (n, agent.nu, k))
    u[:, :, 0] = 0.0 if agent.name != "unicycle" else [agent.v_max, 0.0]  # straight
    return agent.project(u)


@pytest.mark.parametrize("name", AGENTS)
def test_rollout_equals_a_brute_force_loop(name):
    agent = make_agent(name)
    rng = np.random.default_rng(0)
    n, k = 30, 12
    u = random_controls(agent, rng, n, k)
    x0 = np.array([1.0, -2.0, 3.0])  # heading beyond pi: rollouts wrap the start heading
    states = agent.rollout(x0, u, DT)
    assert states.shape == (3, n + 1, k) and states[0].flags.c_contiguous
    for j in range(k):
        s = [x0[0], x0[1], (x0[2] + math.pi) % (2 * math.pi) - math.pi]
        expected = [s]
        for i in range(n):
            s = brute_step(agent, s, u[i, :, j])
            expected.append(s)
        np.testing.assert_allclose(states[:, :, j].T, expected, rtol=0, atol=2e-6)


@pytest.mark.parametrize("name", AGENTS)
def test_rollout_from_several_starts_equals_separate_rollouts(name):
    agent = make_agent(name)
    u = random_controls(agent, np.random.default_rng(1), 20, 8)
    starts = np.array([[0.0, 5.0], [0.0, -1.0], [0.2, -2.5]])  # (3, S = 2)
    both = agent.rollout(starts, u, DT, starts=2)
    for s in range(2):
        np.testing.assert_array_equal(
            both[:, :, s * 8 : (s + 1) * 8], agent.rollout(starts[:, s], u, DT)
        )
    np.testing.assert_array_equal(agent.rollout_one(starts[:, 0], u[:, :, 3], DT), both[:, :, 3].T)


@pytest.mark.parametrize("name", AGENTS)
def test_step_matches_rollout_and_jacobians_match_finite_differences(name):
    agent = make_agent(name)
    rng = np.random.default_rng(2)
    U = random_controls(agent, rng, 6, 2)[:, :, 1]
    if name == "unicycle":
        U[:, 0] = np.clip(U[:, 0], 0.2, 0.8)  # inside the bounds: derivatives both ways
    states = agent.rollout_one(np.array([0.5, 0.5, 0.4]), U, DT)
    for i in range(6):
        np.testing.assert_allclose(agent.step(states[i], U[i], DT), states[i + 1], atol=1e-9)
    A, B = agent.jacobians(states, U, DT)
    assert A.shape == (6, 3, 3) and B.shape == (6, 3, agent.nu)
    h = 1e-6
    for i in range(6):
        for c in range(3):
            d = np.zeros(3)
            d[c] = h
            fd = (agent.step(states[i] + d, U[i], DT) - agent.step(states[i] - d, U[i], DT)) / 2 / h
            np.testing.assert_allclose(A[i][:, c], fd, atol=1e-7)
        for c in range(agent.nu):
            d = np.zeros(agent.nu)
            d[c] = h
            fd = (agent.step(states[i], U[i] + d, DT) - agent.step(states[i], U[i] - d, DT)) / 2 / h
            np.testing.assert_allclose(B[i][:, c], fd, atol=1e-7)


@pytest.mark.parametrize("name", AGENTS)
def test_projection_lands_inside_and_keeps_inside_points(name):
    agent = make_agent(name)
    rng = np.random.default_rng(3)
    u = rng.normal(0, 3, (5, agent.nu, 200))
    p = agent.project(u)
    assert (p >= agent.lower[None, :, None]).all() and (p <= agent.upper[None, :, None]).all()
    if agent.norm_axes is not None:
        assert (np.hypot(p[:, 0], p[:, 1]) <= agent.norm_limit * (1 + 1e-12)).all()
        box = np.clip(u[:, :2], -agent.v_max, agent.v_max)
        cross = p[:, 0] * box[:, 1] - p[:, 1] * box[:, 0]
        np.testing.assert_allclose(cross, 0, atol=1e-12)  # the box point scaled, never turned
    np.testing.assert_allclose(agent.project(p), p, rtol=1e-15, atol=0)  # idempotent
    with pytest.raises(ValueError, match="control"):
        agent.project(np.zeros((5, agent.nu + 1, 3)))


def test_first_guesses():
    state, goal = np.array([0.0, 0.0, 2.0]), np.array([3.0, 4.0])
    np.testing.assert_array_equal(
        make_agent("dubins").first_guess(state, goal, 4), np.zeros((4, 1))
    )
    np.testing.assert_array_equal(
        make_agent("unicycle").first_guess(state, goal, 2), [[1, 0], [1, 0]]
    )
    np.testing.assert_allclose(make_agent("holonomic").first_guess(state, goal, 1), [[0.9, 1.2, 0]])


def test_registry_and_bad_input():
    assert set(AGENTS) <= set(agent_names())
    with pytest.raises(ValueError, match="unknown agent 'boat'; valid names: dubins"):
        make_agent("boat")
    with pytest.raises(ValueError, match="unknown parameter.*r_min.*'holonomic'.*v_max"):
        make_agent("holonomic", r_min=1.0)
    for bad in ({"v_max": float("nan")}, {"v_max": 0.0}, {"omega_max": "fast"}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            make_agent("unicycle", **bad)
    with pytest.raises(TypeError, match="agent .thing. must be a subclass of Agent"):
        register_agent("thing")(dict)


class _Bad(Agent):
    controls = ("a", "b")

    def __init__(self, lower, upper):
        self.set_bounds(lower, upper)


@pytest.mark.parametrize(
    "lower, upper, word",
    [
        ([0.0, 1.0], [1.0, 0.5], "control.*b.*lower <= upper"),
        ([0.0, -np.inf], [1.0, 1.0], "control.*b.*finite"),
        ([0.0, np.nan], [1.0, 1.0], "control.*b"),
        ([0.0], [1.0], "one entry per control"),
    ],
)
def test_bounds_that_are_not_finite_or_ordered_are_named(lower, upper, word):
    with pytest.raises(ValueError, match=word):
        _Bad(lower, upper)


def test_a_registered_agent_plans_with_every_controller():
    """The README's example: a point robot that commands its world-frame velocity in a box."""

    @register_agent("point")
    class Point(Agent):
        controls = ("u_x", "u_y")
        param_names = ("v_max",)
        default_Sigma = (1.0, 1.0)  # (m/s)^2
        default_perturbation = "mixed"

        def __init__(self, v_max=1.0):
            self.v_max = v_max
            self.set_bounds([-v_max, -v_max], [v_max, v_max])

        @property
        def max_speed(self):
            return self.v_max * np.sqrt(2)

        def step(self, state, u, dt):
            u = np.asarray(u, dtype=float)
            return np.asarray(state) + dt * np.stack([u[..., 0], u[..., 1], 0 * u[..., 0]], -1)

        def rollout(self, x0, u, dt, starts=1):
            n, _, k = u.shape
            out = np.zeros((3, n + 1, starts, k))  # state-major: x, y, theta
            out[:, 0] = np.reshape(x0, (3, starts, -1))
            out[:2, 1:] = out[:2, :1] + dt * np.cumsum(u, axis=0).transpose(1, 0, 2)[:, :, None]
            out[2, 1:] = out[2, 0]
            return out.reshape(3, n + 1, starts * k)

        def jacobians(self, states, U, dt):
            B = np.zeros((len(U), 3, 2))
            B[:, 0, 0] = B[:, 1, 1] = dt
            return np.broadcast_to(np.eye(3), (len(U), 3, 3)).copy(), B

    try:
        for name in ("mppi", "clustered", "dc", "tube"):
            ctrl = dcmppi.make_controller(name, agent="point", v_max=0.8, seed=0, K=64, N=20)
            state = np.zeros(3)
            for _ in range(120):
                u = ctrl.act(state, np.array([5.0, 2.0]), np.array([[2.5, 0.4, 0.5]]))
                assert np.abs(u).max() <= 0.8
                state = ctrl.agent.step(state, u, 0.1)
                assert np.hypot(state[0] - 2.5, state[1] - 0.4) > 1.0  # never in the cylinder
            assert np.hypot(state[0] - 5.0, state[1] - 2.0) < 0.5, name
    finally:
        from dcmppi.control.agents import base

        base.AGENTS.unregister("point")


@pytest.mark.parametrize("agent", ["dubins", "unicycle", "holonomic"])
def test_bound_gives_project_s_values_for_one_control_vector(agent):
    a = make_agent(agent)
    rng = np.random.default_rng(4)
    edges = [a.lower, a.upper, np.zeros(a.nu), -np.zeros(a.nu)]  # on the box, signed zeros
    edges += [np.where(np.arange(a.nu) % 2, a.lower, -0.0), np.where(a.lower == 0, -0.0, a.upper)]
    for u in [*edges, *rng.normal(0.0, 1.0, (200, a.nu)) * rng.choice([0.1, 1.0, 5.0], (200, 1))]:
        want = a.project(u[None], axis=1)[0]  # inside, on and far beyond the box and the disc
        got = bound(a, u)
        assert np.array_equal(got, want) and np.array_equal(np.signbit(got), np.signbit(want)), u
