"""The task `crowdnav` (CrowdNav's scene): its geometry and CrowdNav's draws, humans that stop
at their goals, determinism, the robot seen or not, bad input, and ORCA against RVO2."""

import math

import numpy as np
import pytest

from dcmppi import tasks
from dcmppi.tasks.pedestrians import crowdnav
from dcmppi.tasks.pedestrians.crowdnav import (
    CIRCLE_RADIUS,
    DISCOMFORT_DISTANCE,
    generate_crowdnav,
)
from dcmppi.tasks.pedestrians.walkers import Pedestrians

pytest.importorskip("navground.core")

HOLD = np.zeros(3)  # the holonomic robot's standing action


def _redraw_rule_holds(world, robot_radius=0.3):
    """CrowdNav's rule: each human's start lies r_h + r_a + DISCOMFORT_DISTANCE or more from
    the robot's and every earlier human's start and goal."""
    starts = np.vstack([world.start[:2], world.moving[:, :2]])
    goals = np.vstack([world.goal, world.moving_goal])
    radii = np.concatenate([[robot_radius], world.moving[:, 3]])
    for i in range(1, len(starts)):
        for j in range(i):
            gap = radii[i] + radii[j] + DISCOMFORT_DISTANCE
            assert np.hypot(*(starts[i] - starts[j])) >= gap
            assert np.hypot(*(starts[i] - goals[j])) >= gap


@pytest.mark.parametrize("seed", range(20))
def test_circle_crossing_geometry(seed):
    world = generate_crowdnav(np.random.RandomState(seed))
    np.testing.assert_array_equal(world.start, [0.0, -CIRCLE_RADIUS, 0.5 * math.pi])
    np.testing.assert_array_equal(world.goal, [0.0, CIRCLE_RADIUS])
    xy = world.moving[:, :2]
    assert xy.shape == (5, 2) and (world.moving[:, 3] == 0.3).all()
    # on the circle within the start noise: each coordinate off by at most 0.5 v_pref
    direction = xy / np.hypot(*xy.T)[:, None]
    off = np.abs(xy - CIRCLE_RADIUS * direction)
    assert np.hypot(*xy.T).min() >= CIRCLE_RADIUS - 0.5 * math.sqrt(2)
    assert off.max() <= 0.5 * math.sqrt(2) + 1e-12
    np.testing.assert_array_equal(world.moving_goal, -xy)  # antipodal goals
    np.testing.assert_array_equal(world.moving_speed, 0.0)  # at rest
    assert world.stop_at_goal and not world.robot_visible
    _redraw_rule_holds(world)


def _crowdnavs_case(k, human_num=5, circle_radius=4.0, radius=0.3, v_pref=1.0):
    """CrowdNav's generate_circle_crossing_human for its test case k, transcribed (crowd_sim.py:
    np.random.seed(1000 + k), then per human: angle, x noise, y noise until clear); numpy's
    global np.random.random is a RandomState's random_sample."""
    random = np.random.RandomState(1000 + k)
    agents = [(0.0, -circle_radius, 0.0, circle_radius, radius)]  # px, py, gx, gy, radius
    for _ in range(human_num):
        while True:
            angle = random.random_sample() * np.pi * 2
            px_noise = (random.random_sample() - 0.5) * v_pref
            py_noise = (random.random_sample() - 0.5) * v_pref
            px = circle_radius * np.cos(angle) + px_noise
            py = circle_radius * np.sin(angle) + py_noise
            collide = False
            for ax, ay, gx, gy, r in agents:
                min_dist = radius + r + 0.2
                if np.hypot(px - ax, py - ay) < min_dist or np.hypot(px - gx, py - gy) < min_dist:
                    collide = True
                    break
            if not collide:
                break
        agents.append((px, py, -px, -py, radius))
    return np.array(agents[1:])


def test_case_k_is_crowdnavs_test_case_k():
    for k in (0, 1, 499):
        task = tasks.load("crowdnav", task_kwargs={"case": k, "random": k + 7}).task
        world = task.generate_world(np.random.RandomState(123))  # the seed does not matter
        expected = _crowdnavs_case(k)
        np.testing.assert_array_equal(world.moving[:, :2], expected[:, :2])
        np.testing.assert_array_equal(world.moving_goal, expected[:, 2:4])


@pytest.mark.parametrize("seed", range(10))
def test_square_crossing_geometry(seed):
    world = generate_crowdnav(np.random.RandomState(seed), "square_crossing", n_humans=8)
    xy, goals = world.moving[:, :2], world.moving_goal
    assert (np.abs(xy) <= 5.0).all() and (np.abs(goals) <= 5.0).all()
    assert (np.sign(xy[:, 0]) == -np.sign(goals[:, 0])).all()  # to the other half
    for i in range(1, len(xy)):
        gap = 0.6 + DISCOMFORT_DISTANCE
        assert np.hypot(*(xy[:i] - xy[i]).T).min() >= gap
        assert np.hypot(*(goals[:i] - goals[i]).T).min() >= gap


def test_randomized_attributes_lie_in_crowdnavs_ranges():
    world = generate_crowdnav(np.random.RandomState(3), n_humans=10, randomize_attributes=True)
    speed, radius = world.moving_pref_speed, world.moving[:, 3]
    assert ((0.5 <= speed) & (speed <= 1.5)).all() and np.ptp(speed) > 0
    assert ((0.3 <= radius) & (radius <= 0.5)).all() and np.ptp(radius) > 0
    _redraw_rule_holds(world)


def test_humans_slow_down_and_stop_at_their_goals():
    world = generate_crowdnav(np.random.RandomState(0))
    peds = Pedestrians(
        "orca",
        world.moving[:, :2],
        np.zeros((5, 2)),
        world.moving_goal,
        world.moving_pref_speed,
        world.moving[:, 3],
        None,
        world.map_bounds,
        0.3,
        False,
        next_goal=None,  # never called: they keep their goals
        random=np.random.RandomState(0),
        dt=0.1,
        stop_at_goal=True,
    )
    speeds = []
    for _ in range(300):
        peds.advance(1, np.array([50.0, 50.0]), np.zeros(2))
        speeds.append(np.hypot(*peds.velocity.T))
    assert np.max(speeds) <= 1.0 + 1e-6  # at most v_pref
    np.testing.assert_array_equal(peds.goal, world.moving_goal)
    xy = np.column_stack([peds.z.real, peds.z.imag])
    assert np.hypot(*(xy - world.moving_goal).T).max() < 0.05
    assert speeds[-1].max() < 0.05


def _episode(steps=30, **kwargs):
    env = tasks.load("crowdnav", task_kwargs={"random": 7, **kwargs})
    env.reset()
    out = [env.physics.moving_obstacles()[:, :2].copy()]
    for _ in range(steps):
        if env.step(HOLD).last():
            break
        out.append(env.physics.moving_obstacles()[:, :2].copy())
    return env, np.array(out)


def test_the_task_defaults_and_determinism():
    env, humans = _episode()
    task = env.task
    assert task.time_limit == 25.0 and task.goal_tolerance == 0.3 and task.robot_radius == 0.3
    assert task.agent.name == "holonomic" and task.agent.params["v_max"] == 1.0
    assert task.behavior == "orca" and not task.robot_visible
    np.testing.assert_array_equal(humans, _episode()[1])
    assert tasks.load("crowdnav", task_kwargs={"agent": "unicycle"}).task.agent.max_speed == 1.0


def test_a_visible_robot_changes_the_humans_motion_only_when_visible():
    # the robot stands at its start on the humans' circle, where one of them is heading
    _, blind = _episode(60)
    _, seen = _episode(60, robot_visible=True)
    np.testing.assert_array_equal(blind, _episode(60, robot_visible=False)[1])
    n = min(len(blind), len(seen))
    assert not np.array_equal(blind[:n], seen[:n])


def test_static_obstacles_stand_in_the_scene_and_the_humans_walk_around_them():
    pillar = [[0.0, 0.0, 1.0]]  # at the circle's centre, which the humans cross

    def gap(humans):  # the humans' smallest surface gap to the pillar over the episode
        return (np.abs(humans[..., 0] + 1j * humans[..., 1]) - 1.3).min()

    env, humans = _episode(60, obstacles=pillar)
    np.testing.assert_array_equal(env.task.world.static, pillar)
    assert len(env.task.world.walls) == crowdnav.OBSTACLE_SIDES
    assert gap(humans) > 0.0 > gap(_episode(60)[1]) + 0.5


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"scenario": "ring"}, "scenario must be one of circle_crossing, square_crossing"),
        ({"n_humans": -1}, "n_humans must be >= 0"),
        ({"obstacles": [[0.0, -4.0, 0.5]]}, "touches the robot at its start (0, -4)"),
        ({"obstacles": [[0.0, 4.2, 0.5]]}, "touches the robot at its goal (0, 4)"),
        ({"obstacles": [[1.0, 1.0, 0.0]]}, "obstacle 0 has radius 0"),
        ({"obstacles": [[1.0, 1.0, 0.5]], "behavior": "hrvo"}, "hrvo ignores obstacles"),
        ({"circle_radius": 12.0}, "leave the map [-10, 10]^2: lower circle_radius or"),
        ({"robot_radius": 9.5}, "with its radius 9.5 m leave the map"),
        (
            {"circle_radius": 0.35},
            "the robot's goal lies 0.7 m from its start, closer than the start",
        ),
        ({"robot_radius": 1.0, "circle_radius": 1.0}, "raise circle_radius to >= 1.1"),
        ({"case": -1}, "case must be >= 0"),
        ({"behavior": "walk"}, "pedestrian behaviour"),
    ],
)
def test_bad_input_is_one_line_naming_the_problem(kwargs, message):
    with pytest.raises(ValueError, match=None) as error:
        tasks.load("crowdnav", task_kwargs=kwargs)
    assert message in str(error.value) and "\n" not in str(error.value)


@pytest.mark.parametrize("scenario, size", [("circle_crossing", "circle_radius"),
                                            ("square_crossing", "square_width")])  # fmt: skip
def test_a_crowd_that_does_not_fit_says_so(scenario, size):
    env = tasks.load("crowdnav", task_kwargs={"n_humans": 300, "scenario": scenario})
    with pytest.raises(
        ValueError, match=f"humans fit in {scenario} .*: lower n_humans or raise {size}$"
    ):
        env.reset()


def test_orca_moves_the_humans_as_rvo2():
    """One step of navground's ORCA (walkers) against RVO2 (pyrvo) run as CrowdNav runs it: a
    fresh simulator per human, the others' velocities as they are, CrowdNav's parameters."""
    pyrvo = pytest.importorskip("pyrvo")
    random = np.random.RandomState(5)
    world = generate_crowdnav(random, n_humans=6)
    xy, goal = world.moving[:, :2], world.moving_goal
    velocity = random.uniform(-0.7, 0.7, (6, 2))
    peds = Pedestrians(
        "orca", xy, velocity, goal, world.moving_pref_speed, world.moving[:, 3], None,
        world.map_bounds, 0.3, False, None, random, 0.25, stop_at_goal=True,
    )  # fmt: skip
    peds.advance(1, np.zeros(2), np.zeros(2))
    for i in range(6):
        sim = pyrvo.RVOSimulator()
        sim.set_time_step(0.25)
        order = [i] + [j for j in range(6) if j != i]
        for j in order:
            sim.add_agent(tuple(xy[j]), 10.0, 10, 5.0, 5.0, 0.3, 1.0, tuple(velocity[j]))
        to_goal = goal[i] - xy[i]
        distance = np.hypot(*to_goal)
        sim.set_agent_pref_velocity(0, tuple(to_goal / max(distance, 1.0)))
        sim.do_step()
        v = sim.get_agent_velocity(0)
        np.testing.assert_allclose(peds.velocity[i], [v.x, v.y], atol=1e-4)


def test_the_goal_is_reached_within_crowdnavs_0_3_m():
    env = tasks.load("crowdnav", task_kwargs={"n_humans": 0, "random": 0})
    env.reset()
    step = env.step(np.array([0.0, 1.0, 0.0]))
    while not step.last():
        step = env.step(np.array([0.0, 1.0, 0.0]))
    y = env.physics.robot_position()[1]
    assert env.task.outcome == "goal" and 3.7 <= y <= 3.8  # 1 m would have ended near y = 3
    model = env.physics.model
    assert model.geom_size[model.geom("goal").id, 0] == 0.3  # the goal's disc drawn
