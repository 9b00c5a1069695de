"""Recorded pedestrians: four-column trajectory files such as ETH/UCY's (plain numpy, no MuJoCo).

A file holds one row per pedestrian per annotated frame, four whitespace-separated numbers
`frame pedestrian_id x y` (positions in metres in the scene's world frame); `checks` reads it,
refuses what is wrong with it (one line naming the file, the person, the frame and the fix) and
says what it did (a person split at a long absence, a far recording moved to the origin). The
ETH/UCY files are not part of dcmppi: a `folder` argument names them, else the folder that
$DCMPPI_CROWDS names (the README of that folder gives the format, the frame rates and the credit
owed: ETH, Pellegrini et al. 2009; UCY, Lerner et al. 2007).

Time: the frame step is each person's most common difference between consecutive annotated
frames (10 in ETH/UCY, 1 or 12 in TrajNet's files), or `frame_step`; annotated frame f is at
f / frame_step * period. The period is `period`, else the one the file states (a comment
`# period P`), else that of a known recording (PERIODS: biwi_eth's annotated frames are 10
frames of a 15 fps video apart, known by its rows, or by its name with a step of 10), else
PERIOD (0.4 s); prediction papers read every ETH/UCY file at 0.4 s (pass period=PERIOD).

The standard split of forecasting work (Social-GAN, Trajectron++): SCENES name the five test
scenes, TRAINING_ONLY the files that only ever train; `train_files(scene)` leaves one scene out.
"""

import dataclasses
import hashlib
import math
import os
import pathlib

import numpy as np

from dcmppi.control.validation import positive

from . import checks
from .checks import MAX_GAP, MAX_SPEED

CROWDS_ENV = "DCMPPI_CROWDS"  # environment variable naming the folder of the files
FRAME_STEP = 10  # video frames between ETH/UCY's annotated frames (and dcmppi's recordings')
PERIOD = 0.4  # [s] between annotated frames, unless given, stated or known
PERIODS = {"biwi_eth": 10 / 15}  # [s] known recordings of another period (15 fps)
# the known recordings by the sha256 of their rows (as read: frame, id, x, y, float64)
KNOWN = {"4b4aed12e3376b3af7f5572ddbbe01df61057b6727f9570ee5a44df9024bd179": "biwi_eth"}
SCENES = {
    "eth": ("biwi_eth",),
    "hotel": ("biwi_hotel",),
    "univ": ("students001", "students003"),
    "zara1": ("crowds_zara01",),
    "zara2": ("crowds_zara02",),
}
TRAINING_ONLY = ("crowds_zara03", "uni_examples")
FILES = (*(f for files in SCENES.values() for f in files), *TRAINING_ONLY)
READING = ("period", "frame_step", "max_speed", "max_gap")  # how `load` reads a file


@dataclasses.dataclass(frozen=True)
class Track:
    """One person: id, frames (n,) annotated video frames (increasing), times (n,) [s], xy (n, 2)
    positions [m]."""

    id: int
    frames: np.ndarray
    times: np.ndarray
    xy: np.ndarray


@dataclasses.dataclass(frozen=True)
class Recording:
    """The tracks of one file: name (the file's stem), period [s] between annotated frames,
    tracks (the people, by first appearance), frame_step (video frames between annotated
    frames), offset (2,) [m] subtracted from the file's positions (a far recording moved to the
    origin), notes (what reading did, one line each)."""

    name: str
    period: float
    tracks: tuple
    frame_step: float = FRAME_STEP
    offset: tuple = (0.0, 0.0)
    notes: tuple = ()

    def __post_init__(self):
        if self.tracks:
            start = np.array([t.times[0] for t in self.tracks])
            end = np.array([t.times[-1] for t in self.tracks])
        else:
            start = end = np.zeros(0)
        object.__setattr__(self, "_span", (start, end))

    @property
    def ids(self) -> np.ndarray:
        """(T,) the people's ids."""
        return np.array([t.id for t in self.tracks], dtype=int)

    @property
    def duration(self) -> tuple:
        """(first, last) annotated time [s]."""
        start, end = self._span
        return (float(start.min()), float(end.max())) if len(start) else (0.0, 0.0)

    def positions_at(self, t) -> tuple:
        """The people present at time t [s] and where they are: ids (k,), xy (k, 2).

        A person is present from their first to their last annotation (inclusive) and moves
        linearly between consecutive annotated frames (also across a gap in their annotation).
        """
        start, end = self._span
        present = np.flatnonzero((start <= t) & (t <= end))
        xy = np.empty((len(present), 2))
        for row, i in enumerate(present):
            track = self.tracks[i]
            xy[row, 0] = np.interp(t, track.times, track.xy[:, 0])
            xy[row, 1] = np.interp(t, track.times, track.xy[:, 1])
        return self.ids[present], xy


@dataclasses.dataclass(frozen=True)
class Windows:
    """Forecasting windows: obs + pred consecutive annotated frames of one person each.

    xy: (M, obs + pred, 2) the person's positions; the first `obs` are observed, the rest the
      future to predict. id: (M,) the person's id; frame: (M,) the video frame of the window's
      last observed position; source: (M,) the index of its recording in `names`.
    neighbours: (M,) tuple of (K_m, obs, 2) the observed positions of the other people annotated
      at any observed frame of window m (nan where one is not annotated).
    period: [s] between annotated frames; names: the recordings' names.
    """

    xy: np.ndarray
    id: np.ndarray
    frame: np.ndarray
    source: np.ndarray
    neighbours: tuple
    obs: int
    period: float
    names: tuple = ()

    def __len__(self):
        return len(self.xy)

    @property
    def observed(self) -> np.ndarray:
        """(M, obs, 2) the observed positions."""
        return self.xy[:, : self.obs]

    @property
    def future(self) -> np.ndarray:
        """(M, pred, 2) the positions to predict."""
        return self.xy[:, self.obs :]


def crowds_folder(folder=None, argument="folder") -> pathlib.Path:
    """The folder of the recordings: `folder`, else the one $DCMPPI_CROWDS names.

    Raises:
      ValueError: one line naming both ways to give it (the folder as `argument`=DIR), when
        neither names a folder.
    """
    fix = f"set {CROWDS_ENV}=DIR, the folder of the eight files, or pass {argument}=DIR"
    given = folder if folder is not None else os.environ.get(CROWDS_ENV)
    if not given:
        raise ValueError(f"the ETH/UCY recordings are not part of dcmppi: {fix}")
    path = pathlib.Path(given)
    if not path.is_dir():
        where = argument if folder is not None else CROWDS_ENV
        raise ValueError(f"{where}={path}: no such folder of ETH/UCY files; {fix}")
    return path


@dataclasses.dataclass(frozen=True)
class Examined:
    """What reading a file found: path; recording (None where refused); positions (its rows);
    frame_step, period [s] and speeds [m/s] between consecutive annotations of a person (None
    where not reached); problems (the lines that refuse it); notes (what reading did, and a
    median speed that questions the period)."""

    path: pathlib.Path
    recording: Recording | None
    positions: int
    frame_step: float | None
    period: float | None
    speeds: np.ndarray | None
    problems: tuple
    notes: tuple


def examine(
    name_or_path,
    folder=None,
    period=None,
    frame_step=None,
    max_speed=MAX_SPEED,
    max_gap=MAX_GAP,
    argument="folder",
) -> Examined:
    """A recording read and checked (`load`'s arguments): its problems listed, not raised.

    Raises:
      ValueError: one line naming the file, for a missing, unreadable or empty file or one that
        is not four numbers a row, or naming the argument, for a bad argument.
    """
    path = file_path(name_or_path, folder, argument)
    if frame_step is not None:
        frame_step = positive("frame_step", frame_step)
    max_speed, max_gap = positive("max_speed", max_speed), positive("max_gap", max_gap)
    rows = checks.read(path)
    step, found = checks.check(path, rows, frame_step, FRAME_STEP)
    if not found:
        period, found = _period(path, rows, step, period)
    if found:
        return Examined(path, None, len(rows.frame), step, None, None, tuple(found), ())
    people, found = checks.people(path, rows, step, period, max_speed, max_gap)
    if found:
        seen = (step, period, people.speeds, tuple(found), people.notes)
        return Examined(path, None, len(rows.frame), *seen)
    tracks = [
        Track(i, f, t, xy)
        for i, f, t, xy in zip(people.ids, people.frames, people.times, people.xy, strict=True)
    ]
    tracks.sort(key=lambda t: (t.frames[0], t.id))
    offset = tuple(float(x) for x in people.offset)
    rec = Recording(path.stem, period, tuple(tracks), step, offset, people.notes)
    notes = people.notes + tuple(checks.walking_note(path, people.speeds, period))
    return Examined(path, rec, len(rows.frame), step, period, people.speeds, (), notes)


def load(
    name_or_path,
    folder=None,
    period=None,
    frame_step=None,
    max_speed=MAX_SPEED,
    max_gap=MAX_GAP,
    argument="folder",
) -> Recording:
    """One recording: a file name of FILES (in `crowds_folder(folder)`) or a path to a file.

    period: [s] between annotated frames (None: stated by the file, else known, else PERIOD;
    module docstring); frame_step: video frames between annotated frames (None: inferred);
    max_speed [m/s]: the fastest a person may move between consecutive annotations; max_gap [s]:
    a person absent for longer is read as two (checks). argument: the name the folder has in the
    caller's messages.

    Raises:
      ValueError: one line naming the file, for a missing file or one that the checks refuse
        (its first problem; `examine` lists them all).
    """
    found = examine(name_or_path, folder, period, frame_step, max_speed, max_gap, argument)
    if found.problems:
        more = sum(not p.startswith("...") for p in found.problems[1:])
        raise ValueError(found.problems[0] + (f" (and {more} more problems)" if more else ""))
    return found.recording


def file_path(name_or_path, folder=None, argument="folder") -> pathlib.Path:
    """The file of a name of FILES (in `crowds_folder(folder)`) or a path; a ValueError naming
    it where there is no such file."""
    name = str(name_or_path)
    path = pathlib.Path(name)
    if not (path.suffix or os.sep in name):
        path = crowds_folder(folder, argument) / f"{name}.txt"
    if not path.is_file():
        raise ValueError(f"{path}: no such recording; files: {', '.join(FILES)}")
    return path


def _period(path, rows, step, given) -> tuple:
    """(period [s] (module docstring), []), or (None, [the line that refuses a given period the
    file contradicts])."""
    if given is None:
        if rows.period is not None:
            return rows.period, []
        digest = hashlib.sha256(np.column_stack([rows.frame, rows.id, rows.xy]).tobytes())
        known = KNOWN.get(digest.hexdigest())
        if known is None and step == FRAME_STEP:
            known = path.stem
        return PERIODS.get(known, PERIOD), []
    period = positive("period", given)
    if rows.period is not None and not math.isclose(period, rows.period, rel_tol=1e-9):
        return None, [
            f"{path}: the file states {rows.period:g} s between annotated frames (its '# period' "
            f"line), read at period={period:g}: pass period={rows.period:g}"
        ]
    return period, []


def save(recording, path, frame_step=None):
    """Writes `recording` in the four-column format (tab-separated) that `load` reads, with a
    first line `# period P` that gives load its period, its annotated frames frame_step apart
    (None: the recording's) and its positions where the file had them (the offset added back).
    """
    step = recording.frame_step if frame_step is None else positive("frame_step", frame_step)
    rows = [
        np.column_stack(
            [t.frames / recording.frame_step * step, np.full(len(t.frames), t.id), t.xy]
        )
        for t in recording.tracks
    ]
    rows = np.concatenate(rows) if rows else np.zeros((0, 4))
    rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
    rows[:, 2:] += recording.offset
    header = f"period {float(recording.period)!r}"
    np.savetxt(
        path,
        rows,
        fmt=["%.1f", "%.1f", "%.6f", "%.6f"],
        delimiter="\t",
        header=header,
        comments="# ",
    )


def scene(name, folder=None, period=None, **reading) -> list:
    """The recordings of test scene `name` (a key of SCENES), as `load` reads them (reading:
    its frame_step, max_speed, max_gap)."""
    if name not in SCENES:
        raise ValueError(f"unknown scene {name!r}; scenes: {', '.join(SCENES)}")
    return [load(f, folder, period, **reading) for f in SCENES[name]]


def train_files(test_scene) -> tuple:
    """The files that train a model tested on `test_scene` (leave one scene out): every file of
    FILES but the test scene's, the training-only ones included."""
    if test_scene not in SCENES:
        raise ValueError(f"unknown scene {test_scene!r}; scenes: {', '.join(SCENES)}")
    return tuple(f for f in FILES if f not in SCENES[test_scene])


def windows(recordings, obs=8, pred=12) -> Windows:
    """Every window of obs + pred consecutive annotated frames of every person (windows that
    overlap, one frame apart, as the standard protocol takes them), with the neighbours'
    observed positions.

    recordings: a Recording or a list of them (one period).
    """
    recordings = [recordings] if isinstance(recordings, Recording) else list(recordings)
    if len({r.period for r in recordings}) > 1:
        raise ValueError("windows of recordings of different periods; load them at one period")
    if obs < 2 or pred < 1:
        raise ValueError(f"obs >= 2 and pred >= 1 frames; got obs={obs}, pred={pred}")
    parts = [_windows(r, obs, pred, i) for i, r in enumerate(recordings)]
    length = obs + pred
    return Windows(
        np.concatenate([p[0] for p in parts]) if parts else np.zeros((0, length, 2)),
        np.concatenate([p[1] for p in parts]).astype(int) if parts else np.zeros(0, int),
        np.concatenate([p[2] for p in parts]) if parts else np.zeros(0),
        np.concatenate([p[3] for p in parts]).astype(int) if parts else np.zeros(0, int),
        tuple(n for p in parts for n in p[4]),
        obs,
        recordings[0].period if recordings else PERIOD,
        tuple(r.name for r in recordings),
    )


def _windows(recording, obs, pred, source):
    """xy, id, frame, source, neighbours of the windows of one recording."""
    length = obs + pred
    tracks = recording.tracks
    if not tracks:
        return np.zeros((0, length, 2)), [], [], [], ()
    # grid (F, T, 2) of every person's position by annotated frame index, nan where absent
    origin = min(t.frames[0] for t in tracks)
    index = [np.rint((t.frames - origin) / recording.frame_step).astype(int) for t in tracks]
    first = min(i[0] for i in index)
    grid = np.full((max(i[-1] for i in index) - first + 1, len(tracks), 2), np.nan)
    for column, (i, track) in enumerate(zip(index, tracks, strict=True)):
        grid[i - first, column] = track.xy
    xy, ids, frames, neighbours = [], [], [], []
    for column, (i, track) in enumerate(zip(index, tracks, strict=True)):
        for s in range(len(i) - length + 1):
            if i[s + length - 1] - i[s] != length - 1:  # a gap in the annotation
                continue
            xy.append(track.xy[s : s + length])
            ids.append(track.id)
            frames.append(track.frames[s + obs - 1])
            seen = grid[i[s] - first : i[s] - first + obs]  # (obs, T, 2)
            present = ~np.isnan(seen[..., 0]).all(axis=0)
            present[column] = False
            neighbours.append(seen[:, present].transpose(1, 0, 2))
    xy = np.array(xy).reshape(-1, length, 2)
    return xy, ids, frames, np.full(len(xy), source), tuple(neighbours)
