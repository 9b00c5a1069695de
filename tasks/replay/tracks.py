"""A recorded person's track read at any instant, and the replaced person as the robot's
reference.

Between annotated frames a track is linear (`interp`; its velocity: `slope`). The replaced
person's own track is the human reference (`Human`): their time to the goal region and their
path to it, sampled at the recording's frame period as `sampled_path_length` samples the robot's
(a path sampled every 0.1 s is longer than the same path every 0.4 s, from jitter).
"""

import dataclasses
import math

import numpy as np

from dcmppi.control import defaults

from ..worlds.base import GOAL_TOLERANCE


@dataclasses.dataclass(frozen=True)
class Human:
    """The replaced person, the reference the robot is compared with.

    recording: the file's name; id: the person's id; times (n,) [s] from their first
    annotation; xy (n, 2) their annotated positions; period [s] between annotated frames;
    duration [s]: first to last annotation; time_to_goal [s]: the first control instant at
    which their track is within GOAL_TOLERANCE of their last position (how the robot's goal is
    judged); path_length [m]: their path to there, sampled at the period (`sampled_path_length`).
    """

    recording: str
    id: int
    times: np.ndarray
    xy: np.ndarray
    period: float
    duration: float
    time_to_goal: float
    path_length: float


def top_speed(track) -> float:
    """The fastest speed [m/s] of a track between consecutive annotated frames (0: one frame)."""
    if len(track.times) < 2:
        return 0.0
    return float((np.hypot(*np.diff(track.xy, axis=0).T) / np.diff(track.times)).max())


def start_pose(track) -> np.ndarray:
    """(3,) the first position and the heading of the first displacement (0 if none)."""
    moves = np.diff(track.xy, axis=0)
    moving = np.flatnonzero(np.hypot(*moves.T) > 0)
    d = moves[moving[0]] if len(moving) else np.zeros(2)
    return np.array([*track.xy[0], math.atan2(d[1], d[0])])


def sampled_path_length(times, xy, period) -> float:
    """The length [m] of a path xy (n, 2) at increasing times (n,) [s], sampled every `period`
    from its first time and at its last (linear between the given points)."""
    times, xy = np.asarray(times, dtype=float), np.asarray(xy, dtype=float)
    span = times[-1] - times[0]
    grid = times[0] + period * np.arange(int(math.floor(span / period + 1e-9)) + 1)
    if grid[-1] < times[-1] - 1e-9:
        grid = np.append(grid, times[-1])
    points = np.column_stack([np.interp(grid, times, xy[:, 0]), np.interp(grid, times, xy[:, 1])])
    return float(np.hypot(*np.diff(points, axis=0).T).sum())


def human(recording, person, dt=defaults.DT) -> Human:
    """The Human reference of track `person` of `recording` (control period dt [s])."""
    track = recording.tracks[person]
    times = track.times - track.times[0]
    goal = track.xy[-1]
    # the control instants until the last annotation, and one after it (at the goal)
    instants = np.arange(int(math.floor(times[-1] / dt + 1e-9)) + 2) * dt
    at = interp(instants, times, track.xy)
    k = int(np.flatnonzero(np.hypot(*(at - goal).T) <= GOAL_TOLERANCE)[0])
    until = times < instants[k]
    path_t = np.append(times[until], instants[k])
    path_xy = np.vstack([track.xy[until], at[k]])
    return Human(
        recording.name,
        track.id,
        times,
        track.xy,
        recording.period,
        float(times[-1]),
        float(instants[k]),
        sampled_path_length(path_t, path_xy, recording.period),
    )


def interp(t, times, xy) -> np.ndarray:
    """Positions (len(t), 2) of the track xy (n, 2) at `times`, linear between them."""
    return np.column_stack([np.interp(t, times, xy[:, 0]), np.interp(t, times, xy[:, 1])])


def slope(t, times, xy) -> np.ndarray:
    """The velocity (2,) of the linear track at time t: its segment ending at or after t
    (the first for t at the first time; zero for a single annotation)."""
    if len(times) < 2:
        return np.zeros(2)
    i = min(max(int(np.searchsorted(times, t)) - 1, 0), len(times) - 2)
    return (xy[i + 1] - xy[i]) / (times[i + 1] - times[i])
