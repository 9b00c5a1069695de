"""Run one episode: a `dcmppi.tasks` environment driven by a `dcmppi` controller.

This is the only module that joins the two sides: tasks know no controller, controllers
import no MuJoCo. An episode is fully determined by its `EpisodeSpec`; the same spec
gives the same outcome, path and clearance on every run, worker and executor.
"""

from __future__ import annotations

import dataclasses
import functools
import inspect
import json
import math
import numbers
import time
import zlib
from collections.abc import Callable

import numpy as np


@dataclasses.dataclass(frozen=True)
class EpisodeSpec:
    """One episode: which task, world, noise and controller, with all parameters.

    `seed` fixes the world and the noise sequence (the task's `random`) and, through a
    separate stream, the controller's sampling. Every controller of a paired comparison
    runs with the same `seed` for the same environment.

    `controller` is a name `dcmppi.bench.plugins.resolve_controller` resolves (built-in, entry
    point or package.module:ClassName). `controller_params` are its own parameters (each must
    be accepted); `shared_params` are common to the controllers of an experiment and each
    controller takes those its class accepts.
    """

    task: str
    controller: str
    noise: str = "none"
    seed: int = 0
    task_params: dict = dataclasses.field(default_factory=dict)
    controller_params: dict = dataclasses.field(default_factory=dict)
    shared_params: dict = dataclasses.field(default_factory=dict)

    def controller_seed(self) -> int:
        """Seed of the controller's Generator: independent of the world's stream."""
        return int(np.random.SeedSequence([self.seed, 1]).generate_state(1)[0])


def make_env(spec: EpisodeSpec):
    """The dm_control environment of `spec` (imports MuJoCo)."""
    from dcmppi import tasks

    task_kwargs = {"random": spec.seed, "noise": spec.noise, **spec.task_params}
    return tasks.load(spec.task, task_kwargs=task_kwargs)


def robot_keys() -> list[str]:
    """The parameters the plant and the planner share: the agent, its parameters and the robot
    radius. They are task parameters; the runner hands them to the controller."""
    from dcmppi.control.agents import agent_param_names

    return ["agent", "robot_radius", *agent_param_names()]


def _shared_args(spec: EpisodeSpec) -> dict:
    """The seed, the task's robot parameters (agent included, the task's defaults where
    task_params do not set them: the corridor's 0.3 m radius, the square's 1 m/s) and the
    shared parameters."""
    keys = robot_keys()
    clash = sorted(set(keys) & (set(spec.controller_params) | set(spec.shared_params)))
    if clash:
        raise ValueError(
            f"{', '.join(clash)}: robot parameters are task parameters (the plant and the "
            "planner share them); set them with --task-param / task_params"
        )
    return {**_robot(spec), **spec.shared_params, "seed": spec.controller_seed()}


def controller_for(spec: EpisodeSpec):
    """The controller of `spec`, planning with the task's agent and robot parameters.

    It gets its own parameters, and of the seed, the robot parameters and the shared
    parameters those its class accepts (see `dcmppi.bench.plugins.build`).
    """
    from dcmppi.bench.plugins import build

    return build(spec.controller, spec.controller_params, _shared_args(spec))


def check_specs(specs) -> None:
    """Build (and reset) the environment of the first spec and the controller of every distinct
    one, so that a bad name, parameter, world or missing dependency fails before anything is
    recorded. A shared parameter that none of the controllers takes is an error (a misspelt
    name)."""
    from dcmppi.bench.plugins import accepted_params, resolve_controller

    first = {}
    for spec in specs:
        key = json.dumps([spec.controller, spec.controller_params], sort_keys=True)
        first.setdefault(key, spec)
    unused = set().union(*(spec.shared_params for spec in first.values()))
    for i, spec in enumerate(first.values()):
        controller_for(spec)
        shared = _shared_args(spec)
        prediction = {**shared, **spec.controller_params}.get("prediction")
        accepted = accepted_params(resolve_controller(spec.controller), shared["agent"], prediction)
        unused = set() if accepted is None else unused - accepted
        if i == 0:  # a world the task cannot draw (an impossible layout) fails here
            env = make_env(spec)
            env.reset()
            env.close()
    if unused:
        names = ", ".join(dict.fromkeys(spec.controller for spec in first.values()))
        raise ValueError(
            f"parameter(s) {', '.join(sorted(unused))} set for every controller but taken by "
            f"none of them ({names}); check the names"
        )


def act(controller, observation) -> np.ndarray:
    """The controller's action for a task observation, as the task's action array (nu,).

    Calls act(state, goal, static, moving, obstacle_model) and passes the map's bounds as
    `bounds`, and the observed velocities of the moving obstacles as `moving_velocity` (and the
    true futures as `moving_futures`, see `TrueFutures`) where the observation has them, to
    controllers whose act takes that keyword (dcmppi's do; a user's may not)."""
    args = (
        observation["robot_pose"],
        observation["goal"],
        observation["static_obstacles"],
        observation["moving_obstacles"],
        observation["obstacle_model"],
    )
    extra = {
        name: observation[key] for name, key in _keywords(type(controller)) if key in observation
    }
    u = controller.act(*args, **extra)
    return np.asarray(u, dtype=np.float64).reshape(-1)


# act's keywords: (controller keyword, observation key)
_KEYWORDS = (
    ("bounds", "map_bounds"),
    ("moving_velocity", "moving_velocity"),
    ("moving_futures", "moving_futures"),
)


@functools.cache
def _keywords(cls) -> tuple:
    """Those of _KEYWORDS whose keyword cls.act accepts."""
    return tuple((name, key) for name, key in _KEYWORDS if _takes(cls, name))


def _takes(cls, name: str) -> bool:
    """Whether cls.act accepts the keyword `name`."""
    try:
        parameters = inspect.signature(cls.act).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(p.name == name or p.kind == p.VAR_KEYWORD for p in parameters)


_WARM: set[str] = set()  # controller configurations this process has warmed up


def warm_up(spec: EpisodeSpec, observation) -> None:
    """One untimed act() of a throwaway copy of the controller on `observation`, once per
    process and controller configuration: first-call costs (numba compilation, imports,
    caches) stay out of the timed steps. The copy has its own generator; the episode's
    controller is untouched."""
    key = json.dumps(
        [spec.task, spec.controller, spec.controller_params, spec.shared_params, _robot(spec)],
        sort_keys=True,
        default=repr,
    )
    if key not in _WARM:
        controller = controller_for(spec)
        controller.reset()
        act(controller, observation)
        _WARM.add(key)


def _robot(spec: EpisodeSpec) -> dict:
    """The robot the task simulates for spec (dcmppi.tasks.robot), computed once per task and
    task parameters."""
    return dict(_task_robot(spec.task, json.dumps(spec.task_params, sort_keys=True)))


@functools.lru_cache(maxsize=64)
def _task_robot(task: str, task_params: str) -> tuple:
    from dcmppi.tasks import robot

    return tuple(robot(task, json.loads(task_params)).items())


class Diagnosis:
    """Per-step readings of a controller's `diagnostics`, for any controller: attributes it
    lacks are skipped (getattr with defaults).

    ess: effective sample size; clusters: DBSCAN clusters (labels >= 0) where `labels` is
    set; fallback: whether `chosen == -1` (Alg. 1 over all samples) where `labels` is set;
    deviation: Tube-MPPI's real-to-nominal position distance at the start of the step, before
    any reset (`nominal_deviation`; else |x[:2] - nominal_state[:2]| where `nominal_state` is
    set).
    """

    def __init__(self):
        self.ess: list[float] = []
        self.clusters: list[int] = []
        self.fallback: list[bool] = []
        self.deviation: list[float] = []

    def read(self, controller, state: np.ndarray) -> None:
        """Read the diagnostics of the step that `controller` just planned from `state` (3,)."""
        d = getattr(controller, "diagnostics", None)
        ess = getattr(d, "ess", None)
        if isinstance(ess, numbers.Real) and math.isfinite(ess):
            self.ess.append(float(ess))
        labels = getattr(d, "labels", None)
        if labels is not None:
            labels = np.asarray(labels)
            self.clusters.append(_distinct(labels[labels >= 0], len(labels)))
            self.fallback.append(getattr(d, "chosen", -1) == -1)
        deviation = getattr(d, "nominal_deviation", None)
        nominal = getattr(d, "nominal_state", None)
        if isinstance(deviation, numbers.Real) and math.isfinite(deviation):
            self.deviation.append(float(deviation))
        elif nominal is not None:
            self.deviation.append(float(np.hypot(*(state[:2] - np.asarray(nominal)[:2]))))

    def result(self) -> dict:
        """ess_mean, clusters_mean, fallback_share, tube_deviation_p95 (None: not recorded)."""

        def mean(xs):
            return float(np.mean(xs)) if xs else None

        return {
            "ess_mean": mean(self.ess),
            "clusters_mean": mean(self.clusters),
            "fallback_share": mean(self.fallback),
            "tube_deviation_p95": float(np.percentile(self.deviation, 95))
            if self.deviation
            else None,
        }


def _distinct(values: np.ndarray, bound: int) -> int:
    """The number of distinct values (n,): by counting where they are integers in [0, bound)
    (DBSCAN's labels), else by sorting."""
    if values.dtype.kind == "i" and values.max(initial=0) < bound:
        return int(np.count_nonzero(np.bincount(values)))
    return len(np.unique(values))


PERSONAL_SPACE = 0.5  # [m] a pedestrian's surface this close to the robot's is in its space
NEAR = 2.0  # [m] pedestrians this close (surface to surface) count in the speed loss


def time_to_collision(position, velocity, radius) -> np.ndarray:
    """Times [s] (L,) until two discs first touch at constant velocities: position, velocity
    (L, 2) of each obstacle relative to the robot, radius (L,) the sums of the two radii.
    0 where they touch already; inf where they are not on a collision course."""
    p = np.asarray(position, dtype=np.float64)
    v = np.asarray(velocity, dtype=np.float64)
    a = np.einsum("ij,ij->i", v, v)
    b = np.einsum("ij,ij->i", p, v)  # |p + v t|^2 = R^2: a t^2 + 2 b t + c = 0
    c = np.einsum("ij,ij->i", p, p) - np.asarray(radius, dtype=np.float64) ** 2
    disc = b * b - a * c
    closing = (b < 0) & (disc >= 0) & (a > 0)
    t = np.full(len(p), np.inf)
    t[closing] = (-b[closing] - np.sqrt(disc[closing])) / a[closing]
    t[c <= 0] = 0.0
    return t


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
    """The field's crowd-navigation metrics of an episode, from the simulation's truth read at
    every control instant (the start and after every step): the robot's position and velocity
    and the moving obstacles' positions, radii and velocities (`moving_velocity()`) from
    `env.physics`, their preferred speeds from `env.task.world.moving_pref_speed` (nan: none,
    as for today's Dubins arcs).
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
        self.instants = 0
        self.min_gap = math.inf
        self.personal = 0
        self.min_ttc = math.inf
        self.loss_sum = 0.0
        self.loss_count = 0
        self.read(physics)

    def read(self, physics) -> None:
        """Record the state of `physics` now."""
        robot_v = physics.robot_velocity()[:2]
        self.velocity.append(robot_v)
        if not self.pedestrians:
            return
        moving = physics.moving_obstacles()
        xy, radius = moving[:, :2], moving[:, 3]
        velocity = physics.moving_velocity()
        rel = xy - physics.robot_pose()[:2]
        gap = np.hypot(rel[:, 0], rel[:, 1]) - radius - self.robot_radius
        self.instants += 1
        self.min_gap = min(self.min_gap, float(gap.min()))
        self.personal += bool((gap < PERSONAL_SPACE).any())
        ttc = time_to_collision(rel, velocity - robot_v, radius + self.robot_radius)
        self.min_ttc = min(self.min_ttc, float(ttc.min()))
        if self.pref_speed is not None:
            near = gap < NEAR
            speed = np.hypot(velocity[near, 0], velocity[near, 1])
            self.loss_sum += float(np.sum(1.0 - speed / self.pref_speed[near]))
            self.loss_count += int(near.sum())

    def result(self) -> dict:
        """jerk_mean [m/s^3]; with moving obstacles (else None): min_ped_gap [m] (surface to
        surface), personal_space_share (share of the instants with a pedestrian within
        PERSONAL_SPACE), min_ttc [s] (inf: never on a collision course); ped_speed_loss: mean
        over instants and pedestrians within NEAR of 1 - speed / preferred speed (None without
        preferred speeds or with none near)."""
        crowd = self.pedestrians
        return {
            "jerk_mean": mean_jerk(self.velocity, self.dt),
            "min_ped_gap": self.min_gap if crowd else None,
            "personal_space_share": self.personal / self.instants if crowd else None,
            "min_ttc": self.min_ttc if crowd else None,
            "ped_speed_loss": self.loss_sum / self.loss_count if self.loss_count else None,
        }


class TrueFutures:
    """The moving obstacles' true futures for a controller whose predictor takes "futures"
    (prediction="given"): where they ignore the robot, one run of their own model from the
    episode's start (dcmppi.bench.futures.obstacle_tracks) is their future at every step.

    `at(step)`: (L, 1, N + 1, 2) their centres after step, step + 1, ..., step + N control
    steps (one future each).
    """

    def __init__(self, spec: EpisodeSpec, N: int):
        from dcmppi.bench.futures import obstacle_tracks, reset_exogenous

        env = make_env(spec)
        world = reset_exogenous(env, spec.task, "prediction 'given' (the true futures)")
        steps = int(np.ceil(env.task.time_limit / env.control_timestep())) + N
        tracks = [world.moving[:, :2], *obstacle_tracks(env, steps)]  # (steps + 1) x (L, 2)
        self.tracks = np.stack(tracks, axis=1)[:, None]  # (L, 1, steps + 1, 2)
        self.N = N

    def at(self, step: int) -> np.ndarray:
        return self.tracks[:, :, step : step + self.N + 1]


def _wants_futures(controller) -> bool:
    return "futures" in getattr(getattr(controller, "predictor", None), "inputs", ())


class Episode:
    """A running episode of `spec`, advanced one control step at a time.

    Attributes: spec, env, controller, time_step (the latest dm_env TimeStep), poses (list of
    (3,) robot poses x, y, yaw, the start's and one per step), path (array (steps + 1, 2) of
    their positions), ctrl_s and env_s (seconds per step in the controller and in env.step),
    diagnosis (`Diagnosis` of every step), metrics (`FieldMetrics` of every step).
    """

    def __init__(self, spec: EpisodeSpec):
        self.start = time.perf_counter()
        self.spec = spec
        self.env = make_env(spec)
        self.controller = controller_for(spec)
        self.controller.reset()
        self.time_step = self.env.reset()
        wants = _wants_futures(self.controller)
        self.true_futures = TrueFutures(spec, self.controller.N) if wants else None
        self.poses = [self.time_step.observation["robot_pose"].copy()]
        warm_up(spec, self.observation)
        self.ctrl_s: list[float] = []
        self.env_s: list[float] = []
        self.diagnosis = Diagnosis()
        self.metrics = FieldMetrics(self.env)

    @property
    def path(self) -> np.ndarray:
        return np.asarray(self.poses)[:, :2]

    @property
    def done(self) -> bool:
        return self.time_step.last()

    @property
    def observation(self) -> dict:
        """The task's observation now, with the true futures where the controller takes them."""
        observation = self.time_step.observation
        if self.true_futures is None:
            return observation
        return {**observation, "moving_futures": self.true_futures.at(len(self.poses) - 1)}

    def step(self) -> None:
        """One control step: the controller acts on the observation, the task steps."""
        observation = self.observation
        t0 = time.perf_counter()
        action = act(self.controller, observation)
        t1 = time.perf_counter()
        self.time_step = self.env.step(action)
        t2 = time.perf_counter()
        self.ctrl_s.append(t1 - t0)
        self.env_s.append(t2 - t1)
        self.diagnosis.read(self.controller, observation["robot_pose"])
        self.poses.append(self.time_step.observation["robot_pose"].copy())
        self.metrics.read(self.env.physics)

    def result(self) -> dict:
        """The metrics of the finished episode (see `run_episode`)."""
        from dcmppi.tasks.barn import navigation_score
        from dcmppi.tasks.world_base import GOAL_TOLERANCE

        path = self.path
        outcome = self.env.task.outcome
        ctrl_ms = 1e3 * np.asarray(self.ctrl_s)
        elapsed = float(self.env.physics.data.time)
        optimal = getattr(self.env.task, "optimal_time", None)
        length = float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))
        world = self.env.task.world
        contact = self.env.physics.first_contact
        kind = None
        if outcome == "collision":
            kind = "pedestrian" if contact["geom"].startswith("moving") else "static"
        return {
            "outcome": outcome,
            "success": outcome == "goal",
            "collision": outcome == "collision",
            "collision_kind": kind,
            "timeout": outcome == "time_limit",
            "failure": outcome != "goal",
            "steps": len(self.ctrl_s),
            "time_to_goal": elapsed if outcome == "goal" else None,
            "nav_score": None
            if optimal is None
            else navigation_score(outcome == "goal", elapsed, optimal),
            "path_length": length,
            "spl": spl(outcome == "goal", world.start[:2], world.goal, GOAL_TOLERANCE, length),
            **self.metrics.result(),
            "min_clearance": float(self.env.task.min_clearance),
            "ctrl_ms_mean": float(ctrl_ms.mean()) if ctrl_ms.size else 0.0,
            "ctrl_ms_p95": float(np.percentile(ctrl_ms, 95)) if ctrl_ms.size else 0.0,
            "env_ms_mean": float(1e3 * np.mean(self.env_s)) if self.env_s else 0.0,
            **self.diagnosis.result(),
            "wall_s": time.perf_counter() - self.start,
            "final_pose": [float(v) for v in self.poses[-1]],
            "trace": encode_trace(self.poses),
        }


def run_episode(
    spec: EpisodeSpec,
    on_step: Callable[[Episode], None] | None = None,
    keep_path: bool = False,
) -> dict:
    """Run `spec` to termination and return its metrics.

    Args:
      spec: the episode.
      on_step: optional callback `on_step(episode)` after the reset and after every step
        (videos use it); it must not change the episode.
      keep_path: also return the robot's positions, array (steps + 1, 2), under "path".

    Returns:
      A dict: outcome ("goal" | "collision" | "left_map" | "time_limit"), success (the goal),
      collision, collision_kind ("pedestrian": the first contact was a moving obstacle,
      "static": a static one or a wall; None without collision), timeout (the time limit),
      failure, steps, time_to_goal [s] (None unless reached), nav_score (BARN's navigation
      score where the task gives an `optimal_time`, i.e. a BARN world; else None),
      path_length [m], spl (success weighted by path length, see `spl`), the crowd metrics of
      `FieldMetrics.result` (jerk_mean, min_ped_gap, personal_space_share, min_ttc,
      ped_speed_loss), min_clearance [m], ctrl_ms_mean, ctrl_ms_p95 (controller time per
      step, first-call costs excluded by `warm_up`), env_ms_mean, the diagnostics ess_mean,
      clusters_mean, fallback_share, tube_deviation_p95 [m] (None where the controller records
      none; see `Diagnosis`), wall_s, final_pose ([x, y, yaw] when it ended), trace (bytes: the
      robot's pose at every control instant, see `encode_trace`; `dcmppi.bench.replay` compares
      it).
    """
    episode = Episode(spec)
    if on_step is not None:
        on_step(episode)
    while not episode.done:
        episode.step()
        if on_step is not None:
            on_step(episode)
    result = episode.result()
    if keep_path:
        result["path"] = episode.path
    return result


def encode_trace(poses) -> bytes:
    """Poses (n, 3) x, y, yaw as zlib-compressed little-endian float32 (a result's "trace")."""
    return zlib.compress(np.asarray(poses, dtype="<f4").reshape(-1, 3).tobytes())


def decode_trace(blob: bytes) -> np.ndarray:
    """The poses (n, 3) float32 of an `encode_trace` blob."""
    return np.frombuffer(zlib.decompress(blob), dtype="<f4").reshape(-1, 3)
