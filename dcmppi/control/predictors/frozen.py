"""The moving obstacles seen as static where they are now, weight alpha (mppi, clustered, tube).

An obstacle is left out when no rollout can reach it within the horizon:
|p_0 - o_l| > v N dt + robot_radius + r_l, v the agent's top speed, r_l the obstacle's radius
plus obstacle_margin.
"""

import numpy as np

from dcmppi.control.predictors.base import Prediction, Predictor, register_predictor


@register_predictor("frozen")
class Frozen(Predictor):
    """Each moving obstacle frozen at its current position (module docstring)."""

    def predict(self, state, moving, obstacle_model, rng):
        if len(moving) == 0:  # the static tasks: none of the work below
            return self.none()
        radius = moving[:, 3] + self.obstacle_margin
        reach = self.max_speed * self.N * self.dt + self.robot_radius + radius
        near = np.hypot(moving[:, 0] - state[0], moving[:, 1] - state[1]) <= reach
        frozen = moving[near]
        tracks = np.broadcast_to(frozen[:, None, :2], (len(frozen), self.N + 1, 2))
        return Prediction(tracks, radius[near] + self.robot_radius, self.alpha)
