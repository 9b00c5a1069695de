"""Obstacle predictors: what the moving obstacles will do over the horizon, as tracks that the
objective counts collisions with (the moving-obstacle term of the cost).

Every planner takes `prediction=` a registered name; `make_controller` passes a predictor's own
parameters (`own_params`) alongside the planner's. Built in:
- "frozen": the obstacles stay where they are now, weight alpha (mppi, clustered, tube);
- "prior": P sampled Dubins futures from the population Gaussian, weight beta / P (dc, paper
  Alg. 3);
- "ekf": P futures drawn from a Gaussian-sum EKF of each obstacle (parameter measurement_std);
- "cv": P constant-velocity futures from the observed velocities (parameter cv_std);
- "social": P social-force futures of the pedestrians, pushed by each other and the robot's plan
  (parameter cv_std);
- "given": the caller's own futures (act's moving_futures), e.g. a forecaster's or the truth;
- "learned": P recorded continuations of the most similar recorded situations, from a model
  that `dcmppi predictor train` fits to recorded crowds (parameter model: its file).
A new predictor is a `Predictor` subclass registered by name (README, "Your own predictor").
One module each, beside base.py (the interface, its result, the registry) and filter.py (the
EKF of one obstacle that "ekf" runs).

May import numpy, numba, scipy (the learned model), dcmppi.control's kernels (dynamics, normal,
social), validation and registry; never a planner, MuJoCo or the tasks (a predictor sees
observations, not the world).
"""

from dcmppi.control.predictors import cv, ekf, frozen, given, learned, prior, social  # noqa: F401  (registers the built-in predictors)
from dcmppi.control.predictors.base import (
    Prediction,
    Predictor,
    make_predictor,
    predictor_class,
    predictor_names,
    register_predictor,
)

__all__ = [
    "Prediction",
    "Predictor",
    "make_predictor",
    "predictor_class",
    "predictor_names",
    "register_predictor",
]
