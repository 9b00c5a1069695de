"""The shared plant of every benchmark world: a robot among cylinders in MuJoCo.

`Physics` owns the MuJoCo model (models/arena.xml with one robot of models/robots/ and a fixed
number of obstacle slots), moves the moving obstacles every physics substep (Dubins arcs,
worlds.arcs.DubinsObstacles, for the "constant" behaviour, else `pedestrians.walkers.Pedestrians`,
or a task's own motion such as replay.people.RecordedPeople), and records robot-obstacle
contacts and the analytic clearance; walls are rows of static cylinders
(pedestrians.worlds.wall_cylinders). The task that drives it is navigation.Navigation.
"""

import copy
import functools
import math
from importlib import resources

import mujoco
import numba
import numpy as np
from absl import logging
from dm_control import mujoco as dm_mujoco
from dm_control.mujoco import engine, index
from dm_control.mujoco.wrapper import core
from dm_control.rl import control

from dcmppi.control import defaults
from dcmppi.control.kernels.libm import cabs, cabs_or_nan, nan_min

from .pedestrians import walkers
from .worlds.arcs import DubinsObstacles
from .worlds.base import BEHAVIOR_CONSTANT, GOAL_TOLERANCE, World

OBSTACLE_HALF_HEIGHT = 0.5  # [m]
PARKED = -1000.0  # [m] x, y of unused static slots (also disabled and hidden)
_HIDDEN_GROUP = 3  # geom group that MuJoCo's renderer hides by default
_NO_CONTACT = int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
ROBOT_PREFIX = "robot/"  # names of the attached robot file's elements get this prefix
ROBOT_FILE_RADIUS = 0.5  # [m] hull radius the robot files are drawn at
BROADPHASE_BYTES = 4  # per pair of bodies: MuJoCo's broadphase stack (2 measured), with room


@functools.lru_cache(maxsize=32)
def _compiled_model(robot_file, num_static, num_moving, robot_radius) -> mujoco.MjModel:
    """The arena with the robot of `robot_file`, num_static world-geom slots and num_moving
    mocap-body slots."""
    models = resources.files("dcmppi.models")
    spec = mujoco.MjSpec.from_string(models.joinpath("arena.xml").read_text())
    robot = mujoco.MjSpec.from_string(models.joinpath("robots", robot_file).read_text())
    scale = robot_radius / ROBOT_FILE_RADIUS
    for geom in robot.geoms:  # drawn geoms follow the hull's radius, at their heights
        geom.pos = np.asarray(geom.pos) * [scale, scale, 1.0]
        geom.size = np.asarray(geom.size) * (scale if geom.name != "hull" else 1.0)
    robot.geom("hull").size[0] = robot_radius
    spec.attach(robot, prefix=ROBOT_PREFIX, frame=spec.worldbody.add_frame())
    static_class = spec.find_default("static_obstacle")
    for i in range(num_static):
        spec.worldbody.add_geom(
            static_class, name=f"static_{i}", pos=[PARKED, PARKED, OBSTACLE_HALF_HEIGHT]
        )
    moving_class, heading_class = (
        spec.find_default("moving_obstacle"),
        spec.find_default("moving_heading"),
    )
    for i in range(num_moving):
        body = spec.worldbody.add_body(
            name=f"moving_{i}", mocap=True, pos=[PARKED, PARKED, OBSTACLE_HALF_HEIGHT]
        )
        body.add_geom(moving_class, name=f"moving_{i}")
        body.add_geom(
            heading_class, name=f"moving_heading_{i}", pos=[0.5, 0.0, OBSTACLE_HALF_HEIGHT + 0.02]
        )
    model = spec.compile()
    pairs = BROADPHASE_BYTES * model.nbody**2  # the broadphase's stack, beside the default arena
    if 2 * pairs > model.narena:  # thousands of moving obstacles (bodies)
        spec.memory = model.narena + pairs
        model = spec.compile()
    return model


def _set_cylinders(model, ids, radius, half_height=OBSTACLE_HALF_HEIGHT):
    """Sets cylinder sizes and the bounding volumes MuJoCo's collision broadphase uses."""
    model.geom_size[ids, 0] = radius
    model.geom_size[ids, 1] = half_height
    model.geom_rbound[ids] = np.hypot(radius, half_height)
    model.geom_aabb[ids, :3] = 0.0
    model.geom_aabb[ids, 3] = radius
    model.geom_aabb[ids, 4] = radius
    model.geom_aabb[ids, 5] = half_height


def _set_heading_bars(model, ids, radius):
    """Sizes each moving obstacle's heading bar to its radius (from 0.1 to 0.9 of it, ahead of
    the centre) and its bounding volumes; the bars collide with nothing."""
    model.geom_pos[ids, 0] = 0.5 * radius
    model.geom_size[ids, 0] = 0.4 * radius
    model.geom_rbound[ids] = np.linalg.norm(model.geom_size[ids], axis=1)
    model.geom_aabb[ids, 3] = model.geom_size[ids, 0]


# no static obstacles and no moving ones, for _clearances
_NO_SOLID, _NO_MOVING = np.zeros(0, dtype=np.complex128), np.zeros((0, 0), dtype=np.complex128)


@numba.njit(inline="always")
def _surface_gaps(x, y, centres, radii, out):
    """out[j] = cabs(centres[j].real - x, centres[j].imag - y) - radii[j] (numpy's np.abs of the
    complex difference, less the radius), in a loop that vectorises and a pass for the rare nan."""
    for j in range(len(out)):
        out[j] = cabs_or_nan(centres[j].real - x, centres[j].imag - y) - radii[j]
    for j in range(len(out)):
        if out[j] != out[j]:
            out[j] = cabs(centres[j].real - x, centres[j].imag - y) - radii[j]


@numba.njit(cache=True, error_model="numpy")
def _clearances(robot, solid_z, solid_r, moving, moving_r, radius):
    """The nearest obstacle surface from each robot centre, less the robot's radius (n,), and each
    static and moving obstacle's from the last centre (M,), (L,); robot (n,) complex, solid_z (M,)
    complex, moving (n, L) complex (or (0, 0): none). The values of the numpy expressions
    np.abs(robot[:, None] - solid_z) - solid_r and np.abs(moving - robot[:, None]) - moving_r,
    their minima over obstacles (np.minimum of the two), less radius; inf (not less radius)
    where there are no obstacles; nan where a distance is (its sign and payload unspecified)."""
    n, count = len(robot), len(solid_z)
    if n == 0:  # numpy's each[-1] of no centres
        raise IndexError("no robot centres")
    movers = moving.shape[1] if moving.shape[0] else 0
    if len(solid_r) != count or movers and (moving.shape[0] != n or len(moving_r) != movers):
        raise ValueError("obstacle centres, radii and robot centres do not match")
    nearest, gaps, each = np.full(n, np.inf), np.empty(count), np.empty(movers)
    for i in range(n):
        x, y = robot[i].real, robot[i].imag
        if count:
            _surface_gaps(x, y, solid_z, solid_r, gaps)
            nearest[i] = nan_min(gaps)
        if movers:
            _surface_gaps(x, y, moving[i], moving_r, each)
            low, static = nan_min(each), nearest[i]  # np.minimum(static, low)
            nearest[i] = static if static != static or low >= static else low
        if count or movers:
            nearest[i] -= radius
    return nearest, gaps - radius, each - radius


class Physics(dm_mujoco.Physics):
    """Physics with obstacle slots, moving obstacles and contact/clearance bookkeeping.

    Only obstacles that the robot could reach within the coming control step take part in
    MuJoCo's collision detection (their conaffinity is switched on at the start of each
    `step`); the rest are skipped, which keeps a step cheap with hundreds of obstacles. With
    none of them near, collision detection is switched off for the step (MuJoCo's contact
    flag): it could find no contact, and it costs a third of a substep.
    """

    @classmethod
    def for_slots(
        cls, num_static, num_moving, bounds, robot_radius=defaults.ROBOT_RADIUS, robot="dubins.xml"
    ):
        """A new Physics with the robot of file `robot`, fixed obstacle slots, and the top
        camera and floor fitted to bounds."""
        model = copy.copy(_compiled_model(robot, num_static, num_moving, float(robot_radius)))
        physics = cls.from_model(core.MjModel(model))
        physics._bind(num_static, num_moving, float(robot_radius))
        physics._fit_view(np.asarray(bounds, dtype=np.float64))
        return physics

    def _reload_from_data(self, data):
        """dm_control's (dm-control 1.0), but the named indexers (`named`) are built when first
        read: they take about 5 ms, half of a forest episode's set-up, and no episode reads
        them (a test guards a dm_control update)."""
        if not isinstance(data, core.MjData):
            raise TypeError(f"Expected wrapper.MjData. Got: {type(data)}.")
        self._data = data
        self._warnings = self.data.warning.number  # the counters that step() compares
        self._warnings_before = np.empty_like(self._warnings)
        self._new_warnings = np.empty(dtype=bool, shape=(len(self._warnings),))
        with self._contexts_lock:
            if self._contexts:
                self._free_rendering_contexts()
        try:
            self.after_reset()
        except control.PhysicsError as e:
            logging.warning(e)
        self._named = None

    @property
    def named(self):
        """dm_control's named indexers of the model and data (physics.named.data.qpos, ...)."""
        if self._named is None:
            axes = index.make_axis_indexers(self.model)
            self._named = engine.NamedIndexStructs(
                model=index.struct_indexer(self.model, "mjmodel", axes),
                data=index.struct_indexer(self.data, "mjdata", axes),
            )
        return self._named

    def _bind(self, num_static, num_moving, robot_radius):
        m, d = self.model.ptr, self.data.ptr
        self._m, self._d = m, d
        self.robot_radius = robot_radius
        self._robot_geom = m.geom(ROBOT_PREFIX + "hull").id
        first = m.geom("static_0").id if num_static else 0
        self._static_ids = np.arange(first, first + num_static)
        self._moving_ids = np.array([m.geom(f"moving_{i}").id for i in range(num_moving)], int)
        self._moving_bodies = np.array([m.body(f"moving_{i}").id for i in range(num_moving)], int)
        self._heading_ids = np.array(
            [m.geom(f"moving_heading_{i}").id for i in range(num_moving)], int
        )
        mocap = m.body_mocapid[self._moving_bodies]
        if num_moving and not (np.diff(mocap) == 1).all():
            raise RuntimeError("moving obstacle mocap slots are not contiguous")
        self._mocap = slice(mocap[0], mocap[-1] + 1) if num_moving else slice(0, 0)
        self._qpos, self._qvel, self._ctrl = d.qpos, d.qvel, d.ctrl
        self._qfrc_applied = d.qfrc_applied
        self._opt = m.opt
        self._contact_off = False  # collision detection switched off by _activate_near
        self._geom_conaffinity, self._body_conaffinity = m.geom_conaffinity, m.body_conaffinity
        self._gain = m.actuator_gainprm[:, 0].copy()  # kv of the planar and turn actuators
        self._mocap_xy = d.mocap_pos[self._mocap, :2]
        self._mocap_quat = d.mocap_quat[self._mocap]
        self._moving = None
        self._walking = False  # the moving obstacles see the robot: Pedestrians or a motion
        self._coming = False  # set_world's motion: rows whose obstacles come and go
        self.control_period = defaults.DT  # [s] make_environment sets the environment's
        self._moving_obs = np.zeros((num_moving, 4))
        self._solid = np.zeros((0, 3))
        self._solid_ids = self._static_ids[:0]
        self._solid_z = np.zeros(0, dtype=np.complex128)
        self._solid_r = np.zeros(0)
        self._near = None  # conaffinity bytes of the solid and moving slots, last written
        self._speed_bound = 0.0
        self.collided = False
        self.first_contact = None
        self.min_clearance = np.inf
        self._clearance = np.inf
        self._static_clearance = np.zeros(0)
        self._moving_clearance = np.zeros(num_moving)

    def _fit_view(self, bounds):
        """Centres floor and top camera on the map; camera height shows it all at 16:9."""
        m = self._m
        centre = 0.5 * (bounds[:2] + bounds[2:])
        extent = bounds[2:] - bounds[:2] + 4.0
        floor = m.geom("floor").id
        m.geom_pos[floor, :2] = centre
        m.geom_size[floor, :2] = 0.5 * extent + 20.0
        m.cam_pos[m.camera("top").id, :2] = centre
        self._view_extent = extent
        self.fit_top_camera(16, 9)

    def fit_top_camera(self, width, height):
        """Sets the top camera's height so that the map (and 2 m around it) fills a frame of
        width x height (any units) (dcmppi.render sets it for each frame's size)."""
        m = self._m
        cam = m.camera("top").id
        half = np.tan(np.deg2rad(m.cam_fovy[cam]) / 2.0)
        extent = self._view_extent
        m.cam_pos[cam, 2] = max(extent[1], extent[0] * height / width) / (2.0 * half)

    # Episode set-up -------------------------------------------------------------------------

    def set_world(
        self,
        world: World,
        velocity,
        command,
        top_speed,
        next_goal=None,
        random=None,
        motion=None,
        goal_tolerance=GOAL_TOLERANCE,
    ):
        """Places robot, goal and obstacles of `world`; clears the records.

        velocity: the robot's world-frame (vx, vy, yaw rate) at the start; command: the three
        actuator targets at the start; top_speed: the robot's fastest planar speed [m/s].
        Pedestrian worlds (behavior not "constant") also need next_goal(random, i, position)
        and random (np.random.RandomState), see `walkers.Pedestrians`.
        motion: the moving obstacles' own motion instead of the world's behaviour, or None. It
        has advance(n, robot_xy, robot_velocity) -> complex (n, L) (as `Pedestrians`), z,
        theta, velocity, max_speed [m/s], radius (L,) each row's disc and present (L,) bool:
        a row that is not present holds no obstacle now (radius 0 in `moving_obstacles`, and
        the motion parks it far away, so it touches nothing); world.moving is its state at
        t = 0 (replay.people.RecordedPeople: rows that recorded people come and go by).
        goal_tolerance [m]: the radius of the goal's disc."""
        self._place_static(world.static)
        goal = self._m.geom("goal").id
        self._m.geom_pos[goal, :2] = world.goal
        self._m.geom_size[goal, 0] = goal_tolerance
        moving = world.moving
        self._size_moving(moving[:, 3] if motion is None else motion.radius)
        self._coming = motion is not None  # rows that obstacles come and go by
        self._walking = self._coming or len(moving) > 0 and world.behavior != BEHAVIOR_CONSTANT
        self._moving, obstacle_speed = self._obstacle_motion(world, next_goal, random, motion)
        if len(moving):
            self._mocap_xy[:] = moving[:, :2]
            self._set_mocap_heading(moving[:, 2])
        # Fastest closing speed robot-obstacle, with room for disturbances [m/s].
        self._speed_bound = 2.0 * top_speed + 1.0 + obstacle_speed
        self._place_robot(world.start, velocity, command, moving)

    def _place_static(self, static):
        """Puts the solid rows of static (M, 3) x, y, radius into the static slots; parks and
        hides the rest (radius 0)."""
        m = self._m
        solid = static[:, 2] > 0
        ids = self._static_ids
        m.geom_pos[ids, :2] = np.where(solid[:, None], static[:, :2], PARKED)
        _set_cylinders(m, ids, np.where(solid, static[:, 2], 1.0))
        m.geom_conaffinity[ids] = 0
        m.geom_group[ids] = np.where(solid, 0, _HIDDEN_GROUP)
        self._solid = static[solid]
        self._solid_ids = ids[solid]
        self._solid_z = self._solid[:, 0] + 1j * self._solid[:, 1]
        self._solid_r = self._solid[:, 2].copy()

    def _size_moving(self, radius):
        """Sizes the moving slots to radius (L,). No obstacle collides (the static slots'
        conaffinity is cleared too) until `step` enables the near ones (`_activate_near`)."""
        m = self._m
        self._moving_obs[:, 3] = radius
        _set_cylinders(m, self._moving_ids, radius)
        _set_heading_bars(m, self._heading_ids, radius)
        m.geom_conaffinity[self._moving_ids] = 0
        m.body_conaffinity[self._moving_bodies] = 0
        self._switch_contacts(True)
        self._near = None

    def _obstacle_motion(self, world, next_goal, random, motion):
        """The moving obstacles' model (set_world's motion, walkers.Pedestrians, DubinsObstacles
        or None without any) and their top speed [m/s]."""
        moving = world.moving
        if motion is not None:
            return motion, motion.max_speed
        if self._walking:
            heading = np.column_stack([np.cos(moving[:, 2]), np.sin(moving[:, 2])])
            # They walk in the map and along its walls (the corridor's reach past its ends).
            corners = np.concatenate([world.map_bounds.reshape(2, 2), world.walls.reshape(-1, 2)])
            pedestrians = walkers.Pedestrians(
                world.behavior,
                moving[:, :2],
                world.moving_speed[:, None] * heading,
                world.moving_goal,
                world.moving_pref_speed,
                moving[:, 3],
                world.walls,
                [*corners.min(axis=0), *corners.max(axis=0)],
                self.robot_radius,
                world.robot_visible,
                next_goal,
                random,
                self.control_period,
                world.stop_at_goal,
                world.slow_at_goal,
                world.safety_space,
            )
            return pedestrians, walkers.MAX_SPEED_FACTOR * world.moving_pref_speed.max()
        if len(moving):
            arcs = DubinsObstacles(
                moving[:, :3],
                world.moving_speed,
                world.moving_turn_rate,
                world.map_bounds,
                self.timestep(),
            )
            return arcs, np.abs(world.moving_speed).max()
        return None, 0.0

    def _place_robot(self, start, velocity, command, moving):
        """Puts the robot at start (3,) with its velocity and actuator command, no disturbance;
        clears the contact and clearance records (moving (L, 4): the obstacles now)."""
        self._qpos[:3] = start
        self._qvel[:3] = velocity
        self._ctrl[:] = command
        self._qfrc_applied[:] = 0.0
        self.collided = False
        self.first_contact = None
        moving_z = (moving[:, 0] + 1j * moving[:, 1])[None] if len(moving) else None
        robot = np.array([complex(start[0], start[1])])
        self._clearance = self._update_clearance(robot, moving_z)[0]
        self.min_clearance = self._clearance

    def _set_mocap_heading(self, heading):
        self._mocap_quat[:, 0] = np.cos(0.5 * heading)
        self._mocap_quat[:, 3] = np.sin(0.5 * heading)

    # Control --------------------------------------------------------------------------------

    def set_command(self, command):
        """The three actuator targets (see tasks/robots.py)."""
        self._ctrl[:] = command

    def set_disturbance(self, velocity):
        """Holds generalized forces that offset the robot's (vx, vy, yaw rate) by `velocity`.

        Each force is gain x velocity, so against the velocity actuators the robot settles
        (after the actuator lag) at the commanded velocity plus `velocity`.
        """
        self._qfrc_applied[:3] = self._gain * velocity

    # Simulation -----------------------------------------------------------------------------

    def step(self, nstep=1):
        """Advances nstep physics steps, moving the obstacles and recording contacts each one.

        Every substep integrates (mj_step2), moves the mocap obstacles to the new time, then
        recomputes positions and contacts (mj_step1), so contacts always compare robot and
        obstacles at the same instant. Pedestrians plan the whole step from the robot's position
        and velocity at its start.
        """
        moving = moving_xy = None
        if self._walking:
            robot_xy = self._qpos[:2].copy()
            moving = self._moving.advance(nstep, robot_xy, self._qvel[:2].copy())
            if self._coming:  # one may appear within the step: its nearest substep counts
                gap = np.abs(moving - complex(*robot_xy)).min(axis=0)
                self._moving_clearance = gap - self._moving_obs[:, 3] - self.robot_radius
            else:  # one that reached its goal may reappear elsewhere: its clearance from there
                self._moving_clearance = _clearances(
                    np.array([complex(*robot_xy)]), _NO_SOLID, self._solid_r[:0], moving[:1],
                    self._moving_obs[:, 3], self.robot_radius,
                )[2]  # fmt: skip
        elif self._moving is not None:
            moving = self._moving.advance(nstep)
        self._activate_near(nstep * self._opt.timestep)
        if moving is not None:
            moving_xy = np.stack([moving.real, moving.imag], axis=-1)
        # dm_control's check_invalid_state, without a context manager per step
        warnings = self._warnings.tobytes()
        robot = self._substeps(nstep, moving_xy)
        if self._warnings.tobytes() != warnings:
            self._raise_warnings(np.frombuffer(warnings, self._warnings.dtype))
        if moving is not None:
            self._set_mocap_heading(self._moving.theta)
        clearance = self._update_clearance(robot.view(np.complex128)[:, 0], moving)
        self._clearance = clearance[-1]
        self.min_clearance = min(self.min_clearance, clearance.min())

    def _substeps(self, nstep, moving_xy):
        """MuJoCo's nstep substeps (mj_step2, the mocap obstacles set to moving_xy (nstep, L, 2)
        or left where they are with None, mj_step1), recording the first contact. Returns the
        robot's x, y after each substep (nstep, 2)."""
        m, d = self._m, self._d
        robot = np.empty((nstep, 2))
        qpos, mocap_xy, step1, step2 = self._qpos, self._mocap_xy, mujoco.mj_step1, mujoco.mj_step2
        for k in range(nstep):
            step2(m, d)
            if moving_xy is not None:
                mocap_xy[:] = moving_xy[k]
            step1(m, d)
            robot[k, 0] = qpos[0]
            robot[k, 1] = qpos[1]
            if d.ncon and not self.collided:
                self._record_contact()
        return robot

    def _raise_warnings(self, before):
        """dm_control's PhysicsError (or its log line under suppress_physics_errors) for the
        MuJoCo warnings counted since `before` (mjNWARNING,)."""
        with self.check_invalid_state():
            self._warnings_before[:] = before

    def _activate_near(self, duration):
        """Enables collisions with the obstacles the robot could touch within `duration`, and
        collision detection only when there is one (writes the model only when that set
        changed)."""
        reach = 0.5 + self._speed_bound * duration
        static = self._static_clearance < reach
        moving = self._moving_clearance < reach if len(self._moving_ids) else static[:0]
        near = static.tobytes() + moving.tobytes()
        if near != self._near:
            self._near = near
            self._geom_conaffinity[self._solid_ids] = static
            if len(self._moving_ids):
                self._geom_conaffinity[self._moving_ids] = moving
                self._body_conaffinity[self._moving_bodies] = moving
            self._switch_contacts(static.any() or moving.any())

    def _switch_contacts(self, on):
        """MuJoCo's collision detection on or off by its disable bit, leaving every other bit
        as the model has it: a user's own flags, their contact bit too (one set while ours is set
        cannot be told from ours)."""
        flags = int(self._opt.disableflags)
        if self._contact_off:  # the bit is ours to clear
            flags &= ~_NO_CONTACT
        self._contact_off = not on and not flags & _NO_CONTACT
        self._opt.disableflags = flags if on else flags | _NO_CONTACT

    def _record_contact(self):
        d = self._d
        self.collided = True
        a, b = d.contact.geom[0]
        self.first_contact = dict(
            time=float(d.time),
            robot_xy=self._qpos[:2].copy(),
            geom=self._m.geom(int(b if a == self._robot_geom else a)).name,
            distance=float(d.contact.dist[0]),
        )

    def _update_clearance(self, robot, moving):
        """Minimum clearance (n,) at robot centres (n,) complex, obstacles moving (n, L) complex
        (or None: where they are is not needed).

        Also keeps each obstacle's clearance at the last centre for `_activate_near`.
        """
        clearance, self._static_clearance, each = _clearances(
            robot, self._solid_z, self._solid_r, _NO_MOVING if moving is None else moving,
            self._moving_obs[:, 3], self.robot_radius,
        )  # fmt: skip
        if moving is not None:
            self._moving_clearance = each
        return clearance

    # Readouts -------------------------------------------------------------------------------

    @property
    def obstacle_motion(self):
        """The moving obstacles' own model (walkers.Pedestrians, DubinsObstacles or
        set_world's motion; None without any). Its `advance` moves them without the physics:
        where they ignore the robot, stepping it alone gives the episode's future of them."""
        return self._moving

    def robot_pose(self):
        """(3,) x, y, yaw of the robot, yaw wrapped to [-pi, pi)."""
        pose = self._qpos[:3].copy()
        pose[2] = (pose[2] + math.pi) % (2.0 * math.pi) - math.pi
        return pose

    def robot_position(self):
        """x, y of the robot (floats)."""
        return tuple(self._qpos[:2].tolist())

    def robot_velocity(self):
        """(3,) world-frame vx, vy and yaw rate."""
        return self._qvel[:3].copy()

    def moving_obstacles(self):
        """(L, 4) x, y, heading, radius of the moving obstacles now (radius 0: a row that holds
        none now, see set_world's motion)."""
        obs = self._moving_obs.copy()
        if self._moving is not None:
            obs[:, 0] = self._moving.z.real
            obs[:, 1] = self._moving.z.imag
            obs[:, 2] = self._moving.theta
        if self._coming:
            obs[~self._moving.present, 3] = 0.0
        return obs

    def moving_velocity(self):
        """(L, 2) world-frame velocities of the moving obstacles now."""
        if self._moving is None:
            return np.zeros((len(self._moving_obs), 2))
        return np.array(self._moving.velocity, dtype=np.float64)

    def clearance(self):
        """Minimum robot-obstacle surface distance now [m] (inf without obstacles)."""
        return self._clearance
