"""Timing's problems: the tasks' forest, crowd and pedestrian worlds, and the push of
forest+push.

The worlds are the tasks' own, drawn by their generators (dcmppi.tasks.worlds.paper, plain
numpy) from `np.random.RandomState(SEED)`: the same arrays a task observes (static (M, 3) rows
x, y, radius, radius-0 rows padding; moving (L, 4) rows x, y, heading, radius; the map's bounds
(4,)), and the crowd moves as the crowd task's obstacles do (tasks.worlds.arcs.DubinsObstacles).
The pedestrian problems (PEDESTRIANS) are a task's world with its pedestrians
(tasks.pedestrians.walkers.Pedestrians) built as the task's physics builds them, walking to the
goals the task's next_goal gives.
"""

import numpy as np

from dcmppi.tasks.pedestrians import walkers as task_pedestrians
from dcmppi.tasks.pedestrians.corridor import Corridor
from dcmppi.tasks.pedestrians.crowd import Crowd
from dcmppi.tasks.worlds import arcs as task_arcs
from dcmppi.tasks.worlds import paper as task_worlds

SEED = 0
GENERATORS = {"forest": task_worlds.generate_forest, "crowd": task_worlds.generate_crowd}


def world(family, seed=SEED, **counts):
    """The tasks' World (dcmppi.tasks.worlds.base.World) of a problem family ("forest", "crowd");
    `counts` go to its generator (forest: n_clusters, map_size; crowd: n_obstacles)."""
    return GENERATORS[family](np.random.RandomState(seed), **counts)


def dense_forest(clusters, seed=SEED):
    """The forest task's world with `clusters` clusters of cylinders (generate_forest's
    n_clusters), at the forest's density or below: above the task's FOREST_CLUSTERS both sides
    of the map grow by sqrt(clusters / FOREST_CLUSTERS) (the task's map would leave no room for
    a start and a goal), so the cost map grows with them."""
    grow = max(1.0, (clusters / task_worlds.FOREST_CLUSTERS) ** 0.5)
    size = tuple(grow * side for side in task_worlds.MAP_SIZE)
    return world("forest", seed, n_clusters=clusters, map_size=size)


# The pedestrian problems' tasks (default parameters): the corridor (12 social-force
# pedestrians between walls, static cylinder rows in `static`), the crowd of 100 walkers and
# one of 20.
PEDESTRIANS = {
    "corridor": Corridor,
    "crowd-sf": lambda: Crowd(behavior="social_force"),
    "crowd-sf-20": lambda: Crowd(behavior="social_force", n_obstacles=20),
}


def pedestrian_task(problem, seed=SEED):
    """The task of a pedestrian problem (a key of PEDESTRIANS) with its world drawn as the task
    draws an episode's (`task.world`), and that RandomState, which the task hands on to its
    pedestrians' next_goal."""
    task = PEDESTRIANS[problem]()
    random = np.random.RandomState(seed)
    task.world = task.generate_world(random)
    return task, random


def walking_crowd(task, random, dt):
    """The pedestrians of `task.world` as the task's physics builds them (Physics.set_world):
    tasks.pedestrians.walkers.Pedestrians stepping once per control period dt [s], walls and the
    box of the map and the walls as bounds, task.next_goal on arrival. Advance it with
    advance(1, robot_xy, robot_velocity); observe it with `observed` and its `velocity`."""
    w = task.world
    heading = np.column_stack([np.cos(w.moving[:, 2]), np.sin(w.moving[:, 2])])
    corners = np.concatenate([w.map_bounds.reshape(2, 2), w.walls.reshape(-1, 2)])
    return task_pedestrians.Pedestrians(
        w.behavior,
        w.moving[:, :2],
        w.moving_speed[:, None] * heading,
        w.moving_goal,
        w.moving_pref_speed,
        w.moving[:, 3],
        w.walls,
        [*corners.min(axis=0), *corners.max(axis=0)],
        task.robot_radius,
        w.robot_visible,
        task.next_goal,
        random,
        dt,
    )


def forest(seed=SEED):
    """The forest world's static (M, 3), start (3,) and goal (2,)."""
    w = world("forest", seed)
    return w.static, np.array(w.start), w.goal


def moving_crowd(w, dt):
    """The crowd of World w as the task moves it: DubinsObstacles, one exact arc per control
    period dt [s], reflecting off the map's walls. Observe it with `observed`."""
    return task_arcs.DubinsObstacles(
        w.moving[:, :3], w.moving_speed, w.moving_turn_rate, w.map_bounds, dt
    )


def observed(crowd, radius):
    """(L, 4) x, y, heading, radius of a crowd (DubinsObstacles or Pedestrians) now, as the task
    observes them."""
    return np.column_stack([crowd.z.real, crowd.z.imag, crowd.theta, radius])


PUSH_STD = (0.15, 0.03, 0.01)  # std of the push along [m], across [m] and of the turn [rad]


def push(steps, seed=0):
    """(steps, 3) offsets (along, across, turn) of forest+push, from a seeded generator."""
    return np.random.default_rng(seed).normal(0.0, PUSH_STD, (steps, 3))


def pushed(state, offset):
    """state (3,) moved by offset[0] along its heading, offset[1] to its left, turned offset[2]."""
    c, s = np.cos(state[2]), np.sin(state[2])
    along, across, turn = offset
    return state + np.array([along * c - across * s, along * s + across * c, turn])
