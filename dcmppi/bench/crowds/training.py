"""A learned predictor's model of recorded crowds: what `dcmppi predictor train` and a model
recipe run. Deterministic: the same recordings, seed and window count give the same bytes."""

from dcmppi.control.predictors import learned
from dcmppi.tasks.replay import recordings


def read(names, folder=None, period=recordings.PERIOD) -> list:
    """The Recordings of files `names` (paths, or names of recordings.FILES in `folder`, else
    $DCMPPI_CROWDS), every one read at `period` [s] between frames."""
    return [recordings.load(name, folder, period) for name in names]


def train(data, out, seed=0, max_windows=None) -> learned.Model:
    """A learned predictor's model of `data` (Recordings of one period) written to `out`; at
    most `max_windows` windows, drawn by `seed` (None: all)."""
    model = learned.fit(recordings.windows(data), seed, max_windows=max_windows)
    model.save(out)
    return model
