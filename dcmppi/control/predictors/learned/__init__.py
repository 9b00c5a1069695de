"""The learned predictor: futures of recorded crowds, the continuations of the most similar
recorded situations (nearest-neighbour retrieval of whole trajectories), weight beta / P.

    model.py      the Model: a person's features, the retrieval of P futures (`forecast`), the
                  model file (`save`, `load`, `sha256`)
    training.py   `fit`: a Model of forecasting windows, its shrink fitted on held-out folds
    predictor.py  the predictor `learned` (`Learned`): the pedestrians tracked step by step and
                  forecast by a model file

A model's file comes from recorded crowds: `dcmppi predictor train`, or a model recipe of an
experiment (dcmppi.bench.crowds). Like every predictor, no MuJoCo and no tasks: numpy and scipy
(the k-d tree, the tracks' assignment).
"""

from dcmppi.control.predictors.learned.model import (
    APPROXIMATION,
    Model,
    load,
    neighbours_now,
    rotate,
    sha256,
)
from dcmppi.control.predictors.learned.predictor import Learned
from dcmppi.control.predictors.learned.training import fit

__all__ = ["APPROXIMATION", "Learned", "Model", "fit", "load", "neighbours_now", "rotate", "sha256"]
