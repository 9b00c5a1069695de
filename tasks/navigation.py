"""The shared task of every benchmark world: drive a robot among cylinders to its goal.

`Navigation` is the dm_control task: it draws a `worlds.base.World` per episode, maps the
agent's controls to the actuators of the plant (physics.Physics), injects noise, and ends the
episode at the goal, on a collision, when the robot leaves the map, or at the time limit.
Subclasses only say how a world is drawn (those whose moving obstacles may walk through
pedestrians.base.PedestrianNavigation).
"""

import collections
import math

import numpy as np
from dm_control.rl import control
from dm_env import specs

from dcmppi.control import defaults
from dcmppi.control.agents import make_agent
from dcmppi.control.kernels.projection import bound
from dcmppi.control.validation import positive

from . import robots
from .physics import Physics
from .worlds.base import (
    GOAL_TOLERANCE,
    World,
    default_time_limit,
    impossible,
)
from .worlds.base import map_bounds as map_bounds_of
from .worlds.sampling import random_points

PHYSICS_TIMESTEP = 0.01  # [s] MuJoCo timestep: 10 substeps per control step (defaults.DT)
# Noise profiles of the experiments (docs/design.md, Experiments).
NOISE_PROFILES = ("none", "control", "process")
CONTROL_NOISE = 0.1  # variance of the control noise on every control, in its own units (paper)
PROCESS_VELOCITY_STD = 0.1  # [m/s] std of the planar velocity disturbance, per axis
PROCESS_YAW_RATE_STD = 0.1  # [rad/s] std of the yaw-rate disturbance
MEASUREMENT_STREAM = 1  # spawn key of the measurement-noise stream under the noise seed


# A dm_control.rl.control.Task, not dm_control.suite's base.Task: importing dm_control.suite
# loads every suite domain, scipy with them.
class Navigation(control.Task):
    """Drive a robot to the goal without touching an obstacle or leaving the map.

    The robot is an agent of docs/design.md (`agent`: "dubins" by default, "unicycle",
    "holonomic"; its parameters such as v_max go alongside), simulated by its MuJoCo plant
    (tasks/robots.py).
    Action: (nu,) the agent's controls (dubins: the turn rate omega; unicycle: v, omega;
    holonomic: u_x, u_y, u_theta). An action outside the spec is clipped to it, as dm_control
    does, and a holonomic velocity beyond v_max is scaled back onto |(u_x, u_y)| = v_max.
    Reward: 1 on the step that reaches the goal, else 0. Discount: 0 at the goal, on a collision
    and on leaving the map (terminal); 1 at the time limit (truncation).
    Noise (drawn from the task's random): "control" adds N(0, Sigma) to each applied control
    every control step (Sigma per control, in its own units; default 0.1 for every control, the
    paper's turn-rate variance: a holonomic robot's velocity errs by 0.32 m/s std, a tenth of
    the variance its planners sample with); "process" adds that, plus velocity disturbances
    (std process_velocity_std per planar axis, process_yaw_rate_std for the yaw rate) held for
    the control step as forces that the actuators have to fight.
    Measurements: obstacle_measurement_std > 0 [m] adds N(0, std^2) to each coordinate of every
    moving obstacle's observed position at every control step (a stream of its own, derived
    from the episode's noise seed, so world and control noise stay those of std = 0), and the
    headings and velocities are then not observed: that column of `moving_obstacles` and
    `moving_velocity` are nan. Rows keep their order (obstacles are matched by index). std = 0
    (default) observes the exact poses and velocities (L, 2) (world frame).
    Pedestrians (tasks whose `behavior` is not "constant"): the observation never shows their
    goals or preferred speeds; on reaching its goal pedestrian i gets the next from
    `next_goal`.
    """

    default_agent = "dubins"
    goal_tolerance = GOAL_TOLERANCE  # [m] the goal is reached within this distance of it

    def __init__(
        self,
        random=None,
        noise="none",
        agent=None,
        robot_radius=defaults.ROBOT_RADIUS,
        Sigma=None,
        process_velocity_std=PROCESS_VELOCITY_STD,
        process_yaw_rate_std=PROCESS_YAW_RATE_STD,
        time_limit=None,
        obstacle_measurement_std=0.0,
        **agent_params,
    ):
        """Args: see the class docstring; time_limit [s] defaults to the task's own."""
        if noise not in NOISE_PROFILES:
            raise ValueError(f"noise must be one of {NOISE_PROFILES}, got {noise!r}")
        self.agent = make_agent(self.default_agent if agent is None else agent, **agent_params)
        self.plant = robots.plant(self.agent)
        self.robot_radius = positive("robot_radius", robot_radius)
        if Sigma is None:
            Sigma = [CONTROL_NOISE] * self.agent.nu
        self.Sigma = self.agent.variances(Sigma, allow_zero=True)
        self.process_std = np.array(
            [
                positive("process_velocity_std", process_velocity_std, allow_zero=True),
                process_velocity_std,
                positive("process_yaw_rate_std", process_yaw_rate_std, allow_zero=True),
            ]
        )
        self._time_limit = None if time_limit is None else positive("time_limit", time_limit)
        self.obstacle_measurement_std = positive(
            "obstacle_measurement_std", obstacle_measurement_std, allow_zero=True
        )
        self.noise = noise
        self._random = (
            random if isinstance(random, np.random.RandomState) else np.random.RandomState(random)
        )
        self._noise_random = np.random.RandomState(0)
        self._measurement_random = np.random.default_rng(0)
        self.world = None
        self._outcome = None
        self._min_clearance = np.inf

    # What subclasses provide ------------------------------------------------------------------

    num_static = 1  # static slots (fixed per instance)
    num_moving = 0  # moving slots (fixed per instance)

    def generate_world(self, random) -> World:
        """Draws this episode's world from `random` (a RandomState)."""
        raise NotImplementedError

    def obstacle_motion(self):
        """This episode's motion of the moving obstacles (physics.Physics.set_world's `motion`),
        called after generate_world; None (this one): the physics moves them by the world's
        behaviour."""
        return None

    def next_goal(self, random, i, position):
        """Pedestrian i's next goal on reaching its goal at `position` (2,): (None, goal (2,)),
        None keeping it where it is. This one draws a uniform point of the map at least its
        radius inside the edges from `random` (the episode's world RandomState)."""
        radius = self.world.moving[i, 3]
        return None, random_points(random, 1, self.world.map_bounds, radius)[0]

    @property
    def map_bounds(self) -> np.ndarray:
        """(4,) xmin, ymin, xmax, ymax of this instance's map."""
        return map_bounds_of()

    @property
    def time_limit(self) -> float:
        """Episode time limit [s]: by default 3 x the time to drive around the map at the
        agent's top speed."""
        if self._time_limit is not None:
            return self._time_limit
        return default_time_limit(self.map_bounds, self.agent.max_speed)

    @property
    def random(self) -> np.random.RandomState:
        """The task's RandomState: each episode's world and noise seeds come from it."""
        return self._random

    # Results ----------------------------------------------------------------------------------

    @property
    def outcome(self):
        """None while running, then "goal", "collision", "left_map" or "time_limit"."""
        return self._outcome

    @property
    def min_clearance(self) -> float:
        """Minimum robot-obstacle surface distance so far this episode [m]."""
        return self._min_clearance

    # dm_control Task API ----------------------------------------------------------------------

    def initialize_episode(self, physics):
        world_seed, noise_seed = self.random.randint(0, 2**31 - 1, size=2)
        world_random = np.random.RandomState(world_seed)  # the world, then the pedestrians' goals
        world = self.generate_world(world_random)
        if world.static.shape != (self.num_static, 3) or world.moving.shape != (self.num_moving, 4):
            raise RuntimeError(f"{type(self).__name__} drew a world of the wrong size")
        problem = impossible(world, self.robot_radius)
        if problem is not None:
            raise ValueError(
                f"{type(self).__name__} drew an impossible world: {problem[0]}; change its task "
                "parameters"
            )
        self.world = world
        self._noise_random = np.random.RandomState(noise_seed)
        self._measurement_random = np.random.default_rng([noise_seed, MEASUREMENT_STREAM])
        velocity = robots.start_velocity(self.agent, world.start[2])
        command = self._command(self.agent.first_guess(world.start, world.goal, 1)[0])
        physics.set_world(
            world,
            velocity,
            command,
            self.agent.max_speed,
            self.next_goal,
            world_random,
            self.obstacle_motion(),
            self.goal_tolerance,
        )
        self._outcome = None
        self._min_clearance = physics.min_clearance
        # what after_step compares with, as floats
        self._goal = tuple(float(v) for v in world.goal)
        self._goal_tolerance = float(self.goal_tolerance)
        self._map_bounds = tuple(float(v) for v in world.map_bounds)
        self._end_time = self.time_limit - 0.5 * physics.timestep()
        self._noise_std = np.sqrt(self.Sigma)
        self._observation = collections.OrderedDict(
            robot_pose=None,
            robot_velocity=None,
            goal=world.goal,
            static_obstacles=world.static,
            moving_obstacles=None,
            moving_velocity=None,
            obstacle_model=world.obstacle_model,
            map_bounds=world.map_bounds,
            clearance=None,
        )
        self.after_step(physics)  # the start's own outcome (in contact, at the goal)

    def _command(self, u):
        """Actuator targets of the controls u (nu,), already within the bounds."""
        return self.plant.command(self.agent, u)

    def before_step(self, action, physics):
        u = np.asarray(action, dtype=np.float64).reshape(-1)
        if u.shape != (self.agent.nu,) or not all(map(math.isfinite, u.tolist())):
            raise ValueError(
                f"action must be {self.agent.nu} finite number(s) {self.agent.controls} "
                f"(agent {self.agent.name!r}), got {action!r}"
            )
        u = bound(self.agent, u)  # agent.project's values, in one compiled call
        if self.noise != "none":
            u = u + self._noise_std * self._noise_random.randn(self.agent.nu)
        if self.noise == "process":
            physics.set_disturbance(self.process_std * self._noise_random.randn(3))
        physics.set_command(self._command(u))

    def after_step(self, physics):
        self._min_clearance = physics.min_clearance
        if self._outcome is not None:
            return
        x, y = physics.robot_position()
        xmin, ymin, xmax, ymax = self._map_bounds
        gx, gy = self._goal
        dx, dy = x - gx, y - gy
        tolerance = self._goal_tolerance
        if physics.collided:
            self._outcome = "collision"
        # hypot >= max(|dx|, |dy|): np.hypot only where it can be within the tolerance
        elif max(abs(dx), abs(dy)) <= tolerance and np.hypot(dx, dy) <= tolerance:
            self._outcome = "goal"
        elif not (xmin <= x <= xmax and ymin <= y <= ymax):
            self._outcome = "left_map"
        elif physics.time() >= self._end_time:
            self._outcome = "time_limit"

    def get_observation(self, physics):
        obs = self._observation.copy()
        obs["robot_pose"] = physics.robot_pose()
        obs["robot_velocity"] = physics.robot_velocity()
        obs["moving_obstacles"], obs["moving_velocity"] = self._measure(
            physics.moving_obstacles(), physics.moving_velocity()
        )
        obs["clearance"] = np.array([physics.clearance()])
        return obs

    def _measure(self, moving, velocity):
        """The observed moving obstacles (L, 4) and velocities (L, 2): positions with
        measurement noise, headings and velocities nan when obstacle_measurement_std > 0, else
        the exact values."""
        std = self.obstacle_measurement_std
        if std > 0:
            moving[:, :2] += std * self._measurement_random.standard_normal((len(moving), 2))
            moving[:, 2] = np.nan
            velocity[:] = np.nan
        return moving, velocity

    def get_reward(self, physics):
        return 1.0 if self._outcome == "goal" else 0.0

    def get_termination(self, physics):
        if self._outcome is None:
            return None
        return 1.0 if self._outcome == "time_limit" else 0.0

    def action_spec(self, physics):
        a = self.agent
        return specs.BoundedArray((a.nu,), np.float64, a.lower, a.upper, name=",".join(a.controls))

    def observation_spec(self, physics):
        shapes = dict(
            robot_pose=(3,),
            robot_velocity=(3,),
            goal=(2,),
            static_obstacles=(self.num_static, 3),
            moving_obstacles=(self.num_moving, 4),
            moving_velocity=(self.num_moving, 2),
            obstacle_model=(4,),
            map_bounds=(4,),
            clearance=(1,),
        )
        return collections.OrderedDict(
            (name, specs.Array(shape, np.float64, name=name)) for name, shape in shapes.items()
        )


def make_environment(task: Navigation, environment_kwargs=None) -> control.Environment:
    """The dm_control Environment of `task`: control step defaults.DT, substeps PHYSICS_TIMESTEP."""
    environment_kwargs = dict(environment_kwargs or {})
    if "time_limit" in environment_kwargs:
        raise ValueError(
            "set the time limit with task_kwargs={'time_limit': seconds}: the task "
            "ends the episode itself so that it can report the outcome"
        )
    environment_kwargs.setdefault("control_timestep", defaults.DT)
    physics = Physics.for_slots(
        task.num_static, task.num_moving, task.map_bounds, task.robot_radius, task.plant.model
    )
    physics.model.opt.timestep = PHYSICS_TIMESTEP
    physics.control_period = float(environment_kwargs["control_timestep"])
    return control.Environment(physics, task, **environment_kwargs)
