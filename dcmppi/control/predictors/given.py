"""Futures the caller gives: Controller.act(..., moving_futures=) (predictor input "futures").

For a robot whose own forecaster (a learnt model, a tracker's) predicts the moving obstacles,
and for the benchmark's oracle: where the obstacles ignore the robot their true paths are known
in advance (dcmppi.bench.episodes.runner gives them), which says how far a planner gets with a
perfect prediction. F futures per obstacle, each weight beta / F; a certain collision costs beta, as
with the sampled futures of "prior". An obstacle is left out when none of its futures comes
within reach of a rollout at any step.
"""

import numpy as np

from dcmppi.control.predictors.base import register_predictor
from dcmppi.control.predictors.prior import SampledFutures


@register_predictor("given")
class Given(SampledFutures):
    """The caller's futures (L, F, N + 1, 2) of the L moving obstacles (module docstring)."""

    inputs = ("futures",)

    def predict(self, state, moving, obstacle_model, rng, futures=None):
        if len(moving) == 0:
            return self.none()
        futures = check_futures(futures, len(moving), self.N)
        radius = moving[:, 3] + self.obstacle_margin
        near = self.reached(state, futures, radius)
        return self.prediction(futures[near], radius[near])

    def reached(self, state, futures, radius):
        """(L,) whether some future of each obstacle comes within collision distance of some
        rollout: |f(t_i) - p_0| <= v_max t_i + robot_radius + radius at some step i. The others
        cost nothing, and their far positions would only spread the step's track cells."""
        t = np.arange(self.N + 1) * self.dt
        reach = self.max_speed * t + self.robot_radius + radius[:, None, None]  # (L, 1, N + 1)
        gap = np.hypot(futures[..., 0] - state[0], futures[..., 1] - state[1])  # (L, F, N + 1)
        return (gap <= reach).any(axis=(1, 2))


def check_futures(futures, L, N) -> np.ndarray:
    """The (L, F, N + 1, 2) finite futures of L obstacles over N steps, or one ValueError."""
    if futures is None:
        raise ValueError(
            "prediction 'given' needs the moving obstacles' futures: act(..., moving_futures=) "
            f"of shape ({L}, F, {N + 1}, 2)"
        )
    futures = np.asarray(futures, dtype=float)
    if futures.ndim != 4 or futures.shape[0] != L or futures.shape[2:] != (N + 1, 2):
        raise ValueError(
            f"moving_futures must have shape ({L}, F, {N + 1}, 2): F futures of the {L} moving "
            f"obstacles at the {N + 1} rollout steps; got {futures.shape}"
        )
    if futures.shape[1] < 1 or not np.isfinite(futures).all():
        raise ValueError("moving_futures must hold at least one future, all finite")
    return futures
