"""DC-MPPI's futures (paper Alg. 3): P sampled Dubins arcs per moving obstacle, weight beta / P.

Every moving obstacle gets P futures, each an arc with one constant speed and turn rate drawn from
the known Gaussian obstacle_model (v_mean, v_std, omega_mean, omega_std), speeds clipped at 0 (a
Dubins obstacle does not reverse), from the observed position and heading. An obstacle whose
heading is not observed (nan, a sensor of positions only) gets a heading uniform in [0, 2 pi) per
future. Reflections off the map boundary are not predicted (5 s horizon). Every future has
theta = 1 / P (a Monte-Carlo collision probability) and a state x_i pays
beta * sum_l sum_p theta * 1[|p_i - o_l^p(t_i)| <= robot_radius + r_l] (paper Eq. 30-31).

An obstacle is left out when none of its futures can reach any rollout within the horizon:
|p_0 - o_l^p(0)| > (v + |v_lp|) N dt + robot_radius + r_l for every p, with v the agent's top
speed and r_l the obstacle's radius plus `obstacle_margin`. This is exact, not a heuristic.

Moving obstacles enter the cost only through these futures (their t = 0 positions included,
with weight beta), not also as alpha-weighted static obstacles: the paper's augmented cost
(Eq. 30-31) adds the beta term to the static-map cost psi, and alpha = 100 beta would otherwise
dominate the prediction and turn dc back into clustered MPPI around frozen obstacles.
"""

import numpy as np

from dcmppi.control.kernels.dynamics import obstacle_futures
from dcmppi.control.kernels.normal import standard_normal
from dcmppi.control.predictors.base import (
    Prediction,
    Predictor,
    check_obstacle_model,
    register_predictor,
)


def sample_speeds(rng, obstacle_model, L, P):
    """Speeds and turn rates (L, P) each of P futures of L obstacles from the known Gaussian.

    obstacle_model: (4,) v_mean, v_std, omega_mean, omega_std. Speeds are clipped at 0.
    """
    v_mean, v_std, w_mean, w_std = obstacle_model
    z = standard_normal(rng, (2, L, P))
    return np.maximum(v_mean + v_std * z[0], 0.0), w_mean + w_std * z[1]


class SampledFutures(Predictor):
    """Base of the predictors of P Dubins futures per obstacle (weight beta / P)."""

    def futures(self, state, moving, pose, speed, turn):
        """The Prediction of the futures of the obstacles within reach.

        pose: (L, 1, 3) or (L, P, 3) start poses; speed, turn: (L, P) of the moving (L, 4).
        """
        radius = moving[:, 3] + self.obstacle_margin
        near = self.within_reach(state, pose, speed, radius)
        n = int(near.sum())
        pose = np.broadcast_to(pose[near], (n, self.P, 3))
        futures = obstacle_futures(
            pose.reshape(-1, 3), speed[near].reshape(-1, 1), turn[near].reshape(-1, 1),
            self.N, self.dt,
        ).reshape(n, self.P, self.N + 1, 2)  # fmt: skip
        return self.prediction(futures, radius[near])

    def within_reach(self, state, start, speed, radius):
        """(L,) whether any future of each obstacle can come within collision distance of a
        rollout: |p_0 - start| <= (v + speed) N dt + robot_radius + radius for some future.

        start: (L, 1, >=2) or (L, P, >=2) start positions (x, y first); speed: (L, P) bounds of
        the futures' speeds; radius: (L,) obstacle radii with the margin.
        """
        reach = (self.max_speed + np.abs(speed)) * self.N * self.dt + self.robot_radius
        reach = reach + radius[:, None]
        gap = np.hypot(start[..., 0] - state[0], start[..., 1] - state[1])  # (L, 1) or (L, P)
        return (gap <= reach).any(axis=1)

    def prediction(self, futures, radius):
        """The Prediction of futures (n, F, N + 1, 2) of n obstacles of radii (n,) (with the
        margin): every future a track of weight beta / F (F = P for the sampled ones)."""
        count = futures.shape[1]
        return Prediction(
            futures.reshape(-1, self.N + 1, 2),
            np.repeat(radius + self.robot_radius, count),
            self.beta / count,
            futures,
            collision_cost=self.beta,
        )

    def empty(self):
        return Prediction(
            np.zeros((0, self.N + 1, 2)),
            np.zeros(0),
            self.beta / self.P,
            np.zeros((0, self.P, self.N + 1, 2)),
            collision_cost=self.beta,
        )


@register_predictor("prior")
class Prior(SampledFutures):
    """P futures per obstacle from the population Gaussian (module docstring)."""

    def predict(self, state, moving, obstacle_model, rng):
        if len(moving) == 0:
            return self.none()
        model = check_obstacle_model(obstacle_model, self.name)
        speed, turn = sample_speeds(rng, model, len(moving), self.P)
        pose = moving[:, None, :3]  # (L, 1, 3): the futures of an obstacle start alike
        unseen = np.isnan(moving[:, 2])
        if unseen.any():
            pose = np.repeat(pose, self.P, axis=1)
            pose[unseen, :, 2] = rng.uniform(0.0, 2.0 * np.pi, (unseen.sum(), self.P))
        return self.futures(state, moving, pose, speed, turn)
