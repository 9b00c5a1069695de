"""How constant-velocity extrapolation errs in recorded crowds, by observed speed (`dcmppi
crowds spread`): what the `cv` predictor's cv_std and cv_std_still stand for.

At every annotation k >= 1 of every track, v = (x_k - x_{k-1}) / (t_k - t_{k-1}) is the observed
velocity and, for each horizon H whose instant t_k + H the track still covers, the velocity
error is (x(t_k + H) - x_k - v H) / H (x(t) interpolated linearly between annotations). A speed
bin's spread is the root mean square of the errors' components: the std per axis of a zero-mean
velocity error, as `cv_std` is.
"""

import numpy as np

HORIZONS = (1.2, 2.4, 4.8)  # [s]
SPEED_BINS = (0.0, 0.1, 0.3, 0.6, 1.0, 1.4, 2.0)  # [m/s] bin edges (the last bin is open)


def velocity_errors(recording, horizons=HORIZONS) -> tuple:
    """speed (n,) [m/s] and error (n, H, 2) [m/s] (nan beyond a track's end) at every
    annotation k >= 1 of every track of `recording` (module docstring)."""
    speeds, errors = [np.zeros(0)], [np.zeros((0, len(horizons), 2))]
    for track in recording.tracks:
        t, xy = track.times, track.xy
        if len(t) < 2:
            continue
        v = np.diff(xy, axis=0) / np.diff(t)[:, None]  # (n - 1, 2) at annotations 1 .. n - 1
        error = np.full((len(v), len(horizons), 2), np.nan)
        for h, horizon in enumerate(horizons):
            later = t[1:] + horizon
            inside = later <= t[-1]
            at = np.column_stack([np.interp(later, t, xy[:, 0]), np.interp(later, t, xy[:, 1])])
            e = (at - xy[1:] - v * horizon) / horizon
            error[inside, h] = e[inside]
        speeds.append(np.hypot(v[:, 0], v[:, 1]))
        errors.append(error)
    return np.concatenate(speeds), np.concatenate(errors)


def by_speed(recordings, horizons=HORIZONS, bins=SPEED_BINS) -> list:
    """One row per speed bin of all `recordings`: {"low", "high" (None: open), "samples" (per
    horizon), "spread" (per horizon, [m/s]; None without samples), "median" (per horizon: of
    the error's norm)}."""
    found = [velocity_errors(r, horizons) for r in recordings]
    speed = np.concatenate([f[0] for f in found])
    error = np.concatenate([f[1] for f in found])
    edges = [*bins, np.inf]
    rows = []
    for low, high in zip(edges[:-1], edges[1:], strict=True):
        rows.append(_row(error[(speed >= low) & (speed < high)], low, high))
    return rows


def _row(error, low, high) -> dict:
    """The row of the errors (m, H, 2) of one speed bin."""
    valid = ~np.isnan(error[..., 0])  # (m, H)
    samples = valid.sum(axis=0)
    spread, median = [], []
    for h in range(error.shape[1]):
        e = error[valid[:, h], h]
        spread.append(float(np.sqrt(np.mean(e**2))) if len(e) else None)
        median.append(float(np.median(np.hypot(e[:, 0], e[:, 1]))) if len(e) else None)
    return {
        "low": float(low),
        "high": None if np.isinf(high) else float(high),
        "samples": [int(n) for n in samples],
        "spread": spread,
        "median": median,
    }


def table(rows, horizons=HORIZONS) -> str:
    """The rows as a markdown table: samples at the middle horizon, the spread at each."""
    middle = len(horizons) // 2
    head = ["observed speed [m/s]", f"samples (H = {horizons[middle]:g} s)"]
    head += [f"H = {h:g} s" for h in horizons]
    lines = ["| " + " | ".join(head) + " |", "|---|" + "---:|" * (len(head) - 1)]
    for row in rows:
        name = (
            f"{row['low']:g} and over" if row["high"] is None else f"{row['low']:g}-{row['high']:g}"
        )
        cells = [name, str(row["samples"][middle])]
        cells += ["-" if s is None else f"{s:.2f}" for s in row["spread"]]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)
