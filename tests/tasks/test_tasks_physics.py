"""The MuJoCo plant: collisions, clearance, robot dynamics, moving obstacles, world generators."""

import mujoco
import numpy as np
import pytest
from fused_cabs import needs_fused_cabs

from dcmppi import tasks
from dcmppi.control import defaults
from dcmppi.tasks import navigation, physics
from dcmppi.tasks.worlds import arcs, paper, sampling
from dcmppi.tasks.worlds import base as world_base


def drive(env, omega=0.0, steps=10_000):
    """Resets, applies a constant turn rate until the episode ends; returns the steps taken."""
    ts = env.reset()
    for i in range(steps):
        ts = env.step([omega])
        if ts.last():
            return i + 1
    return steps


@pytest.mark.parametrize("robot_radius", [0.5, 0.3])
def test_collision_at_the_analytic_distance(robot_radius):
    env = tasks.load("blocked", {"robot_radius": robot_radius, "obstacle_radius": 1.5})
    drive(env)
    assert env.task.outcome == "collision"
    ts_discount = env.task.get_termination(env.physics)
    assert ts_discount == 0.0
    contact = env.physics.first_contact
    obstacle = env.task.world.static[0]
    centre_distance = np.hypot(*(contact["robot_xy"] - obstacle[:2]))
    touching = robot_radius + obstacle[2]
    # Contacts are checked every 10 ms substep: the first one is at most v * 10 ms deep.
    assert touching - defaults.V * navigation.PHYSICS_TIMESTEP - 1e-6 <= centre_distance < touching
    assert contact["geom"] == "static_0"
    assert env.task.min_clearance < 0


def test_crossing_obstacle_meets_the_straight_driving_robot():
    env = tasks.load("crossing", {"distance": 20.0, "obstacle_speed": 1.0})
    drive(env)
    assert env.task.outcome == "collision"
    assert env.physics.first_contact["geom"] == "moving_0"
    # Head-on at closing speed 2 m/s: contact when the centres are 1.5 m apart, 0.75 s early.
    t_meet = 10.0
    assert env.physics.first_contact["time"] == pytest.approx(t_meet - 0.75, abs=0.02)


def test_crossing_from_the_side_also_meets():
    env = tasks.load("crossing", {"approach_angle": np.pi / 2, "obstacle_turn_rate": 0.2})
    drive(env)
    assert env.task.outcome == "collision"
    assert env.physics.first_contact["time"] == pytest.approx(10.0, abs=1.2)


def test_free_space_never_collides_and_clearance_is_analytic():
    env = tasks.load("blocked", {"time_limit": 40.0})
    ts = env.reset()
    obstacle = ts.observation["static_obstacles"][0]
    lowest = np.inf
    while not ts.last():
        ts = env.step([1.0])  # circle of radius 1 m around a point 1 m left of the start
        x, y, _ = ts.observation["robot_pose"]
        expected = np.hypot(x - obstacle[0], y - obstacle[1]) - obstacle[2] - 0.5
        np.testing.assert_allclose(ts.observation["clearance"], [expected], atol=1e-9)
        lowest = min(lowest, expected)
    assert env.task.outcome == "time_limit"
    assert not env.physics.collided
    assert env.physics.first_contact is None
    assert 0 < env.task.min_clearance <= lowest + 1e-9


def _numpy_clearances(robot, solid, solid_r, moving, moving_r, radius):
    """The numpy expressions `physics._clearances` computes (its docstring)."""
    clearance, static_last, moving_last = None, np.zeros(0), np.zeros(0)
    if len(solid):
        each = np.abs(robot[:, None] - solid) - solid_r
        clearance, static_last = each.min(axis=1), each[-1] - radius
    if moving.size:
        each = np.abs(moving - robot[:, None])
        each -= moving_r
        nearest, moving_last = each.min(axis=1), each[-1] - radius
        clearance = nearest if clearance is None else np.minimum(clearance, nearest)
    if clearance is None:
        return np.full(len(robot), np.inf), static_last, moving_last
    return clearance - radius, static_last, moving_last


@needs_fused_cabs
def test_clearance_kernel_gives_numpys_values():
    rng = np.random.default_rng(3)
    special = [np.nan, np.inf, -np.inf, 0.0, -0.0, 1e-310, 1e300]
    for trial in range(400):
        n, m, l = rng.integers(1, 12), rng.integers(0, 300), rng.integers(0, 40)
        if m == l == 0:
            m = 1
        scale = 10.0 ** rng.integers(-2, 3)
        robot, solid, moving = (
            (rng.normal(size=shape) + 1j * rng.normal(size=shape)) * scale
            for shape in (n, m, (n, l))
        )
        solid_r, moving_r = rng.random(m) * scale, rng.random(l) * scale
        if trial % 5 == 0 and m:  # nan propagates as numpy's min and minimum do
            solid[rng.integers(m)] = complex(rng.choice(special), rng.choice(special))
        if trial % 6 == 0 and l:
            moving[rng.integers(n), rng.integers(l)] = complex(rng.choice(special), 0.0)
        if trial % 7 == 0 and m:  # a centre on a cylinder's axis
            solid[rng.integers(m)] = robot[-1]
        if trial % 4 == 0 and l:
            moving[-1, rng.integers(l)] = robot[-1]
        moving = moving if l else physics._NO_MOVING
        got = physics._clearances(robot, solid, solid_r, moving, moving_r, 0.3)
        want = _numpy_clearances(robot, solid, solid_r, moving, moving_r, 0.3)
        for g, w in zip(got, want, strict=True):  # a nan's sign is numpy's choice of nan
            assert (
                np.where(np.isnan(g), np.nan, g).tobytes()
                == np.where(np.isnan(w), np.nan, w).tobytes()
            ), (trial, g, w)


def test_clearance_kernel_refuses_shapes_that_do_not_match():
    robot, none = np.array([0j, 1j]), physics._NO_SOLID
    with pytest.raises(ValueError, match="do not match"):  # numpy would broadcast one row
        physics._clearances(robot, none, np.zeros(0), np.array([[5 + 0j]]), np.ones(1), 0.3)
    with pytest.raises(ValueError, match="do not match"):
        physics._clearances(
            robot, np.array([3 + 0j]), np.zeros(2), physics._NO_MOVING, none.real, 0.3
        )
    with pytest.raises(ValueError, match="do not match"):
        physics._clearances(robot, none, np.zeros(0), np.ones((2, 3), complex), np.ones(2), 0.3)


def test_forest_episodes_start_collision_free():
    env = tasks.load("forest", {"random": 3})
    for _ in range(5):
        obs = env.reset().observation
        assert obs["clearance"][0] >= sampling.START_GOAL_CLEARANCE
        ts = env.step([0.0])
        assert not env.physics.collided or ts.last()


def test_robot_tracks_turn_rate_with_lag_and_holds_speed():
    env = tasks.load("blocked", {"time_limit": 20.0})
    env.reset()
    env.step([0.8])
    rate_after_one_step = env.physics.robot_velocity()[2]
    assert 0.6 < rate_after_one_step < 0.8  # first-order lag, 50 ms time constant
    for _ in range(20):
        env.step([0.8])
    vx, vy, rate = env.physics.robot_velocity()
    yaw = env.physics.robot_pose()[2]
    assert rate == pytest.approx(0.8, abs=1e-3)
    assert np.hypot(vx, vy) == pytest.approx(defaults.V, abs=0.02)
    lateral = -np.sin(yaw) * vx + np.cos(yaw) * vy
    assert abs(lateral) < 0.05


def test_full_turn_traces_a_circle_of_radius_r_min():
    env = tasks.load("blocked", {"time_limit": 20.0})
    env.reset()
    xy = []
    for _ in range(80):
        ts = env.step([defaults.omega_max()])
        xy.append(ts.observation["robot_pose"][:2])
    x, y = np.array(xy[15:]).T  # after the actuator transient, more than one revolution
    a, b, c = np.linalg.lstsq(np.column_stack([x, y, np.ones_like(x)]), x**2 + y**2, rcond=None)[0]
    radius = np.sqrt(c + a**2 / 4 + b**2 / 4)
    assert radius == pytest.approx(defaults.R_MIN, abs=0.01)
    np.testing.assert_allclose(np.hypot(x - a / 2, y - b / 2), radius, atol=0.01)


def test_process_disturbance_offsets_the_velocity():
    env = tasks.load("blocked", {"time_limit": 20.0})
    env.reset()
    env.physics.set_disturbance(np.array([0.0, 0.3, 0.0]))
    for _ in range(3):
        env.physics.set_command([defaults.V, 0.0, 0.0])
        env.physics.step(10)
    vx, vy, _ = env.physics.robot_velocity()
    assert vx == pytest.approx(defaults.V, abs=1e-2)  # start faces +x
    assert vy == pytest.approx(0.3, abs=1e-2)


def test_moving_obstacles_follow_dubins_arcs_and_stay_in_the_map():
    env = tasks.load("crowd", {"random": 5, "n_obstacles": 40, "agent": "dubins"})
    ts = env.reset()
    world = env.task.world
    xmin, ymin, xmax, ymax = world.map_bounds
    inside_all_along = np.ones(40, bool)
    for step in range(1, 81):
        ts = env.step([1.0])
        moving = ts.observation["moving_obstacles"]
        assert (moving[:, 0] >= xmin).all() and (moving[:, 0] <= xmax).all()
        assert (moving[:, 1] >= ymin).all() and (moving[:, 1] <= ymax).all()
        t = step * defaults.DT
        arc = arcs.dubins_pose(world.moving[:, :3], world.moving_speed, world.moving_turn_rate, t)
        inside = (arc[:, 0] > xmin) & (arc[:, 0] < xmax) & (arc[:, 1] > ymin) & (arc[:, 1] < ymax)
        inside_all_along &= inside
        ok = inside_all_along
        np.testing.assert_allclose(moving[ok, :2], arc[ok, :2], atol=1e-9)
        np.testing.assert_allclose(
            np.cos(moving[ok, 2] - arc[ok, 2]), 1.0, atol=1e-9
        )  # same heading
        if ts.last():
            break
    assert inside_all_along.sum() > 20
    assert (~inside_all_along).any(), "no obstacle reached the wall; pick another seed"


def test_obstacles_move_every_substep():
    env = tasks.load("crossing", {"time_limit": 5.0})
    env.reset()
    mocap_x = []
    physics = env.physics
    for _ in range(10):
        physics.step(1)
        mocap_x.append(physics.data.mocap_pos[0, 0])
    steps = np.diff(mocap_x)
    np.testing.assert_allclose(steps, -1.0 * navigation.PHYSICS_TIMESTEP, atol=1e-9)


def test_dubins_obstacle_reflects_off_a_wall():
    bounds = np.array([0.0, 0.0, 10.0, 10.0])
    pose = np.array([[0.05, 5.0, np.pi], [5.0, 9.97, np.pi / 2]])
    obstacles = arcs.DubinsObstacles(pose, [1.0, 1.0], [0.0, 0.0], bounds, 0.01)
    z = obstacles.advance(10)
    np.testing.assert_allclose(z[-1].real[0], 0.05, atol=1e-9)  # 0.05 m out, 0.05 m back
    np.testing.assert_allclose(obstacles.theta[0], 0.0, atol=1e-9)  # now heading +x
    np.testing.assert_allclose(z[-1].imag[1], 9.93, atol=1e-9)
    np.testing.assert_allclose(obstacles.theta[1], -np.pi / 2, atol=1e-9)
    # Speed is kept: every substep moves 1 cm.
    path = np.abs(np.diff(np.concatenate([[pose[0, 0] + 1j * pose[0, 1]], z[:, 0]])))
    np.testing.assert_allclose(path, 0.01, atol=1e-9)


def test_forest_generator_makes_overlapping_clusters_and_far_apart_start_goal():
    random = np.random.RandomState(0)
    world = paper.generate_forest(random, n_clusters=30)
    static = world.static
    assert static.shape == (30 * paper.FOREST_CYLINDERS_PER_CLUSTER, 3)
    solid = static[static[:, 2] > 0]
    assert 30 <= len(solid) < len(static)
    assert (static[len(solid) :] == 0).all()  # padding at the end
    lo, hi = paper.FOREST_RADIUS_RANGE
    assert (solid[:, 2] >= lo).all() and (solid[:, 2] <= hi).all()
    assert len(np.unique(solid[:, 2])) == len(solid)  # different radii
    distance = np.hypot(*(world.goal - world.start[:2]))
    assert distance >= sampling.MIN_START_GOAL_DISTANCE
    for point in (world.start[:2], world.goal):
        margin = world_base.clearance(point, solid, defaults.ROBOT_RADIUS).min()
        assert margin >= sampling.START_GOAL_CLEARANCE
    # Every cylinder after the first of its cluster overlaps another cylinder.
    gaps = world_base.clearance(solid[:, :2], solid, 0.0) - solid[:, 2:3]
    np.fill_diagonal(gaps, np.inf)
    assert (gaps.min(axis=1) < 0).mean() > 0.5
    # Start faces the goal.
    heading = np.arctan2(*(world.goal - world.start[:2])[::-1])
    assert world.start[2] == pytest.approx(heading)


def test_forest_density_is_n_clusters():
    few = paper.forest_obstacles(np.random.RandomState(0), n_clusters=10)
    many = paper.forest_obstacles(np.random.RandomState(0), n_clusters=60)
    assert (few[:, 2] > 0).sum() < (many[:, 2] > 0).sum()


def test_crowd_generator_follows_the_spec():
    world = paper.generate_crowd(np.random.RandomState(1))
    moving = world.moving
    assert moving.shape == (100, 4)
    xmin, ymin, xmax, ymax = world.map_bounds
    assert ((moving[:, 0] >= xmin) & (moving[:, 0] <= xmax)).all()
    assert ((moving[:, 1] >= ymin) & (moving[:, 1] <= ymax)).all()
    surface = np.hypot(*(moving[:, :2] - world.start[:2]).T) - moving[:, 3]
    assert surface.min() >= paper.CROWD_START_CLEARANCE
    lo, hi = world_base.OBSTACLE_SPEED_RANGE
    assert (world.moving_speed >= lo).all() and (world.moving_speed <= hi).all()
    lo, hi = world_base.OBSTACLE_TURN_RATE_RANGE
    assert (world.moving_turn_rate >= lo).all() and (world.moving_turn_rate <= hi).all()
    assert np.hypot(*(world.goal - world.start[:2])) >= sampling.MIN_START_GOAL_DISTANCE


def test_blocked_obstacle_sits_on_the_start_goal_line():
    env = tasks.load("blocked", {"lateral_jitter": 0.0})
    obs = env.reset().observation
    start, goal, obstacle = obs["robot_pose"], obs["goal"], obs["static_obstacles"][0]
    np.testing.assert_allclose(obstacle[:2], 0.5 * (start[:2] + goal))
    jittered = tasks.load("blocked", {"lateral_jitter": 1.0, "random": 4})
    shifted = jittered.reset().observation["static_obstacles"][0]
    assert 0 < abs(shifted[1] - obstacle[1]) <= 1.0


# Constant commands per agent, held for 1 s from rest or, for the car, from its speed.
PLANT_CASES = {
    "dubins": [[0.0], [1.0], [-0.6]],
    "unicycle": [[1.0, 0.0], [0.5, 1.0], [0.8, -0.5], [0.0, 1.0]],
    "holonomic": [[1.5, 0.0, 0.0], [0.6, -1.2, 0.5], [-1.0, 1.0, -1.0], [0.0, 0.0, 1.0]],
}
TAU_PLANAR, TAU_YAW = 0.02, 0.05  # [s] the actuators' time constants (models/robots/*.xml)


@pytest.mark.parametrize("agent", sorted(PLANT_CASES))
def test_agent_model_matches_its_mujoco_plant_over_one_second(agent):
    """The analytic model has no actuator lag; after T = 1 s of a constant command the plant's
    pose differs from it by the lags' once-only losses: at most speed x tau_planar (+ one 10 ms
    substep) of position, omega x tau_yaw of heading, and the position that the heading lag
    turns away, speed x T x omega x tau_yaw."""
    env = tasks.load("blocked", {"agent": agent, "time_limit": 5.0})
    model = env.task.agent
    report, failures = [], []
    for u in PLANT_CASES[agent]:
        ts = env.reset()
        predicted = ts.observation["robot_pose"].copy()
        for _ in range(10):
            ts = env.step(u)
            predicted = model.step(predicted, np.array(u, dtype=float), defaults.DT)
        actual = ts.observation["robot_pose"]
        position = np.hypot(*(actual[:2] - predicted[:2]))
        heading = abs((actual[2] - predicted[2] + np.pi) % (2 * np.pi) - np.pi)
        speed = (
            model.v if agent == "dubins" else np.hypot(*u[:-1]) if agent == "holonomic" else u[0]
        )
        omega = abs(u[-1])
        bound_position = speed * (TAU_PLANAR + navigation.PHYSICS_TIMESTEP + omega * TAU_YAW)
        bound_heading = omega * TAU_YAW + 1e-3
        report.append(f"u={u}: {position:.4f} m (<= {bound_position:.3f}), {heading:.4f} rad")
        if position > bound_position + 1e-3 or heading > bound_heading:
            failures.append(u)
    message = f"{agent} plant vs analytic model after 1 s: " + "; ".join(report)
    assert not failures, message
    print(message)


def test_a_step_of_no_substeps_raises_and_keeps_the_clearances():
    env = tasks.load("forest", task_kwargs={"random": 0})
    env.reset()
    before = env.physics._static_clearance.copy()
    with pytest.raises(IndexError):
        env.physics.step(0)
    np.testing.assert_array_equal(env.physics._static_clearance, before)


def test_named_indexers_are_built_when_first_read():
    from dm_control import mujoco as dm_mujoco

    env = tasks.load("forest", task_kwargs={"random": 0})
    env.reset()
    physics = env.physics
    assert physics._named is None  # an episode never builds them
    np.testing.assert_array_equal(physics.named.data.qpos, physics.data.qpos)
    slot = physics.model.name2id("static_0", "geom")
    np.testing.assert_array_equal(
        physics.named.model.geom_pos["static_0"], physics.model.geom_pos[slot]
    )
    copied = physics.copy()  # dm_control's copy goes through the override too
    np.testing.assert_array_equal(copied.named.data.qpos, physics.data.qpos)
    # dm_control's own construction sets nothing that ours does not (guards a dm_control update)
    plain = dm_mujoco.Physics.from_model(physics.model)
    assert set(vars(plain)) <= set(vars(physics))


def test_an_invalid_physics_state_raises_dm_control_s_physics_error():
    """Physics.step checks MuJoCo's warnings as dm_control's check_invalid_state does (it reads
    dm_control's private warning counters: this test guards a dm_control update)."""
    from dm_control.rl.control import PhysicsError

    env = tasks.load("blocked")
    env.reset()
    env.physics.step(10)  # a valid step raises nothing
    env.physics.data.qvel[0] = np.nan  # MuJoCo warns (a bad state) and resets it
    with pytest.raises(PhysicsError, match="Physics state is invalid. Warning.s. raised: mjWARN"):
        env.physics.step(10)
    env.physics.data.qvel[0] = np.nan
    with env.physics.suppress_physics_errors():  # dm_control's switch: a log line instead
        env.physics.step(10)


def _episode(task, params, omega):
    """A constant turn rate to the end: the poses, the first contact and, per step, whether
    MuJoCo's collision detection was off and whether any obstacle could be touched."""
    env = tasks.load(task, params)
    ts, rows = env.reset(), []
    m = env.physics.model
    while not ts.last():
        ts = env.step([omega])
        off = bool(m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT)
        rows.append((ts.observation["robot_pose"].tobytes(), off, bool(m.geom_conaffinity.any())))
    contact = env.physics.first_contact
    return rows, contact and {**contact, "robot_xy": contact["robot_xy"].tobytes()}


@pytest.mark.parametrize(
    "task, params",
    [("blocked", {}), ("crossing", {"distance": 20.0, "obstacle_speed": 1.0})],
)
def test_collision_detection_is_off_only_with_nothing_near(task, params, monkeypatch):
    """A step with no obstacle in reach runs without MuJoCo's collision detection; the episode
    is that of detection always on, to the bit, its first contact too."""
    rows, contact = _episode(task, params, 0.0)
    monkeypatch.setattr(physics, "_NO_CONTACT", 0)
    always, always_contact = _episode(task, params, 0.0)
    assert contact is not None and contact == always_contact
    assert [r[0] for r in rows] == [r[0] for r in always]
    assert [(off, near) for _, off, near in rows].count((True, False)) > 10
    assert all(off != near for _, off, near in rows)  # off exactly when nothing is near
    assert not any(off for _, off, _ in always)


def test_a_user_s_disable_flags_survive_resets_and_the_contact_switch():
    """Switching collision detection off where nothing is near touches only its own bit: flags
    a user sets on the model stay through resets and steps, contacts off included."""
    bits = mujoco.mjtDisableBit
    env = tasks.load("blocked")
    m = env.physics.model
    m.opt.disableflags |= bits.mjDSBL_WARMSTART
    offs = set()
    for _ in range(2):
        env.reset()
        for _ in range(20):
            env.step([0.0])
            assert m.opt.disableflags & bits.mjDSBL_WARMSTART
            offs.add(bool(m.opt.disableflags & bits.mjDSBL_CONTACT))
    assert offs == {True}  # nothing near in the first steps: the switch was used
    env = tasks.load("blocked")
    m = env.physics.model
    m.opt.disableflags |= bits.mjDSBL_CONTACT  # the user's own: contacts off for good
    ts = env.reset()
    while not ts.last():
        ts = env.step([0.0])
        assert m.opt.disableflags & bits.mjDSBL_CONTACT
    assert env.physics.first_contact is None  # it drove through the blocking obstacle


@pytest.mark.parametrize("robot_radius", [0.3, 0.5, 1.0])
def test_drawn_geoms_follow_the_radii_and_stay_in_sight(robot_radius):
    """The robot's drawn geoms scale with its radius in the plane and keep their heights: the
    heading marker stays on top of the hull (a 0.3 m robot's is not buried in it). Each moving
    obstacle's heading bar spans 0.1 to 0.9 of its own radius."""
    env = tasks.load("corridor", {"robot_radius": robot_radius, "random": 0})
    env.reset()
    m = env.physics.model
    hull, marker = m.geom("robot/hull").id, m.geom("robot/heading").id
    assert m.geom_pos[marker, 2] > m.geom_size[hull, 1]  # its centre above the hull's top
    np.testing.assert_allclose(m.geom_pos[marker, 0] + m.geom_size[marker, 0], robot_radius)
    for g in range(m.ngeom):
        if m.geom(g).name.startswith("robot/wheel"):
            assert m.geom_pos[g, 2] == -0.1  # the robot file's height, whatever the radius
    bars = env.physics._heading_ids
    radius = env.physics.moving_obstacles()[:, 3]
    assert radius.min() > 0
    np.testing.assert_allclose(m.geom_pos[bars, 0] - m.geom_size[bars, 0], 0.1 * radius)
    np.testing.assert_allclose(m.geom_pos[bars, 0] + m.geom_size[bars, 0], 0.9 * radius)
