"""Timing's problems: the forest, the crowd and its motion, and the push of forest+push.

Arrays follow the observation contract: static (M, 3) rows x, y, radius; moving (L, 4) rows x, y,
heading, radius; states (3,) x, y, heading.
"""

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.dynamics import dubins_step

FOREST_CLUSTERS = 60


def forest(seed=0):
    """(M, 3) cylinders: clusters of 2-5 overlapping cylinders of radius 0.3-1.5 m."""
    rng = np.random.default_rng(seed)
    w, h = defaults.MAP_SIZE
    rows = []
    for _ in range(FOREST_CLUSTERS):
        c = rng.uniform([0, 0], [w, h])
        for _ in range(rng.integers(2, 6)):
            rows.append([*(c + rng.normal(0, 1.0, 2)), rng.uniform(0.3, 1.5)])
    cyl = np.array(rows)
    start, goal = np.array([2.0, 25.0]), np.array([73.0, 25.0])
    clear = lambda p: np.hypot(*(cyl[:, :2] - p).T) > cyl[:, 2] + 3.0  # noqa: E731
    return cyl[clear(start) & clear(goal)], np.array([*start, 0.0]), goal


def crowd(seed=0):
    """(100, 4) moving obstacles x, y, heading, radius and their true (speed, turn rate)."""
    rng = np.random.default_rng(seed)
    w, h = defaults.MAP_SIZE
    L = 100
    moving = np.column_stack(
        [
            rng.uniform(0, w, L),
            rng.uniform(0, h, L),
            rng.uniform(0, 2 * np.pi, L),
            np.full(L, defaults.MOVING_OBSTACLE_RADIUS),
        ]
    )
    speed = rng.uniform(*defaults.OBSTACLE_SPEED_RANGE, L)
    turn = rng.uniform(*defaults.OBSTACLE_TURN_RATE_RANGE, L)
    return moving, speed, turn


def obstacle_model():
    """The known Gaussian (v_mean, v_std, omega_mean, omega_std) of the crowd (docs/design.md)."""
    return np.array(
        [
            *defaults.uniform_mean_std(*defaults.OBSTACLE_SPEED_RANGE),
            *defaults.uniform_mean_std(*defaults.OBSTACLE_TURN_RATE_RANGE),
        ]
    )


def move_crowd(moving, speed, turn, dt):
    """One control period of the true obstacle motion, reflecting off the map boundary."""
    nxt = dubins_step(moving[:, :3], turn, speed, dt)
    w, h = defaults.MAP_SIZE
    out_x = (nxt[:, 0] < 0) | (nxt[:, 0] > w)
    out_y = (nxt[:, 1] < 0) | (nxt[:, 1] > h)
    nxt[out_x, 2] = np.pi - nxt[out_x, 2]
    nxt[out_y, 2] = -nxt[out_y, 2]
    nxt[:, 0] = np.clip(nxt[:, 0], 0, w)
    nxt[:, 1] = np.clip(nxt[:, 1], 0, h)
    return np.column_stack([nxt, moving[:, 3]])


PUSH_STD = (0.15, 0.03, 0.01)  # std of the push along [m], across [m] and of the turn [rad]


def push(steps, seed=0):
    """(steps, 3) offsets (along, across, turn) of forest+push, from a seeded generator."""
    return np.random.default_rng(seed).normal(0.0, PUSH_STD, (steps, 3))


def pushed(state, offset):
    """state (3,) moved by offset[0] along its heading, offset[1] to its left, turned offset[2]."""
    c, s = np.cos(state[2]), np.sin(state[2])
    along, across, turn = offset
    return state + np.array([along * c - across * s, along * s + across * c, turn])
