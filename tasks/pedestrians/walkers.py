"""Pedestrians that walk to goals and react to each other, the walls and (optionally) the robot.

Each pedestrian wants to walk straight to its goal at its preferred speed (the desired velocity)
and a behaviour turns that into its velocity for the next control period:

    social_force   Helbing & Molnar's social force, dcmppi.control.kernels.social (the `social`
                   predictor's own model)
    orca, hrvo     navground's ORCA (RVO2's reciprocal velocity obstacles) and HRVO (which
                   ignores walls: worlds with walls refuse it)
    hl             navground's HL (Guzzi et al. 2013, a human-like heuristic)

BEHAVIOR registers them by name with their settings (`Behavior`), and "constant", the crowd's
Dubins arcs (worlds.arcs.DubinsObstacles, not this class).
navground's behaviours get, each step, the other pedestrians within NEIGHBOR_RANGE (and the
robot when visible) as neighbours, the walls as line obstacles and the desired velocity as their
target; an omnidirectional kinematics caps their speed at MAX_SPEED_FACTOR x the preferred
speed, as the social force does. ORCA uses CrowdNav's settings (time horizons 5 s, at most 10
neighbours). navground computes in float32; positions integrate in float64 here.

A pedestrian within its radius of its goal gets the next from next_goal at the start of the
next control period: a new goal, or a respawn somewhere else (the density stays). A task may
also set `change_goals(random, step, position, goal) -> goal` (L, 2), called at the start of
every control period after the arrivals (step: the periods walked so far), to change goals
before arrival. With
stop_at_goal (CrowdNav's humans) it keeps its goal and stops there instead: its desired speed is
min(preferred speed, distance to the goal / ARRIVAL_TIME), its top speed the preferred one.
"""

import dataclasses

import numpy as np

from dcmppi.control.kernels import social
from dcmppi.control.kernels.social import MAX_SPEED_FACTOR
from dcmppi.control.registry import Registry
from dcmppi.control.validation import array, positive

from ..worlds.base import BEHAVIOR_CONSTANT

NEIGHBOR_RANGE = 10.0  # [m] centre distance within which navground's behaviours see others
MAX_NEIGHBORS = 10  # ORCA's and HRVO's nearest neighbours (CrowdNav's ORCA)
ORCA_TIME_HORIZON = 5.0  # [s] for other agents and for walls (CrowdNav's ORCA)
ARRIVAL_TIME = 1.0  # [s] stop_at_goal: near the goal, desired velocity = its offset / this


@dataclasses.dataclass(frozen=True)
class Behavior:
    """How the moving obstacles move (an entry of BEHAVIOR).

    navground: navground's behaviour class, or None: the compiled social force.
    time_horizon: [s] for other agents and for walls (None: navground's default).
    max_neighbors: the nearest neighbours it considers (None: navground's default).
    sees_walls: False for a behaviour that ignores walls (worlds with walls refuse it).
    relaxes: whether it relaxes from its actuated twist rather than from the velocity.
    walks: False for the crowd's Dubins arcs (worlds.arcs.DubinsObstacles, not Pedestrians).
    """

    navground: str | None = None
    time_horizon: float | None = None
    max_neighbors: int | None = None
    sees_walls: bool = True
    relaxes: bool = False
    walks: bool = True


BEHAVIOR = Registry("pedestrian behaviour")
BEHAVIOR.register(BEHAVIOR_CONSTANT)(Behavior(walks=False))
BEHAVIOR.register("social_force")(Behavior())
BEHAVIOR.register("orca")(Behavior("ORCABehavior", ORCA_TIME_HORIZON, MAX_NEIGHBORS))
BEHAVIOR.register("hrvo")(Behavior("HRVOBehavior", None, MAX_NEIGHBORS, sees_walls=False))
BEHAVIOR.register("hl")(Behavior("HLBehavior", relaxes=True))
BEHAVIORS = tuple(BEHAVIOR.names())  # every task's `behavior`, "constant" included
WALKING = tuple(b for b in BEHAVIORS if BEHAVIOR.get(b).walks)  # Pedestrians' own

__all__ = ["BEHAVIOR", "BEHAVIORS", "MAX_SPEED_FACTOR", "WALKING", "Pedestrians", "walking"]


def walking(behavior) -> Behavior:
    """The Behavior of `behavior`, one of WALKING, else a ValueError naming the valid ones."""
    entry = BEHAVIOR.get(behavior)
    if not entry.walks:
        raise ValueError(
            f"behavior {behavior!r} moves with arcs.DubinsObstacles, not Pedestrians; walking "
            f"behaviours: {', '.join(WALKING)}"
        )
    return entry


class Pedestrians:
    """L pedestrians moving by `behavior`, stepping once per control period dt and
    interpolated linearly to the physics substeps.

    Attributes:
      z: (L,) complex centres now.
      theta: (L,) headings (direction of the velocity; kept when standing).
      velocity: (L, 2) world-frame velocities now (held over the last control period).
      goal: (L, 2) current goals.
      pref_speed, radius: (L,).
    """

    def __init__(
        self,
        behavior,
        position,
        velocity,
        goal,
        pref_speed,
        radius,
        walls,
        bounds,
        robot_radius,
        robot_visible,
        next_goal,
        random,
        dt,
        stop_at_goal=False,
        slow_at_goal=False,
        safety_space=0.0,
    ):
        """
        Args:
          behavior: one of WALKING.
          position, velocity, goal: (L, 2) at t = 0.
          pref_speed, radius: (L,) > 0.
          walls: (W, 4) segments x0, y0, x1, y1.
          bounds: (4,) xmin, ymin, xmax, ymax of the map; not used: pedestrians may walk
            beyond it (the corridor's ends).
          robot_radius: [m]; robot_visible: whether the pedestrians react to the robot.
          next_goal: next_goal(random, i, position) -> (new_position or None, new_goal (2,)),
            called when pedestrian i is within its radius of its goal: None keeps walking from
            where it is, a position respawns it there (its velocity kept).
          random: np.random.RandomState handed to next_goal.
          dt: control period [s].
          stop_at_goal: keep the goals and stop at them (module docstring); next_goal unused.
          slow_at_goal: walk as with stop_at_goal but take the next goals.
          safety_space: [m] >= 0 added to every radius (the robot's too) in the behaviour.
        """
        self._spec = walking(behavior)
        self.behavior = behavior
        position = array("position", position, ("L", 2), finite=True)
        n = len(position)
        self.velocity = array("velocity", velocity, (n, 2), finite=True)
        self.goal = array("goal", goal, (n, 2), finite=True)
        self.pref_speed = _positive(pref_speed, "pref_speed", n)
        self.radius = _positive(radius, "radius", n)
        self._walls = _walls(walls, behavior)
        self._robot_radius = float(robot_radius)
        self._robot_visible = bool(robot_visible)
        self._next_goal, self._random, self._dt = next_goal, random, float(dt)
        self._pos = position.copy()
        self.z = position[:, 0] + 1j * position[:, 1]
        self.theta = _headings(self.velocity, self.goal - position)
        self._stop_at_goal = bool(stop_at_goal)
        self._slow_at_goal = self._stop_at_goal or bool(slow_at_goal)
        self._max_speed = (1.0 if self._slow_at_goal else MAX_SPEED_FACTOR) * self.pref_speed
        self._space = positive("safety_space", safety_space, allow_zero=True)
        self._behaviors = None if self._spec.navground is None else self._navground_behaviors()
        self.change_goals, self._steps = None, 0

    def advance(self, n, robot_xy, robot_velocity) -> np.ndarray:
        """Moves one control period in n substeps; returns the centres after each substep as
        complex (n, L) (the same contract as worlds.arcs.DubinsObstacles.advance). robot_xy,
        robot_velocity (2,): the robot now (ignored unless robot_visible)."""
        if self._robot_visible:
            robot_xy = array("robot_xy", robot_xy, (2,), finite=True)
            robot_velocity = array("robot_velocity", robot_velocity, (2,), finite=True)
        if not self._stop_at_goal:
            self._arrivals()
        if self.change_goals is not None:
            goal = self.change_goals(self._random, self._steps, self._pos.copy(), self.goal.copy())
            self.goal = array("change_goals' goals", goal, self.goal.shape, finite=True)
        self._steps += 1
        start = self._pos
        desired = self._desired()
        if self._behaviors is None:
            robot = (robot_xy[None], [self._robot_radius + self._space])
            others = robot if self._robot_visible else _NOBODY
            end, velocity = social.step(
                start, self.velocity, desired, self.radius + self._space, self._max_speed,
                self._dt, *others, self._walls,
            )  # fmt: skip
        else:
            velocity = self._navground_velocities(desired, robot_xy, robot_velocity)
        bad = np.flatnonzero(~np.isfinite(velocity).all(axis=1))
        if len(bad):
            i = bad[0]
            raise ValueError(
                f"pedestrian {i} ({self.behavior}) got the non-finite velocity {velocity[i]} at "
                f"position {start[i]}, goal {self.goal[i]}"
            )
        if self._behaviors is not None:
            end = start + self._dt * velocity
        z0, z1 = self.z, end[:, 0] + 1j * end[:, 1]
        z = z0 + (np.arange(1, n + 1) / n)[:, None] * (z1 - z0)
        z[-1] = z1
        speed = np.hypot(*velocity.T)
        self.theta = np.where(speed > 0, np.arctan2(velocity[:, 1], velocity[:, 0]), self.theta)
        self._pos, self.velocity, self.z = end, velocity, z1
        return z

    def _arrivals(self):
        """Pedestrians within their radius of their goals get their next goals (in index order)."""
        gap = np.hypot(*(self.goal - self._pos).T)
        for i in np.flatnonzero(gap <= self.radius):
            position, goal = self._next_goal(self._random, int(i), self._pos[i].copy())
            self.goal[i] = array("next_goal's goal", goal, (2,), finite=True)
            if position is not None:
                self._pos[i] = array("next_goal's position", position, (2,), finite=True)
                self.z[i] = complex(*self._pos[i])

    def _desired(self):
        """Desired velocities (L, 2): towards the goals at the preferred speeds (with
        stop_at_goal or slow_at_goal, at most distance / ARRIVAL_TIME)."""
        to_goal = self.goal - self._pos
        distance = np.hypot(*to_goal.T)
        scale = np.divide(
            self.pref_speed, distance, out=np.zeros_like(distance), where=distance > 0
        )
        if self._slow_at_goal:
            scale = np.minimum(scale, 1.0 / ARRIVAL_TIME)
        return to_goal * scale[:, None]

    def _navground_behaviors(self):
        """One navground behaviour per pedestrian, walls set once."""
        try:
            import navground.core as core
        except ImportError as error:
            raise ImportError(
                f"behavior {self.behavior!r} needs navground: pip install navground"
            ) from error
        self._core = core
        spec = self._spec
        lines = [core.LineSegment(w[:2], w[2:]) for w in self._walls]
        behaviors = []
        for i in range(len(self._pos)):
            kinematics = core.kinematics.OmnidirectionalKinematics(self._max_speed[i])
            behavior = getattr(core.behaviors, spec.navground)(
                kinematics=kinematics, radius=self.radius[i] + self._space
            )
            if spec.time_horizon is not None:
                behavior.time_horizon = spec.time_horizon
                behavior.static_time_horizon = spec.time_horizon
            if spec.max_neighbors is not None:
                behavior.max_number_of_neighbors = spec.max_neighbors
            behavior.optimal_speed = self.pref_speed[i]
            state = behavior.environment_state
            state.line_obstacles = lines
            behaviors.append((behavior, state))
        return behaviors

    def _navground_velocities(self, desired, robot_xy, robot_velocity):
        """Every behaviour's command (L, 2) from the same state (pedestrians move together)."""
        core = self._core
        pos, vel = self._pos, self.velocity
        distance = np.hypot(*(pos[:, None] - pos[None]).transpose(2, 0, 1))
        np.fill_diagonal(distance, np.inf)
        if self._robot_visible:
            robot = [core.Neighbor(robot_xy, self._robot_radius + self._space, robot_velocity)]
            near_robot = np.hypot(*(pos - robot_xy).T) < NEIGHBOR_RANGE
        stop = core.Target.Stop()
        relaxes = self._spec.relaxes
        out = np.empty_like(vel)
        for i, (behavior, state) in enumerate(self._behaviors):
            behavior.position = pos[i]
            behavior.velocity = vel[i]
            if relaxes:  # HL relaxes from its actuated twist, not from the velocity
                behavior.actuated_twist = core.Twist2(vel[i])
            behavior.orientation = self.theta[i]
            neighbors = [
                core.Neighbor(pos[j], self.radius[j] + self._space, vel[j])
                for j in np.flatnonzero(distance[i] < NEIGHBOR_RANGE)
            ]
            if self._robot_visible and near_robot[i]:
                neighbors += robot
            state.neighbors = neighbors
            # At its goal: navground's Stop (HRVO turns a zero target velocity into nan)
            moving = desired[i, 0] or desired[i, 1]
            behavior.target = core.Target.Velocity(desired[i]) if moving else stop
            out[i] = behavior.compute_cmd(self._dt, core.Frame.absolute, True).velocity
        return out


_NOBODY = (np.zeros((0, 2)), np.zeros(0))  # no robot among the pushing agents


def _walls(walls, behavior) -> np.ndarray:
    """walls (W, 4) segments x0, y0, x1, y1 (None: none) as float64, else a ValueError: a
    segment of zero length, or walls for a behaviour that ignores them."""
    walls = array("walls", np.zeros((0, 4)) if walls is None else walls, ("W", 4), finite=True)
    flat = np.flatnonzero(np.hypot(*(walls[:, 2:] - walls[:, :2]).T) == 0)
    if len(flat):
        raise ValueError(f"walls {flat} have zero length: give segments x0, y0, x1, y1")
    if not BEHAVIOR.get(behavior).sees_walls and len(walls):
        others = [b for b in WALKING if BEHAVIOR.get(b).sees_walls]
        raise ValueError(
            f"{behavior} ignores walls: in a world with walls use one of {', '.join(others)}"
        )
    return walls


def _headings(velocity, to_goal) -> np.ndarray:
    """Headings (L,): along velocity (L, 2), or along to_goal (L, 2) where standing."""
    return np.where(
        np.hypot(*velocity.T) > 0,
        np.arctan2(velocity[:, 1], velocity[:, 0]),
        np.arctan2(to_goal[:, 1], to_goal[:, 0]),
    )


def _positive(value, name, rows):
    """value as a float64 (rows,) array > 0, else a ValueError naming the first bad index."""
    value = array(name, value, (rows,))
    bad = np.flatnonzero(~(np.isfinite(value) & (value > 0)))
    if len(bad):
        raise ValueError(f"{name} must be > 0; pedestrian {bad[0]} has {float(value[bad[0]])}")
    return value
