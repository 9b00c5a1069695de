"""A scene of ETH/UCY recordings and its episodes (DistNav's: "Move Beyond Trajectories", RSS
2021): which people the robot may replace, in which order, and whom each episode holds.

A scene's episodes are its people who walk at least MIN_PATH (summed over their annotated
frames) and come within MEET_DISTANCE of another person (centre to centre, at an annotated
frame), in an order fixed by EPISODE_SEED and the recordings' names. An episode's others are
the people annotated within its time limit, each in a row while present (`window`).

Data: the recordings are not part of dcmppi (`recordings`): `folder` names their folder, else
$DCMPPI_CROWDS; a scene is a test scene (eth, hotel, univ, zara1, zara2), a file name of
recordings.FILES or a path to a four-column file, read as recordings.load reads it (`reading`:
its period, frame_step, max_speed and max_gap).
"""

import dataclasses
import functools
import os
import pathlib
import zlib

import numpy as np

from dcmppi.control import defaults

from . import recordings

MIN_PATH = 5.0  # [m] a replaced person walks at least this far ...
MEET_DISTANCE = 2.0  # [m] ... and comes this close to another (centres, an annotated frame)
TIME_FACTOR = 2.0  # an episode's time limit / the replaced person's own time
EPISODE_SEED = 2026  # orders each scene's episodes


@dataclasses.dataclass(frozen=True, eq=False)
class Scene:
    """The recordings of one scene and its episodes: (recording index, track index) pairs in
    their seeded order (one object per scene: load_scene keeps it)."""

    name: str
    recordings: tuple
    episodes: tuple


def scene_files(scene, folder=None) -> tuple:
    """The paths of the files of `scene`: a name of recordings.SCENES or recordings.FILES (in
    recordings.crowds_folder(folder), the argument `path` of the task) or a path to a file."""
    name = str(scene)
    if name in recordings.SCENES or name in recordings.FILES:
        base = recordings.crowds_folder(folder, "path")
        return tuple(str(base / f"{f}.txt") for f in recordings.SCENES.get(name, (name,)))
    if pathlib.Path(name).suffix or os.sep in name:
        return (name,)
    raise ValueError(
        f"unknown scene {name!r}; scenes: {', '.join(recordings.SCENES)}, a file of "
        f"{', '.join(recordings.FILES)} or a path to a file"
    )


def given_scene(name, given) -> str:
    """The scene of the task parameter `given` (a scene or a list of them) that a results
    database names `name` (a scene, else a recording's name): the path whose file is `name`
    (a scene given as a file), else `name`."""
    for scene in given if isinstance(given, (list, tuple)) else [given]:
        if str(scene) not in recordings.SCENES and pathlib.Path(str(scene)).stem == name:
            return str(scene)
    return name


def load_scene(files, **reading) -> Scene:
    """The Scene of the files (paths) read as recordings.load reads them with `reading` (period,
    frame_step, max_speed, max_gap) and its episodes, one object while the files and `reading`
    stay the same; a ValueError where it has none."""
    stamps = []
    for f in files:
        try:
            stat = os.stat(f)
            stamps.append((stat.st_mtime_ns, stat.st_size))
        except OSError:
            stamps.append(None)  # recordings.load says why
    return _load_scene(tuple(map(str, files)), tuple(stamps), tuple(sorted(reading.items())))


@functools.lru_cache(maxsize=16)
def _load_scene(files, stamps, reading=()) -> Scene:
    """load_scene of files whose modification times and sizes are `stamps`, `reading` as
    (name, value) pairs."""
    recs = tuple(recordings.load(f, argument="path", **dict(reading)) for f in files)
    name = "+".join(r.name for r in recs)
    found = [(r, i) for r, rec in enumerate(recs) for i in candidates(rec)]
    if not found:
        raise ValueError(
            f"scene {name} has no episode: nobody walks >= {MIN_PATH:g} m and meets another "
            f"within {MEET_DISTANCE:g} m"
        )
    rng = np.random.default_rng([EPISODE_SEED, zlib.crc32(name.encode())])
    order = rng.permutation(len(found))
    return Scene(name, recs, tuple(found[i] for i in order))


def candidates(recording) -> list:
    """Indices of the tracks of `recording` that may be replaced: a path of at least MIN_PATH
    over their annotated frames and another person within MEET_DISTANCE at one of them."""
    tracks = recording.tracks
    frames = np.concatenate([t.frames for t in tracks]) if tracks else np.zeros(0)
    who = np.concatenate([np.full(len(t.frames), i) for i, t in enumerate(tracks)] or [[]])
    xy = np.concatenate([t.xy for t in tracks]) if tracks else np.zeros((0, 2))
    order = np.argsort(frames, kind="stable")
    frames, who, xy = frames[order], who[order].astype(int), xy[order]
    met = np.zeros(len(tracks), dtype=bool)
    cuts = np.flatnonzero(np.diff(frames)) + 1
    for rows in np.split(np.arange(len(frames)), cuts):
        if len(rows) > 1:
            gap = np.hypot(*(xy[rows, None] - xy[None, rows]).transpose(2, 0, 1))
            np.fill_diagonal(gap, np.inf)
            met[who[rows[(gap <= MEET_DISTANCE).any(axis=1)]]] = True
    walked = [np.hypot(*np.diff(t.xy, axis=0).T).sum() >= MIN_PATH for t in tracks]
    return [i for i in range(len(tracks)) if met[i] and walked[i]]


def window(recording, person, duration, gap=defaults.DT) -> tuple:
    """The others of an episode that replaces track `person` for `duration` [s]: their track
    indices (P,) (those annotated in the window, by first appearance), each one's row (P,)
    and the number of rows L. A row is reused once its person left more than `gap` before the
    next one appears, so that it is padding at one control instant at least between two people
    (with the data's frames, L is the most people present at once)."""
    start = np.array([t.times[0] for t in recording.tracks])
    end = np.array([t.times[-1] for t in recording.tracks])
    t0 = start[person]
    others = np.flatnonzero((start <= t0 + duration) & (end >= t0))
    others = others[others != person]
    free, rows = [], np.empty(len(others), dtype=int)  # free: end of each row's last person
    for k, j in enumerate(others):
        open_rows = [r for r, until in enumerate(free) if until + gap < start[j]]
        row = open_rows[0] if open_rows else len(free)
        if row == len(free):
            free.append(0.0)
        free[row] = end[j]
        rows[k] = row
    return others, rows, len(free)


@functools.lru_cache(maxsize=4096)
def episode_window(scene, k, time_limit) -> tuple:
    """`window` of episode k of `scene` for time_limit [s] (None: TIME_FACTOR x the person's
    own time)."""
    r, i = scene.episodes[k]
    rec = scene.recordings[r]
    track = rec.tracks[i]
    own = TIME_FACTOR * (track.times[-1] - track.times[0])
    return window(rec, i, own if time_limit is None else time_limit)


def episode_index(scene, recording: str, person: int, path=None, **reading) -> int:
    """The index among `scene`'s episodes (its files read with `reading`, as load_scene's) of
    the one that replaces person `person` of the recording named `recording` (what a results
    database stores); a ValueError if none does."""
    sc = load_scene(scene_files(scene, path), **reading)
    for k, (r, i) in enumerate(sc.episodes):
        if sc.recordings[r].name == recording and sc.recordings[r].tracks[i].id == person:
            return k
    raise ValueError(f"scene {scene}: no episode replaces person {person} of {recording}")
