"""Constant-velocity futures (the field's standard predictor), weight beta / P.

Future p of moving obstacle l walks straight on from the observed position o_l with the
observed velocity v_l plus an error dv_lp ~ N(0, cv_std^2 I) drawn once per future from the
planner's rng:

    o_l^p(t_i) = o_l + (v_l + dv_lp) t_i,   t_i = i dt, i = 0..N,

so the futures spread linearly with time (std sigma_l t_i per axis). sigma_l is cv_std, or with
cv_std_still given, a ramp from cv_std_still for an obstacle observed standing to cv_std at
STILL_SPEED and above: in the ETH/UCY recordings people standing (under 0.1 m/s) keep their
velocity 2-3 times as well as walkers do (docs/crowds.md). Every future has
theta = 1 / P, a certain collision with an obstacle costs beta, as in "prior". An obstacle is
left out exactly as in "prior", with |v_l + dv_lp| as the speed of future p.

The velocities are the observation's (Controller.act's moving_velocity, predictor input
"velocity"): a step with a moving obstacle whose velocity is missing (None, or nan: a sensor of
positions only) is an error.
"""

import numpy as np

from dcmppi.control.kernels.normal import standard_normal
from dcmppi.control.predictors.base import register_predictor
from dcmppi.control.predictors.prior import SampledFutures
from dcmppi.control.validation import positive

# Velocity error std per axis [m/s]: pedestrians walk at 1-1.5 m/s and change speed and heading
# within a few seconds; 0.3 m/s (a quarter of a walking speed, a heading error of about 15 deg)
# spreads the futures by about 1.5 m at a 5 s horizon, a sidestep or a slowdown.
CV_STD = 0.3
# Speed [m/s] from which an obstacle's error is cv_std: in the recordings, people at 0.1-0.3 m/s
# already change their velocity as much as walkers.
STILL_SPEED = 0.3


def check_velocity(velocity, moving, name):
    """The (L, 2) velocities of the L moving obstacles (L > 0), or a ValueError naming the fix."""
    velocity = None if velocity is None else np.asarray(velocity, dtype=float)
    if velocity is None or np.isnan(velocity).any():
        raise ValueError(
            f"prediction {name!r} needs the moving obstacles' velocities (moving_velocity); "
            "this observation has none: observe them (obstacle_measurement_std = 0) or use "
            "prediction='ekf'"
        )
    if velocity.shape != (len(moving), 2):
        raise ValueError(
            f"velocity must have shape ({len(moving)}, 2), one row per moving obstacle; got "
            f"{velocity.shape}"
        )
    return velocity


@register_predictor("cv")
class ConstantVelocity(SampledFutures):
    """P constant-velocity futures per obstacle (module docstring).

    Extra args: cv_std: std of each future's velocity error per axis [m/s] (>= 0);
    cv_std_still: the std for an obstacle observed standing [m/s] (>= 0; None: cv_std).
    """

    own_params = ("cv_std", "cv_std_still")
    inputs = ("velocity",)

    def __init__(self, *, cv_std=CV_STD, cv_std_still=None, **shared):
        self.cv_std = positive("cv_std", cv_std, allow_zero=True)
        if cv_std_still is not None:
            cv_std_still = positive("cv_std_still", cv_std_still, allow_zero=True)
        self.cv_std_still = cv_std_still
        super().__init__(**shared)

    def velocities(self, moving, velocity, rng):
        """(L, P, 2) the velocity of every future: v_l + dv_lp of the L moving obstacles."""
        velocity = check_velocity(velocity, moving, self.name)
        std = self.cv_std
        if self.cv_std_still is not None:
            ramp = np.minimum(np.hypot(velocity[:, 0], velocity[:, 1]) / STILL_SPEED, 1.0)
            std = (self.cv_std_still + (self.cv_std - self.cv_std_still) * ramp)[:, None, None]
        return velocity[:, None] + std * standard_normal(rng, (len(moving), self.P, 2))

    def predict(self, state, moving, obstacle_model, rng, velocity=None):
        if len(moving) == 0:
            return self.none()
        v = self.velocities(moving, velocity, rng)
        radius = moving[:, 3] + self.obstacle_margin
        near = self.within_reach(state, moving[:, None, :2], np.hypot(v[..., 0], v[..., 1]), radius)
        t = self.dt * np.arange(self.N + 1)
        futures = moving[near, None, None, :2] + v[near, :, None] * t[:, None]
        return self.prediction(futures, radius[near])
