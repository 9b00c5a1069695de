"""The paper's worlds as plain numpy: the static forest and the moving crowd (docs/design.md).

`base` holds their contract (`World`, `make_world`), pedestrians.worlds the corridor and the
square, `arcs` how the crowd moves (`DubinsObstacles`).
"""

import numpy as np

from dcmppi.control import defaults

from .base import (
    BEHAVIOR_CONSTANT,
    MAP_SIZE,
    OBSTACLE_SPEED_RANGE,
    OBSTACLE_TURN_RATE_RANGE,
    World,
    crowd_obstacle_model,
    make_world,
    map_bounds,
)
from .sampling import heading_to, place_discs, random_points, sample_start_goal

# Forest (docs/design.md, Experiments). FOREST_CLUSTERS is the one density knob: the number of
# obstacle clusters in the 75 x 50 m map. 65 is chosen so that `mppi` without noise fails
# in about 1-2 % of environments (paper: 1.2 %). Measured with `dcmppi bench` (mppi, no
# noise): 45 -> 1/200 failures, 60 -> 2/300, 70 -> 15/600, 75 -> 6/300.
FOREST_CLUSTERS = 65
FOREST_CYLINDERS_PER_CLUSTER = 4  # at most; each cluster has 1..this many cylinders
FOREST_RADIUS_RANGE = (0.4, 1.6)  # [m] radii of the cylinders
# Crowd (docs/design.md, Experiments): moving cylinders on Dubins arcs, or walkers.
CROWD_SIZE = 100
CROWD_START_CLEARANCE = 3.0  # [m] no moving obstacle surface this close to the start
CROWD_REDRAWS = 1000  # draws of the obstacles near the start before giving up
MOVING_OBSTACLE_RADIUS = 1.0  # [m]


def forest_obstacles(
    random,
    n_clusters=FOREST_CLUSTERS,
    cylinders_per_cluster=FOREST_CYLINDERS_PER_CLUSTER,
    radius_range=FOREST_RADIUS_RANGE,
    bounds=None,
) -> np.ndarray:
    """Clusters of overlapping cylinders of different radii (docs/design.md, Experiments).

    Each cluster has 1..cylinders_per_cluster cylinders: the first at a uniform random centre,
    each next one overlapping a random earlier one of its cluster (centre distance 30-85 % of
    the sum of radii), so clusters form irregular blobs.

    Returns:
      (n_clusters * cylinders_per_cluster, 3) rows x, y, radius; unused rows are zero padding.
    """
    bounds = map_bounds() if bounds is None else np.asarray(bounds, dtype=np.float64)
    n, k = int(n_clusters), int(cylinders_per_cluster)
    count = random.randint(1, k + 1, size=n)
    radius = random.uniform(*radius_range, size=(n, k))
    angle = random.uniform(0.0, 2.0 * np.pi, size=(n, k))
    overlap = random.uniform(0.3, 0.85, size=(n, k))
    parent_u = random.uniform(size=(n, k))
    xy = np.empty((n, k, 2))
    xy[:, 0] = random.uniform(bounds[:2], bounds[2:], size=(n, 2))
    rows = np.arange(n)
    for j in range(1, k):
        parent = (parent_u[:, j] * j).astype(int)
        step = overlap[:, j] * (radius[rows, parent] + radius[:, j])
        xy[:, j] = xy[rows, parent] + step[:, None] * np.stack(
            [np.cos(angle[:, j]), np.sin(angle[:, j])], axis=-1
        )
    cylinders = np.concatenate([xy, radius[..., None]], axis=-1)
    used = np.arange(k) < count[:, None]
    out = np.zeros((n * k, 3))
    out[: used.sum()] = cylinders[used]
    return out


def generate_forest(
    random,
    n_clusters=FOREST_CLUSTERS,
    robot_radius=defaults.ROBOT_RADIUS,
    map_size=MAP_SIZE,
    **forest_kwargs,
) -> World:
    """A static forest world: `forest_obstacles` plus a random start and goal >= 30 m apart."""
    bounds = map_bounds(map_size)
    static = forest_obstacles(random, n_clusters, bounds=bounds, **forest_kwargs)
    start, goal = sample_start_goal(random, static, bounds, robot_radius)
    return make_world(start, goal, static=static, bounds=bounds)


def generate_crowd(
    random,
    n_obstacles=CROWD_SIZE,
    robot_radius=defaults.ROBOT_RADIUS,
    speed_range=OBSTACLE_SPEED_RANGE,
    turn_rate_range=OBSTACLE_TURN_RATE_RANGE,
    obstacle_radius=MOVING_OBSTACLE_RADIUS,
    map_size=MAP_SIZE,
    behavior=BEHAVIOR_CONSTANT,
    robot_visible=False,
) -> World:
    """The dynamic crowd (docs/design.md): uniform positions, headings, speeds and turn rates.

    Obstacles whose surface starts within CROWD_START_CLEARANCE of the start are redrawn (a
    ValueError when some are still near after CROWD_REDRAWS rounds).
    With a pedestrians' `behavior` (not "constant") the same draws follow, then each obstacle
    overlapping an earlier one is redrawn (`place_discs`), and each gets a goal (a uniform point
    of the map) and its drawn speed as its preferred speed, heading for its goal.
    """
    bounds = map_bounds(map_size)
    start, goal = sample_start_goal(random, np.zeros((0, 3)), bounds, robot_radius)
    n = int(n_obstacles)
    xy = _clear_of_start(random, n, start[:2], bounds, obstacle_radius)
    heading = random.uniform(0.0, 2.0 * np.pi, size=n)
    speed = random.uniform(*speed_range, size=n)
    turn_rate = random.uniform(*turn_rate_range, size=n)
    walkers = {}
    if behavior != BEHAVIOR_CONSTANT:
        blocked = [[*start[:2], CROWD_START_CLEARANCE]]
        xy = place_discs(
            random,
            n,
            obstacle_radius,
            bounds[:2],
            bounds[2:],
            blocked,
            initial=xy,
            name="n_obstacles",
        )
        moving_goal = random_points(random, n, bounds, obstacle_radius)
        heading = heading_to(xy, moving_goal)
        turn_rate = np.zeros(n)
        walkers = dict(moving_goal=moving_goal, pref_speed=speed, robot_visible=robot_visible)
    moving = np.column_stack([xy, heading, np.full(n, float(obstacle_radius))])
    return make_world(
        start,
        goal,
        moving=moving,
        speed=speed,
        turn_rate=turn_rate,
        bounds=bounds,
        obstacle_model=crowd_obstacle_model(speed_range, turn_rate_range),
        behavior=behavior,
        **walkers,
    )


def _clear_of_start(random, n, start, bounds, radius) -> np.ndarray:
    """n uniform centres (n, 2) in bounds (4,) whose discs of `radius` keep CROWD_START_CLEARANCE
    from start (2,): the near ones redrawn, at most CROWD_REDRAWS times, else a ValueError."""
    xy = random.uniform(bounds[:2], bounds[2:], size=(n, 2))
    for _ in range(CROWD_REDRAWS):
        near = np.hypot(*(xy - start).T) - radius < CROWD_START_CLEARANCE
        if not near.any():
            return xy
        xy[near] = random.uniform(bounds[:2], bounds[2:], size=(near.sum(), 2))
    raise ValueError(
        f"obstacles of radius {radius:g} m find no place {CROWD_START_CLEARANCE:g} m clear of "
        f"the start on a {bounds[2]:g} x {bounds[3]:g} m map: lower obstacle_radius"
    )
