"""The social force kernel: its force law, walls, the speed cap, rollout = repeated steps, and
the comparison with navground's SocialForce where the two formulations meet."""

import math

import numpy as np
import pytest

from dcmppi.control.kernels import social

R = 0.3  # pedestrian radius [m]
NONE = (np.zeros((0, 2)), np.zeros(0))  # no pushing agents


def force(pos, vel=None, radius=R, others=NONE, walls=None, **constants):
    """The social force on n agents (n, 2) without the relaxation term (desired = velocity)."""
    pos = np.asarray(pos, dtype=float)
    vel = np.zeros_like(pos) if vel is None else np.asarray(vel, dtype=float)
    n = len(pos)
    _, new_vel = social.step(
        pos, vel, vel, np.full(n, radius), np.full(n, 1e9), 1e-3, *others, walls, **constants
    )
    return (new_vel - vel) / 1e-3


def walk(pos, vel, desired, steps, others_path=None, others_radius=(), walls=None, speed=1.2):
    """Positions (n, steps + 1, 2) of one future (rollout with P = 1)."""
    n = len(pos)
    path = np.zeros((steps + 1, 0, 2)) if others_path is None else others_path
    out = social.rollout(
        np.asarray(pos, dtype=float)[None],
        np.asarray(vel, dtype=float)[None],
        np.asarray(desired, dtype=float)[None],
        np.full(n, R),
        np.full(n, social.MAX_SPEED_FACTOR * speed),
        0.1,
        steps,
        path,
        np.asarray(others_radius, dtype=float),
        walls,
    )
    return out[0]


def test_pair_force_is_the_exponential_of_the_surface_distance_equal_and_opposite():
    f = force([[0.0, 0.0], [0.5, 0.9]])
    d = math.hypot(0.5, 0.9)
    expected = social.A * math.exp((2 * R - d) / social.B) * np.array([-0.5, -0.9]) / d
    np.testing.assert_allclose(f[0], expected, rtol=1e-6)
    np.testing.assert_allclose(f[1], -f[0], rtol=1e-12)


def test_forces_beyond_the_cutoff_are_skipped():
    cut = social.B * math.log(1 / social.FORCE_CUTOFF)  # surface distance
    near = force([[0.0, 0.0], [2 * R + cut - 1e-3, 0.0]])
    np.testing.assert_allclose(-near[0, 0], social.FORCE_CUTOFF * social.A, rtol=1e-2)
    assert not force([[0.0, 0.0], [2 * R + cut + 1e-3, 0.0]]).any()


def test_agents_at_one_point_are_pushed_apart_along_x():
    f = force([[1.0, 1.0], [1.0, 1.0]])
    np.testing.assert_allclose(f, [[social.A * math.exp(2 * R / social.B), 0.0], -f[0]])


def test_wall_pushes_along_the_normal_from_its_nearest_point_and_ends():
    walls = np.array([[0.0, 0.0, 4.0, 0.0]])
    f = np.concatenate([force([p], walls=walls) for p in ([2.0, 0.7], [-0.4, 0.3], [3.0, 0.0])])
    np.testing.assert_allclose(f[0], [0.0, social.A * math.exp((R - 0.7) / social.B)], rtol=1e-12)
    d = math.hypot(0.4, 0.3)  # beyond the end x = 0: pushed away from the end point
    np.testing.assert_allclose(
        f[1], social.A * math.exp((R - d) / social.B) * np.array([-0.8, 0.6])
    )
    assert f[2, 1] > 0 and f[2, 0] == 0  # centred on the wall: its left normal


def test_pushing_agents_push_but_do_not_move():
    robot = (np.array([[1.0, 0.0]]), np.array([0.5]))
    f = force([[0.0, 0.0]], others=robot)
    np.testing.assert_allclose(f, [[-social.A * math.exp((R + 0.5 - 1.0) / social.B), 0.0]])


def test_relaxation_brings_a_lone_agent_to_its_desired_velocity():
    traj = walk([[0.0, 0.0]], [[0.0, 0.0]], [[1.2, 0.5]], 40)
    speed = np.hypot(*np.diff(traj[0, -3:], axis=0).T) / 0.1
    np.testing.assert_allclose(speed, 1.3, rtol=1e-3)
    heading = np.diff(traj[0, -2:], axis=0)[0]
    assert abs(math.atan2(heading[1], heading[0]) - math.atan2(0.5, 1.2)) < 1e-3


def test_speed_is_capped_at_max_speed():
    # Far apart and pulled hard towards their desired velocities, then a pair overlapping.
    pos = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [0.1, 10.0]])
    desired = np.array([[5.0, 0.0], [0.0, -5.0], [0.0, 0.0], [0.0, 0.0]])
    max_speed = np.array([1.0, 1.5, 2.0, 2.5])
    new_pos, new_vel = social.step(
        pos, np.zeros((4, 2)), desired, np.full(4, R), max_speed, 0.5, *NONE, None
    )
    np.testing.assert_allclose(np.hypot(*new_vel.T), max_speed, rtol=1e-12)
    np.testing.assert_allclose(new_pos, pos + 0.5 * new_vel, rtol=1e-15)


def test_passing_pedestrians_are_pushed_apart_and_do_not_overlap():
    # Centres 0.6 m apart laterally: without forces the two would just touch when passing.
    pos = np.array([[0.0, 0.0], [8.0, 0.6]])
    vel = np.array([[1.2, 0.0], [-1.2, 0.0]])
    traj = walk(pos, vel, vel, 80)
    gap = np.hypot(*(traj[0] - traj[1]).T) - 2 * R
    assert gap.min() > 0.1
    assert traj[0, -1, 1] < -0.1 and traj[1, -1, 1] > 0.7  # each deviated to its own side
    assert traj[0, -1, 0] > 8.0 and traj[1, -1, 0] < 0.0  # and they passed


def test_walls_keep_a_pedestrian_inside_a_corridor():
    walls = np.array([[0.0, 0.0, 30.0, 0.0], [0.0, 3.0, 30.0, 3.0]])
    for y, vy in ((0.8, -0.6), (2.2, 0.6)):  # desired velocity 27 deg into a wall
        desired = [[1.2, vy]]
        traj = walk([[1.0, y]], desired, desired, 150, walls=walls)
        assert R < traj[0, :, 1].min() and traj[0, :, 1].max() < 3.0 - R
        assert traj[0, -1, 0] > 15.0  # still walking along


def test_rollout_equals_repeated_steps_bit_for_bit():
    rng = np.random.default_rng(3)
    P, n, steps = 3, 12, 30
    pos = rng.uniform([0.0, 0.5], [12.0, 5.5], (P, n, 2))
    vel = rng.normal(0.0, 1.0, (P, n, 2))
    desired = rng.normal(0.0, 1.2, (P, n, 2))
    radius, max_speed = rng.uniform(0.2, 0.4, n), rng.uniform(1.0, 2.0, n)
    robot = np.stack([np.linspace(0.0, 12.0, steps + 1), np.full(steps + 1, 3.0)], axis=-1)
    others_path = robot[:, None, :]
    walls = np.array([[0.0, 0.0, 12.0, 0.0], [0.0, 6.0, 12.0, 6.0], [6.0, 2.0, 7.0, 3.0]])
    out = social.rollout(
        pos, vel, desired, radius, max_speed, 0.1, steps, others_path, [0.3], walls
    )
    assert out.shape == (P, n, steps + 1, 2)
    for f in range(P):
        p, v = pos[f], vel[f]
        np.testing.assert_array_equal(out[f, :, 0], p)
        for k in range(steps):
            p, v = social.step(
                p, v, desired[f], radius, max_speed, 0.1, others_path[k], [0.3], walls
            )
            np.testing.assert_array_equal(out[f, :, k + 1], p)


def test_bad_input_names_the_problem():
    ok = dict(
        pos=np.zeros((2, 2)),
        vel=np.zeros((2, 2)),
        desired=np.zeros((2, 2)),
        radius=np.full(2, R),
        max_speed=np.ones(2),
        dt=0.1,
        others_pos=np.zeros((0, 2)),
        others_radius=np.zeros(0),
        walls=None,
    )
    cases = [
        (dict(vel=np.zeros((3, 2))), r"pos, vel and desired must share a shape \(n, 2\)"),
        (dict(pos=np.zeros((1, 2, 2))), r"pos, vel and desired must share a shape \(n, 2\)"),
        (dict(radius=np.ones(3)), r"radius must have shape \(2,\)"),
        (dict(others_radius=np.ones(1)), r"others_radius must have shape \(0,\)"),
        (dict(walls=np.zeros((1, 4))), "walls \\[0\\] have zero length"),
        (dict(walls=np.zeros((1, 3))), r"walls must have shape \(W, 4\)"),
        (dict(dt=0.0), "dt must be > 0"),
    ]
    for change, message in cases:
        with pytest.raises(ValueError, match=message):
            social.step(**{**ok, **change})
    with pytest.raises(ValueError, match=r"others_path must have shape \(4, m, 2\)"):
        social.rollout(
            np.zeros((1, 2, 2)), np.zeros((1, 2, 2)), np.zeros((1, 2, 2)), np.full(2, R),
            np.ones(2), 0.1, 3, np.zeros((3, 0, 2)), np.zeros(0), None,
        )  # fmt: skip


# navground's SocialForce (navground.core.behaviors.social_force) is Helbing & Molnar's
# elliptical form: V(b) = v_a exp(-b / v_r) with b the semi-minor axis of the ellipse through
# the agent with foci at the neighbour and at its position step_duration later, a field of view
# (weight c behind), centre distances (radii ignored) and walls U(d) = u_a exp(-d / u_r). With
# the potentials matched to ours (scale B, amplitudes absorbing the radii) the wall force is the
# same; the force of a neighbour at rest is 2.5 x ours (their gradient of b is 2.5 x its true
# value there), and one approaching head-on exerts none (b = 0, gradient set to 0).


def _navground_behavior(neighbors=(), lines=(), **kwargs):
    core = pytest.importorskip("navground.core")
    from navground.core.behaviors.social_force import SocialForceBehavior

    behavior = SocialForceBehavior(
        kinematics=core.kinematics.OmnidirectionalKinematics(10.0), radius=R, phi=math.pi, c=1.0,
        **kwargs,
    )  # fmt: skip
    behavior.position = (0.0, 0.0)
    behavior.environment_state.neighbors = list(neighbors)
    behavior.environment_state.line_obstacles = list(lines)
    return behavior


def test_wall_force_equals_navgrounds_with_the_potential_matched():
    core = pytest.importorskip("navground.core")
    from navground.core.behaviors.social_force import ExponentialPotential

    potential = ExponentialPotential(social.A * social.B * math.exp(R / social.B), social.B)
    for y in (-0.5, -0.8, -1.5):
        wall = core.LineSegment((-5.0, y), (5.0, y))
        theirs = _navground_behavior(lines=[wall], u=potential).segment_repulsion_force(wall)
        ours = force([[0.0, 0.0]], walls=np.array([[-5.0, y, 5.0, y]]))[0]
        np.testing.assert_allclose(ours, theirs, rtol=1e-5, atol=1e-7)


def test_pair_force_against_navgrounds_neighbor_force():
    core = pytest.importorskip("navground.core")
    from navground.core.behaviors.social_force import ExponentialPotential

    potential = ExponentialPotential(social.A * social.B * math.exp(2 * R / social.B), social.B)
    for d in (0.7, 1.0, 2.0):
        at_rest = core.Neighbor((d, 0.0), R, (0.0, 0.0))
        theirs = _navground_behavior([at_rest], v=potential).neighbor_repulsion_force(at_rest)
        ours = force([[0.0, 0.0], [d, 0.0]])[0]
        np.testing.assert_allclose(theirs, 2.5 * ours, rtol=1e-5)
        head_on = core.Neighbor((d, 0.0), R, (-d, 0.0))  # reaches us in step_duration = 1 s
        theirs = _navground_behavior([head_on], v=potential).neighbor_repulsion_force(head_on)
        assert not np.any(theirs) and ours[0] < 0


def test_head_on_pair_deviates_to_opposite_sides_as_in_navground():
    core = pytest.importorskip("navground.core")
    pos = np.array([[0.0, 0.0], [6.0, 0.2]])
    vel = np.array([[1.2, 0.0], [-1.2, 0.0]])
    ours = walk(pos, vel, vel, 80)[:, -1]
    behaviors = [_navground_behavior() for _ in range(2)]
    theirs = pos.copy()
    v = vel.copy()
    for _ in range(80):
        for i, (b, other) in enumerate(zip(behaviors, (1, 0), strict=True)):
            b.position, b.velocity = theirs[i], v[i]
            b.environment_state.neighbors = [core.Neighbor(theirs[other], R, v[other])]
            b.target = core.Target.Velocity(vel[i])
        v = np.array([b.compute_cmd(0.1, core.Frame.absolute, True).velocity for b in behaviors])
        theirs = theirs + 0.1 * v
    for end in (ours, theirs):
        assert end[0, 1] < 0.0 < 0.2 < end[1, 1]  # each to its own side
        assert end[0, 0] > 6.0 and end[1, 0] < 0.0  # and they passed
