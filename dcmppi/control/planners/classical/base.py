"""What the classical controllers share: the robot, the observation, the velocity they track.

A classical controller plans one command per step from the same observation as every planner
(`act(state, goal, static, moving, obstacle_model, bounds, moving_velocity)`) with the task's
robot (agent, its limits, robot_radius); it keeps no sampled rollouts. It is not a
`dcmppi.Controller` (no K, N, Sigma ...): its keyword parameters are those of its class's
`__init__` and its bases' (a subclass passes the robot's on as `**robot`), which `param_names()`
lists for `make_controller` and the bench.

Its state between steps is the command it gave last (`velocity`, world frame, and `omega`): the
robot's velocity as the reciprocal planners, the social force and the dynamic window need it,
the plants tracking their commands (the observation's `robot_velocity` does not reach `act`).
"""

import inspect
import math

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.agents import Agent, agent_class, agent_names, make_agent
from dcmppi.control.kernels.costs import valid_cylinders
from dcmppi.control.kernels.projection import bound
from dcmppi.control.planners.diagnostics import Diagnostics
from dcmppi.control.planners.observations import observed_velocity, state_and_goal
from dcmppi.control.planners.shield import make_shield, shielded
from dcmppi.control.planners.velocities import moving_obstacle_velocity
from dcmppi.control.validation import floats, positive, seed_param

RANGE = 10.0  # [m] obstacles whose surface lies this far from the robot's are ignored
PLAN_STEPS = 20  # the drawn plan: the command held for this many control steps (2 s)


class Classical:
    """Base of the classical controllers (orca, hrvo, hl, social_force, dwa).

    Args (keywords): agent (a registered name or an Agent; one that steers only where the
      class's `needs_speed` allows) and its parameters (dubins: v, r_min; unicycle and
      holonomic: v_max, omega_max; None: the agent's default), robot_radius [m], dt: the
      control period [s], seed: accepted for the common interface (these planners draw
      nothing: the same observations give the same commands), shield: the safety shield of the
      command (dcmppi.control.planners.shield; None or false: off, the default).
    A subclass implements `_solve(obs)` -> (nu,) controls, through the agent's answers
    (`holonomic`, `steers_only`, `command`, `world_velocity`), never its name.
    """

    name = None
    needs_speed = False  # whether it refuses an agent that steers only (at a fixed speed)
    samples = False  # whether _solve leaves its sampled trajectories in diagnostics.states
    default_prediction = "frozen"  # read by make_controller's parameter check; none is used

    def __init__(
        self,
        *,
        agent="dubins",
        robot_radius=defaults.ROBOT_RADIUS,
        dt=defaults.DT,
        seed=None,
        v=None,
        r_min=None,
        v_max=None,
        omega_max=None,
        shield=None,
    ):
        kind = type(agent) if isinstance(agent, Agent) else agent_class(agent)
        if self.needs_speed and kind.steers_only:
            valid = [n for n in agent_names() if not agent_class(n).steers_only]
            raise ValueError(
                f"controller {self.name!r} drives the {', '.join(valid)} agents; got "
                f"{kind.name!r} (--task-param agent=NAME)"
            )
        given = {"v": v, "r_min": r_min, "v_max": v_max, "omega_max": omega_max}
        self.agent = make_agent(agent, **{k: x for k, x in given.items() if x is not None})
        self.robot_radius = positive("robot_radius", robot_radius, allow_zero=True)
        self.dt = positive("dt", dt)
        self.seed = seed_param(seed)
        self.shield, self.safety = make_shield(shield, self.agent, self.robot_radius, self.dt)
        self.reset()

    @classmethod
    def param_names(cls):
        """The keyword parameters of every `__init__` along the class's bases (the agent's
        included): a subclass names its own and passes the robot's on as `**robot`."""
        names = []
        for klass in cls.__mro__:
            if "__init__" in klass.__dict__:
                parameters = inspect.signature(klass.__init__).parameters.values()
                own = [p.name for p in parameters if p.kind == p.KEYWORD_ONLY]
                names += [n for n in own if n not in names]
        return names

    @property
    def params(self):
        """All parameters as a dict (for records)."""
        skip = ("agent", "seed", "v", "r_min", "v_max", "omega_max")
        own = {n: getattr(self, n) for n in self.param_names() if n not in skip}
        return {"agent": self.agent.name, **self.agent.params, **own, "seed": self.seed}

    @property
    def nu(self):
        return self.agent.nu

    def reset(self, seed=None):
        """A new episode: the robot at rest (the car at its speed along its heading, set at the
        first step)."""
        if seed is not None:
            self.seed = seed_param(seed)
        self.velocity = None  # world-frame velocity of the last command; None: none given yet
        self.omega = 0.0
        self.diagnostics = Diagnostics()

    def act(
        self,
        state,
        goal,
        static=None,
        moving=None,
        obstacle_model=None,
        bounds=None,
        moving_velocity=None,
    ):
        """Controls to apply now; the arguments are `dcmppi.Controller.act`'s (the futures
        aside): state (3,), goal (2,), static (M, 3), moving (L, 4) x, y, heading (nan: not
        observed), radius, obstacle_model (4,), bounds (4,) and moving_velocity (L, 2) (nan rows:
        not observed). Returns (nu,) controls within the agent's bounds."""
        state, goal = state_and_goal(state, goal)
        if self.velocity is None:
            self.velocity = start_velocity(self.agent, state[2])
        observed = moving
        moving = valid_cylinders(moving, "moving", columns=4, unobserved=2)
        velocity = observed_velocity(moving_velocity, observed)
        obs = Observation(
            state=state,
            goal=goal,
            static=valid_cylinders(static, "static"),
            moving=moving,
            moving_velocity=moving_obstacle_velocity(moving, velocity, obstacle_model),
            bounds=None if bounds is None else floats("bounds", bounds).reshape(4),
        )
        u = bound(self.agent, np.asarray(self._solve(obs), dtype=np.float64))
        if self.safety is not None:
            args = (obs.static, obs.moving, obs.moving_velocity, None, obs.bounds)
            u = shielded(self.safety, self.diagnostics, state, u, *args)
        self.velocity, self.omega = self.agent.world_velocity(state[2], u)
        plan = np.tile(u, (PLAN_STEPS, 1))
        d = self.diagnostics
        if not self.samples:  # a planner that samples leaves its trajectories in _solve
            d.states = self.agent.rollout_one(state, plan, self.dt)[None]  # (1, N + 1, 3)
        d.plan, d.action = plan, u
        return u

    def _solve(self, obs):
        raise NotImplementedError


class Observation:
    """One step's observation, checked: state (3,), goal (2,), static (M, 3) and moving (L, 4)
    without padding rows, moving_velocity (L, 2) (finite), bounds (4,) or None."""

    __slots__ = ("state", "goal", "static", "moving", "moving_velocity", "bounds")

    def __init__(self, **values):
        for k, x in values.items():
            setattr(self, k, x)

    def near(self, reach):
        """The static (M', 3) and the moving (L', 4) obstacles and their velocities (L', 2)
        whose surfaces lie within `reach` of the robot's centre now."""
        xy = self.state[:2]
        s = self.static[np.hypot(*(self.static[:, :2] - xy).T) - self.static[:, 2] < reach]
        keep = np.hypot(*(self.moving[:, :2] - xy).T) - self.moving[:, 3] < reach
        return s, self.moving[keep], self.moving_velocity[keep]

    def walls(self):
        """The map's edges (4, 4) as segments x0, y0, x1, y1 (none without bounds)."""
        if self.bounds is None:
            return np.zeros((0, 4))
        x0, y0, x1, y1 = self.bounds
        return np.array([[x0, y0, x1, y0], [x1, y0, x1, y1], [x1, y1, x0, y1], [x0, y1, x0, y0]])


def start_velocity(agent, heading):
    """The robot's world-frame velocity (2,) before its first command: an agent that steers
    only at its speed along its heading, any other at rest."""
    if agent.steers_only:
        return agent.max_speed * np.array([math.cos(heading), math.sin(heading)])
    return np.zeros(2)
