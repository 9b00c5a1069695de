"""Random starts, goals and discs of the world generators (plain numpy, `random` a RandomState).

Each function's draws are part of the worlds' identity: the same `random` gives the same world.
"""

import numpy as np

from .base import clearance

MIN_START_GOAL_DISTANCE = 30.0  # [m]
START_GOAL_CLEARANCE = 1.0  # [m] free space around the robot at start and goal
BORDER = 2.0  # [m] start and goal keep this far from the map edge
PEDESTRIAN_START_GAP = 0.2  # [m] surface gap between pedestrians, and to a wall, at t = 0


def sample_free_points(
    random,
    count,
    static,
    bounds,
    robot_radius,
    margin=START_GOAL_CLEARANCE,
    border=BORDER,
    batch=256,
    tries=200,
):
    """Draws points (count, 2) uniform in the map whose robot disc clears `static` by `margin`."""
    xmin, ymin, xmax, ymax = bounds
    solid = static[static[:, 2] > 0]
    for _ in range(tries):
        xy = random.uniform(
            [xmin + border, ymin + border], [xmax - border, ymax - border], size=(batch, 2)
        )
        if len(solid):
            xy = xy[clearance(xy, solid, robot_radius).min(axis=-1) >= margin]
        if len(xy) >= count:
            return xy[:count]
    raise RuntimeError(
        "no collision-free start/goal found: the map is too crowded; lower the "
        "obstacle density (e.g. the forest's n_clusters)"
    )


def sample_start_goal(
    random, static, bounds, robot_radius, min_distance=MIN_START_GOAL_DISTANCE, **kwargs
):
    """Random collision-free start pose (3,) facing the goal, and goal (2,) >= min_distance away."""
    start = sample_free_points(random, 1, static, bounds, robot_radius, **kwargs)[0]
    for _ in range(100):
        goals = sample_free_points(random, 64, static, bounds, robot_radius, **kwargs)
        far = goals[np.hypot(*(goals - start).T) >= min_distance]
        if len(far):
            goal = far[0]
            yaw = np.arctan2(goal[1] - start[1], goal[0] - start[0])
            return np.array([start[0], start[1], yaw]), goal
    raise RuntimeError(f"no goal {min_distance} m from the start: the map is too small")


def random_points(random, count, bounds, border=0.0) -> np.ndarray:
    """Points (count, 2) uniform in the map `bounds` (4,) shrunk by `border` on every side."""
    bounds = np.asarray(bounds, dtype=np.float64)
    return random.uniform(bounds[:2] + border, bounds[2:] - border, size=(count, 2))


def heading_to(xy, target) -> np.ndarray:
    """Headings (L,) from points xy (L, 2) toward target (L, 2)."""
    return np.arctan2(target[:, 1] - xy[:, 1], target[:, 0] - xy[:, 0])


def place_discs(
    random,
    count,
    radius,
    low,
    high,
    blocked=None,
    gap=PEDESTRIAN_START_GAP,
    initial=None,
    name="n_pedestrians",
    where="the map",
    batch=64,
    tries=50,
) -> np.ndarray:
    """Centres (count, 2) of discs of `radius`, uniform in the box low..high (2,), clear of the
    discs `blocked` (K, 3) x, y, radius and `gap` from each other (surface to surface).

    Discs are placed one after another, each at the first of up to tries x batch draws that is
    clear; with `initial` (count, 2), disc i stays at initial[i] when that is clear.

    Raises:
      ValueError: disc i found no room: it says that i fit and names the parameter `name`.
    """
    placed = np.zeros((count, 3))
    placed[:, 2] = radius + gap  # a placed disc inflated by the gap
    blocked = np.zeros((0, 3)) if blocked is None else np.asarray(blocked, np.float64)
    for i in range(count):
        discs = np.concatenate([blocked, placed[:i]])

        def clear(xy, discs=discs):
            if not len(discs):
                return np.ones(len(xy), bool)
            return clearance(xy, discs, radius).min(axis=-1) >= 0.0

        if initial is not None and clear(initial[i : i + 1])[0]:
            placed[i, :2] = initial[i]
            continue
        for _ in range(tries):
            xy = random.uniform(low, high, size=(batch, 2))
            ok = clear(xy)
            if ok.any():
                placed[i, :2] = xy[np.argmax(ok)]
                break
        else:
            raise ValueError(
                f"only {i} of {count} pedestrians of radius {radius:g} m fit in {where} "
                f"({gap:g} m apart, clear of the robot): lower {name}"
            )
    return placed[:, :2].copy()
