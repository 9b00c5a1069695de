"""Forecasts of recorded people: the standard ETH/UCY protocol and its metrics.

    metrics.py       ADE / FDE (most likely, best of P), the KDE NLL and 90 % coverage of the
                     whole sample set
    forecasters.py   constant velocity, with heading noise, and any registered predictor
                     through its Predictor interface
    evaluation.py    leave one scene out, every window: `evaluate` and its `table`

May import dcmppi.control (the predictors, the learned model) and dcmppi.tasks (the recordings).
"""

from dcmppi.bench.forecasts.evaluation import evaluate, table

__all__ = ["evaluate", "table"]
