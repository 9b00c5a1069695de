"""The task `crowdnav_plus` (CrowdNav++'s scene): its numbers against CrowdNav++'s config, its
draws against CrowdNav++'s code, respawns, ORCA's safety space and bad input."""

import numpy as np
import pytest

from dcmppi import tasks
from dcmppi.tasks.pedestrians import crowdnav_plus
from dcmppi.tasks.pedestrians.crowdnav_plus import generate_crowdnav_plus
from dcmppi.tasks.pedestrians.walkers import Pedestrians

HOLD = np.zeros(3)


def _their_case(seed, human_num=20, circle_radius=crowdnav_plus.CIRCLE_RADIUS, arena=6.0, r=0.3):
    """CrowdNav++'s CrowdSimVarNum.reset for a holonomic robot (crowd_sim_var_num.py:
    generate_robot_humans, generate_circle_crossing_human), transcribed: np.random.seed(seed),
    then (px, py, gx, gy) of the robot and each human's (px, py, gx, gy)."""
    rng = np.random.RandomState(seed)
    while True:
        px, py, gx, gy = rng.uniform(-arena, arena, 4)
        if np.linalg.norm([px - gx, py - gy]) >= 8:
            break
    rng.randint(low=human_num, high=human_num + 1)
    agents = [(px, py, gx, gy)]
    for _ in range(human_num):
        while True:
            angle = rng.random_sample() * np.pi * 2
            px_noise = rng.uniform(0, 1) * 2
            py_noise = rng.uniform(0, 1) * 2
            hx = circle_radius * np.cos(angle) + px_noise
            hy = circle_radius * np.sin(angle) + py_noise
            min_dist = r + r + 0.25  # human.radius + agent.radius + discomfort_dist
            if not any(
                np.linalg.norm((hx - a[0], hy - a[1])) < min_dist
                or np.linalg.norm((hx - a[2], hy - a[3])) < min_dist
                for a in agents
            ):
                break
        agents.append((hx, hy, -hx, -hy))
    return np.array(agents)


def _on_shifted_circle(xy, tol=0.0):
    """Whether xy (2,) is R (cos a, sin a) + U(0, 2)^2 for some angle a (within tol)."""
    a = np.linspace(0.0, 2.0 * np.pi, 7200)
    offset = xy[None] - crowdnav_plus.CIRCLE_RADIUS * np.column_stack([np.cos(a), np.sin(a)])
    return bool(((offset >= -tol) & (offset <= 2.0 + tol)).all(axis=1).any())


def test_the_defaults_are_crowdnav_plus_config():
    """crowd_nav/configs/config.py: 20 humans, circle 6 sqrt(2), radius 0.3, v_pref 1, time
    limit 50, ORCA safety space 0.15 (+ the 0.01 of its orca.py), invisible holonomic robot of
    radius 0.3 at 1 m/s; the robot's start and goal in [-6, 6]^2 at least 8 m apart."""
    task = tasks.load("crowdnav_plus", task_kwargs={"random": 1}).task
    assert (task.num_moving, task.radius, task.speed_range) == (20, 0.3, (1.0, 1.0))
    assert task.circle_radius == pytest.approx(8.485281374238571)  # their log's circle width
    assert (task.time_limit, task.goal_tolerance, task.robot_radius) == (50.0, 0.3, 0.3)
    assert task.agent.name == "holonomic" and task.agent.params["v_max"] == 1.0
    assert task.behavior == "orca" and not task.robot_visible
    assert crowdnav_plus.SAFETY_SPACE == pytest.approx(0.01 + 0.15)
    for seed in range(20):
        world = generate_crowdnav_plus(np.random.RandomState(seed))
        assert (np.abs(world.start[:2]) <= 6).all() and (np.abs(world.goal) <= 6).all()
        assert np.hypot(*(world.start[:2] - world.goal)) >= 8.0
        xy = world.moving[:, :2]
        np.testing.assert_array_equal(world.moving_goal, -xy)
        assert all(_on_shifted_circle(p) for p in xy)
        assert not all(_on_shifted_circle(p) for p in -xy)  # the noise is not centred
        assert world.slow_at_goal and not world.stop_at_goal
        assert world.safety_space == pytest.approx(0.16)


def test_case_k_is_crowdnav_plus_test_draw_k():
    for k in (0, 1, 2, 7):
        env = tasks.load("crowdnav_plus", task_kwargs={"case": k, "random": k + 3})
        env.reset()
        world, theirs = env.task.world, _their_case(1000 + 425 + k)
        np.testing.assert_allclose(world.start[:2], theirs[0, :2], atol=1e-12)
        np.testing.assert_allclose(world.goal, theirs[0, 2:], atol=1e-12)
        np.testing.assert_allclose(world.moving[:, :2], theirs[1:, :2], atol=1e-12)
        np.testing.assert_allclose(world.moving_goal, theirs[1:, 2:], atol=1e-12)


def test_humans_respawn_on_the_circle_on_arrival():
    env = tasks.load("crowdnav_plus", task_kwargs={"n_humans": 3, "random": 2})
    env.reset()
    before = env.physics.moving_obstacles()[:, :2]
    respawned = set()
    for _ in range(260):  # 26 s: each crosses the ~17 m circle at 1 m/s
        env.step(HOLD)
        now = env.physics.moving_obstacles()[:, :2]
        jump = np.hypot(*(now - before).T) > 1.0
        for i in np.flatnonzero(jump):
            respawned.add(int(i))
            assert _on_shifted_circle(now[i], tol=0.1)  # one control step (<= 0.1 m) after
            # its goal: the antipode of its new start
            np.testing.assert_allclose(env.task._goals[i], -now[i], atol=0.1)
        before = now
        if env.task.outcome is not None:
            break
    assert respawned


def test_goals_change_every_five_seconds_with_the_given_chance():
    """CrowdNav++'s random_goal_changing: nothing before 5 s; at 5 s each human (chance 1)
    walks to a new goal on the circle shifted by at most v_pref / 2 per coordinate, clear of
    the others' positions and goals; with chance 0 (the default) no goal changes."""
    changed = {}
    for chance in (0.0, 1.0):
        env = tasks.load(
            "crowdnav_plus", task_kwargs={"n_humans": 6, "random": 5, "goal_change_chance": chance}
        )
        env.reset()
        walkers = env.physics.obstacle_motion
        goals = [walkers.goal.copy()]
        for _ in range(51):  # the round runs as period 50 (5 s) starts
            env.step(HOLD)
            goals.append(walkers.goal.copy())
        assert env.task.outcome is None  # the robot standing at its start is not hit
        moved = [np.abs(g - goals[0]).max(axis=1) > 1e-9 for g in goals]
        changed[chance] = moved
        assert not any(m.any() for m in moved[:50])  # nobody arrives within 5 s
        if chance:
            assert moved[51].all()
            new, where = goals[51], env.physics.moving_obstacles()[:, :2]
            offset = new - crowdnav_plus.CIRCLE_RADIUS * new / np.hypot(*new.T)[:, None]
            assert (np.hypot(*offset.T) <= np.sqrt(0.5) + 1e-9).all()
            for i in range(6):  # 0.3 + 0.3 + 0.25 from the others' goals and positions then
                others = np.concatenate([new[:i], goals[50][i + 1 :], where[np.arange(6) != i]])
                assert np.hypot(*(others - new[i]).T).min() >= 0.85 - 0.1  # they walked 0.1 m
    assert not changed[0.0][51].any()


def test_goal_change_chance_is_a_probability():
    with pytest.raises(ValueError, match=r"goal_change_chance must be a probability in \[0, 1\]"):
        tasks.load("crowdnav_plus", task_kwargs={"goal_change_chance": 1.5})


def _closest_pass(safety_space):
    """Two ORCA pedestrians head-on, 0.2 m off line: their smallest centre distance."""
    peds = Pedestrians(
        "orca", [[-3.0, 0.1], [3.0, -0.1]], np.zeros((2, 2)), [[5.0, 0.1], [-5.0, -0.1]],
        [1.0, 1.0], [0.3, 0.3], None, [-10, -10, 10, 10], 0.3, False, None,
        np.random.RandomState(0), 0.1, slow_at_goal=True, safety_space=safety_space,
    )  # fmt: skip
    gaps = []
    for _ in range(80):
        z = peds.advance(1, np.zeros(2), np.zeros(2))[-1]
        gaps.append(abs(z[0] - z[1]))
    assert np.hypot(*peds.velocity.T).max() <= 1.0 + 1e-6  # slow_at_goal: at most v_pref
    return min(gaps)


def test_orca_keeps_the_safety_space():
    plain, spaced = _closest_pass(0.0), _closest_pass(0.16)
    assert plain >= 0.6 - 0.02 and spaced >= 0.6 + 2 * 0.16 - 0.02 > plain + 0.2


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"n_humans": -1}, "n_humans must be >= 0"),
        ({"robot_spacing": 17.0}, "robot_spacing 17 m does not fit in the arena"),
        ({"arena_size": 0.0}, "arena_size must be > 0"),
        ({"safety_space": -0.1}, "safety_space must be >= 0"),
        ({"case": -2}, "case must be >= 0"),
        ({"obstacles": [[1.0, 1.0, 0.0]]}, "obstacle 0 has radius 0"),
        ({"scenario": "circle_crossing"}, "unknown task_kwargs ['scenario']"),
    ],
)
def test_bad_input_is_one_line_naming_the_problem(kwargs, message):
    with pytest.raises(ValueError) as error:
        tasks.load("crowdnav_plus", task_kwargs=kwargs)
    assert message in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"obstacles": [[0.0, 0.0, 8.0]]}, "the robot found no start and goal 8 m apart"),
        ({"n_humans": 130}, "of 130 humans fit on the 8.48528 m circle"),
    ],
)
def test_a_scene_that_cannot_be_placed_says_so(kwargs, message):
    env = tasks.load("crowdnav_plus", task_kwargs=kwargs)
    with pytest.raises(ValueError) as error:
        env.reset()
    assert message in str(error.value) and "\n" not in str(error.value)
