"""A learned predictor's model of recorded crowds: what `dcmppi predictor train` and a model
recipe run. Deterministic: the same recordings, seed and window count give the same bytes."""

import numpy as np

from dcmppi.control.predictors import learned
from dcmppi.tasks.replay import recordings


def read(names, folder=None, period=recordings.PERIOD, **reading) -> list:
    """The Recordings of files `names` (paths, or names of recordings.FILES in `folder`, else
    $DCMPPI_CROWDS), every one read at `period` [s] between frames (`reading`: recordings.load's
    frame_step, max_speed, max_gap)."""
    return [recordings.load(name, folder, period, **reading) for name in names]


def train(data, out, seed=0, max_windows=None, obs=8, pred=12) -> learned.Model:
    """A learned predictor's model of `data` (Recordings of one period) written to `out`; at
    most `max_windows` windows of obs + pred frames, drawn by `seed` (None: all).

    Raises:
      ValueError: one line naming the recordings where they hold fewer than 2 windows.
    """
    windows = recordings.windows(data, obs, pred)
    if len(windows) < 2:
        longest = max((_longest_run(r, t) for r in data for t in r.tracks), default=0)
        raise ValueError(
            f"{', '.join(r.name for r in data) or 'no recording'}: {len(windows)} windows of "
            f"{obs + pred} consecutive annotated frames of one person (the longest run has "
            f"{longest}); a model needs at least 2: train on longer recordings"
        )
    model = learned.fit(windows, seed, max_windows=max_windows)
    model.save(out)
    return model


def _longest_run(recording, track) -> int:
    """The most consecutive annotated frames of `track`."""
    breaks = np.flatnonzero(np.diff(track.frames) != recording.frame_step)
    edges = np.r_[0, breaks + 1, len(track.frames)]
    return int(np.diff(edges).max())
