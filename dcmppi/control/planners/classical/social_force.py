"""`social_force`: the robot walks as the pedestrians do, by the project's social-force kernel.

Each step the robot is one agent of dcmppi.control.kernels.social (Helbing & Molnar's circular
social force, the `social_force` pedestrians' and the `social` predictor's model): its desired
velocity points at the goal at its preferred speed, it relaxes from its last command towards it
in tau and is pushed by the static cylinders and the moving obstacles within RANGE (as agents
that it does not move: their velocities play no part in the circular form) and by the map's
edges (as walls). The kernel's velocity after one control period is the command: the holonomic
robot's as it is; the unicycle turns towards it (velocities.track). The car (dubins), which can
neither slow down nor sidestep, is refused. The walker's velocity
is the kernel's own state from step to step (what a non-holonomic robot makes of it would lose
the sideways push at every step).
"""

import numpy as np

from dcmppi.control.kernels import social
from dcmppi.control.planners.classical.base import RANGE, Classical
from dcmppi.control.planners.registry import register
from dcmppi.control.planners.velocities import track
from dcmppi.control.validation import positive


@register("social_force")
class SocialForce(Classical):
    """The pedestrians' social force (Helbing & Molnar 1995) walking the robot to its goal.

    Args (keywords; the robot's as `Classical`), defaults and their sources:
      A: 10 m/s^2, B: 0.3 m, tau: 0.5 s (dcmppi.control.kernels.social: the pedestrians').
      pref_speed: the desired speed [m/s]; None: the agent's top speed (a pedestrian walks at
        its preferred speed, capped at 1.3 x it; the robot's cap is its top speed).
    """

    needs_speed = True  # a walker slows and sidesteps; the car can do neither

    def __init__(
        self,
        *,
        A=social.A,
        B=social.B,
        tau=social.TAU,
        pref_speed=None,
        agent="holonomic",
        **robot,
    ):
        super().__init__(agent=agent, **robot)  # robot_radius, dt, seed, the agent's limits
        self.A, self.B, self.tau = positive("A", A), positive("B", B), positive("tau", tau)
        speed = self.agent.max_speed
        self.pref_speed = speed if pref_speed is None else positive("pref_speed", pref_speed)
        self._radius = np.array([max(self.robot_radius, 1e-9)])
        self._max_speed = np.array([speed])

    def _solve(self, obs):
        state = obs.state
        to_goal = obs.goal - state[:2]
        distance = float(np.hypot(*to_goal))
        desired = to_goal * (self.pref_speed / distance) if distance > 0 else np.zeros(2)
        static, moving, _ = obs.near(RANGE)
        others = np.concatenate([static[:, :2], moving[:, :2]])
        radii = np.concatenate([static[:, 2], moving[:, 3]])
        if self._walker is None:
            self._walker = self.velocity.copy()
        _, velocity = social.step(
            state[None, :2], self._walker[None], desired[None], self._radius, self._max_speed,
            self.dt, others, radii, obs.walls(), A=self.A, B=self.B, tau=self.tau,
        )  # fmt: skip
        self._walker = velocity[0]
        return track(self.agent, state[2], self._walker)

    def reset(self, seed=None):
        super().reset(seed)
        self._walker = None  # the walker's velocity, which the robot tracks
