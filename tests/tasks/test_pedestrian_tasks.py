"""Pedestrians in the tasks: the corridor, the square and the walking crowd (issue 24)."""

import numpy as np
import pytest

from dcmppi import tasks
from dcmppi.tasks import navigation
from dcmppi.tasks.pedestrians import base as pedestrian_base
from dcmppi.tasks.pedestrians import walkers
from dcmppi.tasks.pedestrians import worlds as pedestrian_worlds
from dcmppi.tasks.worlds import arcs, paper, sampling
from dcmppi.tasks.worlds import base as world_base

GENERATORS = {
    "corridor": pedestrian_worlds.generate_corridor,
    "square": pedestrian_worlds.generate_square,
    "crowd": lambda random: paper.generate_crowd(random, behavior="orca"),
}


def _surface_gaps(moving):
    """Surface gaps (L, L) between the cylinders moving (L, 4), inf on the diagonal."""
    gaps = world_base.clearance(moving[:, :2], moving, 0.0) - moving[:, 3:4]
    np.fill_diagonal(gaps, np.inf)
    return gaps


@pytest.mark.parametrize("name", GENERATORS)
def test_same_seed_same_world_other_seed_other_world(name):
    a, b, c = (GENERATORS[name](np.random.RandomState(seed)) for seed in (3, 3, 4))
    for field in ("start", "goal", "static", "moving", "moving_goal", "moving_pref_speed", "walls"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert not np.array_equal(a.moving, c.moving)


def test_corridor_walls_are_segments_and_rows_of_cylinders_with_their_faces_on_them():
    world = pedestrian_worlds.generate_corridor(np.random.RandomState(0))
    length, width = pedestrian_worlds.CORRIDOR_SIZE
    np.testing.assert_array_equal(world.map_bounds, [0.0, 0.0, length, width])
    walls = world.walls
    assert walls.shape == (2, 4)
    np.testing.assert_array_equal(np.sort(walls[:, [1, 3]], axis=None), [0, 0, width, width])
    assert (
        walls[:, [0, 2]].min()
        < -pedestrian_worlds.CORRIDOR_END
        < length + pedestrian_worlds.CORRIDOR_END
        < walls[:, [0, 2]].max()
    )
    static = world.static
    np.testing.assert_array_equal(static[:, 2], pedestrian_worlds.WALL_RADIUS)
    for face, centre in (
        (0.0, -pedestrian_worlds.WALL_RADIUS),
        (width, width + pedestrian_worlds.WALL_RADIUS),
    ):
        row = static[np.isclose(static[:, 1], centre)]
        x = np.sort(row[:, 0])
        assert len(row) > 200 and np.diff(x).max() <= pedestrian_worlds.WALL_SPACING + 1e-12
        assert (
            x[0] <= -pedestrian_worlds.CORRIDOR_END
            and x[-1] >= length + pedestrian_worlds.CORRIDOR_END
        )
        # the row's inner face never reaches into the corridor
        assert np.abs(row[:, 1] - face).min() == pytest.approx(pedestrian_worlds.WALL_RADIUS)
    assert len(static) == len(pedestrian_worlds.wall_cylinders(walls))


def test_corridor_robot_and_pedestrians_start_where_the_design_says():
    for seed in range(5):
        world = pedestrian_worlds.generate_corridor(np.random.RandomState(seed), n_pedestrians=12)
        width = pedestrian_worlds.CORRIDOR_SIZE[1]
        margin = pedestrian_worlds.PEDESTRIAN_RADIUS + pedestrian_worlds.ROBOT_WALL_CLEARANCE
        assert (
            world.start[0] == pedestrian_worlds.CORRIDOR_START_X
            and world.goal[0] == pedestrian_worlds.CORRIDOR_GOAL_X
        )
        for y in (world.start[1], world.goal[1]):
            assert margin <= y <= width - margin
        heading = np.arctan2(*(world.goal - world.start[:2])[::-1])
        assert world.start[2] == pytest.approx(heading)
        moving, goal = world.moving, world.moving_goal
        # half head-on (toward -x), half the robot's way, each heading for its goal
        head_on = goal[:, 0] < 0
        assert head_on.sum() == 6
        np.testing.assert_array_equal(goal[head_on, 0], -pedestrian_worlds.CORRIDOR_END)
        np.testing.assert_array_equal(goal[~head_on, 0], 20.0 + pedestrian_worlds.CORRIDOR_END)
        assert (np.cos(moving[head_on, 2]) < 0).all() and (np.cos(moving[~head_on, 2]) > 0).all()
        np.testing.assert_allclose(world.moving_speed, world.moving_pref_speed)
        lo, hi = pedestrian_worlds.CORRIDOR_SPEED_RANGE
        assert ((world.moving_pref_speed >= lo) & (world.moving_pref_speed <= hi)).all()
        # inside the corridor, clear of the walls, of each other and of the robot
        r = moving[:, 3]
        assert (moving[:, 1] - r >= sampling.PEDESTRIAN_START_GAP - 1e-12).all()
        assert (width - moving[:, 1] - r >= sampling.PEDESTRIAN_START_GAP - 1e-12).all()
        assert (np.abs(moving[:, 0] - 10.0) <= 10.0 + pedestrian_worlds.CORRIDOR_END).all()
        assert _surface_gaps(moving).min() >= sampling.PEDESTRIAN_START_GAP - 1e-12
        robot = world_base.clearance(world.start[:2], moving, pedestrian_worlds.PEDESTRIAN_RADIUS)
        assert robot.min() >= pedestrian_worlds.PEDESTRIAN_START_CLEARANCE
        assert world.behavior == "social_force" and not world.robot_visible
    np.testing.assert_allclose(
        world.obstacle_model, [1.2, 0.2, 0.0, pedestrian_worlds.PEDESTRIAN_TURN_RATE_STD]
    )


def test_square_start_and_goal_on_opposite_sides_pedestrians_apart():
    sides = set()
    for seed in range(12):
        world = pedestrian_worlds.generate_square(np.random.RandomState(seed))
        start, goal = world.start[:2], world.goal
        edge, size = pedestrian_worlds.SQUARE_EDGE, pedestrian_worlds.SQUARE_SIZE[0]
        axis = int(np.isclose(abs(goal[1] - start[1]), size - 2 * edge))
        assert abs(goal[axis] - start[axis]) == pytest.approx(size - 2 * edge)
        assert edge <= min(*start, *goal) and max(*start, *goal) <= size - edge
        sides.add((axis, bool(goal[axis] > start[axis])))
        moving = world.moving
        assert len(moving) == pedestrian_worlds.SQUARE_PEDESTRIANS
        assert ((moving[:, :2] >= moving[:, 3:]) & (moving[:, :2] <= size - moving[:, 3:])).all()
        assert _surface_gaps(moving).min() >= sampling.PEDESTRIAN_START_GAP - 1e-12
        robot = world_base.clearance(start, moving, pedestrian_worlds.PEDESTRIAN_RADIUS)
        assert robot.min() >= pedestrian_worlds.PEDESTRIAN_START_CLEARANCE
        assert ((world.moving_pref_speed >= 1.0) & (world.moving_pref_speed <= 2.0)).all()
        assert (world.moving_goal >= 0).all() and (world.moving_goal <= size).all()
    assert len(sides) == 4  # every side is a start side for some seed
    assert world.behavior == "orca"


def test_a_walking_crowd_keeps_the_constant_crowds_draws_where_they_do_not_overlap():
    constant = paper.generate_crowd(np.random.RandomState(2))
    walking = paper.generate_crowd(np.random.RandomState(2), behavior="social_force")
    np.testing.assert_array_equal(constant.start, walking.start)
    np.testing.assert_array_equal(constant.moving_speed, walking.moving_speed)
    np.testing.assert_array_equal(walking.moving_pref_speed, walking.moving_speed)
    kept = (constant.moving[:, :2] == walking.moving[:, :2]).all(axis=1)
    assert 0.5 < kept.mean() < 1.0  # some overlapped and were redrawn
    assert _surface_gaps(walking.moving).min() >= sampling.PEDESTRIAN_START_GAP - 1e-12
    assert _surface_gaps(constant.moving).min() < 0  # the Dubins crowd may overlap
    assert np.isnan(constant.moving_goal).all() and np.isnan(constant.moving_pref_speed).all()
    np.testing.assert_array_equal(walking.moving_turn_rate, 0.0)
    np.testing.assert_array_equal(walking.obstacle_model, constant.obstacle_model)


def test_too_many_pedestrians_say_how_many_fit():
    with pytest.raises(ValueError, match=r"only \d+ of 400 pedestrians .*lower n_pedestrians"):
        pedestrian_worlds.generate_corridor(np.random.RandomState(0), n_pedestrians=400)
    env = tasks.load("square", {"n_pedestrians": 150, "random": 0})
    with pytest.raises(ValueError, match=r"only \d+ of 150 pedestrians .*the square"):
        env.reset()


@pytest.mark.parametrize(
    "name, kwargs, message",
    [
        ("corridor", dict(behavior="waltz"), "unknown pedestrian behaviour 'waltz'; valid names"),
        ("corridor", dict(behavior="constant"), "walking behaviours: hl, hrvo, orca, social_force"),
        ("square", dict(behavior="ORCA"), "unknown pedestrian behaviour 'ORCA'"),
        ("crowd", dict(behavior="dance"), "valid names: constant, hl, hrvo, orca, social_force"),
        ("corridor", dict(n_pedestrians=-1), "n_pedestrians must be >= 0"),
        ("corridor", dict(n_pedestrians=2.5), "n_pedestrians must be an integer"),
        ("corridor", dict(pedestrian_radius=0.0), "pedestrian_radius must be > 0"),
        ("square", dict(pedestrian_radius=-0.3), "pedestrian_radius must be > 0"),
        ("corridor", dict(speed_range=(0.0, 2.0)), "speed_range must satisfy 0.0 < low"),
        ("corridor", dict(speed=(-1.0, 0.2)), "speed must be"),
        ("corridor", dict(speed=(1.2, -0.1)), "std >= 0"),
        ("square", dict(speed_range=(-1.0, 1.0)), "speed_range must satisfy 0.0 < low"),
        ("crowd", dict(behavior="orca", speed_range=(0.0, 1.0)), "speed_range"),
        ("corridor", dict(robot_visible="yes"), "robot_visible must be true or false"),
        ("crowd", dict(robot_visible=1), "robot_visible must be true or false"),
    ],
)
def test_bad_pedestrian_kwargs_name_the_problem(name, kwargs, message):
    with pytest.raises(ValueError, match=message):
        tasks.load(name, kwargs)


def test_every_walking_behavior_is_valid_in_the_tasks():
    walking = walkers.WALKING
    assert {"social_force", "orca"} <= set(walking)
    for behavior in walking:
        assert tasks.load("corridor", {"behavior": behavior}).task.behavior == behavior
    # a stopped constant crowd (speeds 0) is fine: only walkers need a speed > 0
    tasks.load("crowd", {"speed_range": (0.0, 0.0)})


def test_task_defaults_robot_and_time_limit():
    corridor = tasks.load("corridor").task
    assert corridor.agent.name == "holonomic" and corridor.agent.max_speed == 1.5
    assert corridor.robot_radius == 0.3 and corridor.behavior == "social_force"
    assert corridor.num_moving == 12 and not corridor.robot_visible
    assert corridor.time_limit == pytest.approx(pedestrian_base.TIME_FACTOR * 20.0 / 1.5)
    square = tasks.load("square").task
    assert square.agent.name == "holonomic" and square.agent.max_speed == 1.0
    assert square.robot_radius == 0.3 and square.behavior == "orca" and square.num_moving == 7
    assert square.time_limit == pytest.approx(pedestrian_base.TIME_FACTOR * 8.0 / 1.0)
    assert tasks.load("square", {"v_max": 2.0}).task.agent.max_speed == 2.0
    assert tasks.load("square", {"agent": "dubins"}).task.agent.max_speed == 1.0
    assert tasks.load("corridor", {"time_limit": 9.0}).task.time_limit == 9.0


def test_corridor_pedestrians_walk_toward_their_goals_and_are_observed_exactly():
    env = tasks.load("corridor", {"random": 1, "robot_visible": True})
    ts = env.reset()
    world = env.task.world
    obs = ts.observation
    heading = np.column_stack([np.cos(world.moving[:, 2]), np.sin(world.moving[:, 2])])
    np.testing.assert_allclose(obs["moving_velocity"], world.moving_speed[:, None] * heading)
    first = obs["moving_obstacles"][:, :2]
    for _ in range(20):  # 2 s, the robot standing still
        ts = env.step([0.0, 0.0, 0.0])
    assert env.task.outcome is None
    obs = ts.observation
    people = env.physics._moving
    arrived = (people.goal != world.moving_goal).any(axis=1)
    assert 0 < arrived.sum() < len(arrived)
    # those that arrived walk again from their start end ...
    start_x, _ = pedestrian_worlds.corridor_ends(world.moving_goal[:, 0] < 0)
    assert (np.abs(obs["moving_obstacles"][arrived, 0] - start_x[arrived]) < 2.0 * 2.0).all()
    # ... the others made their way to their goals at about their preferred speeds
    moved = obs["moving_obstacles"][:, :2] - first
    to_goal = world.moving_goal - first
    along = ((moved * to_goal).sum(axis=1) / np.hypot(*to_goal.T))[~arrived]
    pref_speed = world.moving_pref_speed[~arrived]
    assert (along > 0.5 * 2.0 * pref_speed).all()
    assert (along <= 2.0 * walkers.MAX_SPEED_FACTOR * pref_speed).all()
    np.testing.assert_array_equal(obs["moving_velocity"], people.velocity)
    np.testing.assert_allclose(obs["moving_obstacles"][:, 0], people.z.real)
    heading = np.arctan2(people.velocity[:, 1], people.velocity[:, 0])
    np.testing.assert_allclose(np.cos(obs["moving_obstacles"][:, 2] - heading), 1.0)
    # a noisy tracker sees positions only
    noisy = tasks.load("corridor", {"random": 1, "obstacle_measurement_std": 0.1})
    obs = noisy.reset().observation
    assert np.isnan(obs["moving_velocity"]).all() and np.isnan(obs["moving_obstacles"][:, 2]).all()


def test_corridor_pedestrians_reappear_at_their_start_end():
    env = tasks.load("corridor", {"random": 0})
    env.reset()
    world, random = env.task.world, np.random.RandomState(0)
    lane = pedestrian_worlds.corridor_lane(pedestrian_worlds.PEDESTRIAN_RADIUS)
    for i in range(len(world.moving)):
        head_on = world.moving_goal[i, 0] < 0
        position, goal = env.task.next_goal(random, i, world.moving_goal[i])
        assert position[0] == (21.0 if head_on else -1.0)
        assert goal[0] == (-1.0 if head_on else 21.0)
        assert lane[0] <= position[1] <= lane[1] and lane[0] <= goal[1] <= lane[1]
    # square and crowd: a new goal in the map, walking on from where it is
    env = tasks.load("square", {"random": 0})
    env.reset()
    position, goal = env.task.next_goal(random, 0, np.array([4.0, 4.0]))
    assert position is None and (0.3 <= goal).all() and (goal <= 7.7).all()


def test_robot_visible_changes_how_pedestrians_walk():
    def walk(visible):
        env = tasks.load("square", {"random": 5, "robot_visible": visible, "time_limit": 3.0})
        ts, out = env.reset(), []
        while not ts.last():
            ts = env.step([0.0, 0.0, 0.0])
            out.append(ts.observation["moving_obstacles"][:, :2])
        return np.array(out)

    invisible, visible = walk(False), walk(True)
    assert invisible.shape == visible.shape
    assert not np.allclose(invisible, visible)


def test_touching_a_wall_is_a_collision():
    env = tasks.load("corridor", {"random": 0, "n_pedestrians": 0})
    ts = env.reset()
    while not ts.last():
        ts = env.step([0.0, -1.0, 0.0])  # straight at the wall y = 0
    assert env.task.outcome == "collision"
    contact = env.physics.first_contact
    assert contact["geom"].startswith("static_")
    assert contact["robot_xy"][1] == pytest.approx(env.task.robot_radius, abs=0.02)
    assert env.task.min_clearance <= 0.01


def test_constant_crowd_moves_as_dubins_obstacles():
    env = tasks.load("crowd", {"random": 3, "n_obstacles": 30})
    ts = env.reset()
    world = env.task.world
    assert world.behavior == "constant"
    obstacles = arcs.DubinsObstacles(
        world.moving[:, :3],
        world.moving_speed,
        world.moving_turn_rate,
        world.map_bounds,
        navigation.PHYSICS_TIMESTEP,
    )
    for _ in range(15):
        moving, pose = ts.observation["moving_obstacles"], obstacles.pose()
        np.testing.assert_array_equal(moving[:, :2], pose[:, :2])
        np.testing.assert_allclose(np.cos(moving[:, 2] - pose[:, 2]), 1.0)
        np.testing.assert_allclose(ts.observation["moving_velocity"], obstacles.velocity)
        speed = np.hypot(*ts.observation["moving_velocity"].T)
        np.testing.assert_allclose(speed, world.moving_speed)
        ts = env.step([0.5, 0.0, 0.0])
        obstacles.advance(10)


@pytest.mark.parametrize("behavior", ["social_force", "orca"])
def test_a_walking_crowd_runs_and_stays_deterministic(behavior):
    def episode():
        env = tasks.load(
            "crowd", {"random": 2, "n_obstacles": 20, "behavior": behavior, "time_limit": 2.0}
        )
        ts, out = env.reset(), []
        while not ts.last():
            ts = env.step([0.5, 0.5, 0.0])
            out.append(ts.observation["moving_obstacles"])
        return np.array(out)

    a, b = episode(), episode()
    np.testing.assert_array_equal(a, b)
    assert np.abs(a[-1, :, :2] - a[0, :, :2]).max() > 1.0


def test_a_pedestrian_reappearing_on_the_robot_collides_in_that_step(monkeypatch):
    env = tasks.load("corridor", {"random": 0, "n_pedestrians": 2})
    ts = env.reset()
    people = env.physics._moving
    robot = ts.observation["robot_pose"][:2]
    people.goal[0] = [people.z[0].real, people.z[0].imag]  # arrives now ...
    # ... and reappears touching the robot (the task's own respawns are outside the map)
    monkeypatch.setattr(
        env.task, "next_goal", lambda random, i, position: (robot + [0.4, 0.0], robot)
    )
    env.physics._moving._next_goal = env.task.next_goal
    env.step([0.0, 0.0, 0.0])
    assert env.task.outcome == "collision"
    assert env.physics.first_contact["geom"] == "moving_0"
