"""The replay task: the robot in place of one recorded person of an ETH/UCY crowd, among the
others' recorded tracks (DistNav's episodes; docs/crowds.md).

    recordings.py  the ETH/UCY files (four columns: frame id x y) as Recordings of Tracks, the
                   test scenes' files and their standard split, forecasting windows
    scenes.py      a scene's episodes: whom the robot may replace, in which order, and whom each
                   episode holds (`load_scene`, `window`, `episode_index`)
    tracks.py      a recorded track read at any instant; the replaced person as the robot's
                   reference (`Human`, `sampled_path_length`)
    people.py      the others' motion every physics substep (`RecordedPeople`); the task's
                   collision rule checked on the replaced people (`self_collisions`)
    task.py        the task `Replay`

The names the bench and docs/crowds.md use are importable from here: Replay, episode_index,
self_collisions and sampled_path_length.
"""

from .people import self_collisions
from .scenes import episode_index
from .task import Replay
from .tracks import sampled_path_length

__all__ = ["Replay", "episode_index", "sampled_path_length", "self_collisions"]
