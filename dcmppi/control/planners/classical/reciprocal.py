"""`orca`, `hrvo`, `hl`: the robot driven by navground's behaviours, the pedestrians' library.

Each step the behaviour gets the robot's pose, its last command as its velocity (and as the
twist it relaxes from), the goal as its target point, and within RANGE of the robot the static
cylinders as discs, the moving obstacles as neighbours with their observed velocities (see
velocities.moving_obstacle_velocity) and the map's edges as line obstacles (HRVO ignores lines, as
for the pedestrians); it returns a feasible twist for the agent's kinematics:

    holonomic   navground's OmnidirectionalKinematics (max_speed, omega_max): the command is
                its world-frame velocity, turn rate 0 (the robot keeps its heading)
    others      navground's AheadKinematics (max_speed, omega_max): forward speed and turn
                rate (the unicycle), the heading following the velocity the behaviour wants

An agent that steers only (the car, dubins: a fixed speed) fits no navground kinematics and is
refused. navground is
imported when the first such controller is made (`import dcmppi.control` does not load it);
it computes in float32, deterministically.
"""

import numpy as np

from dcmppi.control.planners.classical.base import RANGE, Classical
from dcmppi.control.planners.registry import register
from dcmppi.control.validation import positive

# ORCA's and HRVO's settings: CrowdNav's ORCA (Chen et al. 2019, crowd_sim's orca.py), as the
# `orca` pedestrians of dcmppi.tasks use them; everything else navground's defaults.
TIME_HORIZON = 5.0  # [s] ORCA's time horizon for neighbours and for static obstacles
MAX_NEIGHBORS = 10  # ORCA's and HRVO's nearest neighbours considered
SAFETY_MARGIN = 0.02  # [m] CrowdNav adds 0.01 m to every agent's radius: 0.02 m between two


class Reciprocal(Classical):
    """A navground behaviour driving the holonomic or the unicycle robot (base of orca, hrvo,
    hl)."""

    needs_speed = True
    behavior = None  # navground's class name

    def _setup(self, safety_margin, horizon, settings):
        """navground's behaviour for this agent, its parameters set."""
        try:
            import navground.core as core
        except ImportError as error:  # a dependency of dcmppi; a broken install
            raise ImportError(
                f"controller {self.name!r} needs navground: pip install navground"
            ) from error
        self._core = core
        self.safety_margin = positive("safety_margin", safety_margin, allow_zero=True)
        self.horizon = positive("horizon", horizon)
        agent = self.agent
        kinematics = (
            core.kinematics.OmnidirectionalKinematics(agent.max_speed, agent.omega_max)
            if agent.holonomic
            else core.kinematics.AheadKinematics(agent.max_speed, agent.omega_max)
        )
        self._behavior = getattr(core.behaviors, self.behavior)(
            kinematics=kinematics, radius=self.robot_radius
        )
        b = self._behavior
        b.optimal_speed = agent.max_speed
        b.safety_margin = self.safety_margin
        b.horizon = self.horizon
        for name, value in settings.items():
            b.set(name, value)

    def reset(self, seed=None):
        super().reset(seed)
        self._walls = None

    def _solve(self, obs):
        core, b = self._core, self._behavior
        state = obs.state
        b.position = state[:2]
        b.orientation = state[2]
        b.velocity = self.velocity
        b.actuated_twist = core.Twist2(self.velocity, self.omega, core.Frame.absolute)
        b.target = core.Target.Point(obs.goal, 0.0)
        env = b.environment_state
        static, moving, velocity = obs.near(max(RANGE, self.horizon))
        env.static_obstacles = [core.Disc(c[:2], c[2]) for c in static]
        pairs = zip(moving, velocity, strict=True)
        env.neighbors = [core.Neighbor(m[:2], m[3], v) for m, v in pairs]
        walls = obs.walls()
        if self._walls is None or not np.array_equal(self._walls, walls):
            env.line_obstacles = [core.LineSegment(w[:2], w[2:]) for w in walls]
            self._walls = walls
        holonomic = self.agent.holonomic
        frame = core.Frame.absolute if holonomic else core.Frame.relative
        twist = b.compute_cmd(self.dt, frame, True)
        v, omega = np.asarray(twist.velocity, dtype=np.float64), float(twist.angular_speed)
        if not (np.isfinite(v).all() and np.isfinite(omega)):
            v, omega = np.zeros(2), 0.0  # a degenerate geometry: stand still
        # the holonomic robot keeps its heading; the others take the forward speed, turn rate
        return self.agent.command(v, 0.0 if holonomic else omega)


@register("orca")
class ORCA(Reciprocal):
    """ORCA, reciprocal velocity obstacles (van den Berg et al. 2011), by navground.

    Args (keywords; the robot's as `Classical`), defaults and their sources:
      time_horizon: 5 s, for neighbours and static obstacles (CrowdNav's ORCA, as the orca
        pedestrians; navground's default 10 s).
      max_neighbors: 10 (CrowdNav's ORCA; navground's default 1000).
      effective_center: False (navground's default; True: ORCA about a point ahead of a
        non-holonomic robot's centre).
      safety_margin: 0.02 m (CrowdNav's ORCA adds 0.01 m to every agent's radius; navground's
        default 0).
      horizon: 5 m (navground's default perception horizon).
    """

    behavior = "ORCABehavior"

    def __init__(
        self,
        *,
        time_horizon=TIME_HORIZON,
        max_neighbors=MAX_NEIGHBORS,
        effective_center=False,
        safety_margin=SAFETY_MARGIN,
        horizon=5.0,
        agent="holonomic",
        **robot,
    ):
        super().__init__(agent=agent, **robot)  # robot_radius, dt, seed, the agent's limits
        self.time_horizon = positive("time_horizon", time_horizon)
        self.max_neighbors = positive("max_neighbors", max_neighbors, integer=True)
        self.effective_center = bool(effective_center)
        self._setup(
            safety_margin,
            horizon,
            {
                "time_horizon": self.time_horizon,
                "static_time_horizon": self.time_horizon,
                "max_neighbors": self.max_neighbors,
                "effective_center": self.effective_center,
            },
        )


@register("hrvo")
class HRVO(Reciprocal):
    """HRVO, hybrid reciprocal velocity obstacles (Snape et al. 2011), by navground.

    Args (keywords; the robot's as `Classical`), defaults and their sources:
      max_neighbors: 10 (as orca: CrowdNav's ORCA; navground's default 1000).
      uncertainty_offset: 0 (navground's default).
      safety_margin: 0.02 m (as orca; navground's default 0). horizon: 5 m (navground's
        default).
    """

    behavior = "HRVOBehavior"

    def __init__(
        self,
        *,
        max_neighbors=MAX_NEIGHBORS,
        uncertainty_offset=0.0,
        safety_margin=SAFETY_MARGIN,
        horizon=5.0,
        agent="holonomic",
        **robot,
    ):
        super().__init__(agent=agent, **robot)  # robot_radius, dt, seed, the agent's limits
        self.max_neighbors = positive("max_neighbors", max_neighbors, integer=True)
        self.uncertainty_offset = positive(
            "uncertainty_offset", uncertainty_offset, allow_zero=True
        )
        self._setup(
            safety_margin,
            horizon,
            {"max_neighbors": self.max_neighbors, "uncertainty_offset": self.uncertainty_offset},
        )


@register("hl")
class HL(Reciprocal):
    """HL, the human-like heuristic (Guzzi et al. 2013), by navground.

    Args (keywords; the robot's as `Classical`), defaults navground's (Guzzi et al.'s):
      tau: 0.125 s, relaxation time of the speed. eta: 0.5 s, time to reach the obstacle-free
      distance. aperture: pi rad, half the field of directions searched. directions: 101,
      the directions it evaluates (navground's `resolution`). safety_margin: 0 m. horizon:
      5 m, how far it looks.
    """

    behavior = "HLBehavior"

    def __init__(
        self,
        *,
        tau=0.125,
        eta=0.5,
        aperture=np.pi,
        directions=101,
        safety_margin=0.0,
        horizon=5.0,
        agent="holonomic",
        **robot,
    ):
        super().__init__(agent=agent, **robot)  # robot_radius, dt, seed, the agent's limits
        self.tau = positive("tau", tau)
        self.eta = positive("eta", eta)
        self.aperture = positive("aperture", aperture)
        self.directions = positive("directions", directions, integer=True)
        self._setup(
            safety_margin,
            horizon,
            {"tau": self.tau, "eta": self.eta, "aperture": self.aperture,
             "resolution": self.directions},
        )  # fmt: skip
