"""Crowds for the learned predictor: its recorded and simulated data, its models as experiments
ask for them, its forecasts against the recordings.

    recording.py         simulated crowds recorded as ETH/UCY files (`dcmppi record`): the
                         moving obstacles of a task's episodes, the robot parked away
    training.py          a model of recordings (`dcmppi predictor train`, a recipe's training)
    recipes.py           model recipes: an experiment's `model` table resolved per environment
                         into a model file, trained on first use and cached
    forecast_metrics.py  ADE / FDE (most likely, best of P), the KDE NLL and 90 % coverage of
                         the whole sample set
    forecasters.py       constant velocity, with heading noise, and any registered predictor
                         through its Predictor interface
    evaluation.py        the standard ETH/UCY protocol, leave one scene out, every window:
                         `evaluate` and its `table` (`dcmppi predictor eval`)
    spread.py            constant velocity's error in the recordings by observed speed
                         (`dcmppi crowds spread`)

The learned model itself (features, retrieval, fit) is dcmppi.control.predictors.learned; the
ETH/UCY files are read by dcmppi.tasks.replay.recordings. May import dcmppi.bench.episodes (the
obstacles' own motion, the environments' seeds), dcmppi.control's predictors and presets
(dcmppi.control.defaults) and dcmppi.tasks; experiments use the recipes.
"""
