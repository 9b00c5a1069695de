"""One episode's world as plain numpy: the `World` contract, its map, and its checks.

Nothing here builds physics, so benchmarks and plots can regenerate the exact worlds a task
drew (same `random` -> same world). Arrays follow the observation contract:
static (M, 3) rows x, y, radius (radius 0 = padding); moving (L, 4) rows x, y, heading, radius.
Walls are segments (W, 4) x0, y0, x1, y1 for the pedestrians' forces and, for the physics and
the planners, rows of overlapping static cylinders (pedestrians.worlds.wall_cylinders).
The generators: `paper` (forest, crowd), pedestrians.worlds (corridor, square); `sampling`
draws their starts, goals and discs.
"""

import dataclasses
import math

import numpy as np

from dcmppi.control import defaults

# Maps (docs/design.md, Experiments).
MAP_SIZE = (75.0, 50.0)  # [m], x in [0, 75], y in [0, 50]
GOAL_TOLERANCE = 1.0  # [m] the goal is reached within this distance
TIME_LIMIT_FACTOR = 3.0  # time limit = 3 x map perimeter / v (paper)
MAX_COORDINATE = 1e6  # [m] |coordinate| and radius bound (the planners refuse states beyond it)
# The paper's moving obstacles: uniform ranges; controllers are told the Gaussian with the same
# mean and std (`crowd_obstacle_model`, every world's default).
OBSTACLE_SPEED_RANGE = (0.5, 1.5)  # [m/s]
OBSTACLE_TURN_RATE_RANGE = (-0.5, 0.5)  # [rad/s]
BEHAVIOR_CONSTANT = "constant"  # Dubins arcs (arcs.DubinsObstacles), else a pedestrians' behaviour


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
        another behaviour of tasks.pedestrians.walkers.BEHAVIOR (pedestrians that walk).
      moving_goal: (L, 2) the pedestrians' first goals (hidden; nan for "constant").
      moving_pref_speed: (L,) the pedestrians' preferred speeds [m/s] (hidden; nan for
        "constant").
      walls: (W, 4) wall segments x0, y0, x1, y1 that the pedestrians see; they walk within
        the box of map_bounds and the walls.
      robot_visible: whether the pedestrians react to the robot.
      stop_at_goal: whether the pedestrians stop at their first goals (CrowdNav's humans,
        walkers.Pedestrians) rather than walk on to next ones.
      slow_at_goal: whether they walk as stop_at_goal's (at most their preferred speeds, slower
        near their goals) but take next goals (CrowdNav++'s humans).
      safety_space: [m] added to every disc in the pedestrians' behaviour, not in the physics
        (CrowdNav++'s ORCA safety space).
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
    stop_at_goal: bool = False
    slow_at_goal: bool = False
    safety_space: float = 0.0


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
    stop_at_goal=False,
    slow_at_goal=False,
    safety_space=0.0,
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
    return World(
        **arrays,
        behavior=str(behavior),
        robot_visible=bool(robot_visible),
        stop_at_goal=bool(stop_at_goal),
        slow_at_goal=bool(slow_at_goal),
        safety_space=float(safety_space),
    )


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


def clearance(xy, obstacles, robot_radius) -> np.ndarray:
    """Surface distances (..., K) from robot centres xy (..., 2) to cylinders (K, >=3).

    Columns 0, 1 of `obstacles` are the centre and its last column the radius.
    """
    xy = np.asarray(xy, dtype=np.float64)
    d = np.hypot(xy[..., 0, None] - obstacles[:, 0], xy[..., 1, None] - obstacles[:, 1])
    return d - obstacles[:, -1] - robot_radius
