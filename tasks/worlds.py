"""The worlds of the benchmark as plain numpy: generators, Dubins obstacle motion, clearance.

Nothing here builds physics, so benchmarks and plots can regenerate the exact worlds a task
drew (same `random` -> same world). Arrays follow the observation contract:
static (M, 3) rows x, y, radius (radius 0 = padding); moving (L, 4) rows x, y, heading, radius.
Walls are segments (W, 4) x0, y0, x1, y1 for the pedestrians' forces and, for the physics and
the planners, rows of overlapping static cylinders (`wall_cylinders`).
"""

import dataclasses
import math

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.dynamics import wrap_angle

# Maps (docs/design.md, Experiments).
MAP_SIZE = (75.0, 50.0)  # [m], x in [0, 75], y in [0, 50]
MIN_START_GOAL_DISTANCE = 30.0  # [m]
TIME_LIMIT_FACTOR = 3.0  # time limit = 3 x map perimeter / v (paper)

# Forest (docs/design.md, Experiments). FOREST_CLUSTERS is the one density knob: the number of
# obstacle clusters in the 75 x 50 m map. 65 is chosen so that `mppi` without noise fails
# in about 1-2 % of environments (paper: 1.2 %). Measured with `dcmppi bench` (mppi, no
# noise): 45 -> 1/200 failures, 60 -> 2/300, 70 -> 15/600, 75 -> 6/300.
FOREST_CLUSTERS = 65
FOREST_CYLINDERS_PER_CLUSTER = 4  # at most; each cluster has 1..this many cylinders
FOREST_RADIUS_RANGE = (0.4, 1.6)  # [m] radii of the cylinders
START_GOAL_CLEARANCE = 1.0  # [m] free space around the robot at start and goal
MAX_COORDINATE = 1e6  # [m] |coordinate| and radius bound (the planners refuse states beyond it)
BORDER = 2.0  # [m] start and goal keep this far from the map edge
CROWD_SIZE = 100
CROWD_START_CLEARANCE = 3.0  # [m] no moving obstacle surface this close to the start
# The crowd's uniform ranges; controllers are told the Gaussian with the same mean and std.
OBSTACLE_SPEED_RANGE = (0.5, 1.5)  # [m/s]
OBSTACLE_TURN_RATE_RANGE = (-0.5, 0.5)  # [rad/s]
MOVING_OBSTACLE_RADIUS = 1.0  # [m]

# Pedestrian worlds (issue 24; docs/design.md, Experiments).
BEHAVIOR_CONSTANT = "constant"  # the Dubins arcs above (worlds.DubinsObstacles)
PEDESTRIAN_RADIUS = 0.3  # [m]
PEDESTRIAN_START_GAP = 0.2  # [m] surface gap between pedestrians, and to a wall, at t = 0
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


@dataclasses.dataclass(frozen=True)
class World:
    """One episode's world.

    Attributes:
      start: (3,) robot start pose x, y, yaw.
      goal: (2,) goal x, y.
      static: (M, 3) static cylinders x, y, radius; radius-0 rows are padding (walls included,
        as `wall_cylinders`).
      moving: (L, 4) moving cylinders at t = 0: x, y, heading, radius.
      moving_speed: (L,) true speeds [m/s] at t = 0 (hidden from controllers): the velocity
        is speed x (cos, sin) of the heading.
      moving_turn_rate: (L,) true turn rates [rad/s] (hidden; 0 for pedestrians).
      map_bounds: (4,) xmin, ymin, xmax, ymax.
      obstacle_model: (4,) known Gaussian v_mean, v_std, omega_mean, omega_std.
      behavior: how the moving cylinders move: "constant" (Dubins arcs, `DubinsObstacles`) or
        a pedestrians' behaviour of tasks.pedestrians.BEHAVIORS.
      moving_goal: (L, 2) the pedestrians' first goals (hidden; nan for "constant").
      moving_pref_speed: (L,) the pedestrians' preferred speeds [m/s] (hidden; nan for
        "constant").
      walls: (W, 4) wall segments x0, y0, x1, y1 that the pedestrians see; they walk within
        the box of map_bounds and the walls.
      robot_visible: whether the pedestrians react to the robot.
    """

    start: np.ndarray
    goal: np.ndarray
    static: np.ndarray
    moving: np.ndarray
    moving_speed: np.ndarray
    moving_turn_rate: np.ndarray
    map_bounds: np.ndarray
    obstacle_model: np.ndarray
    moving_goal: np.ndarray
    moving_pref_speed: np.ndarray
    walls: np.ndarray
    behavior: str = BEHAVIOR_CONSTANT
    robot_visible: bool = False


def map_bounds(map_size=MAP_SIZE) -> np.ndarray:
    """Bounds (4,) of a map [0, w] x [0, h]."""
    return np.array([0.0, 0.0, float(map_size[0]), float(map_size[1])])


def default_time_limit(bounds, v=defaults.V) -> float:
    """TIME_LIMIT_FACTOR x the time to drive around the map's perimeter at speed v [s]."""
    xmin, ymin, xmax, ymax = bounds
    return TIME_LIMIT_FACTOR * 2.0 * ((xmax - xmin) + (ymax - ymin)) / v


def uniform_mean_std(lo: float, hi: float) -> tuple[float, float]:
    """Mean and standard deviation of U(lo, hi)."""
    return 0.5 * (lo + hi), (hi - lo) / math.sqrt(12.0)


def crowd_obstacle_model(
    speed_range=OBSTACLE_SPEED_RANGE, turn_rate_range=OBSTACLE_TURN_RATE_RANGE
) -> np.ndarray:
    """The Gaussian (4,) v_mean, v_std, omega_mean, omega_std matching the crowd's uniforms."""
    return np.array([*uniform_mean_std(*speed_range), *uniform_mean_std(*turn_rate_range)])


def make_world(
    start,
    goal,
    static=None,
    moving=None,
    speed=None,
    turn_rate=None,
    bounds=None,
    obstacle_model=None,
    behavior=BEHAVIOR_CONSTANT,
    moving_goal=None,
    pref_speed=None,
    walls=None,
    robot_visible=False,
) -> World:
    """A `World` from loose arrays; static gets one padding row when empty."""
    static = np.zeros((1, 3)) if static is None or len(static) == 0 else static
    moving = np.zeros((0, 4)) if moving is None else moving
    length = len(moving)
    arrays = dict(
        start=start,
        goal=goal,
        static=static,
        moving=moving,
        moving_speed=np.zeros(length) if speed is None else speed,
        moving_turn_rate=np.zeros(length) if turn_rate is None else turn_rate,
        map_bounds=map_bounds() if bounds is None else bounds,
        obstacle_model=crowd_obstacle_model() if obstacle_model is None else obstacle_model,
        moving_goal=np.full((length, 2), np.nan) if moving_goal is None else moving_goal,
        moving_pref_speed=np.full(length, np.nan) if pref_speed is None else pref_speed,
        walls=np.zeros((0, 4)) if walls is None else walls,
    )
    for name, value in arrays.items():
        value = np.array(value, dtype=np.float64)
        value.flags.writeable = False
        arrays[name] = value
    return World(**arrays, behavior=str(behavior), robot_visible=bool(robot_visible))


def impossible(world: World, robot_radius: float) -> tuple[str, int | None] | None:
    """Why `world` would score its controller unfairly, or None: a start or goal outside the
    map, a robot that touches a static or moving cylinder at its start, a goal inside a static
    cylinder (no controller could avoid the failure).

    Returns:
      (the reason, one line; the row of world.static involved, None if none).
    """
    start, goal, bounds = world.start[:2], world.goal, world.map_bounds
    for name, point in (("start", start), ("goal", goal)):
        if not ((bounds[:2] <= point).all() and (point <= bounds[2:]).all()):
            return f"the {name} {_xy(point)} is outside the map {_xy(bounds)}", None
    rows = np.flatnonzero(world.static[:, 2] > 0)
    solid = world.static[rows]
    if len(solid):
        gap = clearance(start, solid, robot_radius)
        if gap.min() <= 0:
            i = int(np.argmin(gap))
            return (
                f"the robot (radius {robot_radius:g} m) at its start {_xy(start)} touches the "
                f"cylinder {_xy(solid[i])}",
                int(rows[i]),
            )
        inside = clearance(goal, solid, 0.0)
        if inside.min() < 0:
            i = int(np.argmin(inside))
            return f"the goal {_xy(goal)} is inside the cylinder {_xy(solid[i])}", int(rows[i])
    if len(world.moving):
        gap = clearance(start, world.moving, robot_radius)
        if gap.min() <= 0:
            i = int(np.argmin(gap))
            return (
                f"the robot (radius {robot_radius:g} m) at its start {_xy(start)} touches moving "
                f"obstacle {i} at {_xy(world.moving[i, :2])}",
                None,
            )
    return None


def _xy(values) -> str:
    return "(" + ", ".join(f"{float(v):g}" for v in values) + ")"


def pedestrian_obstacle_model(speed_mean, speed_std) -> np.ndarray:
    """The Gaussian (4,) of a pedestrian world: their preferred speeds' mean and std, and turn
    rates N(0, PEDESTRIAN_TURN_RATE_STD^2)."""
    return np.array([speed_mean, speed_std, 0.0, PEDESTRIAN_TURN_RATE_STD])


def clearance(xy, obstacles, robot_radius) -> np.ndarray:
    """Surface distances (..., K) from robot centres xy (..., 2) to cylinders (K, >=3).

    Columns 0, 1 of `obstacles` are the centre and its last column the radius.
    """
    xy = np.asarray(xy, dtype=np.float64)
    d = np.hypot(xy[..., 0, None] - obstacles[:, 0], xy[..., 1, None] - obstacles[:, 1])
    return d - obstacles[:, -1] - robot_radius


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

    Obstacles whose surface starts within CROWD_START_CLEARANCE of the start are redrawn.
    With a pedestrians' `behavior` (not "constant") the same draws follow, then each obstacle
    overlapping an earlier one is redrawn (`place_discs`), and each gets a goal (a uniform point
    of the map) and its drawn speed as its preferred speed, heading for its goal.
    """
    bounds = map_bounds(map_size)
    start, goal = sample_start_goal(random, np.zeros((0, 3)), bounds, robot_radius)
    n = int(n_obstacles)
    xy = random.uniform(bounds[:2], bounds[2:], size=(n, 2))
    while True:
        near = np.hypot(*(xy - start[:2]).T) - obstacle_radius < CROWD_START_CLEARANCE
        if not near.any():
            break
        xy[near] = random.uniform(bounds[:2], bounds[2:], size=(near.sum(), 2))
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
    """The corridor (issue 24, DRA-MPPI's scene): walls at y = 0 and y = width, pedestrians in
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
    bounds = map_bounds(size)
    margin = robot_radius + ROBOT_WALL_CLEARANCE
    y_start, y_goal = random.uniform(margin, width - margin, size=2)
    heading = math.atan2(y_goal - y_start, CORRIDOR_GOAL_X - CORRIDOR_START_X)
    start = np.array([CORRIDOR_START_X, y_start, heading])
    walls = corridor_walls(size)
    n = int(n_pedestrians)
    head_on = np.arange(n) < n - n // 2
    _, goal_x = corridor_ends(head_on, size)
    lane = corridor_lane(radius, size)
    robot = [[*start[:2], robot_radius + PEDESTRIAN_START_CLEARANCE]]
    low, high = [-CORRIDOR_END, lane[0]], [length + CORRIDOR_END, lane[1]]
    xy = place_discs(random, n, radius, low, high, robot, where="the corridor")
    moving_goal = np.column_stack([goal_x, random.uniform(*lane, size=n)])
    pref_speed = np.clip(random.normal(*speed, size=n), *speed_range)
    moving = np.column_stack([xy, heading_to(xy, moving_goal), np.full(n, float(radius))])
    return make_world(
        start,
        [CORRIDOR_GOAL_X, y_goal],
        static=wall_cylinders(walls),
        moving=moving,
        speed=pref_speed,
        bounds=bounds,
        obstacle_model=pedestrian_obstacle_model(*speed),
        behavior=behavior,
        moving_goal=moving_goal,
        pref_speed=pref_speed,
        walls=walls,
        robot_visible=robot_visible,
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
    """The square (issue 24, C-Uniform's scene): pedestrians crossing between random points.

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
    robot = [[*start[:2], robot_radius + PEDESTRIAN_START_CLEARANCE]]
    xy = place_discs(
        random, n, radius, bounds[:2] + radius, bounds[2:] - radius, robot, where="the square"
    )
    moving_goal = random_points(random, n, bounds, radius)
    pref_speed = random.uniform(*speed_range, size=n)
    moving = np.column_stack([xy, heading_to(xy, moving_goal), np.full(n, float(radius))])
    return make_world(
        start,
        goal,
        moving=moving,
        speed=pref_speed,
        bounds=bounds,
        obstacle_model=pedestrian_obstacle_model(*uniform_mean_std(*speed_range)),
        behavior=behavior,
        moving_goal=moving_goal,
        pref_speed=pref_speed,
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


def dubins_pose(pose, speed, turn_rate, t) -> np.ndarray:
    """Closed-form Dubins arcs (no boundary): poses (..., 3) after time t from pose (..., 3)."""
    x, y, theta = np.moveaxis(np.asarray(pose, dtype=np.float64), -1, 0)
    dtheta = np.asarray(turn_rate) * t
    chord = np.asarray(speed) * t * np.sinc(dtheta / (2.0 * np.pi))
    mid = theta + 0.5 * dtheta
    return np.stack([x + chord * np.cos(mid), y + chord * np.sin(mid), theta + dtheta], axis=-1)


class DubinsObstacles:
    """Cylinders moving with constant speed and turn rate, reflecting off the map boundary.

    Each substep of length h moves an obstacle along the exact arc; a centre that leaves the
    bounds is mirrored back and its heading reflected (x wall: theta -> pi - theta, y wall:
    theta -> -theta), so centres always stay inside the map.
    """

    def __init__(self, pose, speed, turn_rate, bounds, h):
        """pose (L, 3) x, y, heading; speed, turn_rate (L,); bounds (4,); h substep [s]."""
        self.z = pose[:, 0] + 1j * pose[:, 1]
        self.theta = np.array(pose[:, 2], dtype=np.float64)
        self._speed = np.asarray(speed, dtype=np.float64)
        self._bounds = np.asarray(bounds, dtype=np.float64)
        self._dtheta = np.asarray(turn_rate, dtype=np.float64) * h
        self._chord = np.asarray(speed, dtype=np.float64) * h * np.sinc(self._dtheta / (2 * np.pi))
        self._half = 0.5 * self._dtheta
        self._steps = None

    def pose(self) -> np.ndarray:
        """Current poses (L, 3) x, y, heading (wrapped to [-pi, pi))."""
        return np.column_stack([self.z.real, self.z.imag, wrap_angle(self.theta)])

    @property
    def velocity(self) -> np.ndarray:
        """World-frame velocities (L, 2) now: speed x (cos, sin) of the heading."""
        return self._speed[:, None] * np.column_stack([np.cos(self.theta), np.sin(self.theta)])

    def advance(self, n) -> np.ndarray:
        """Moves n substeps; returns the centres after each substep as complex (n, L)."""
        if self._steps is None or len(self._steps) != n:
            # Chord k of each arc, relative to the heading at the window start.
            k = np.arange(n)[:, None] + 0.5
            self._steps = self._chord * np.exp(1j * k * self._dtheta)
        z = self.z + np.cumsum(self._steps * np.exp(1j * self.theta), axis=0)
        theta = self.theta + n * self._dtheta
        xmin, ymin, xmax, ymax = self._bounds
        x, y = z.real, z.imag
        out = (x < xmin) | (x > xmax) | (y < ymin) | (y > ymax)
        if out.any():
            idx = np.flatnonzero(out.any(axis=0))
            z[:, idx], theta[idx] = self._advance_reflecting(idx, n)
        self.z = z[-1].copy()
        self.theta = wrap_angle(theta)
        return z

    def _advance_reflecting(self, idx, n):
        """Substep-by-substep motion with reflections for the (few) obstacles idx."""
        xmin, ymin, xmax, ymax = self._bounds
        z = np.empty((n, len(idx)), dtype=np.complex128)
        theta_end = np.empty(len(idx))
        for j, i in enumerate(idx):
            x, y, theta = self.z[i].real, self.z[i].imag, self.theta[i]
            chord, half, dtheta = self._chord[i], self._half[i], self._dtheta[i]
            for k in range(n):
                x += chord * math.cos(theta + half)
                y += chord * math.sin(theta + half)
                theta += dtheta
                if not xmin <= x <= xmax:
                    x = 2.0 * (xmin if x < xmin else xmax) - x
                    theta = math.pi - theta
                if not ymin <= y <= ymax:
                    y = 2.0 * (ymin if y < ymin else ymax) - y
                    theta = -theta
                z[k, j] = complex(x, y)
            theta_end[j] = theta
        return z, theta_end
