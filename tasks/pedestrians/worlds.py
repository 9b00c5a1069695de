"""The pedestrian worlds as plain numpy: the corridor, the square, and walls.

Pedestrians walk to goals (`walkers`); a world gives their first goals and preferred
speeds. Walls are segments (W, 4) for the pedestrians' forces and rows of static cylinders
(`wall_cylinders`) for the physics and the planners.
"""

import math

import numpy as np

from ..worlds.base import World, make_world, map_bounds, uniform_mean_std
from ..worlds.sampling import PEDESTRIAN_START_GAP, heading_to, place_discs, random_points

# Pedestrian worlds (docs/design.md, Experiments).
PEDESTRIAN_RADIUS = 0.3  # [m]
PEDESTRIAN_START_CLEARANCE = 1.0  # [m] surface gap between any pedestrian and the robot at t = 0
# Std of the turn rate in the pedestrian worlds' obstacle_model, so that the `prior` predictor
# runs: walkers do not turn at random rates (they steer toward goals and away from others). Of
# the order measured from the headings every 0.1 s over 30 s corridor episodes (robot still,
# invisible): social force 0.6 rad/s, ORCA 1.2 rad/s (median 0, heavy tails).
PEDESTRIAN_TURN_RATE_STD = 0.5  # [rad/s]
WALL_RADIUS = 0.15  # [m] radius of the cylinders a wall is made of
WALL_SPACING = 0.1  # [m] largest distance between neighbouring wall cylinders
# Corridor (DRA-MPPI's scene): 20 x 6 m between two walls, pedestrians in both directions.
CORRIDOR_SIZE = (20.0, 6.0)  # [m]
CORRIDOR_PEDESTRIANS = 12
CORRIDOR_SPEED = (1.2, 0.2)  # [m/s] mean, std of the preferred speeds (normal) ...
CORRIDOR_SPEED_RANGE = (0.5, 2.0)  # [m/s] ... clipped to this range
CORRIDOR_START_X, CORRIDOR_GOAL_X = 1.0, 19.0  # [m] the robot's start and goal x
CORRIDOR_END = 1.0  # [m] pedestrians walk between x = -CORRIDOR_END and length + CORRIDOR_END
ROBOT_WALL_CLEARANCE = 0.5  # [m] robot surface to wall at the start and the goal
# Square (C-Uniform's scene): 8 x 8 m, pedestrians crossing between random points.
SQUARE_SIZE = (8.0, 8.0)  # [m]
SQUARE_PEDESTRIANS = 7
SQUARE_SPEED_RANGE = (1.0, 2.0)  # [m/s] preferred speeds, uniform
SQUARE_EDGE = 1.0  # [m] the robot's start and goal lie this far inside opposite sides


def pedestrian_obstacle_model(speed_mean, speed_std) -> np.ndarray:
    """The Gaussian (4,) of a pedestrian world: their preferred speeds' mean and std, and turn
    rates N(0, PEDESTRIAN_TURN_RATE_STD^2)."""
    return np.array([speed_mean, speed_std, 0.0, PEDESTRIAN_TURN_RATE_STD])


def wall_cylinders(walls, radius=WALL_RADIUS, spacing=WALL_SPACING) -> np.ndarray:
    """The static cylinders (K, 3) x, y, radius that make the walls (W, 4) solid.

    Each segment x0, y0 -> x1, y1 has its free side on its left; its cylinders stand in a row
    at most `spacing` apart, their centres `radius` to its right, so the cylinders' faces touch
    the segment (at most radius - sqrt(radius^2 - spacing^2 / 4) behind it between two).
    """
    rows = [np.zeros((0, 3))]
    for x0, y0, x1, y1 in np.asarray(walls, dtype=np.float64).reshape(-1, 4):
        dx, dy = x1 - x0, y1 - y0
        length = math.hypot(dx, dy)
        t = np.linspace(0.0, 1.0, int(math.ceil(length / spacing)) + 1)
        right = np.array([dy, -dx]) / length
        xy = np.column_stack([x0 + t * dx, y0 + t * dy]) + radius * right
        rows.append(np.column_stack([xy, np.full(len(t), radius)]))
    return np.concatenate(rows)


def corridor_walls(size=CORRIDOR_SIZE) -> np.ndarray:
    """The corridor's two walls (2, 4) along y = 0 and y = width, free side inside.

    They reach CORRIDOR_END + 1 m past the map's ends: past where pedestrians appear and go.
    """
    length, width = size
    x0, x1 = -CORRIDOR_END - 1.0, length + CORRIDOR_END + 1.0
    return np.array([[x0, 0.0, x1, 0.0], [x1, width, x0, width]])


def corridor_ends(head_on, size=CORRIDOR_SIZE):
    """Where pedestrians appear and where they walk to: x (L,), (L,) for head_on (L,) bool.

    Both ends lie CORRIDOR_END outside the map, so a pedestrian never appears on the robot
    (the robot leaving the map ends its episode).
    """
    west, east = -CORRIDOR_END, size[0] + CORRIDOR_END
    head_on = np.asarray(head_on, bool)
    return np.where(head_on, east, west), np.where(head_on, west, east)


def corridor_lane(radius, size=CORRIDOR_SIZE):
    """The y range (2,) of a pedestrian centre PEDESTRIAN_START_GAP clear of both walls."""
    return np.array([radius + PEDESTRIAN_START_GAP, size[1] - radius - PEDESTRIAN_START_GAP])


def generate_corridor(
    random,
    n_pedestrians=CORRIDOR_PEDESTRIANS,
    robot_radius=PEDESTRIAN_RADIUS,
    speed=CORRIDOR_SPEED,
    speed_range=CORRIDOR_SPEED_RANGE,
    radius=PEDESTRIAN_RADIUS,
    behavior="social_force",
    robot_visible=False,
    size=CORRIDOR_SIZE,
) -> World:
    """The corridor (DRA-MPPI's scene): walls at y = 0 and y = width, pedestrians in
    both directions.

    The robot starts at x = CORRIDOR_START_X, its goal is at x = CORRIDOR_GOAL_X, both at a
    uniform y whose robot disc clears the walls by ROBOT_WALL_CLEARANCE. The first
    n - n // 2 pedestrians walk head-on (toward -x), the others the robot's way; at t = 0
    they stand anywhere along their way (x between the `corridor_ends`, a uniform y of
    `corridor_lane`), none within PEDESTRIAN_START_CLEARANCE of the robot, each walking at
    its preferred speed (normal `speed` (mean, std) clipped to `speed_range`) to a goal at the
    far end at a uniform y of the lane.

    Raises:
      ValueError: the pedestrians do not fit (`place_discs`).
    """
    length, width = size
    margin = robot_radius + ROBOT_WALL_CLEARANCE
    y_start, y_goal = random.uniform(margin, width - margin, size=2)
    heading = math.atan2(y_goal - y_start, CORRIDOR_GOAL_X - CORRIDOR_START_X)
    start = np.array([CORRIDOR_START_X, y_start, heading])
    n = int(n_pedestrians)
    head_on = np.arange(n) < n - n // 2
    _, goal_x = corridor_ends(head_on, size)
    lane = corridor_lane(radius, size)
    low, high = [-CORRIDOR_END, lane[0]], [length + CORRIDOR_END, lane[1]]
    xy = _place_pedestrians(random, n, radius, start, robot_radius, low, high, "the corridor")
    goals = np.column_stack([goal_x, random.uniform(*lane, size=n)])
    speeds = np.clip(random.normal(*speed, size=n), *speed_range)
    goal, bounds, walls = [CORRIDOR_GOAL_X, y_goal], map_bounds(size), corridor_walls(size)
    return _pedestrian_world(
        start, goal, bounds, xy, radius, goals, speeds, speed, behavior, robot_visible, walls
    )


def generate_square(
    random,
    n_pedestrians=SQUARE_PEDESTRIANS,
    robot_radius=PEDESTRIAN_RADIUS,
    speed_range=SQUARE_SPEED_RANGE,
    radius=PEDESTRIAN_RADIUS,
    behavior="orca",
    robot_visible=False,
    size=SQUARE_SIZE,
) -> World:
    """The square (C-Uniform's scene): pedestrians crossing between random points.

    The robot starts SQUARE_EDGE inside a random side of the map, at a uniform point along
    it, facing its goal, which lies SQUARE_EDGE inside the opposite side. Pedestrians stand
    at uniform points of the map (centres inside it), none within PEDESTRIAN_START_CLEARANCE
    of the robot, each walking at its preferred speed (uniform in `speed_range`) to a uniform
    point of the map.

    Raises:
      ValueError: the pedestrians do not fit (`place_discs`).
    """
    bounds = map_bounds(size)
    start, goal = _opposite_sides(random, bounds, SQUARE_EDGE)
    n = int(n_pedestrians)
    low, high = bounds[:2] + radius, bounds[2:] - radius
    xy = _place_pedestrians(random, n, radius, start, robot_radius, low, high, "the square")
    goals = random_points(random, n, bounds, radius)
    speeds = random.uniform(*speed_range, size=n)
    speed = uniform_mean_std(*speed_range)
    return _pedestrian_world(
        start, goal, bounds, xy, radius, goals, speeds, speed, behavior, robot_visible
    )


def _place_pedestrians(random, n, radius, start, robot_radius, low, high, where) -> np.ndarray:
    """Centres (n, 2) of n pedestrians of `radius` in the box low..high (2,), none within
    PEDESTRIAN_START_CLEARANCE of the robot of `robot_radius` at its start pose (3,)."""
    robot = [[*start[:2], robot_radius + PEDESTRIAN_START_CLEARANCE]]
    return place_discs(random, n, radius, low, high, robot, where=where)


def _pedestrian_world(
    start, goal, bounds, xy, radius, goals, speeds, speed, behavior, robot_visible, walls=None
) -> World:
    """The `World` of pedestrians at xy (n, 2) of `radius`, each heading for its first goal
    goals (n, 2) at its preferred speed speeds (n,), whose population has (mean, std) `speed`,
    walking with `behavior`; the robot's start (3,) and goal (2,), the map's bounds (4,) and
    the walls (W, 4), none by default."""
    walls = np.zeros((0, 4)) if walls is None else walls
    moving = np.column_stack([xy, heading_to(xy, goals), np.full(len(xy), float(radius))])
    return make_world(
        start,
        goal,
        static=wall_cylinders(walls),
        moving=moving,
        speed=speeds,
        bounds=bounds,
        obstacle_model=pedestrian_obstacle_model(*speed),
        behavior=behavior,
        moving_goal=goals,
        pref_speed=speeds,
        walls=walls,
        robot_visible=robot_visible,
    )


def _opposite_sides(random, bounds, edge):
    """Start pose (3,) `edge` inside a random side of the map, facing the goal (2,), `edge`
    inside the opposite side; both at uniform points along their sides."""
    xmin, ymin, xmax, ymax = bounds
    side = random.randint(4)  # 0: west -> east, 1: south -> north, 2, 3: the reverse
    u = random.uniform(size=2)
    if side % 2 == 0:
        points = np.column_stack(
            [[xmin + edge, xmax - edge], ymin + edge + u * (ymax - ymin - 2 * edge)]
        )
    else:
        points = np.column_stack(
            [xmin + edge + u * (xmax - xmin - 2 * edge), [ymin + edge, ymax - edge]]
        )
    start, goal = points[::-1] if side >= 2 else points
    yaw = math.atan2(goal[1] - start[1], goal[0] - start[0])
    return np.array([start[0], start[1], yaw]), goal
