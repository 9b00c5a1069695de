"""The worlds of the benchmark as plain numpy: generators, Dubins obstacle motion, clearance.

Nothing here builds physics, so benchmarks and plots can regenerate the exact worlds a task
drew (same `random` -> same world). Arrays follow the observation contract:
static (M, 3) rows x, y, radius (radius 0 = padding); moving (L, 4) rows x, y, heading, radius.
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
BORDER = 2.0  # [m] start and goal keep this far from the map edge
CROWD_SIZE = 100
CROWD_START_CLEARANCE = 3.0  # [m] no moving obstacle surface this close to the start
# The crowd's uniform ranges; controllers are told the Gaussian with the same mean and std.
OBSTACLE_SPEED_RANGE = (0.5, 1.5)  # [m/s]
OBSTACLE_TURN_RATE_RANGE = (-0.5, 0.5)  # [rad/s]
MOVING_OBSTACLE_RADIUS = 1.0  # [m]


@dataclasses.dataclass(frozen=True)
class World:
    """One episode's world.

    Attributes:
      start: (3,) robot start pose x, y, yaw.
      goal: (2,) goal x, y.
      static: (M, 3) static cylinders x, y, radius; radius-0 rows are padding.
      moving: (L, 4) moving cylinders at t = 0: x, y, heading, radius.
      moving_speed: (L,) true speeds [m/s] (hidden from controllers).
      moving_turn_rate: (L,) true turn rates [rad/s] (hidden from controllers).
      map_bounds: (4,) xmin, ymin, xmax, ymax.
      obstacle_model: (4,) known Gaussian v_mean, v_std, omega_mean, omega_std.
    """

    start: np.ndarray
    goal: np.ndarray
    static: np.ndarray
    moving: np.ndarray
    moving_speed: np.ndarray
    moving_turn_rate: np.ndarray
    map_bounds: np.ndarray
    obstacle_model: np.ndarray


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
    )
    for name, value in arrays.items():
        value = np.array(value, dtype=np.float64)
        value.flags.writeable = False
        arrays[name] = value
    return World(**arrays)


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
) -> World:
    """The dynamic crowd (docs/design.md): uniform positions, headings, speeds and turn rates.

    Obstacles whose surface starts within CROWD_START_CLEARANCE of the start are redrawn.
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
    moving = np.column_stack([xy, heading, np.full(n, float(obstacle_radius))])
    return make_world(
        start,
        goal,
        moving=moving,
        speed=speed,
        turn_rate=turn_rate,
        bounds=bounds,
        obstacle_model=crowd_obstacle_model(speed_range, turn_rate_range),
    )


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
        self._bounds = np.asarray(bounds, dtype=np.float64)
        self._dtheta = np.asarray(turn_rate, dtype=np.float64) * h
        self._chord = np.asarray(speed, dtype=np.float64) * h * np.sinc(self._dtheta / (2 * np.pi))
        self._half = 0.5 * self._dtheta
        self._steps = None

    def pose(self) -> np.ndarray:
        """Current poses (L, 3) x, y, heading (wrapped to [-pi, pi))."""
        return np.column_stack([self.z.real, self.z.imag, wrap_angle(self.theta)])

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
