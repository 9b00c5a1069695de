"""The safety shield (dcmppi.control.planners.shield): a safe command unchanged, an unsafe one
moved clear, for every agent kind, through every planner, and nothing at all when off."""

import numpy as np
import pytest

from dcmppi.control import make_controller
from dcmppi.control.agents import make_agent
from dcmppi.control.planners.shield import Shield, shield_param

DT, RADIUS = 0.1, 0.3
NO_STATIC = np.zeros((0, 3))
AGENTS = ("holonomic", "unicycle", "dubins")


def forward(agent):
    """Controls (nu,) of full speed along the heading 0, no turning."""
    return agent.command(np.array([agent.max_speed, 0.0]), 0.0)


def head_on(distance, offset=0.05, speed=1.0):
    """A walker of radius 0.3 `distance` ahead of the robot at the origin (heading 0), slightly
    to its left, walking straight at it: moving (1, 4), velocity (1, 2)."""
    return np.array([[distance, offset, np.pi, 0.3]]), np.array([[-speed, 0.0]])


def gap_after_one_step(agent, u, moving, velocity):
    """The gap between the robot's and the walker's discs after one control period."""
    robot = agent.step(np.zeros(3), u, DT)
    walker = moving[0, :2] + DT * velocity[0]
    return np.hypot(*(robot[:2] - walker)) - RADIUS - moving[0, 3]


@pytest.mark.parametrize("name", AGENTS)
def test_a_safe_command_comes_back_unchanged(name):
    agent = make_agent(name)
    shield = Shield(agent, RADIUS, DT)
    u = forward(agent)
    behind = np.array([[-3.0, 0.0, 0.0, 0.3], [0.0, 3.0, 0.0, 0.3]])  # behind, and walking off
    out, changed = shield(np.zeros(3), u, NO_STATIC, behind, np.array([[-1.0, 0.0], [0, 1.0]]))
    assert out is u and not changed


@pytest.mark.parametrize("name", ("holonomic", "unicycle"))
def test_an_unsafe_command_keeps_the_next_gap_above_the_radius_sum(name):
    agent = make_agent(name)
    moving, velocity = head_on(0.75)
    u = forward(agent)
    assert gap_after_one_step(agent, u, moving, velocity) < 0  # the planner's command collides
    out, changed = Shield(agent, RADIUS, DT)(np.zeros(3), u, NO_STATIC, moving, velocity)
    assert changed
    assert gap_after_one_step(agent, out, moving, velocity) > 0
    assert np.array_equal(out, agent.project(out[None, :, None])[0, :, 0])  # within bounds


@pytest.mark.parametrize("name", AGENTS)
def test_every_agent_turns_away_from_a_walker_ahead(name):
    agent = make_agent(name)
    moving, velocity = head_on(2.0)  # a walker slightly to the left: go right
    out, changed = Shield(agent, RADIUS, DT)(
        np.zeros(3), forward(agent), NO_STATIC, moving, velocity
    )
    v, omega = agent.world_velocity(0.0, out)
    assert changed
    assert (v[1] < 0) if agent.holonomic else (omega < 0)


def sidestep(agent, turn_at, steps=30):
    """A holonomic plan (steps, nu): full speed ahead, then from step `turn_at` full speed to
    the right."""
    plan = np.repeat(forward(agent)[None], steps, axis=0)
    plan[turn_at:] = agent.command(np.array([0.0, -agent.max_speed]), 0.0)
    return plan


def test_a_plan_that_curves_clear_passes_its_command_unchanged():
    agent = make_agent("holonomic", v_max=1.0)
    moving, velocity = head_on(2.5, offset=0.0, speed=0.5)  # at constant velocity: a collision
    plan = sidestep(agent, turn_at=1)  # one step ahead, then out of the walker's way
    u = plan[0]
    on, off = Shield(agent, RADIUS, DT), Shield(agent, RADIUS, DT, plan=False)
    assert off(np.zeros(3), u, NO_STATIC, moving, velocity, None, plan)[1]  # the command alone
    out, changed = on(np.zeros(3), u, NO_STATIC, moving, velocity, None, plan)
    assert out is u and not changed
    late = sidestep(agent, turn_at=12)  # turns too late to keep clear: filtered as before
    out, changed = on(np.zeros(3), u, NO_STATIC, moving, velocity, None, late)
    assert changed and np.array_equal(out, off(np.zeros(3), u, NO_STATIC, moving, velocity)[0])
    bounds = np.array([-5.0, -0.5, 5.0, 5.0])  # the right edge 0.5 m away: the plan leaves it
    assert on(np.zeros(3), u, NO_STATIC, moving, velocity, bounds, plan)[1]


def loop(ctrl, steps=40):
    """The actions (steps, nu) of `ctrl` driving at a walker that comes head-on."""
    state, actions = np.zeros(3), []
    moving, velocity = head_on(4.0)
    for _ in range(steps):
        u = ctrl.act(state, np.array([8.0, 0.0]), None, moving, None, moving_velocity=velocity)
        state = ctrl.agent.step(state, u, DT)
        moving[:, :2] += DT * velocity
        actions.append(u)
    return np.array(actions)


@pytest.mark.parametrize("controller", ["mppi", "dc", "orca", "social_force", "dwa"])
def test_the_shield_sees_this_steps_plan_or_none(controller, monkeypatch):
    seen = []
    call = Shield.__call__

    def spy(self, state, u, static, moving, velocity, bounds=None, plan=None):
        seen.append(plan)
        return call(self, state, u, static, moving, velocity, bounds, plan)

    monkeypatch.setattr(Shield, "__call__", spy)
    params = {"agent": "holonomic", "seed": 0}
    if controller in ("mppi", "dc"):
        params.update(K=64, N=20, prediction="cv")
    ctrl = make_controller(controller, shield=True, **params)
    moving, velocity = head_on(2.0)
    for _ in range(3):
        ctrl.act(np.zeros(3), np.array([5.0, 0.0]), None, moving, None, moving_velocity=velocity)
        if controller in ("mppi", "dc"):
            assert seen[-1] is ctrl.diagnostics.plan  # this step's, not the last step's
        else:
            assert seen[-1] is None  # a classical planner has no plan: the command alone
    if controller not in ("mppi", "dc"):  # so the check changes nothing for it
        off = make_controller(controller, shield={"plan": False}, **params)
        monkeypatch.setattr(Shield, "__call__", call)
        np.testing.assert_array_equal(loop(make_controller(controller, shield=True, **params)),
                                      loop(off))  # fmt: skip


def test_static_cylinders_and_the_map_edges_are_kept_clear():
    agent = make_agent("holonomic", v_max=1.0)
    shield = Shield(agent, RADIUS, DT, time_horizon=1.0, margin=0.0)
    u = forward(agent)
    pillar = np.array([[0.7, 0.0, 0.2]])  # 0.2 m from the robot's surface
    out, changed = shield(np.zeros(3), u, pillar, np.zeros((0, 4)), np.zeros((0, 2)))
    held = np.linspace(0.0, 1.0, 101)[:, None] * out[:2]  # the command held for 1 s
    assert changed and np.hypot(*(held - pillar[0, :2]).T).min() >= 0.5 - 1e-9
    bounds = np.array([-5.0, -5.0, 0.5, 5.0])  # the right edge 0.5 m from the centre
    out, changed = shield(np.zeros(3), u, NO_STATIC, np.zeros((0, 4)), np.zeros((0, 2)), bounds)
    assert changed and out[0] == pytest.approx(0.5)


def test_a_robot_surrounded_gets_a_bounded_command():
    agent = make_agent("holonomic", v_max=1.0)
    angles = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    ring = np.column_stack([0.8 * np.cos(angles), 0.8 * np.sin(angles), angles, np.full(8, 0.3)])
    inward = -1.0 * np.column_stack([np.cos(angles), np.sin(angles)])
    out, changed = Shield(agent, RADIUS, DT)(np.zeros(3), forward(agent), NO_STATIC, ring, inward)
    assert changed and np.isfinite(out).all() and np.hypot(*out[:2]) <= 1.0 + 1e-9


@pytest.mark.parametrize(
    ("controller", "agent"), [("mppi", "holonomic"), ("dc", "unicycle"), ("orca", "holonomic"),
                              ("social_force", "unicycle"), ("dwa", "dubins")]
)  # fmt: skip
def test_every_planner_takes_the_shield(controller, agent):
    params = {"agent": agent, "seed": 0}
    if controller in ("mppi", "dc"):
        params.update(K=64, N=10, prediction="cv")
    moving, velocity = head_on(0.75)
    args = (np.zeros(3), np.array([5.0, 0.0]), None, moving, None)
    ctrl = make_controller(controller, shield={"time_horizon": 1.0}, **params)
    ctrl.act(*args, moving_velocity=velocity)
    assert ctrl.diagnostics.shielded is True
    assert ctrl.params["shield"] == {"time_horizon": 1.0, "margin": 0.15, "plan": True}
    off = make_controller(controller, **params)
    off.act(*args, moving_velocity=velocity)
    assert off.safety is None and off.diagnostics.shielded is None and off.shield is None


def test_a_bad_shield_is_one_clear_error():
    assert shield_param(False) is None and shield_param(True) == {
        "time_horizon": 1.5,
        "margin": 0.15,
        "plan": True,
    }
    with pytest.raises(ValueError, match="shield plan must be true or false"):
        shield_param({"plan": "yes"})
    with pytest.raises(ValueError, match="shield must be true, false or a table of time_horizon"):
        shield_param({"tau": 1.0})
    with pytest.raises(ValueError, match="shield time_horizon must be > 0"):
        make_controller("orca", shield={"time_horizon": 0})
