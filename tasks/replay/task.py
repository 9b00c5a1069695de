"""`replay`: the robot replaces one recorded person of an ETH/UCY crowd (DistNav's episodes).

The robot starts where a recorded person first appears, heading along their first displacement,
and its goal is where they were last seen; everyone else walks their recorded track, blind to
the robot, as SocNavBench replays them (people.RecordedPeople). Which people a scene's
episodes replace, and in which order: `scenes`.

Time limit: scenes.TIME_FACTOR x the replaced person's own time (first to last annotation). Top
speed: a holonomic or unicycle robot gets v_max = max(its default, SPEED_MARGIN x the person's
top speed between annotated frames) unless given; with no `episode` the fastest of those the
task may replace.
"""

import functools

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.validation import flag, positive

from ..navigation import PHYSICS_TIMESTEP, Navigation
from ..pedestrians.worlds import pedestrian_obstacle_model
from ..worlds.base import World, make_world
from .people import PEDESTRIAN_RADIUS, RecordedPeople
from .recordings import MAX_GAP, MAX_SPEED
from .scenes import TIME_FACTOR, episode_window, load_scene, scene_files
from .tracks import human, start_pose, top_speed

SPEED_MARGIN = 1.2  # the robot's top speed / the replaced person's top speed
MAP_MARGIN = 2.0  # [m] the map: the recording's bounding box and this much around it
RECORDED = "recorded"  # world.behavior of a replay: people walk their recorded tracks
REACTIVE = "recorded_orca"  # reactive=True: ORCA toward the recording, no longer a recording
_DEFAULT_V_MAX = {"holonomic": defaults.HOLONOMIC_V_MAX, "unicycle": defaults.UNICYCLE_V_MAX}


@functools.lru_cache(maxsize=256)
def _box(scene, r) -> np.ndarray:
    """(4,) the map of recording r of `scene`: its bounding box, MAP_MARGIN around it."""
    xy = np.concatenate([t.xy for t in scene.recordings[r].tracks])
    return np.concatenate([xy.min(axis=0) - MAP_MARGIN, xy.max(axis=0) + MAP_MARGIN])


@functools.lru_cache(maxsize=256)
def _obstacle_model(scene, r) -> np.ndarray:
    """(4,) the Gaussian of recording r's speeds between annotated frames, turn rates as the
    pedestrian worlds' (pedestrians.worlds.pedestrian_obstacle_model)."""
    speeds = np.concatenate(
        [np.hypot(*np.diff(t.xy, axis=0).T) / np.diff(t.times) for t in scene.recordings[r].tracks]
    )
    return pedestrian_obstacle_model(float(speeds.mean()), float(speeds.std()))


class Replay(Navigation):
    """The robot replaces one recorded person of an ETH/UCY scene (module docstring).

    Moving obstacles: the scene's other people (`RecordedPeople`), blind to the robot; the rows
    of absent people are padding (radius 0, parked far away). L (num_moving) is the most
    people present at once in the episode's time limit (of any episode the task may play when
    `episode` is not given). The robot is the holonomic agent of radius PEDESTRIAN_RADIUS by
    default. obstacle_model: the Gaussian of the recording's speeds between annotated frames,
    turn rates N(0, pedestrians.worlds.PEDESTRIAN_TURN_RATE_STD^2).

    Args:
      scene: a test scene (eth, hotel, univ, zara1, zara2), a file name of recordings.FILES or
        a path to a file, or a list of them (episode e: episode e // S of scene e % S).
      path: the folder of the recordings (else $DCMPPI_CROWDS).
      period, frame_step, max_speed, max_gap: how the files are read (recordings.load): the
        seconds between annotated frames (None: the file's own), the video frames between
        them (None: inferred), the fastest a person may move between them [m/s], the longest
        absence [s] before a person is read as two.
      episode: the episode's index (see scene); None: the task's `random` picks a scene and
        one of its episodes for every episode.
      reactive: the people avoid the robot (`RecordedPeople`'s reactive): world.behavior is
        REACTIVE instead of RECORDED and `recorded` is false, no longer a recording.
      pedestrian_radius, robot_radius: the discs [m].
    Attributes: human (the `Human` reference), scene_name (the recording's name) and
    episode_index (the episode played), after a reset.
    """

    default_agent = "holonomic"

    def __init__(
        self,
        scene="eth",
        path=None,
        episode=None,
        reactive=False,
        pedestrian_radius=PEDESTRIAN_RADIUS,
        robot_radius=PEDESTRIAN_RADIUS,
        period=None,
        frame_step=None,
        max_speed=MAX_SPEED,
        max_gap=MAX_GAP,
        **kwargs,
    ):
        self.reactive = flag("reactive", reactive)
        reading = dict(period=period, frame_step=frame_step, max_speed=max_speed, max_gap=max_gap)
        self.pedestrian_radius = positive("pedestrian_radius", pedestrian_radius)
        names = list(scene) if isinstance(scene, (list, tuple)) else [scene]
        if not names:
            raise ValueError("scene: name at least one scene")
        self.scenes = tuple(load_scene(scene_files(name, path), **reading) for name in names)
        count = len(self.scenes)
        if episode is None:
            self._choices = [(s, k) for s in range(count) for k in range(self._count(s))]
        else:
            episode = positive("episode", episode, integer=True, allow_zero=True)
            s, k = episode % count, episode // count
            if k >= self._count(s):
                raise ValueError(
                    f"episode {episode}: scene {self.scenes[s].name} has {self._count(s)} "
                    f"episodes (episode e is episode e // {count} of scene e % {count})"
                )
            self._choices = [(s, k)]
        self.episode = episode
        agent = kwargs.get("agent") or self.default_agent
        if agent in _DEFAULT_V_MAX:
            top = max(top_speed(self._track(choice)) for choice in self._choices)
            kwargs.setdefault("v_max", max(_DEFAULT_V_MAX[agent], SPEED_MARGIN * top))
        super().__init__(robot_radius=robot_radius, **kwargs)
        self._current = self._choices[0] if episode is not None else None
        self.num_moving = max(
            episode_window(self.scenes[s], k, self._time_limit)[2] for s, k in self._choices
        )
        self._motion = None
        self.human = None
        self.scene_name = None
        self.episode_index = episode

    def _count(self, s) -> int:
        return len(self.scenes[s].episodes)

    def _track(self, choice):
        s, k = choice
        r, i = self.scenes[s].episodes[k]
        return self.scenes[s].recordings[r].tracks[i]

    @property
    def recorded(self) -> bool:
        """Whether the people walk their recordings (false with reactive=True)."""
        return not self.reactive

    @property
    def time_limit(self) -> float:
        """TIME_FACTOR x the replaced person's own time, unless time_limit is given (the
        longest of the episodes the task may play before its first reset)."""
        if self._time_limit is not None:
            return self._time_limit
        choices = self._choices if self._current is None else [self._current]
        return max(TIME_FACTOR * float(np.ptp(self._track(c).times)) for c in choices)

    @property
    def map_bounds(self) -> np.ndarray:
        """The recording's bounding box with MAP_MARGIN (their union before the first reset
        when the task may play several recordings)."""
        choices = self._choices if self._current is None else [self._current]
        boxes = np.array([_box(self.scenes[s], self.scenes[s].episodes[k][0]) for s, k in choices])
        return np.concatenate([boxes[:, :2].min(axis=0), boxes[:, 2:].max(axis=0)])

    def generate_world(self, random) -> World:
        if self.episode is None:
            s = random.randint(len(self.scenes))
            self._current = (s, random.randint(self._count(s)))
        s, k = self._current
        scene = self.scenes[s]
        r, i = scene.episodes[k]
        rec = scene.recordings[r]
        track = rec.tracks[i]
        others, rows, _ = episode_window(scene, k, self._time_limit)
        start = start_pose(track)
        self._motion = RecordedPeople(
            [rec.tracks[j] for j in others],
            rows,
            self.num_moving,
            track.times[0],
            self.pedestrian_radius,
            self.robot_radius,
            start[:2],
            PHYSICS_TIMESTEP,
            self.reactive,
        )
        self.human = human(rec, i)
        self.scene_name = rec.name
        self.episode_index = k * len(self.scenes) + s
        return make_world(
            start,
            track.xy[-1],
            moving=self._motion.rows(),
            speed=np.hypot(*self._motion.velocity.T),
            bounds=_box(scene, r),
            obstacle_model=_obstacle_model(scene, r),
            behavior=REACTIVE if self.reactive else RECORDED,
            robot_visible=self.reactive,
        )

    def obstacle_motion(self):
        return self._motion
