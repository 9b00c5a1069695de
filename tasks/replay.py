"""`replay`: the robot replaces one recorded person of an ETH/UCY crowd (DistNav's episodes).

Episodes as DistNav ("Move Beyond Trajectories", RSS 2021) builds them: the robot starts where
a recorded person first appears, heading along their first displacement, and its goal is where
they were last seen; everyone else walks their recorded track, blind to the robot, as
SocNavBench replays them (`RecordedPeople`). A scene's episodes are its people who walk at
least MIN_PATH (summed over their annotated frames) and come within MEET_DISTANCE of another
person (centre to centre, at an annotated frame), in an order fixed by EPISODE_SEED and the
recordings' names.

Discs: every person and the robot are discs of PEDESTRIAN_RADIUS, so that a contact is DistNav's
collision, centres closer than 0.21 m. `self_collisions` checks that distance: replayed along
their own tracks under this rule, the replaced people "collide" in 0-2 % of the episodes of
eth, hotel, zara1 and zara2 and 8.5 % of univ's (students001's annotation has people cross
through each other), where CrowdNav's 0.3 m discs (0.6 m) give 24-87 % (companions walk
0.4-0.5 m apart) and SocNavBench's 0.2 m people and 0.24 m robot (0.44 m) 6-59 %.

Time limit: TIME_FACTOR x the replaced person's own time (first to last annotation). Top speed:
a holonomic or unicycle robot gets v_max = max(its default, SPEED_MARGIN x the person's top
speed between annotated frames) unless given; with no `episode` the fastest of those the task
may replace.
The replaced person's own track is the human reference (`Human`): their time to the goal region
and their path to it, sampled at the recording's frame period as `sampled_path_length` samples
the robot's (a path sampled every 0.1 s is longer than the same path every 0.4 s, from jitter).

Data: the recordings are not part of dcmppi (tasks.recordings): `path` names their folder, else
$DCMPPI_CROWDS; `scene` is a test scene (eth, hotel, univ, zara1, zara2), a file name of
recordings.FILES or a path to a four-column file, or a list of them (episode e is then episode
e // S of scene e % S). Frame periods per file as recordings.PERIODS says.
"""

import dataclasses
import functools
import math
import os
import pathlib
import zlib

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.validation import flag, positive

from . import pedestrians, recordings
from .navigation import PHYSICS_TIMESTEP, Navigation
from .pedestrian_worlds import pedestrian_obstacle_model
from .physics import PARKED
from .world_base import GOAL_TOLERANCE, World, make_world

PEDESTRIAN_RADIUS = 0.105  # [m] people and robot: DistNav's 0.21 m collision distance
MIN_PATH = 5.0  # [m] a replaced person walks at least this far ...
MEET_DISTANCE = 2.0  # [m] ... and comes this close to another (centres, an annotated frame)
TIME_FACTOR = 2.0  # time limit / the replaced person's own time
SPEED_MARGIN = 1.2  # the robot's top speed / the replaced person's top speed
MAP_MARGIN = 2.0  # [m] the map: the recording's bounding box and this much around it
EPISODE_SEED = 2026  # orders each scene's episodes
RECORDED = "recorded"  # world.behavior of a replay: people walk their recorded tracks
REACTIVE = "recorded_orca"  # reactive=True: ORCA toward the recording, no longer a recording
_PARKED = complex(PARKED, PARKED)  # where an absent person's row stands
_DEFAULT_V_MAX = {"holonomic": defaults.HOLONOMIC_V_MAX, "unicycle": defaults.UNICYCLE_V_MAX}


@dataclasses.dataclass(frozen=True, eq=False)
class Scene:
    """The recordings of one scene and its episodes: (recording index, track index) pairs in
    their seeded order (one object per scene: load_scene keeps it)."""

    name: str
    recordings: tuple
    episodes: tuple


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


def scene_files(scene, folder=None) -> tuple:
    """The paths of the files of `scene`: a name of recordings.SCENES or recordings.FILES (in
    recordings.crowds_folder(folder)) or a path to a file."""
    name = str(scene)
    if name in recordings.SCENES or name in recordings.FILES:
        base = recordings.crowds_folder(folder)
        return tuple(str(base / f"{f}.txt") for f in recordings.SCENES.get(name, (name,)))
    if pathlib.Path(name).suffix or os.sep in name:
        return (name,)
    raise ValueError(
        f"unknown scene {name!r}; scenes: {', '.join(recordings.SCENES)}, a file of "
        f"{', '.join(recordings.FILES)} or a path to a file"
    )


def load_scene(files) -> Scene:
    """The Scene of the files (paths) and its episodes, one object while the files stay the same;
    a ValueError where it has none."""
    stamps = []
    for f in files:
        try:
            stat = os.stat(f)
            stamps.append((stat.st_mtime_ns, stat.st_size))
        except OSError:
            stamps.append(None)  # recordings.load says why
    return _load_scene(tuple(map(str, files)), tuple(stamps))


@functools.lru_cache(maxsize=16)
def _load_scene(files, stamps) -> Scene:
    """load_scene of files whose modification times and sizes are `stamps`."""
    recs = tuple(recordings.load(f) for f in files)
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
    instants = np.arange(int(math.floor(times[-1] / dt + 1e-9)) + 1) * dt
    at = _interp(instants, times, track.xy)
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


def _interp(t, times, xy) -> np.ndarray:
    """Positions (len(t), 2) of the track xy (n, 2) at `times`, linear between them."""
    return np.column_stack([np.interp(t, times, xy[:, 0]), np.interp(t, times, xy[:, 1])])


def _slope(t, times, xy) -> np.ndarray:
    """The velocity (2,) of the linear track at time t: its segment ending at or after t
    (the first for t at the first time; zero for a single annotation)."""
    if len(times) < 2:
        return np.zeros(2)
    i = min(max(int(np.searchsorted(times, t)) - 1, 0), len(times) - 2)
    return (xy[i + 1] - xy[i]) / (times[i + 1] - times[i])


class RecordedPeople:
    """The recorded people of one episode, in L rows: the motion physics.Physics advances.

    Person j walks its recorded track from its first annotated time to its last in row
    rows[j], its position linear between annotated frames at every physics substep; otherwise
    it is absent: its row parked at physics.PARKED, not `present` (radius 0 in the
    observation), velocity 0. A person due to appear within a control step whose track comes
    within the collision distance of the robot's position at the step's start (plus the
    robot's speed times the step) is held back until its track is clear: someone entering the
    view where the robot stands appears once the robot has moved, not inside it. Then it walks
    the rest of its track; it contacts the robot only by walking into it.

    reactive: present people avoid the robot and each other (navground's ORCA with the
    pedestrians' settings) while steering toward their recorded position one control step
    ahead, at most pedestrians.MAX_SPEED_FACTOR x their top recorded speed; held back people
    appear on their recorded track.

    Attributes: z (L,) complex centres, theta (L,) headings (of the velocity; kept when
    standing), velocity (L, 2) (the track's segment now; reactive: held over the last control
    step), present (L,) bool, ids (L,) the person in each row (-1: none), radius (L,) every
    row's disc, max_speed [m/s] a bound on their speeds.
    """

    def __init__(self, tracks, rows, L, t0, radius, robot_radius, robot_xy, h, reactive=False):
        """tracks: the P people's recording.Track; rows (P,) each one's row < L; t0 [s] the
        episode's start in the recording; radius, robot_radius [m]; robot_xy (2,) the robot at
        t0; h [s] the physics substep."""
        self._tracks, self._rows = list(tracks), np.asarray(rows, dtype=int)
        self._t0, self._h, self._k = float(t0), float(h), 0
        self._robot_radius = float(robot_radius)
        self._contact = float(radius) + self._robot_radius
        self.reactive = bool(reactive)
        self._first = np.array([t.times[0] for t in self._tracks])
        self._last = np.array([t.times[-1] for t in self._tracks])
        self._top = np.array([top_speed(t) for t in self._tracks])
        self.max_speed = float(self._top.max() * pedestrians.MAX_SPEED_FACTOR) if tracks else 0.0
        self._heading = np.array([start_pose(t)[2] for t in self._tracks])
        self._state = np.zeros(len(self._tracks), dtype=int)  # 0 waiting, 1 present, 2 gone
        self._pos = np.zeros((len(self._tracks), 2))  # where each present person is
        self._vel = np.zeros((len(self._tracks), 2))
        self._orca = {}  # reactive: each present person's navground behaviour
        self.radius = np.full(L, float(radius))
        self.z = np.full(L, _PARKED)
        self.theta = np.zeros(L)
        self.velocity = np.zeros((L, 2))
        self.present = np.zeros(L, dtype=bool)
        self.ids = np.full(L, -1)
        now = np.array([self._t0])
        for j in np.flatnonzero((self._first <= t0) & (t0 <= self._last)):
            track = self._tracks[j]
            xy = _interp(now, track.times, track.xy)
            if np.abs(complex(*xy[0]) - complex(*robot_xy)) > self._contact:
                self._appear(j, xy[0], _slope(t0, track.times, track.xy))
        self._publish()

    def rows(self) -> np.ndarray:
        """(L, 4) x, y, heading, radius now (radius 0 where no one is present)."""
        radius = np.where(self.present, self.radius, 0.0)
        return np.column_stack([self.z.real, self.z.imag, self.theta, radius])

    def advance(self, n, robot_xy, robot_velocity) -> np.ndarray:
        """Moves one control step of n substeps; returns the centres after each substep as
        complex (n, L) (parked rows included). robot_xy, robot_velocity (2,): the robot now."""
        t = self._t0 + (self._k + np.arange(1, n + 1)) * self._h
        self._k += n
        out = np.full((n, len(self.z)), _PARKED)
        robot = complex(*robot_xy)
        here = np.flatnonzero(self._state == 1)
        end = self._orca_step(here, t, robot_xy, robot_velocity) if self.reactive else None
        for k, j in enumerate(here):
            track, on = self._tracks[j], t <= self._last[j]
            if end is None:
                xy = _interp(t[on], track.times, track.xy)
                if on[-1]:
                    self._pos[j], self._vel[j] = xy[-1], _slope(t[-1], track.times, track.xy)
            else:
                share = (np.arange(1, n + 1) / n)[on, None]
                xy = self._pos[j] + share * (end[k] - self._pos[j])
                self._pos[j] = end[k]
            out[on, self._rows[j]] = xy[:, 0] + 1j * xy[:, 1]
            if not on[-1]:
                self._state[j] = 2
        reach = self._contact + math.hypot(*robot_velocity) * n * self._h
        for j in np.flatnonzero((self._state == 0) & (self._first <= t[-1])):
            track, on = self._tracks[j], (t >= self._first[j]) & (t <= self._last[j])
            xy = _interp(t[on], track.times, track.xy)
            if on.any() and (np.abs(xy[:, 0] + 1j * xy[:, 1] - robot) > reach).all():
                out[on, self._rows[j]] = xy[:, 0] + 1j * xy[:, 1]
                self._appear(j, xy[-1], _slope(t[-1], track.times, track.xy))
                if not on[-1]:
                    self._state[j] = 2
            elif self._last[j] <= t[-1]:
                self._state[j] = 2  # it left before its track was clear of the robot
        self._publish()
        return out

    def _appear(self, j, xy, velocity):
        self._state[j] = 1
        self._pos[j], self._vel[j] = xy, velocity

    def _publish(self):
        """The rows' attributes from the people's state."""
        here = np.flatnonzero(self._state == 1)
        rows = self._rows[here]
        walking = here[np.hypot(*self._vel[here].T) > 0]
        self._heading[walking] = np.arctan2(self._vel[walking, 1], self._vel[walking, 0])
        self.z[:], self.velocity[:], self.present[:], self.ids[:] = _PARKED, 0.0, False, -1
        self.z[rows] = self._pos[here, 0] + 1j * self._pos[here, 1]
        self.velocity[rows] = self._vel[here]
        self.theta[rows] = self._heading[here]
        self.present[rows] = True
        self.ids[rows] = [self._tracks[j].id for j in here]

    def _orca_step(self, here, t, robot_xy, robot_velocity) -> np.ndarray:
        """Reactive: where each present person (here) is at the step's end (len(here), 2), by
        ORCA toward its recorded position then; sets their velocities."""
        import navground.core as core

        dt = t[-1] - t[0] + self._h
        pos, vel = self._pos[here], self._vel[here]
        robot = core.Neighbor(
            np.asarray(robot_xy, float), self._robot_radius, np.asarray(robot_velocity, float)
        )
        out = np.empty_like(pos)
        for k, j in enumerate(here):
            track = self._tracks[j]
            aim = _interp([min(t[-1], self._last[j])], track.times, track.xy)[0]
            cap = pedestrians.MAX_SPEED_FACTOR * max(self._top[j], 0.1)
            behavior = self._orca[j] if j in self._orca else self._behavior(j, cap)
            target = (aim - pos[k]) / dt
            speed = math.hypot(*target)
            target = target * min(1.0, cap / speed) if speed > 0 else target
            near = np.hypot(*(pos - pos[k]).T) < pedestrians.NEIGHBOR_RANGE
            near[k] = False
            state = behavior.environment_state
            state.neighbors = [core.Neighbor(pos[i], self.radius[0], vel[i])
                               for i in np.flatnonzero(near)]  # fmt: skip
            if math.hypot(*(pos[k] - robot_xy)) < pedestrians.NEIGHBOR_RANGE:
                state.neighbors = [*state.neighbors, robot]
            behavior.position, behavior.velocity = pos[k], vel[k]
            behavior.orientation = self._heading[j]
            behavior.target = core.Target.Velocity(target) if speed > 0 else core.Target.Stop()
            self._vel[j] = behavior.compute_cmd(dt, core.Frame.absolute, True).velocity
            out[k] = pos[k] + dt * self._vel[j]
        return out

    def _behavior(self, j, cap):
        """Person j's navground ORCA (pedestrians' settings: time horizon, neighbours)."""
        import navground.core as core

        kinematics = core.kinematics.OmnidirectionalKinematics(cap)
        behavior = core.behaviors.ORCABehavior(kinematics=kinematics, radius=self.radius[0])
        behavior.time_horizon = pedestrians.ORCA_TIME_HORIZON
        behavior.static_time_horizon = pedestrians.ORCA_TIME_HORIZON
        behavior.max_number_of_neighbors = pedestrians.MAX_NEIGHBORS
        behavior.optimal_speed = cap
        self._orca[j] = behavior
        return behavior


@functools.lru_cache(maxsize=256)
def _box(scene, r) -> np.ndarray:
    """(4,) the map of recording r of `scene`: its bounding box, MAP_MARGIN around it."""
    xy = np.concatenate([t.xy for t in scene.recordings[r].tracks])
    return np.concatenate([xy.min(axis=0) - MAP_MARGIN, xy.max(axis=0) + MAP_MARGIN])


@functools.lru_cache(maxsize=256)
def _obstacle_model(scene, r) -> np.ndarray:
    """(4,) the Gaussian of recording r's speeds between annotated frames, turn rates as the
    pedestrian worlds' (pedestrian_worlds.pedestrian_obstacle_model)."""
    speeds = np.concatenate(
        [np.hypot(*np.diff(t.xy, axis=0).T) / np.diff(t.times) for t in scene.recordings[r].tracks]
    )
    return pedestrian_obstacle_model(float(speeds.mean()), float(speeds.std()))


@functools.lru_cache(maxsize=4096)
def _window(scene, k, time_limit) -> tuple:
    """`window` of episode k of `scene` for time_limit [s] (None: TIME_FACTOR x the person's
    own time)."""
    r, i = scene.episodes[k]
    rec = scene.recordings[r]
    track = rec.tracks[i]
    own = TIME_FACTOR * (track.times[-1] - track.times[0])
    return window(rec, i, own if time_limit is None else time_limit)


class Replay(Navigation):
    """The robot replaces one recorded person of an ETH/UCY scene (module docstring).

    Moving obstacles: the scene's other people (`RecordedPeople`), blind to the robot; the rows
    of absent people are padding (radius 0, parked far away). L (num_moving) is the most
    people present at once in the episode's time limit (of any episode the task may play when
    `episode` is not given). The robot is the holonomic agent of radius PEDESTRIAN_RADIUS by
    default. obstacle_model: the Gaussian of the recording's speeds between annotated frames,
    turn rates N(0, pedestrian_worlds.PEDESTRIAN_TURN_RATE_STD^2).

    Args:
      scene: a test scene (eth, hotel, univ, zara1, zara2), a file name of recordings.FILES or
        a path to a file, or a list of them (episode e: episode e // S of scene e % S).
      path: the folder of the recordings (else $DCMPPI_CROWDS).
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
        **kwargs,
    ):
        self.reactive = flag("reactive", reactive)
        self.pedestrian_radius = positive("pedestrian_radius", pedestrian_radius)
        names = list(scene) if isinstance(scene, (list, tuple)) else [scene]
        if not names:
            raise ValueError("scene: name at least one scene")
        self.scenes = tuple(load_scene(scene_files(name, path)) for name in names)
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
            _window(self.scenes[s], k, self._time_limit)[2] for s, k in self._choices
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
        others, rows, _ = _window(scene, k, self._time_limit)
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


def episode_index(scene, recording: str, person: int, path=None) -> int:
    """The index among `scene`'s episodes of the one that replaces person `person` of the
    recording named `recording` (what a results database stores); a ValueError if none does."""
    sc = load_scene(scene_files(scene, path))
    for k, (r, i) in enumerate(sc.episodes):
        if sc.recordings[r].name == recording and sc.recordings[r].tracks[i].id == person:
            return k
    raise ValueError(f"scene {scene}: no episode replaces person {person} of {recording}")


def self_collisions(scene, path=None, episodes=None, radius=PEDESTRIAN_RADIUS,
                    robot_radius=PEDESTRIAN_RADIUS, dt=defaults.DT) -> np.ndarray:  # fmt: skip
    """Whether each episode of `scene` (its first `episodes`, or the episodes of the indices
    `episodes` lists; None: all) has its replaced person "collide" when replayed along their
    own track under the task's rule, (E,) bool.

    The robot's disc (robot_radius) follows the person's track; the others are the episode's
    RecordedPeople (held back where they would appear on it); a collision is two centres
    within radius + robot_radius at a physics substep, until the person's position at a control
    instant is within GOAL_TOLERANCE of their goal (where an episode ends).
    """
    sc = load_scene(scene_files(scene, path))
    n = int(round(dt / PHYSICS_TIMESTEP))
    contact = radius + robot_radius
    out = []
    if episodes is None or isinstance(episodes, int):
        chosen = range(len(sc.episodes[:episodes]))
    else:
        chosen = [int(k) for k in episodes]
    for k in chosen:
        r, i = sc.episodes[k]
        rec, track = sc.recordings[r], sc.recordings[r].tracks[i]
        others, rows, L = _window(sc, k, None)
        people = RecordedPeople(
            [rec.tracks[j] for j in others], rows, L, track.times[0], radius, robot_radius,
            track.xy[0], PHYSICS_TIMESTEP,
        )  # fmt: skip
        hit, step = False, 0
        while not hit:
            now = track.times[0] + step * dt
            robot = _interp([now], track.times, track.xy)[0]
            z = people.advance(n, robot, _slope(now, track.times, track.xy))
            me = _interp(now + np.arange(1, n + 1) * PHYSICS_TIMESTEP, track.times, track.xy)
            hit = bool((np.abs(z - (me[:, 0] + 1j * me[:, 1])[:, None]) <= contact).any())
            step += 1
            if np.hypot(*(me[-1] - track.xy[-1])) <= GOAL_TOLERANCE:
                break
        out.append(hit)
    return np.array(out, dtype=bool)
