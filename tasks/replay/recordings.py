"""Recorded pedestrians: the ETH/UCY trajectory files (plain numpy, no MuJoCo).

A file holds one row per pedestrian per annotated frame, four tab- or space-separated columns
`frame pedestrian_id x y` (positions in metres in the scene's world frame); annotated frames are
FRAME_STEP video frames apart. The files are not part of dcmppi: a `folder` argument names them,
else the folder that $DCMPPI_CROWDS names (the README of that folder gives the format, the frame
rates and the credit owed: ETH, Pellegrini et al. 2009; UCY, Lerner et al. 2007).

Time: annotated frame k (video frame k * FRAME_STEP) is at k * period. The period is PERIOD
(0.4 s) for every file but biwi_eth, whose annotated frames are 10 frames of a 15 fps video apart
(PERIODS); prediction papers read every file at 0.4 s (pass period=PERIOD).

The standard split of forecasting work (Social-GAN, Trajectron++): SCENES name the five test
scenes, TRAINING_ONLY the files that only ever train; `train_files(scene)` leaves one scene out.
"""

import dataclasses
import os
import pathlib

import numpy as np

CROWDS_ENV = "DCMPPI_CROWDS"  # environment variable naming the folder of the files
FRAME_STEP = 10  # video frames between annotated frames
PERIOD = 0.4  # [s] between annotated frames: 10 frames of a 25 fps video
PERIODS = {"biwi_eth": 10 / 15}  # [s] files recorded at another rate (15 fps)
SCENES = {
    "eth": ("biwi_eth",),
    "hotel": ("biwi_hotel",),
    "univ": ("students001", "students003"),
    "zara1": ("crowds_zara01",),
    "zara2": ("crowds_zara02",),
}
TRAINING_ONLY = ("crowds_zara03", "uni_examples")
FILES = (*(f for files in SCENES.values() for f in files), *TRAINING_ONLY)


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
    tracks (the people, by first appearance)."""

    name: str
    period: float
    tracks: tuple

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


def crowds_folder(folder=None) -> pathlib.Path:
    """The folder of the recordings: `folder`, else the one $DCMPPI_CROWDS names.

    Raises:
      ValueError: one line naming both ways to give it, when neither names a folder.
    """
    fix = f"set {CROWDS_ENV}=DIR, the folder of the eight files, or pass path=DIR"
    given = folder if folder is not None else os.environ.get(CROWDS_ENV)
    if not given:
        raise ValueError(f"the ETH/UCY recordings are not part of dcmppi: {fix}")
    path = pathlib.Path(given)
    if not path.is_dir():
        where = "folder" if folder is not None else CROWDS_ENV
        raise ValueError(f"{where}={path}: no such folder of ETH/UCY files; {fix}")
    return path


def load(name_or_path, folder=None, period=None) -> Recording:
    """One recording: a file name of FILES (in `crowds_folder(folder)`) or a path to a file.

    period: [s] between annotated frames (None: PERIODS, else PERIOD, by the file's stem).

    Raises:
      ValueError: naming the file, for a missing or malformed file.
    """
    name = str(name_or_path)
    path = pathlib.Path(name)
    if not (path.suffix or os.sep in name):
        path = crowds_folder(folder) / f"{name}.txt"
    if not path.is_file():
        raise ValueError(f"{path}: no such recording; files: {', '.join(FILES)}")
    rows = _read(path)
    period = PERIODS.get(path.stem, PERIOD) if period is None else float(period)
    if not period > 0:
        raise ValueError(f"period must be > 0 s; got {period}")
    order = np.lexsort((rows[:, 0], rows[:, 1]))  # by person, then frame
    rows = rows[order]
    cuts = np.flatnonzero(np.diff(rows[:, 1])) + 1
    tracks = []
    for part in np.split(rows, cuts):
        frames = part[:, 0]
        if np.any(np.diff(frames) <= 0):
            raise ValueError(f"{path}: person {part[0, 1]:g} is annotated twice in one frame")
        tracks.append(Track(int(part[0, 1]), frames, frames / FRAME_STEP * period, part[:, 2:]))
    tracks.sort(key=lambda t: (t.frames[0], t.id))
    return Recording(path.stem, period, tuple(tracks))


def _read(path) -> np.ndarray:
    """(R, 4) rows frame, id, x, y of a four-column file, or a ValueError naming the file."""
    try:
        rows = np.loadtxt(path, ndmin=2)
    except (OSError, ValueError) as e:
        raise ValueError(f"{path}: not a four-column file frame, id, x, y ({e})") from None
    if rows.shape[1:] != (4,) or not len(rows) or not np.isfinite(rows).all():
        raise ValueError(
            f"{path}: expected rows of four finite numbers frame, id, x, y; got {rows.shape}"
        )
    return rows


def save(recording, path):
    """Writes `recording` in the four-column format (tab-separated) that `load` reads; the
    period is not stored (load's `period` gives it back)."""
    rows = [
        np.column_stack([t.frames, np.full(len(t.frames), t.id), t.xy]) for t in recording.tracks
    ]
    rows = np.concatenate(rows) if rows else np.zeros((0, 4))
    rows = rows[np.lexsort((rows[:, 1], rows[:, 0]))]
    np.savetxt(path, rows, fmt=["%.1f", "%.1f", "%.6f", "%.6f"], delimiter="\t")


def scene(name, folder=None, period=None) -> list:
    """The recordings of test scene `name` (a key of SCENES), as `load` reads them."""
    if name not in SCENES:
        raise ValueError(f"unknown scene {name!r}; scenes: {', '.join(SCENES)}")
    return [load(f, folder, period) for f in SCENES[name]]


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
    index = [np.rint(t.frames / FRAME_STEP).astype(int) for t in tracks]
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
