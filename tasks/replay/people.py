"""The recorded people of a replay episode (`RecordedPeople`), and the check of the task's
collision rule against them (`self_collisions`).

Discs: every person and the robot are discs of PEDESTRIAN_RADIUS, so that a contact is DistNav's
collision, centres closer than 0.21 m. `self_collisions` checks that distance: replayed along
their own tracks under this rule, the replaced people "collide" in 0-2 % of the episodes of
eth, hotel, zara1 and zara2 and 8.5 % of univ's (students001's annotation has people cross
through each other), where CrowdNav's 0.3 m discs (0.6 m) give 24-87 % (companions walk
0.4-0.5 m apart) and SocNavBench's 0.2 m people and 0.24 m robot (0.44 m) 6-59 %.
"""

import math

import numpy as np

from dcmppi.control import defaults

from ..navigation import PHYSICS_TIMESTEP
from ..pedestrians import walkers
from ..physics import PARKED
from ..worlds.base import GOAL_TOLERANCE
from .scenes import episode_window, load_scene, scene_files
from .tracks import interp, slope, start_pose, top_speed

PEDESTRIAN_RADIUS = 0.105  # [m] people and robot: DistNav's 0.21 m collision distance
_PARKED = complex(PARKED, PARKED)  # where an absent person's row stands


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
    ahead, at most walkers.MAX_SPEED_FACTOR x their top recorded speed; held back people
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
        self.max_speed = float(self._top.max() * walkers.MAX_SPEED_FACTOR) if tracks else 0.0
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
            xy = interp(now, track.times, track.xy)
            if np.abs(complex(*xy[0]) - complex(*robot_xy)) > self._contact:
                self._appear(j, xy[0], slope(t0, track.times, track.xy))
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
                xy = interp(t[on], track.times, track.xy)
                if on[-1]:
                    self._pos[j], self._vel[j] = xy[-1], slope(t[-1], track.times, track.xy)
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
            xy = interp(t[on], track.times, track.xy)
            if on.any() and (np.abs(xy[:, 0] + 1j * xy[:, 1] - robot) > reach).all():
                out[on, self._rows[j]] = xy[:, 0] + 1j * xy[:, 1]
                self._appear(j, xy[-1], slope(t[-1], track.times, track.xy))
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
            aim = interp([min(t[-1], self._last[j])], track.times, track.xy)[0]
            cap = walkers.MAX_SPEED_FACTOR * max(self._top[j], 0.1)
            behavior = self._orca[j] if j in self._orca else self._behavior(j, cap)
            target = (aim - pos[k]) / dt
            speed = math.hypot(*target)
            target = target * min(1.0, cap / speed) if speed > 0 else target
            near = np.hypot(*(pos - pos[k]).T) < walkers.NEIGHBOR_RANGE
            near[k] = False
            state = behavior.environment_state
            state.neighbors = [core.Neighbor(pos[i], self.radius[0], vel[i])
                               for i in np.flatnonzero(near)]  # fmt: skip
            if math.hypot(*(pos[k] - robot_xy)) < walkers.NEIGHBOR_RANGE:
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
        behavior.time_horizon = walkers.ORCA_TIME_HORIZON
        behavior.static_time_horizon = walkers.ORCA_TIME_HORIZON
        behavior.max_number_of_neighbors = walkers.MAX_NEIGHBORS
        behavior.optimal_speed = cap
        self._orca[j] = behavior
        return behavior


def self_collisions(scene, path=None, episodes=None, radius=PEDESTRIAN_RADIUS,
                    robot_radius=PEDESTRIAN_RADIUS, dt=defaults.DT,
                    **reading) -> np.ndarray:  # fmt: skip
    """Whether each episode of `scene` (its first `episodes`, or the episodes of the indices
    `episodes` lists; None: all) has its replaced person "collide" when replayed along their
    own track under the task's rule, (E,) bool; `reading`: how its files are read (the task's
    period, frame_step, max_speed, max_gap).

    The robot's disc (robot_radius) follows the person's track; the others are the episode's
    RecordedPeople (held back where they would appear on it); a collision is two centres
    within radius + robot_radius at a physics substep, until the person's position at a control
    instant is within GOAL_TOLERANCE of their goal (where an episode ends).
    """
    sc = load_scene(scene_files(scene, path), **reading)
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
        others, rows, L = episode_window(sc, k, None)
        people = RecordedPeople(
            [rec.tracks[j] for j in others], rows, L, track.times[0], radius, robot_radius,
            track.xy[0], PHYSICS_TIMESTEP,
        )  # fmt: skip
        hit, step = False, 0
        while not hit:
            now = track.times[0] + step * dt
            robot = interp([now], track.times, track.xy)[0]
            z = people.advance(n, robot, slope(now, track.times, track.xy))
            me = interp(now + np.arange(1, n + 1) * PHYSICS_TIMESTEP, track.times, track.xy)
            hit = bool((np.abs(z - (me[:, 0] + 1j * me[:, 1])[:, None]) <= contact).any())
            step += 1
            if np.hypot(*(me[-1] - track.xy[-1])) <= GOAL_TOLERANCE:
                break
        out.append(hit)
    return np.array(out, dtype=bool)
