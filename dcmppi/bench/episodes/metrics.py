"""What an episode measures at every control instant beyond its path: the controller's
diagnostics (`Diagnosis`) and the crowd-navigation field's metrics (`FieldMetrics`), with the
functions behind them (time to collision, jerk, SPL).

FieldMetrics reads every instant in one compiled pass (`_instant`, with time_to_collision's
`_ttc`) with the values of the numpy expressions its docstring gives, bit for bit
(tests/bench/test_field_metrics.py compares them): the same products and sums in the same
order, libm's hypot, the correctly rounded square root, numpy's pairwise summation for the speed
loss (dcmppi.control.kernels.sums.pairwise), and numpy's arithmetic on a zero divisor.
"""

from __future__ import annotations

import math
import numbers

import numba
import numpy as np

from dcmppi.control.kernels.sums import pairwise


class Diagnosis:
    """Per-step readings of a controller's `diagnostics`, for any controller: attributes it
    lacks are skipped (getattr with defaults).

    ess: effective sample size; clusters: DBSCAN clusters (labels >= 0) where `labels` is
    set; fallback: whether `chosen == -1` (Alg. 1 over all samples) where `labels` is set;
    deviation: Tube-MPPI's real-to-nominal position distance at the start of the step, before
    any reset (`nominal_deviation`; else |x[:2] - nominal_state[:2]| where `nominal_state` is
    set); shielded: whether the safety shield changed the command, where `shielded` is a bool.
    """

    def __init__(self):
        self.ess: list[float] = []
        self.clusters: list[int] = []
        self.fallback: list[bool] = []
        self.deviation: list[float] = []
        self.shielded: list[bool] = []

    def read(self, controller, state: np.ndarray) -> None:
        """Read the diagnostics of the step that `controller` just planned from `state` (3,)."""
        d = getattr(controller, "diagnostics", None)
        ess = getattr(d, "ess", None)
        if isinstance(ess, numbers.Real) and math.isfinite(ess):
            self.ess.append(float(ess))
        labels = getattr(d, "labels", None)
        if labels is not None:
            self.clusters.append(_clusters(np.asarray(labels)))
            self.fallback.append(getattr(d, "chosen", -1) == -1)
        shielded = getattr(d, "shielded", None)
        if isinstance(shielded, bool):
            self.shielded.append(shielded)
        deviation = getattr(d, "nominal_deviation", None)
        nominal = getattr(d, "nominal_state", None)
        if isinstance(deviation, numbers.Real) and math.isfinite(deviation):
            self.deviation.append(float(deviation))
        elif nominal is not None:
            self.deviation.append(float(np.hypot(*(state[:2] - np.asarray(nominal)[:2]))))

    def result(self) -> dict:
        """ess_mean, clusters_mean, fallback_share, tube_deviation_p95, shield_share (None: not
        recorded)."""

        def mean(xs):
            return float(np.mean(xs)) if xs else None

        return {
            "ess_mean": mean(self.ess),
            "clusters_mean": mean(self.clusters),
            "fallback_share": mean(self.fallback),
            "tube_deviation_p95": float(np.percentile(self.deviation, 95))
            if self.deviation
            else None,
            "shield_share": mean(self.shielded),
        }


def _clusters(labels: np.ndarray) -> int:
    """The number of distinct labels >= 0 (DBSCAN's clusters; -1 marks noise)."""
    if labels.dtype.kind == "i":
        count = _count_labels(labels)
        if count >= 0:
            return count
    return len(np.unique(labels[labels >= 0]))


@numba.njit(cache=True)
def _count_labels(labels):
    """The number of distinct labels >= 0 (n,) when all are below n (DBSCAN's); else -1."""
    seen = np.zeros(len(labels), dtype=np.bool_)
    count = 0
    for v in labels:
        if v < 0:
            continue
        if v >= len(labels):
            return -1
        if not seen[v]:
            seen[v] = True
            count += 1
    return count


PERSONAL_SPACE = 0.5  # [m] a pedestrian's surface this close to the robot's is in its space
DISCOMFORT = 0.2  # [m] CrowdNav's discomfort distance (discomfort_dist), surface to surface
INTRUSION_STEP = 0.25  # [s] CrowdNav++'s prediction interval (data.pred_timestep)
INTRUSION_HORIZON = 5  # CrowdNav++'s predicted positions per instant (sim.predict_steps)
RESPAWN_SPEED = 10.0  # [m/s] an obstacle faster than this between instants respawned
NEAR = 2.0  # [m] pedestrians this close (surface to surface) count in the speed loss
WAIT_SPEED = 0.1  # [m/s] a step slower than this (its mean speed) is waiting
FREE_SPACE = 2.0  # [m] no obstacle's surface this close to the robot's: in free space
SLOW_SHARE = 0.9  # a step slower than this share of the agent's top speed is slow


def time_to_collision(position, velocity, radius) -> np.ndarray:
    """Times [s] (L,) until two discs first touch at constant velocities: position, velocity
    (L, 2) of each obstacle relative to the robot, radius (L,) the sums of the two radii.
    0 where they touch already; inf where they are not on a collision course."""
    p = np.ascontiguousarray(position, dtype=np.float64)
    v = np.ascontiguousarray(velocity, dtype=np.float64)
    reach = np.broadcast_to(np.asarray(radius, dtype=np.float64), (len(p),))
    return _times_to_collision(p, v, np.ascontiguousarray(reach))


@numba.njit(cache=True, error_model="numpy")
def _times_to_collision(p, v, reach):
    t = np.empty(len(p))
    for j in range(len(p)):
        t[j] = _ttc(p[j, 0], p[j, 1], v[j, 0], v[j, 1], reach[j])
    return t


@numba.njit(inline="always", error_model="numpy")
def _ttc(px, py, vx, vy, reach):
    """time_to_collision of one disc: |p + v t| = reach, a t^2 + 2 b t + c = 0."""
    a = vx * vx + vy * vy
    b = px * vx + py * vy
    c = (px * px + py * py) - reach * reach
    disc = b * b - a * c
    if c <= 0:
        return 0.0
    if b < 0 and disc >= 0 and a > 0:
        return (-b - math.sqrt(disc)) / a
    return np.inf


def mean_jerk(velocity, dt: float) -> float | None:
    """Mean norm [m/s^3] of the jerk of planar velocities (n, 2) sampled every dt [s] (second
    differences / dt^2); None for fewer than three samples."""
    v = np.asarray(velocity, dtype=np.float64)
    if len(v) < 3:
        return None
    return float(np.linalg.norm(np.diff(v, n=2, axis=0), axis=1).mean() / dt**2)


def spl(success: bool, start, goal, tolerance: float, path_length: float) -> float:
    """Success weighted by path length: success x shortest / max(path_length, shortest), the
    shortest path the straight line from start (2,) to within `tolerance` of goal (2,)."""
    if not success:
        return 0.0
    shortest = max(0.0, float(np.hypot(*(np.asarray(goal) - np.asarray(start)))) - tolerance)
    longest = max(path_length, shortest)
    return 1.0 if longest == 0 else shortest / longest


class FieldMetrics:
    """The field's crowd-navigation metrics of an episode and where its time goes, from the
    simulation's truth read at every control instant (the start and after every step): the
    robot's position and velocity, the clearance (`clearance()`: the nearest obstacle's
    surface, static, wall or moving, from the robot's) and the moving obstacles' positions,
    radii and velocities (`moving_velocity()`) from `env.physics`, their preferred speeds from
    `env.task.world.moving_pref_speed` (nan: none, as for today's Dubins arcs); the agent's
    top speed, the start and the goal from `env.task`.
    """

    def __init__(self, env):
        physics, world = env.physics, env.task.world
        self.dt = env.control_timestep()
        self.robot_radius = physics.robot_radius
        n = len(world.moving)
        self.pedestrians = n > 0
        pref = np.asarray(world.moving_pref_speed, dtype=np.float64)
        self.pref_speed = pref if np.isfinite(pref).all() else None
        self.velocity: list[np.ndarray] = []  # the robot's planar velocity at each instant
        self.position: list[tuple] = []  # the robot's x, y at each instant
        self.clearance: list[float] = []  # the task's clearance at each instant
        self.top_speed = env.task.agent.max_speed
        self.straight = float(np.hypot(*(world.goal[:2] - world.start[:2])))
        self.instants = 0
        self.min_gap = math.inf
        self.personal = 0
        self.discomfort = 0
        self.min_ttc = math.inf
        self.loss_sum = 0.0
        self.loss_count = 0
        self.crowd: list[np.ndarray] = []  # the moving obstacles' x, y, radius (L, 3) each instant
        self.read(physics)

    def read(self, physics) -> None:
        """Record the state of `physics` now: with the robot's position r and velocity w, each
        obstacle's centre p, radius R and velocity u, rel = p - r and the gap |rel| - R -
        robot_radius (np.hypot), the instant's smallest gap, whether any is below
        PERSONAL_SPACE and whether any is below DISCOMFORT, its smallest
        time_to_collision(rel, u - w, R + robot_radius), and with preferred speeds s the sum
        (np.sum) of 1 - |u| / s (np.hypot) over the gaps below NEAR; and the robot's position
        and the clearance; and the moving obstacles' centres and radii."""
        robot_v = physics.robot_velocity()[:2]
        self.velocity.append(robot_v)
        self.position.append(physics.robot_position())
        self.clearance.append(physics.clearance())
        if not self.pedestrians:
            return
        moving = physics.moving_obstacles()
        self.crowd.append(moving[:, [0, 1, 3]])
        gap, personal, ttc, loss, near = _instant(
            moving,
            physics.moving_velocity(),
            physics.robot_pose()[:2],
            robot_v,
            self.robot_radius,
            _NO_PREF if self.pref_speed is None else self.pref_speed,
        )
        self.instants += 1
        self.min_gap = min(self.min_gap, gap)
        self.personal += personal
        self.discomfort += gap < DISCOMFORT
        self.min_ttc = min(self.min_ttc, ttc)
        if self.pref_speed is not None:
            self.loss_sum += loss
            self.loss_count += near

    def result(self) -> dict:
        """jerk_mean [m/s^3]; with moving obstacles (else None): min_ped_gap [m] (surface to
        surface), personal_space_share (share of the instants with a pedestrian within
        PERSONAL_SPACE), discomfort_frequency (CrowdNav's: the share of the instants with one
        within DISCOMFORT), min_ttc [s] (inf: never on a collision course), intrusion_ratio and
        social_distance [m] (`intrusions`); ped_speed_loss: mean over instants and pedestrians
        within NEAR of 1 - speed / preferred speed (None without preferred speeds or with none
        near); and `time_use`'s."""
        crowd = self.pedestrians
        ratio, social = (None, None)
        if crowd:
            ratio, social = intrusions(self.position, self.crowd, self.robot_radius, self.dt)
        return {
            **self.time_use(),
            "jerk_mean": mean_jerk(self.velocity, self.dt),
            "min_ped_gap": self.min_gap if crowd else None,
            "personal_space_share": self.personal / self.instants if crowd else None,
            "discomfort_frequency": self.discomfort / self.instants if crowd else None,
            "min_ttc": self.min_ttc if crowd else None,
            "intrusion_ratio": ratio,
            "social_distance": social,
            "ped_speed_loss": self.loss_sum / self.loss_count if self.loss_count else None,
        }

    def time_use(self) -> dict:
        """Where the time goes, over the steps between the instants: time_waiting [s], dt for
        each step whose mean speed (the distance between its instants / dt) is below
        WAIT_SPEED; time_slow [s], dt for each step that starts in free space (a clearance of
        FREE_SPACE or more) with a mean speed below SLOW_SHARE of the agent's top speed
        (waiting included); detour: the path's length (as the runner's path_length) over the
        straight distance from the start to the goal's centre (None where they coincide)."""
        step = np.linalg.norm(np.diff(np.asarray(self.position), axis=0), axis=1)
        free = np.asarray(self.clearance[:-1]) >= FREE_SPACE
        slow = free & (step < SLOW_SHARE * self.top_speed * self.dt)
        length = float(np.sum(step))
        return {
            "time_waiting": np.count_nonzero(step < WAIT_SPEED * self.dt) * self.dt,
            "time_slow": np.count_nonzero(slow) * self.dt,
            "detour": length / self.straight if self.straight > 0 else None,
        }


_NO_PREF = np.zeros(0)


def intrusions(robot, crowd, robot_radius, dt) -> tuple[float | None, float | None]:
    """CrowdNav++'s intrusions (its crowd_sim_var_num.py calc_reward, rl/evaluation.py) from
    the robot's centres (K + 1, 2) and the moving obstacles' x, y, radius (K + 1, L, 3) at the
    control instants dt [s] apart: at each instant k < K (those the robot acts at), it intrudes
    where its centre lies closer than radius + robot_radius to an obstacle's centre at
    t_k + j INTRUSION_STEP, j = 1 .. INTRUSION_HORIZON (their true future: here the recorded
    one, linear between instants, the earlier instant's across a respawn (faster than
    RESPAWN_SPEED); times after the last instant and rows of radius 0 left out).

    Returns: (the share of the K instants with an intrusion, the mean over those of the smallest
    intruded centre distance [m], None without any); (None, None) for K = 0."""
    robot = np.asarray(robot, dtype=np.float64)[:, :2]
    crowd = np.asarray(crowd, dtype=np.float64)
    last = len(robot) - 1
    if last < 1:
        return None, None
    nearest = np.full(last, np.inf)
    for j in range(1, INTRUSION_HORIZON + 1):
        f = np.arange(last) + j * INTRUSION_STEP / dt
        i0 = np.floor(f + 1e-9).astype(int)
        w = np.clip(f - i0, 0.0, 1.0)[:, None, None]
        kept = (i0 < last) | ((i0 == last) & (w[:, 0, 0] < 1e-9))
        i0 = np.minimum(i0, last)
        a, b = crowd[i0], crowd[np.minimum(i0 + 1, last)]
        jump = np.hypot(*(b[..., :2] - a[..., :2]).T).T > RESPAWN_SPEED * dt
        at = np.where(jump[..., None], a[..., :2], (1.0 - w) * a[..., :2] + w * b[..., :2])
        d = np.hypot(*(at - robot[:last, None]).T).T
        hit = kept[:, None] & (a[..., 2] > 0) & (b[..., 2] > 0) & (d < a[..., 2] + robot_radius)
        nearest = np.minimum(nearest, np.where(hit, d, np.inf).min(axis=1, initial=np.inf))
    intruded = np.isfinite(nearest)
    social = float(nearest[intruded].mean()) if intruded.any() else None
    return float(intruded.mean()), social


@numba.njit(cache=True, error_model="numpy")
def _instant(moving, velocity, robot_xy, robot_v, robot_radius, pref):
    """FieldMetrics.read's values of one instant: the smallest gap (nan if any is), whether a
    gap is below PERSONAL_SPACE, the smallest time to collision, and the sum and number of the
    speed losses of the obstacles within NEAR (pref (L,), or empty: no losses).
    moving: (L, 4) x, y, heading, radius; velocity: (L, 2); the robot at robot_xy (2,) moving at
    robot_v (2,)."""
    min_gap, personal, min_ttc = np.inf, False, np.inf
    losses = np.empty(len(moving) if len(pref) else 0)
    near = 0
    for j in range(len(moving)):
        px, py = moving[j, 0] - robot_xy[0], moving[j, 1] - robot_xy[1]
        gap = math.hypot(px, py) - moving[j, 3] - robot_radius
        if not gap >= min_gap and min_gap == min_gap:  # numpy's min: a nan stays
            min_gap = gap
        personal |= gap < PERSONAL_SPACE
        vx, vy = velocity[j, 0] - robot_v[0], velocity[j, 1] - robot_v[1]
        min_ttc = min(min_ttc, _ttc(px, py, vx, vy, moving[j, 3] + robot_radius))
        if len(pref) and gap < NEAR:
            losses[near] = 1.0 - math.hypot(velocity[j, 0], velocity[j, 1]) / pref[j]
            near += 1
    return min_gap, personal, min_ttc, 0.0 + pairwise(losses[:near]), near


# Smoothness and indecision (the applied controls and the path of an episode)
LINEAR_CONTROLS = ("u_x", "u_y", "v")  # controls that are velocities [m/s]
ANGULAR_CONTROLS = ("u_theta", "omega")  # controls that are turn rates [rad/s]
STOP_SPEED = 0.05  # [m/s] below it over a control step, the direction of travel is undefined
TURN_DEADBAND = 0.05  # [rad/s] a course rate this small counts as going straight
SIDE_DEADBAND = 0.1  # [m] closer than this to the line through the obstacle: on neither side


def control_rates(actions, controls, dt: float) -> tuple[float | None, float | None]:
    """The applied control's mean rate of change: (linear [m/s^2], angular [rad/s^2]).

    actions (n, nu): the controls the controller commanded at each step (before any control
    noise of the task), named by `controls` (the agent's, e.g. ("u_x", "u_y", "u_theta")).
    linear: the mean over consecutive steps of |du| / dt, the Euclidean norm over the controls
    that are velocities (LINEAR_CONTROLS: a holonomic robot's u_x, u_y; a unicycle's v);
    angular: the same of the turn rate (ANGULAR_CONTROLS: u_theta, omega). None where the
    agent has no such control (the Dubins car's speed is fixed) or for fewer than two steps.
    """
    if len(actions) < 2:
        return None, None
    u = np.asarray(actions, dtype=np.float64).reshape(len(actions), -1)
    du = np.diff(u, axis=0) / dt

    def rate(names):
        cols = [i for i, c in enumerate(controls) if c in names]
        return float(np.linalg.norm(du[:, cols], axis=1).mean()) if cols else None

    return rate(LINEAR_CONTROLS), rate(ANGULAR_CONTROLS)


def turn_sign_changes(path, dt: float) -> int:
    """How often the path's turn rate changes sign: indecision, the robot turning left, then
    right, then left.

    path (n, 2): the robot's positions at the control instants, dt apart. The turn rate is the
    rate of change of the direction of travel (the course): for the Dubins car and the unicycle
    their heading rate (up to the plant's lag), for the holonomic robot, whose heading need not
    follow its motion, the rate at which its velocity turns (the sign of its lateral
    acceleration). Steps slower than STOP_SPEED are skipped (no direction); a course rate
    below TURN_DEADBAND is straight (no sign); the count is the sign changes between the
    remaining turns, in order (left, straight, left is no change; left, right is one).
    """
    d = np.diff(np.asarray(path, dtype=np.float64), axis=0)
    d = d[np.hypot(d[:, 0], d[:, 1]) >= STOP_SPEED * dt]
    if len(d) < 2:
        return 0
    a, b = d[:-1], d[1:]
    turn = np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], (a * b).sum(axis=1))
    signs = np.sign(turn[np.abs(turn) >= TURN_DEADBAND * dt])
    return int(np.count_nonzero(signs[1:] != signs[:-1]))


def indecision(path, dt: float, length: float) -> dict:
    """turn_sign_changes of the path, and per metre travelled (indecision_per_m; `length`, the
    path's length; None for 0) and per second of the episode (indecision_per_s, (n - 1) dt;
    None for a path of one instant)."""
    p = np.asarray(path, dtype=np.float64)
    changes = turn_sign_changes(p, dt)
    duration = (len(p) - 1) * dt
    return {
        "turn_sign_changes": changes,
        "indecision_per_m": changes / length if length > 0 else None,
        "indecision_per_s": changes / duration if duration > 0 else None,
    }


def side_commitment(path, dt: float, start, goal, centre) -> dict:
    """When the robot commits to one side of a single obstacle, and how often it switches.

    path (n, 2): the robot's positions at the control instants, dt apart; start, goal (2,);
    centre (2,): the obstacle's centre. The side at an instant is the sign of the cross
    product of (goal - start) and (robot - centre): +1 left of the line through the centre
    along the start-goal direction, -1 right, none within SIDE_DEADBAND of it. Only the
    instants until the robot draws level with the centre count (its progress along the
    start-goal direction reaches the centre's: after that, the side has been chosen).

    Returns {commit_time [s], commit_delay [s], side_switches}: side_switches, the changes
    of side (left to right or back, instants on neither side skipped) after the first instant
    on a side; commit_time, the first instant from which the robot never changes side again
    (the start of its last side), from the episode's start; commit_delay, commit_time less the
    first instant on a side (0 for a robot that never switches: how long it hesitated once it
    left the line). commit_time and commit_delay are None if the robot never leaves the
    deadband (driving straight into the obstacle).
    """
    along, lateral = _line_frame(path, start, goal, centre)
    level = np.flatnonzero(along >= 0)
    end = level[0] + 1 if level.size else len(along)
    side = np.where(np.abs(lateral[:end]) > SIDE_DEADBAND, np.sign(lateral[:end]), 0.0)
    commit_time, commit_delay, switches = _commitment(side, dt)
    return {"commit_time": commit_time, "commit_delay": commit_delay, "side_switches": switches}


def _line_frame(points, start, goal, centre) -> tuple[np.ndarray, np.ndarray]:
    """Progress along the start-goal direction and lateral offset (left +) of points (n, >= 2)
    relative to centre (2,): each (n,)."""
    p = np.asarray(points, dtype=np.float64)[:, :2]
    e = np.asarray(goal, dtype=np.float64)[:2] - np.asarray(start, dtype=np.float64)[:2]
    e = e / np.hypot(*e)
    rel = p - np.asarray(centre, dtype=np.float64)[:2]
    return rel @ e, e[0] * rel[:, 1] - e[1] * rel[:, 0]


def _commitment(side, dt: float) -> tuple[float | None, float | None, int]:
    """(commit time, commit delay, switches) of a series of sides (n,) (+1, -1; 0: none) dt
    apart, as `side_commitment` defines them."""
    side = np.asarray(side)
    decided = np.flatnonzero(side)
    if not decided.size:
        return None, None, 0
    s = side[decided]
    changes = np.flatnonzero(s[1:] != s[:-1])
    commit = decided[changes[-1] + 1] if changes.size else decided[0]
    return float(commit * dt), float((commit - decided[0]) * dt), int(changes.size)


def planned_side(states, start, goal, centre, reach: float = 0.0) -> int:
    """The side of a single obstacle on which a planned path passes it: +1 left, -1 right
    (as `side_commitment`), 0 none.

    states (N + 1, >= 2): the plan rolled out from the step's state; start, goal (2,) and
    centre (2,) as `side_commitment`'s; reach [m]: the obstacle's radius plus the robot's (0:
    the line's deadband alone). The side is that of the first planned point whose progress
    along the start-goal direction reaches the centre's (where the plan draws level with the
    obstacle); none where no point does within the horizon, or where that point lies within
    max(SIDE_DEADBAND, reach) of the line through the centre: a plan that runs into the
    obstacle passes it on neither side.
    """
    along, lateral = _line_frame(states, start, goal, centre)
    level = np.flatnonzero(along >= 0)
    if not level.size or abs(lateral[level[0]]) <= max(SIDE_DEADBAND, reach):
        return 0
    return 1 if lateral[level[0]] > 0 else -1


class PlanSides:
    """The side of a single obstacle that a controller's plan takes, step by step: the
    decision, which control noise cannot fake (the executed path's side, `side_commitment`,
    reads the robot's wobble too).

    At every control step before the robot draws level with the centre (its progress along
    the start-goal direction reaches the centre's; later steps are not read), the plan
    (`diagnostics.plan`, (N, nu)) is rolled out with the controller's agent
    (`agent.rollout_one`) from the state it was planned from (the step's state; Tube-MPPI's
    nominal state, `diagnostics.nominal_state`, where it records one) and `planned_side` gives
    its side (0 where the step has no plan).

    start, goal (2,), centre (2,): the task's; dt [s]: the control period; reach [m]: the
    obstacle's radius plus the robot's (`planned_side`).
    """

    def __init__(self, start, goal, centre, dt: float, reach: float = 0.0):
        self.start, self.goal, self.centre, self.dt = start, goal, centre, dt
        self.reach = reach
        self.sides: list[int] = []
        self.level = False

    def read(self, controller, state: np.ndarray) -> None:
        """Read the plan of the step that `controller` just planned from `state` (3,)."""
        if self.level:
            return
        along, _ = _line_frame(np.asarray(state)[None], self.start, self.goal, self.centre)
        if along[0] >= 0:
            self.level = True
            return
        d = getattr(controller, "diagnostics", None)
        plan = getattr(d, "plan", None)
        if plan is None:
            self.sides.append(0)
            return
        nominal = getattr(d, "nominal_state", None)
        x0 = np.asarray(state if nominal is None else nominal, dtype=np.float64)
        states = controller.agent.rollout_one(x0, plan, controller.dt)
        self.sides.append(planned_side(states, self.start, self.goal, self.centre, self.reach))

    def result(self) -> dict:
        """plan_commit_time [s] (from the episode's start until the step from which the plan
        keeps its side), plan_commit_delay [s] (from the first step with a planned side until
        then) and plan_side_switches (changes of the planned side, steps without one skipped),
        as `side_commitment` defines them for the path; the times None where no plan took a
        side."""
        commit_time, commit_delay, switches = _commitment(self.sides, self.dt)
        return {
            "plan_commit_time": commit_time,
            "plan_commit_delay": commit_delay,
            "plan_side_switches": switches,
        }


NO_SIDES = dict.fromkeys(("commit_time", "commit_delay", "side_switches"))
NO_PLAN_SIDES = dict.fromkeys(("plan_commit_time", "plan_commit_delay", "plan_side_switches"))
