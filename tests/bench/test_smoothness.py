"""Smoothness and indecision per episode (the applied control's rate, the path's turn-sign
changes, the task blocked's commitment to a side, the path's and the plans') on paths and plans
with known answers, and an episode's record of them."""

from types import SimpleNamespace

import numpy as np
import pytest

from dcmppi.bench.episodes import runner
from dcmppi.bench.episodes.metrics import (
    SIDE_DEADBAND,
    PlanSides,
    control_rates,
    indecision,
    planned_side,
    side_commitment,
    turn_sign_changes,
)
from dcmppi.bench.episodes.runner import EpisodeSpec, run_episode
from dcmppi.control.agents import make_agent

DT = 0.1
SMALL = {"K": 64, "N": 20}


def zigzag(corners, leg=5, step=0.1, angle=0.5):
    """Positions every DT of a path of straight legs of `leg` steps of `step` m, turning by
    +angle, -2 angle, +2 angle, ... at each of `corners` corners (a zig-zag about +x)."""
    heading, points = angle / 2, [np.zeros(2)]
    for k in range(corners + 1):
        for _ in range(leg):
            points.append(points[-1] + step * np.array([np.cos(heading), np.sin(heading)]))
        heading += -angle if k % 2 == 0 else angle
    return np.array(points)


def test_the_control_rate_is_the_mean_step_change_over_dt_per_kind_of_control():
    u = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.5], [1.0, 1.0, 0.5], [1.0, 1.0, -0.5]]
    linear, angular = control_rates(u, ("u_x", "u_y", "u_theta"), 0.5)
    assert linear == pytest.approx((2.0 + 2.0 + 0.0) / 3)  # |(1, 0)|, |(0, 1)|, 0 over 0.5 s
    assert angular == pytest.approx((1.0 + 0.0 + 2.0) / 3)
    assert control_rates([[0.2], [-0.2]], ("omega",), DT) == (None, pytest.approx(4.0))
    assert control_rates([[1.0, 0.0], [1.5, 0.1]], ("v", "omega"), DT) == pytest.approx((5, 1))
    assert control_rates([[1.0, 0.0]], ("v", "omega"), DT) == (None, None)
    assert control_rates([], ("v", "omega"), DT) == (None, None)


def test_a_zigzag_changes_turn_sign_once_per_corner_after_the_first():
    assert turn_sign_changes(zigzag(4), DT) == 3  # corners right, left, right, left
    assert turn_sign_changes(zigzag(1), DT) == 0
    straight = np.column_stack([np.linspace(0, 10, 101), np.zeros(101)])
    assert turn_sign_changes(straight, DT) == 0
    t = np.linspace(0, np.pi, 60)  # one way round a circle, then standing still: no change
    arc = np.vstack([np.column_stack([np.cos(t), np.sin(t)]), np.tile([-1.0, 0.0], (10, 1))])
    assert turn_sign_changes(arc, DT) == 0
    # a tiny wobble below the deadband is straight; the same zig-zag with a stop in a leg too
    wobble = straight + np.column_stack([np.zeros(101), 1e-5 * (-1.0) ** np.arange(101)])
    assert turn_sign_changes(wobble, DT) == 0
    z = zigzag(4)
    stopped = np.vstack([z[:8], np.repeat(z[8:9], 5, axis=0), z[8:]])
    assert turn_sign_changes(stopped, DT) == 3


def test_indecision_is_per_metre_and_per_second():
    z = zigzag(4)  # 25 steps of 0.1 m: 2.5 m in 2.5 s
    got = indecision(z, DT, float(np.hypot(*np.diff(z, axis=0).T).sum()))
    assert got["turn_sign_changes"] == 3
    assert got["indecision_per_m"] == pytest.approx(3 / 2.5)
    assert got["indecision_per_s"] == pytest.approx(3 / 2.5)
    still = indecision(np.zeros((5, 2)), DT, 0.0)
    assert still == {"turn_sign_changes": 0, "indecision_per_m": None, "indecision_per_s": 0.0}
    assert indecision(np.zeros((1, 2)), DT, 0.0)["indecision_per_s"] is None


def path_around(lateral):
    """A path from (0, 0) toward a goal at (20, 0) past an obstacle centred at (10, 0): x
    advancing 0.1 m per step, y = lateral[k] (then on y = lateral[-1] to x = 20)."""
    n = 201
    y = np.concatenate([lateral, np.full(n - len(lateral), lateral[-1])])
    return np.column_stack([np.linspace(0, 20, n), y])


def commitment(path):
    return side_commitment(path, DT, [0.0, 0.0], [20.0, 0.0], [10.0, 0.0])


def test_a_robot_that_goes_left_at_once_commits_at_once_and_never_switches():
    lateral = np.minimum(0.05 * np.arange(80), 2.5)  # leaves the deadband after 2 steps
    got = commitment(path_around(lateral))
    assert got == {"commit_time": pytest.approx(0.3), "commit_delay": 0.0, "side_switches": 0}
    assert 0.05 * 2 <= SIDE_DEADBAND < 0.05 * 3
    right = commitment(path_around(-lateral))
    assert right["commit_time"] == pytest.approx(0.3) and right["side_switches"] == 0


def test_hesitation_left_right_left_counts_two_switches_and_commits_on_the_last_side():
    lateral = np.concatenate([
        np.full(10, 0.0),  # straight for 1 s
        np.full(10, 0.3),  # left from step 10
        np.full(5, 0.0),  # back on the line: no side
        np.full(10, -0.3),  # right from step 25
        np.full(10, 0.5),  # left again from step 35, kept
        np.linspace(0.5, 2.5, 20),
    ])  # fmt: skip
    got = commitment(path_around(lateral))
    assert got["side_switches"] == 2
    assert got["commit_time"] == pytest.approx(3.5)
    assert got["commit_delay"] == pytest.approx(2.5)  # first on a side at 1.0 s


def test_only_the_approach_counts_and_a_straight_drive_never_commits():
    lateral = np.concatenate([np.full(50, 1.0), np.full(60, 1.0), np.full(10, -1.0)])
    got = commitment(path_around(lateral))  # crosses to the right after passing x = 10
    assert got["side_switches"] == 0 and got["commit_time"] == 0.0
    head_on = commitment(path_around(np.zeros(90)))
    assert head_on == {"commit_time": None, "commit_delay": None, "side_switches": 0}


def test_an_episode_records_smoothness_and_blocked_its_commitment():
    blocked = run_episode(EpisodeSpec("blocked", "clustered", "none", 0, {}, SMALL))
    assert blocked["control_rate_linear"] is None  # the Dubins car's speed is fixed
    assert blocked["control_rate_angular"] > 0 and blocked["indecision_per_s"] >= 0
    assert blocked["side_switches"] >= 0 and blocked["commit_time"] is not None
    assert blocked["goal_distance"] >= 0
    spec = EpisodeSpec("crossing", "mppi", "none", 0, {"agent": "holonomic"}, SMALL)
    crossing = run_episode(spec)
    assert crossing["control_rate_linear"] > 0 and crossing["side_switches"] is None
    assert crossing["plan_commit_time"] is None and crossing["scene"] is None


def side(xs, ys, reach=0.0):
    """planned_side of planned points (xs, ys) about the obstacle of `commitment`."""
    states = np.column_stack([xs, ys, np.zeros(len(xs))])
    return planned_side(states, [0.0, 0.0], [20.0, 0.0], [10.0, 0.0], reach)


def test_the_planned_side_is_where_the_plan_draws_level_with_the_centre():
    x = np.linspace(6.0, 14.0, 41)  # level with the centre at x = 10, point 20
    bump = 2.5 * np.exp(-((x - 10.0) ** 2))
    assert side(x, bump) == 1 and side(x, -bump) == -1
    assert side(x, np.where(x < 10.0, 3.0, -3.0)) == -1  # the first point level decides
    assert side(x[:20], bump[:20]) == 0  # the horizon ends short of the centre
    assert side(x, np.full(41, SIDE_DEADBAND / 2)) == 0  # within the deadband: no side
    assert side(x, np.full(41, 2 * SIDE_DEADBAND)) == 1
    assert side(x, 0.5 * bump, reach=2.3) == 0  # 1.25 m: through the disc, no side
    assert side(x, bump, reach=2.3) == 1 and side(x, -bump, reach=2.3) == -1


def sway(lateral, n=30):
    """A holonomic plan at 1.5 m/s along +x that reaches `lateral` m to the left (right: < 0)
    after half its steps and keeps it."""
    u = np.zeros((n, 3))
    u[:, 0] = 1.5
    u[: n // 2, 1] = lateral / (n // 2 * DT)
    return u


def test_plan_sides_count_switches_of_the_plan_before_the_robot_draws_level():
    sides = PlanSides([0.0, 0.0], [20.0, 0.0], [10.0, 0.0], DT)
    agent = make_agent("holonomic")
    plans = [
        sway(1.0, n=10),  # step 0: 1.5 m ahead, short of the centre: no side
        sway(1.0),  # steps 1, 2: left
        sway(1.0),
        sway(-1.0),  # step 3: right, kept
        sway(-1.0),
        sway(1.0),  # step 5: the robot has drawn level, not read
    ]
    xs = [2.0, 6.0, 6.1, 6.2, 6.3, 10.0]
    for x, plan in zip(xs, plans, strict=True):
        d = SimpleNamespace(plan=plan)
        sides.read(SimpleNamespace(agent=agent, dt=DT, diagnostics=d), np.array([x, 0.0, 0.0]))
    assert sides.sides == [0, 1, 1, -1, -1]
    got = sides.result()
    assert got["plan_side_switches"] == 1
    assert got["plan_commit_time"] == pytest.approx(0.3)
    assert got["plan_commit_delay"] == pytest.approx(0.2)  # first planned side at step 1
    never = PlanSides([0.0, 0.0], [20.0, 0.0], [10.0, 0.0], DT)
    never.read(SimpleNamespace(diagnostics=SimpleNamespace(plan=None)), np.zeros(3))
    assert never.result() == {
        "plan_commit_time": None,
        "plan_commit_delay": None,
        "plan_side_switches": 0,
    }
    # Tube-MPPI plans from its nominal state: 0.5 m left of the robot, the plan passes left
    tube = PlanSides([0.0, 0.0], [20.0, 0.0], [10.0, 0.0], DT)
    d = SimpleNamespace(plan=sway(-0.3), nominal_state=np.array([6.0, 0.5, 0.0]))
    tube.read(SimpleNamespace(agent=agent, dt=DT, diagnostics=d), np.array([6.0, 0.0, 0.0]))
    assert tube.sides == [1]


def test_a_blocked_episode_records_the_plans_side_without_changing_them(monkeypatch):
    spec = EpisodeSpec("blocked", "clustered", "control", 0, {}, SMALL)
    got = run_episode(spec)
    assert got["plan_side_switches"] >= 0 and got["plan_commit_time"] is not None
    assert 0 <= got["plan_commit_delay"] <= got["plan_commit_time"]
    # the horizon (2 s at 1 m/s) first reaches the centre 10 m ahead after 8 s
    assert got["plan_commit_time"] >= 7.0
    monkeypatch.setattr(runner.Episode, "_plan_sides", lambda self: None)
    assert run_episode(spec)["trace"] == got["trace"]  # reading the plans changes nothing
    classical = EpisodeSpec("blocked", "orca", "none", 0, {"agent": "unicycle"}, {})
    none = run_episode(classical)
    assert none["plan_side_switches"] is None and none["plan_commit_time"] is None
    assert none["side_switches"] is not None
