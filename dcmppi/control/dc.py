"""DC-MPPI (paper Alg. 3): sampled futures of the moving obstacles in the cost, then Alg. 2.

Once per control step, every moving obstacle gets P futures, each a Dubins arc with one constant
speed and turn rate; the true obstacles keep theirs constant too. Where the futures come from
(`prediction`):
- "prior" (the paper's): speed and turn rate drawn from the known Gaussian (v_mean, v_std,
  omega_mean, omega_std), speeds clipped at 0 (a Dubins obstacle does not reverse), from the
  observed position and heading. An obstacle whose heading is not observed (nan, a sensor of
  positions only) gets a heading uniform in [0, 2 pi) per future.
- "ekf": each obstacle's whole state (x, y, heading, speed, turn rate) drawn from the posterior
  of its own filter (dcmppi.control.prediction.ObstacleFilter): started from the population
  prior at the first step with obstacles, it takes the observed positions once per act()
  (headings are not used), dt apart, with position noise std `measurement_std`. Obstacles are
  matched by index; their number must stay the same until reset().
Reflections off the map boundary are not predicted (5 s horizon). Every future has
theta = 1 / P (a Monte-Carlo collision probability) and a state x_i pays
beta * sum_l sum_p theta * 1[|p_i - o_l^p(t_i)| <= robot_radius + r_l] (paper Eq. 30-31).

An obstacle is skipped when none of its futures can reach any rollout within the horizon:
|p_0 - o_l^p(0)| > (v + |v_lp|) N dt + robot_radius + r_l for every p, with v the agent's top
speed and r_l the obstacle's radius plus `obstacle_margin`. This is exact, not a heuristic.

Moving obstacles enter dc's cost only through these futures (their t = 0 positions included,
with weight beta), not also as alpha-weighted static obstacles: the paper's augmented cost
(Eq. 30-31) adds the beta term to the static-map cost psi, and alpha = 100 beta would otherwise
dominate the prediction and turn dc back into clustered MPPI around frozen obstacles.
"""

import numpy as np

from .clustered import ClusteredMPPI
from .controllers import _positive, register
from .dynamics import obstacle_futures
from .normal import standard_normal
from .prediction import MEASUREMENT_STD, ObstacleFilter

PREDICTIONS = ("prior", "ekf")


def sample_speeds(rng, obstacle_model, L, P):
    """Speeds and turn rates (L, P) each of P futures of L obstacles from the known Gaussian.

    obstacle_model: (4,) v_mean, v_std, omega_mean, omega_std. Speeds are clipped at 0.
    """
    v_mean, v_std, w_mean, w_std = obstacle_model
    z = standard_normal(rng, (2, L, P))
    return np.maximum(v_mean + v_std * z[0], 0.0), w_mean + w_std * z[1]


def check_obstacle_model(obstacle_model):
    """The (4,) array v_mean, v_std, omega_mean, omega_std, or a ValueError."""
    if obstacle_model is None:
        raise ValueError("dc needs obstacle_model (v_mean, v_std, omega_mean, omega_std)")
    model = np.asarray(obstacle_model, dtype=float)
    if model.shape != (4,) or not np.isfinite(model).all() or model[1] < 0 or model[3] < 0:
        raise ValueError(
            f"obstacle_model must be (4,) finite v_mean, v_std >= 0, omega_mean, "
            f"omega_std >= 0; got {obstacle_model}"
        )
    return model


@register("dc")
class DCMPPI(ClusteredMPPI):
    """DC-MPPI, paper Alg. 3 (parameters: ClusteredMPPI's; beta and P are used here).

    Extra args: prediction ("prior" or "ekf", see the module docstring); measurement_std: the
    obstacle sensor's position noise std [m] (> 0), for "ekf".
    """

    own_params = ("prediction", "measurement_std")

    def __init__(self, *, prediction="prior", measurement_std=MEASUREMENT_STD, **params):
        if prediction not in PREDICTIONS:
            raise ValueError(f"prediction must be one of {PREDICTIONS}; got {prediction!r}")
        self.prediction = prediction
        self.measurement_std = _positive("measurement_std", measurement_std)
        super().__init__(**params)

    def reset(self, seed=None):
        """As Controller.reset; also forgets the obstacle filter."""
        super().reset(seed)
        self.filter = None

    def _prepare_obstacles(self, state, moving, obstacle_model):
        if self.prediction == "ekf" and (len(moving) or self.filter is not None):
            self._track(moving, obstacle_model)  # starts at the first step with obstacles
        if len(moving) == 0:
            self._tracks, self._track_distance = np.zeros((0, self.N + 1, 2)), np.zeros(0)
            self.diagnostics.obstacle_samples = np.zeros((0, self.P, self.N + 1, 2))
            return
        if self.prediction == "ekf":
            drawn = self.filter.sample(self.rng, self.P)  # (L, P, 5)
            pose, speed, turn = drawn[..., :3], drawn[..., 3], drawn[..., 4]
        else:
            model = check_obstacle_model(obstacle_model)
            speed, turn = sample_speeds(self.rng, model, len(moving), self.P)
            pose = moving[:, None, :3]  # (L, 1, 3): the futures of an obstacle start alike
            unseen = np.isnan(moving[:, 2])
            if unseen.any():
                pose = np.repeat(pose, self.P, axis=1)
                pose[unseen, :, 2] = self.rng.uniform(0.0, 2.0 * np.pi, (unseen.sum(), self.P))
        radius = moving[:, 3] + self.obstacle_margin
        reach = (self.agent.max_speed + np.abs(speed)) * self.N * self.dt + self.robot_radius
        reach = reach + radius[:, None]
        gap = np.hypot(pose[..., 0] - state[0], pose[..., 1] - state[1])  # (L, 1) or (L, P)
        near = (gap <= reach).any(axis=1)
        n = int(near.sum())
        pose = np.broadcast_to(pose[near], (n, self.P, 3))
        futures = obstacle_futures(
            pose.reshape(-1, 3), speed[near].reshape(-1, 1), turn[near].reshape(-1, 1),
            self.N, self.dt,
        ).reshape(n, self.P, self.N + 1, 2)  # fmt: skip
        self._tracks = futures.reshape(-1, self.N + 1, 2)
        self._track_distance = np.repeat(radius[near] + self.robot_radius, self.P)
        self._track_weight = self.beta / self.P
        self.diagnostics.obstacle_samples = futures

    def _track(self, moving, obstacle_model):
        """One filter update with the observed positions; the posterior into diagnostics."""
        if self.filter is None:
            self.filter = ObstacleFilter(
                check_obstacle_model(obstacle_model), self.measurement_std, self.dt
            )
        self.filter.update(moving[:, :2])
        d = self.diagnostics
        d.obstacle_mean, d.obstacle_cov = self.filter.posterior()
