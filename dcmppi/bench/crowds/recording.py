"""Simulated crowds recorded as ETH/UCY recordings: the moving obstacles of a task's episodes
written in the four-column format (`dcmppi.tasks.replay.recordings`), so that the `learned`
predictor trains on them as on recorded people (`dcmppi record`, a model recipe's `record`).

The robot is absent: it is parked far away and still while the obstacles step by their own
model (`dcmppi.bench.episodes.futures.obstacle_tracks`, what the true futures use), so the
crowd walks as it would with nobody else there, whether or not it could see a robot
(`robot_visible`). The recordings are of crowds without a robot, as ETH/UCY's are, and where an
experiment's pedestrians are blind to the robot (square-orca, crowdnav), its test episodes move
exactly as recorded ones of their seeds would.

Episode e is the task with `random` = SeedSequence([base_seed, e])'s first word
(`environment_seed`: what an experiment of that base seed gives environment e), run for `seconds`
(default: the task's time limit); a frame every `period` seconds (a whole number of control
steps), the first at the reset. Each episode's frames follow the previous one's after a gap of
one frame, and each person (a row of the moving obstacles while it holds someone) gets an id of
their own, so no window or neighbour spans two episodes. A row that moves faster than the
recordings' MAX_SPEED within one control step has respawned (crowdnav_plus's humans, the
corridor's walkers): the people before and after are two.
"""

import numpy as np

from dcmppi import tasks
from dcmppi.bench.episodes import futures
from dcmppi.bench.episodes.seeds import environment_seed
from dcmppi.tasks.replay import recordings

# named in errors: the tasks with walkers
WITH_PEDESTRIANS = ("square", "corridor", "crowd", "crowdnav", "crowdnav_plus")


def record(
    task,
    task_params=None,
    episodes=1,
    base_seed=0,
    period=recordings.PERIOD,
    seconds=None,
    name="recorded",
) -> recordings.Recording:
    """The moving obstacles of `episodes` episodes of `task` (module docstring) as a Recording
    of `period` [s] between frames; deterministic for a base seed.

    Raises:
      ValueError: one line, for a task without moving obstacles, the replay task (its people
        are recordings already), a period that is no whole number of control steps, or bad
        counts.
    """
    params = _checked(task, task_params, episodes, period, seconds)
    tracks, frame0 = [], 0
    for e in range(episodes):
        env = tasks.load(task, task_kwargs={**params, "random": environment_seed(base_seed, e)})
        env.reset()
        xy, present, breaks = _frames(env, task, period, seconds)
        env.close()
        frames = frame0 + np.arange(len(xy))
        tracks += _tracks(xy, present, breaks, frames, period, len(tracks) + 1)
        frame0 += len(xy) + 1
    tracks.sort(key=lambda t: (t.frames[0], t.id))
    return recordings.Recording(name, float(period), tuple(tracks))


def _checked(task, task_params, episodes, period, seconds) -> dict:
    """The task parameters (a new dict) of `record`'s arguments, else its ValueError."""
    if task == "replay":
        raise ValueError(
            "record: the replay task's people are recordings already; train on their files "
            "(dcmppi predictor train --data FILES)"
        )
    if episodes < 1:
        raise ValueError(f"record: episodes must be >= 1, got {episodes}")
    if not period > 0 or (seconds is not None and not seconds > 0):
        raise ValueError(f"record: period and seconds must be > 0, got {period}, {seconds}")
    params = dict(task_params or {})
    for reserved in ("random", "noise"):
        if reserved in params:
            raise ValueError(f"record: {reserved} is set per episode; remove it")
    return params


def _frames(env, task, period, seconds):
    """The centres (F, L, 2), presence (F, L) and respawns (F, L: between the frame before and
    this one) of the moving obstacles of `env` (of `task`, just reset) a frame every `period` s
    for `seconds` (None: the time limit), the first at the reset; a ValueError where period is
    no whole number of control steps or nothing moves."""
    dt = env.control_timestep()
    stride = int(round(period / dt))
    if stride < 1 or abs(stride * dt - period) > 1e-9:
        raise ValueError(
            f"record: period {period} s is no whole number of control steps of {dt:g} s"
        )
    start = np.asarray(env.task.world.moving, dtype=float).reshape(-1, 4)[:, :2]
    if not len(start):
        raise ValueError(
            f"record: task {task} has no moving obstacles to record; tasks with pedestrians: "
            + ", ".join(WITH_PEDESTRIANS)
        )
    xy, present, breaks = [start], [futures.obstacle_presence(env)], [np.zeros(len(start), bool)]
    steps = int(round((seconds if seconds is not None else env.task.time_limit) / dt))
    before, jumped = start, np.zeros(len(start), bool)
    for k, now in enumerate(futures.obstacle_tracks(env, steps), start=1):
        now = np.asarray(now, dtype=float)
        jumped |= np.hypot(*(now - before).T) > recordings.MAX_SPEED * dt
        before = now
        if k % stride == 0:
            xy.append(now)
            present.append(futures.obstacle_presence(env))
            breaks.append(jumped)
            jumped = np.zeros(len(start), bool)
    return np.stack(xy), np.stack(present), np.stack(breaks)


def _tracks(xy, present, breaks, frames, period, first_id) -> list:
    """A recordings.Track of each run (`_runs`) of frames in which a row is present, row by
    row, ids from first_id on: xy (F, L, 2), present and breaks (F, L) (`_frames`) and frames
    (F,) the frame numbers of an episode."""
    runs = [
        (row, part) for row in range(xy.shape[1]) for part in _runs(present[:, row], breaks[:, row])
    ]
    return [
        recordings.Track(
            first_id + i,
            frames[part] * float(recordings.FRAME_STEP),
            frames[part] * period,
            xy[part, row].copy(),
        )
        for i, (row, part) in enumerate(runs)
    ]


def _runs(present, breaks) -> list:
    """The index arrays of the runs of True in `present` (F,), cut before each frame where
    `breaks` (F,), of two frames or more."""
    runs = []
    for a, b in zip(*_edges(present), strict=True):
        cuts = [a, *(a + 1 + np.flatnonzero(breaks[a + 1 : b])), b]
        runs += [np.arange(c, d) for c, d in zip(cuts[:-1], cuts[1:], strict=True) if d - c >= 2]
    return runs


def _edges(present) -> tuple:
    """The starts and ends (exclusive) of the runs of True in `present` (F,)."""
    edges = np.flatnonzero(np.diff(np.r_[0, present.astype(int), 0]))
    return edges[::2], edges[1::2]
