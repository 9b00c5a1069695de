"""Interaction-aware futures: the moving obstacles as social-force pedestrians that avoid each
other and the robot's plan, weight beta / P.

Future p draws the same velocity errors as "cv" (so without interactions its futures are cv's):
pedestrian l wants to walk at desired_lp = v_l + dv_lp, dv_lp ~ N(0, cv_std^2 I), starts at its
observed position with that velocity, and all pedestrians within reach move together by
dcmppi.control.kernels.social.rollout (Helbing & Molnar, the kernel the tasks' pedestrians use):
pushed by each other (their observed radii) and, with reactive=True (the default), by the robot
along its plan (predictor input "robot_plan": the warm start rolled out from the current state,
radius robot_radius), no walls. reactive=False predicts pedestrians blind to the robot (as
CrowdNav++'s): a reactive prediction of a crowd that does not react lets the plan push them
out of its way on paper only. Each pedestrian's speed is capped at MAX_SPEED_FACTOR x its
fastest desired speed over the P futures (the kernel takes one cap per pedestrian).

An obstacle is left out when none of its futures can reach a rollout, with that cap as the
speed of every future (exact: no future is faster); the left-out pedestrians push nobody.
"""

import numpy as np

from dcmppi.control.kernels import social as force
from dcmppi.control.predictors.base import register_predictor
from dcmppi.control.predictors.cv import ConstantVelocity
from dcmppi.control.validation import flag


@register_predictor("social")
class Social(ConstantVelocity):
    """P social-force futures of the pedestrians within reach (module docstring).

    Extra args: cv_std: std of each future's desired-velocity error per axis [m/s] (>= 0);
    reactive: whether the predicted pedestrians avoid the robot's plan (bool).
    """

    inputs = ("velocity", "robot_plan")
    own_params = ("cv_std", "reactive")

    def __init__(self, *, reactive=True, **params):
        self.reactive = flag("reactive", reactive)
        super().__init__(**params)

    def predict(self, state, moving, obstacle_model, rng, velocity=None, robot_plan=None):
        """As Predictor.predict; velocity (L, 2) observed; robot_plan (N + 1, 3) the robot's
        planned states, or None: nothing pushes the pedestrians but themselves."""
        if len(moving) == 0:
            return self.none()
        desired = self.velocities(moving, velocity, rng)  # (L, P, 2)
        cap = force.MAX_SPEED_FACTOR * np.hypot(desired[..., 0], desired[..., 1]).max(axis=1)
        radius = moving[:, 3] + self.obstacle_margin
        near = self.within_reach(state, moving[:, None, :2], cap[:, None], radius)
        if not near.any():
            return self.none()
        desired = np.ascontiguousarray(desired[near].transpose(1, 0, 2))  # (P, n, 2)
        if robot_plan is None or not self.reactive:
            path, robot = np.zeros((self.N + 1, 0, 2)), np.zeros(0)
        else:
            path, robot = np.asarray(robot_plan)[:, None, :2], np.array([self.robot_radius])
        futures = force.rollout(
            np.broadcast_to(moving[near, :2], desired.shape), desired, desired, moving[near, 3],
            cap[near], self.dt, self.N, path, robot, None,
        )  # fmt: skip
        return self.prediction(np.ascontiguousarray(futures.transpose(1, 0, 2, 3)), radius[near])
