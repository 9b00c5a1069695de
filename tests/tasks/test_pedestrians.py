"""Pedestrians: walking to goals, next goals and respawns, walls, the robot seen or not, avoiding
each other, determinism, the speed cap, the substeps, bad input; every behaviour."""

import numpy as np
import pytest

from dcmppi.control.kernels import social
from dcmppi.tasks.pedestrians import walkers
from dcmppi.tasks.pedestrians.walkers import MAX_SPEED_FACTOR, Pedestrians

pytest.importorskip("navground.core")

R = 0.3  # pedestrian radius [m]
DT = 0.1
WALKING = walkers.WALKING
AVOIDING = ("orca", "hrvo", "hl")  # navground's: no overlaps
CORRIDOR = np.array([[-5.0, 0.0, 25.0, 0.0], [-5.0, 3.0, 25.0, 3.0]])


def make(behavior, position, velocity, goal, pref_speed, walls=None, visible=False, **kwargs):
    position = np.asarray(position, dtype=float)
    n = len(position)
    arguments = dict(
        behavior=behavior,
        position=position,
        velocity=velocity,
        goal=goal,
        pref_speed=np.broadcast_to(pref_speed, (n,)),
        radius=np.full(n, R),
        walls=walls,
        bounds=np.array([-5.0, -5.0, 25.0, 5.0]),
        robot_radius=0.3,
        robot_visible=visible,
        next_goal=lambda random, i, xy: (None, random.uniform(-4.0, 4.0, 2)),
        random=np.random.RandomState(0),
        dt=DT,
    )
    return Pedestrians(**{**arguments, **kwargs})


def walk(peds, steps, robot_xy=(50.0, 50.0), robot_velocity=(0.0, 0.0), n=1):
    """Centres (steps * n, L) complex."""
    robot_xy, robot_velocity = np.array(robot_xy), np.array(robot_velocity)
    return np.concatenate([peds.advance(n, robot_xy, robot_velocity) for _ in range(steps)])


def min_gap(z):
    """The smallest surface gap (m) between any two pedestrians over centres z (T, L)."""
    d = np.abs(z[:, :, None] - z[:, None, :])
    d[:, np.arange(z.shape[1]), np.arange(z.shape[1])] = np.inf
    return d.min() - 2 * R


@pytest.mark.parametrize("behavior", WALKING)
def test_lone_pedestrian_walks_to_its_goal_then_to_the_next_or_respawns(behavior):
    calls = []

    def next_goal(random, i, xy):
        calls.append((i, xy))
        # first a new goal from where it stands, then a respawn at the start
        return (
            (None, np.array([4.0, 4.0])) if len(calls) == 1 else (np.zeros(2), np.array([4.0, 0.0]))
        )

    peds = make(behavior, [[0.0, 0.0]], [[1.2, 0.0]], [[4.0, 0.0]], 1.2, next_goal=next_goal)
    z = walk(peds, 25)
    np.testing.assert_allclose(np.abs(np.diff(z[:, 0])) / DT, 1.2, rtol=1e-4)
    np.testing.assert_allclose(z[:, 0].imag, 0.0, atol=1e-6)
    z = np.concatenate([z, walk(peds, 15)])
    assert len(calls) == 1 and calls[0][0] == 0
    assert 4.0 - R <= calls[0][1][0] < 4.0 and abs(calls[0][1][1]) < 1e-6  # at its goal
    assert peds.goal.tolist() == [[4.0, 4.0]] and peds.z[0].imag > 0.3  # heading to the next
    z = walk(peds, 50)
    assert len(calls) == 2 and abs(calls[1][1] - [4.0, 4.0]).max() <= R
    respawn = np.flatnonzero(np.abs(np.diff(z[:, 0])) > 1.0)
    assert len(respawn) == 1  # it jumped back to the start once
    assert abs(z[respawn[0] + 1, 0]) < 0.2  # and walks on from there


@pytest.mark.parametrize("behavior", ("social_force", "orca", "hl"))
def test_walls_keep_a_pedestrian_inside_a_corridor(behavior):
    # The goal lies beyond the wall y = 0: the pedestrian slides along it.
    peds = make(behavior, [[0.0, 1.5]], [[1.0, 0.0]], [[20.0, -1.0]], 1.2, walls=CORRIDOR)
    z = walk(peds, 150)
    assert z.imag.min() > R - 0.01
    assert z[-1, 0].real > 15.0


def test_hrvo_refuses_walls():
    with pytest.raises(
        ValueError,
        match="hrvo ignores walls: in a world with walls use one of hl, orca, social_force",
    ):
        make("hrvo", [[0.0, 1.5]], [[1.0, 0.0]], [[20.0, 1.5]], 1.2, walls=CORRIDOR)


@pytest.mark.parametrize("behavior", WALKING)
def test_visible_robot_in_the_way_makes_pedestrians_deviate(behavior):
    robot = dict(robot_xy=(4.0, 0.1), robot_velocity=(0.0, 0.0))
    paths = {}
    for visible in (False, True):
        peds = make(behavior, [[0.0, 0.0]], [[1.2, 0.0]], [[10.0, 0.0]], 1.2, visible=visible)
        paths[visible] = walk(peds, 80, **robot)[:, 0]
    assert not np.any(paths[False].imag)  # straight through the robot
    assert np.abs(paths[False] - (4.0 + 0.1j)).min() < 2 * R
    assert np.abs(paths[True].imag).max() > 0.2  # around it
    assert paths[True][-1].real > 6.0


@pytest.mark.parametrize("behavior", AVOIDING)
def test_navground_pedestrians_avoid_each_other(behavior):
    # Four pedestrians crossing at the origin, and a head-on pair.
    angles = np.arange(4) * np.pi / 2 + 0.05
    unit = np.column_stack([np.cos(angles), np.sin(angles)])
    position = np.concatenate([-3.0 * unit, [[-10.0, -3.0], [-4.0, -2.9]]])
    goal = np.concatenate([4.0 * unit, [[0.0, -3.0], [-14.0, -2.9]]])
    velocity = 1.2 * (goal - position) / np.hypot(*(goal - position).T)[:, None]
    arrived = set()

    def next_goal(random, i, xy):
        arrived.add(i)
        return None, xy  # stay

    peds = make(behavior, position, velocity, goal, 1.2, next_goal=next_goal)
    z = walk(peds, 100)
    assert min_gap(z) > -0.02
    assert arrived == set(range(6))  # they got past each other


def test_social_force_pushes_passing_pedestrians_apart():
    # Centres 0.6 m apart laterally: without forces the two would touch when passing.
    position = [[0.0, 0.0], [8.0, 0.6]]
    goal = [[12.0, 0.0], [-4.0, 0.6]]
    peds = make("social_force", position, [[1.2, 0.0], [-1.2, 0.0]], goal, 1.2)
    z = walk(peds, 80)
    assert min_gap(z) > 0.1
    assert z[-1, 0].real > 8.0 and z[-1, 1].real < 0.0


def crowd(behavior, seed, visible=True):
    """12 pedestrians in a 6 x 3 m corridor with conflicting goals, respawning at random."""
    random = np.random.RandomState(seed)
    position = np.column_stack([np.repeat([0.5, 2.0, 3.5, 5.0], 3), np.tile([0.6, 1.5, 2.4], 4)])
    goal = position[::-1] + random.uniform(-0.2, 0.2, (12, 2))
    pref = random.uniform(0.8, 1.6, 12)
    walls = None if behavior == "hrvo" else CORRIDOR

    def next_goal(random, i, xy):
        return random.uniform([0.5, 0.5], [5.5, 2.5]), random.uniform([0.5, 0.5], [5.5, 2.5])

    return make(
        behavior, position, np.zeros((12, 2)), goal, pref, walls=walls, visible=visible,
        next_goal=next_goal, random=np.random.RandomState(seed),
    )  # fmt: skip


def crowd_walk(peds, steps=60):
    robot = [np.array([3.0 + 0.01 * k, 1.5]) for k in range(steps)]
    out = [peds.advance(4, xy, np.array([0.1, 0.0])) for xy in robot]
    return np.concatenate(out)


@pytest.mark.parametrize("behavior", WALKING)
def test_same_inputs_give_identical_pedestrians(behavior):
    runs = []
    for _ in range(2):
        peds = crowd(behavior, seed=4)
        runs.append((crowd_walk(peds), peds.velocity, peds.theta, peds.goal))
    for a, b in zip(*runs, strict=True):
        np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("behavior", WALKING)
def test_speeds_stay_within_the_cap(behavior):
    peds = crowd(behavior, seed=1)
    cap = MAX_SPEED_FACTOR * peds.pref_speed * (1 + 1e-6)
    for _ in range(60):
        peds.advance(1, np.array([3.0, 1.5]), np.zeros(2))
        assert (np.hypot(*peds.velocity.T) <= cap).all()


def test_substeps_interpolate_one_control_period_linearly():
    peds = crowd("social_force", seed=2)
    z0 = peds.z.copy()
    z = peds.advance(5, np.array([3.0, 1.5]), np.zeros(2))
    assert z.shape == (5, 12) and z.dtype == np.complex128
    np.testing.assert_array_equal(z[-1], peds.z)
    np.testing.assert_allclose(z, z0 + np.arange(1, 6)[:, None] / 5 * (peds.z - z0), atol=1e-14)
    velocity = peds.velocity[:, 0] + 1j * peds.velocity[:, 1]
    np.testing.assert_allclose((peds.z - z0) / DT, velocity, atol=1e-12)
    np.testing.assert_allclose(peds.theta, np.angle(velocity), atol=1e-12)


def test_a_nan_velocity_names_the_pedestrian(monkeypatch):
    peds = crowd("social_force", seed=0)

    step = social.step

    def bad_step(*args, **kwargs):
        pos, vel = step(*args, **kwargs)
        vel[7] = np.nan
        return pos, vel

    monkeypatch.setattr(social, "step", bad_step)
    with pytest.raises(ValueError, match=r"pedestrian 7 \(social_force\) got the non-finite"):
        peds.advance(1, np.zeros(2), np.zeros(2))


def test_bad_input_names_the_problem():
    ok = dict(
        position=[[0.0, 0.0], [1.0, 1.0]],
        velocity=np.zeros((2, 2)),
        goal=[[5.0, 0.0], [5.0, 1.0]],
        pref_speed=1.2,
    )
    cases = [
        (dict(behavior="walk"), "unknown pedestrian behaviour 'walk'; valid names: .*social_force"),
        (dict(behavior="constant"), "behavior 'constant' moves with arcs.DubinsObstacles"),
        (dict(radius=[0.3, 0.0]), "radius must be > 0; pedestrian 1 has 0.0"),
        (dict(pref_speed=[np.nan, 1.0]), "pref_speed must be > 0; pedestrian 0 has nan"),
        (dict(goal=np.zeros((3, 2))), r"goal must have shape \(2, 2\); got \(3, 2\)"),
        (dict(walls=[[1.0, 1.0, 1.0, 1.0]]), r"walls \[0\] have zero length"),
    ]
    for change, message in cases:
        behavior = change.pop("behavior", "social_force")
        with pytest.raises(ValueError, match=message):
            make(behavior, **{**ok, **change})
    peds = make("orca", **ok, visible=True)
    with pytest.raises(ValueError, match="robot_xy must be finite"):
        peds.advance(1, np.array([np.nan, 0.0]), np.zeros(2))
