"""The replay task: the robot in place of one recorded person of an ETH/UCY crowd, among the
others' recorded tracks (DistNav's episodes; docs/crowds.md).

    recordings.py  four-column files (frame id x y) such as ETH/UCY's as Recordings of Tracks,
                   the test scenes' files and their standard split, forecasting windows
    scenes.py      a scene's episodes: whom the robot may replace, in which order, and whom each
                   episode holds (`load_scene`, `window`, `episode_index`)
    tracks.py      a recorded track read at any instant; the replaced person as the robot's
                   reference (`Human`, `sampled_path_length`)
    people.py      the others' motion every physics substep (`RecordedPeople`); the task's
                   collision rule checked on the replaced people (`self_collisions`)
    task.py        the task `Replay`

    checks.py      a recording file read and checked: its frame step, the problems that
                   refuse it, people split at long absences, far recordings moved

The names the bench and docs/crowds.md use are importable from here: Replay, episode_index,
given_scene, self_collisions, sampled_path_length and READING (the task parameters that say how
the files are read).
"""

from .people import self_collisions
from .recordings import READING
from .scenes import episode_index, given_scene
from .task import Replay
from .tracks import sampled_path_length

__all__ = [
    "READING",
    "Replay",
    "episode_index",
    "given_scene",
    "sampled_path_length",
    "self_collisions",
]
