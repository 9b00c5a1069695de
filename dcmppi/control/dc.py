"""DC-MPPI (paper Alg. 3): sampled futures of the moving obstacles in the cost, then Alg. 2.

Once per control step, every moving obstacle gets P futures, each a Dubins arc with one constant
speed and turn rate drawn from the known Gaussian (v_mean, v_std, omega_mean, omega_std); the
true obstacles keep theirs constant too. Speeds are clipped at 0 (a Dubins obstacle does not
reverse); reflections off the map boundary are not predicted (5 s horizon). Every future has
theta = 1 / P (a Monte-Carlo collision probability) and a state x_i pays
beta * sum_l sum_p theta * 1[|p_i - o_l^p(t_i)| <= robot_radius + r_l] (paper Eq. 30-31).

An obstacle is skipped when none of its futures can reach any rollout within the horizon:
|p_0 - o_l(0)| > (v + max_p v_lp) N dt + robot_radius + r_l, with v the agent's top speed and
r_l the obstacle's radius plus `obstacle_margin`. This is exact, not a heuristic.

Moving obstacles enter dc's cost only through these futures (their t = 0 positions included,
with weight beta), not also as alpha-weighted static obstacles: the paper's augmented cost
(Eq. 30-31) adds the beta term to the static-map cost psi, and alpha = 100 beta would otherwise
dominate the prediction and turn dc back into clustered MPPI around frozen obstacles.
"""

import numpy as np

from .clustered import ClusteredMPPI
from .controllers import register
from .dynamics import obstacle_futures


def sample_speeds(rng, obstacle_model, L, P):
    """Speeds and turn rates (L, P) each of P futures of L obstacles from the known Gaussian.

    obstacle_model: (4,) v_mean, v_std, omega_mean, omega_std. Speeds are clipped at 0.
    """
    v_mean, v_std, w_mean, w_std = obstacle_model
    z = rng.standard_normal((2, L, P))
    return np.maximum(v_mean + v_std * z[0], 0.0), w_mean + w_std * z[1]


@register("dc")
class DCMPPI(ClusteredMPPI):
    """DC-MPPI, paper Alg. 3 (parameters: ClusteredMPPI's; beta and P are used here)."""

    def _prepare_obstacles(self, state, moving, obstacle_model):
        if len(moving) == 0:
            self._tracks, self._track_distance = np.zeros((0, self.N + 1, 2)), np.zeros(0)
            self.diagnostics.obstacle_samples = np.zeros((0, self.P, self.N + 1, 2))
            return
        if obstacle_model is None:
            raise ValueError("dc needs obstacle_model (v_mean, v_std, omega_mean, omega_std)")
        obstacle_model = np.asarray(obstacle_model, dtype=float)
        if (
            obstacle_model.shape != (4,)
            or not np.isfinite(obstacle_model).all()
            or obstacle_model[1] < 0
            or obstacle_model[3] < 0
        ):
            raise ValueError(
                f"obstacle_model must be (4,) finite v_mean, v_std >= 0, omega_mean, "
                f"omega_std >= 0; got {obstacle_model}"
            )
        speed, turn = sample_speeds(self.rng, obstacle_model, len(moving), self.P)
        radius = moving[:, 3] + self.obstacle_margin
        top = self.agent.max_speed + speed.max(axis=1)
        reach = top * self.N * self.dt + self.robot_radius + radius
        near = np.hypot(moving[:, 0] - state[0], moving[:, 1] - state[1]) <= reach
        futures = obstacle_futures(moving[near], speed[near], turn[near], self.N, self.dt)
        self._tracks = futures.reshape(-1, self.N + 1, 2)
        self._track_distance = np.repeat(radius[near] + self.robot_radius, self.P)
        self._track_weight = self.beta / self.P
        self.diagnostics.obstacle_samples = futures
