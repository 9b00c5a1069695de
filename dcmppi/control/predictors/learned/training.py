"""The learned model's training (`fit`): every window's features and future kept, and the
shrink lambda fitted by least squares on held-out folds (each recording held out in turn): the
mean of few neighbours is noisy and a model trained on other scenes biased, so a forecast moves
only as far from constant velocity as held-out data supports (model.py's docstring).
"""

import numpy as np

from dcmppi.control.predictors.learned.model import (
    NEIGHBOURS,
    SOCIAL_WEIGHT,
    SPEED_FLOOR,
    Model,
    feature_weights,
    features,
    heading_and_speed,
    neighbours_now,
    rotate,
)
from dcmppi.control.validation import positive

FIT_K = 20  # retrieved futures per window when fitting the shrink
FOLDS = 5  # held-out folds of the shrink when the windows come from one recording


def fit(
    windows,
    seed=0,
    max_windows=None,
    neighbours=NEIGHBOURS,
    social_weight=SOCIAL_WEIGHT,
) -> Model:
    """A Model of `windows`: any object with observed (M, obs, 2), future (M, pred, 2),
    neighbours ((K_m, obs, 2) per window, nan where not seen), source (M,) its recording, period.

    max_windows: train on this many windows drawn without replacement by `seed` (None: all).
    Deterministic for a seed.

    Raises:
      ValueError: max_windows not a count > 0, or fewer than 2 windows.
    """
    if max_windows is not None:
        max_windows = positive("max_windows", max_windows, integer=True)
    observed = np.asarray(windows.observed, dtype=float)
    future = np.asarray(windows.future, dtype=float)
    source = np.asarray(windows.source)
    chosen = np.arange(len(observed))
    if max_windows is not None and max_windows < len(chosen):
        chosen = np.sort(np.random.default_rng(seed).choice(len(chosen), max_windows, False))
    if len(chosen) < 2:
        raise ValueError(f"windows: a model needs at least 2 windows; got {len(chosen)}")
    observed, future, source = observed[chosen], future[chosen], source[chosen]
    others, velocity = neighbours_now([windows.neighbours[i] for i in chosen])
    heading, speed = heading_and_speed(observed)
    scale = np.maximum(speed, SPEED_FLOOR)
    x = features(observed, others, velocity, heading, scale, neighbours)
    x *= feature_weights(observed.shape[1], neighbours, social_weight)
    local = rotate(future - observed[:, None, -1], -heading[:, None]) / scale[:, None, None]
    shrink = _shrink(x, local, source, speed, scale)
    return Model(
        x, local, observed.shape[1], windows.period, shrink, neighbours, social_weight, seed
    )


def _shrink(x, local, source, speed, scale) -> float:
    """lambda in [0, 1] of least squares over held-out folds: each recording (or, from one
    recording, each of FOLDS blocks) forecast by a tree of the others' windows.

    x: (M, D) the weighted features; local: (M, pred, 2) the futures in the heading frame / scale.
    """
    from scipy.spatial import KDTree

    folds = np.unique(source)
    groups = source if len(folds) > 1 else np.arange(len(source)) * FOLDS // len(source)
    t = np.arange(1, local.shape[1] + 1)
    num = den = 0.0
    for g in np.unique(groups):
        held = groups == g
        if held.all():
            continue
        rest = np.flatnonzero(~held)
        k = min(FIT_K, len(rest))
        index = rest[KDTree(x[rest]).query(x[held], k=k)[1]]
        s = scale[held, None, None]
        mean = (local[index.reshape(held.sum(), k)] * s[..., None]).mean(axis=1)
        cv = np.zeros_like(mean)
        cv[..., 0] = speed[held, None] * t
        truth = local[held] * s
        num += np.sum((mean - cv) * (truth - cv))
        den += np.sum((mean - cv) ** 2)
    return float(np.clip(num / den, 0.0, 1.0)) if den > 0 else 1.0
