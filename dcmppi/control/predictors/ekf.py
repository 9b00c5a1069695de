"""Futures drawn from each obstacle's own filter (paper Sec. IV-B), weight beta / P.

Each obstacle's whole state (x, y, heading, speed, turn rate) is drawn P times from the
posterior of a Gaussian-sum EKF (predictors.filter.ObstacleFilter): started from the population
prior (obstacle_model) at the first step with obstacles, it takes the observed positions once
per step (headings are not used), dt apart, with position noise std `measurement_std` and the
random-walk process noise `process_std` (x, y, heading, speed, turn rate per sqrt(s)). Obstacles
are matched by index; their number must stay the same until reset(). Each draw becomes a Dubins
arc as in "prior".
"""

import dataclasses

from dcmppi.control.predictors.base import check_obstacle_model, register_predictor
from dcmppi.control.predictors.filter import (
    MEASUREMENT_STD,
    PROCESS_STD,
    ObstacleFilter,
    check_process_std,
)
from dcmppi.control.predictors.prior import SampledFutures
from dcmppi.control.validation import positive


@register_predictor("ekf")
class EKF(SampledFutures):
    """Sampled futures from a Gaussian-sum EKF per obstacle (module docstring).

    Extra args: measurement_std: the obstacle sensor's position noise std [m] (> 0);
    process_std: (5,) the filter's random walk per sqrt(s) (default: filter.PROCESS_STD, the
    crowd's near-exact Dubins model; pedestrians need more, design.md).
    """

    own_params = ("measurement_std", "process_std")

    def __init__(self, *, measurement_std=MEASUREMENT_STD, process_std=PROCESS_STD, **shared):
        self.measurement_std = positive("measurement_std", measurement_std)
        self.process_std = check_process_std(process_std)
        super().__init__(**shared)
        self.filter = None

    def reset(self):
        self.filter = None

    def predict(self, state, moving, obstacle_model, rng):
        posterior = None
        if len(moving) or self.filter is not None:  # starts at the first step with obstacles
            if self.filter is None:
                model = check_obstacle_model(obstacle_model, self.name)
                self.filter = ObstacleFilter(
                    model, self.measurement_std, self.dt, process_std=self.process_std
                )
            self.filter.update(moving[:, :2])
            posterior = self.filter.posterior()
        if len(moving) == 0:
            return _with(self.none(), posterior)
        drawn = self.filter.sample(rng, self.P)  # (L, P, 5)
        pose, speed, turn = drawn[..., :3], drawn[..., 3], drawn[..., 4]
        return _with(self.futures(state, moving, pose, speed, turn), posterior)


def _with(prediction, posterior):
    """The prediction with the filter's posterior for the diagnostics."""
    return dataclasses.replace(prediction, posterior=posterior)
