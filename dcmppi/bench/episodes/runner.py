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
import sys
import time
import zlib
from collections.abc import Callable

import numpy as np

from dcmppi.bench.episodes.columns import EpisodeResult
from dcmppi.bench.episodes.metrics import (
    NO_PLAN_SIDES,
    NO_SIDES,
    Diagnosis,
    FieldMetrics,
    PlanSides,
    control_rates,
    indecision,
    side_commitment,
    spl,
)


@dataclasses.dataclass(frozen=True)
class EpisodeSpec:
    """One episode: which task, world, noise and controller, with all parameters.

    `seed` fixes the world and the noise sequence (the task's `random`) and, through a
    separate stream, the controller's sampling. Every controller of a paired comparison
    runs with the same `seed` for the same environment.

    `controller` is a name `dcmppi.bench.episodes.plugins.resolve_controller` resolves (built-in,
    entry point or package.module:ClassName). `controller_params` are its own parameters (each must
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


def check_world(spec: EpisodeSpec) -> None:
    """Build and reset the environment of `spec`: a world its task cannot draw raises."""
    env = make_env(spec)
    try:
        env.reset()
    finally:
        env.close()


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
    parameters those its class accepts (see `dcmppi.bench.episodes.plugins.build`).
    """
    from dcmppi.bench.episodes.plugins import build

    return build(spec.controller, spec.controller_params, _shared_args(spec))


def preset_held(spec: EpisodeSpec, chosen=()) -> list[str]:
    """One line per parameter that the preset of `spec`'s controller sets but an experiment's
    shared parameter sets otherwise: the shared value is explicit and wins, which a row or
    `--param` that names the preset may not mean (the shipped rows name both). `chosen`: the
    shared parameters the user gave (--param), which say what they mean."""
    from dcmppi.control.defaults import PRESETS

    params = {**spec.shared_params, **spec.controller_params}
    name = params.get("preset")
    preset = PRESETS.get(name, {}) if isinstance(name, str) else {}
    return [
        f"{spec.controller} with preset={name!r}: the experiment's shared {key}="
        f"{spec.shared_params[key]!r} holds, not the preset's {key}={value!r}; set {key} in the "
        f"row or with --param to choose"
        for key, value in preset.items()
        if key in spec.shared_params
        and key not in spec.controller_params
        and key not in chosen
        and spec.shared_params[key] != value
    ]


def check_specs(specs, others=(), chosen=()) -> None:
    """Build (and reset) the environment of the first spec and the controller of every distinct
    one, so that a bad name, parameter, world or missing dependency fails before anything is
    recorded. A shared parameter that none of the controllers takes is an error (a misspelt
    name); `others`: (controller, params) of an experiment's rows not run now, which count as
    taking what they accept (the MPPI rows' shared parameters when only classical rows run);
    `chosen`: the shared parameters the user gave, never said to hold over a preset."""
    from dcmppi.bench.episodes.plugins import accepted_params, resolve_controller

    first = {}
    for spec in specs:
        key = json.dumps([spec.controller, spec.controller_params], sort_keys=True)
        first.setdefault(key, spec)
    unused = set().union(*(spec.shared_params for spec in first.values()))
    agent = None
    for i, spec in enumerate(first.values()):
        controller_for(spec)
        shared = _shared_args(spec)
        agent = shared["agent"]
        prediction = {**shared, **spec.controller_params}.get("prediction")
        accepted = accepted_params(resolve_controller(spec.controller), agent, prediction)
        unused = set() if accepted is None else unused - accepted
        if accepted is None or "preset" in accepted:
            for line in preset_held(spec, chosen):
                print(f"dcmppi: {line}", file=sys.stderr)
        if i == 0:  # a world the task cannot draw (an impossible layout) fails here
            check_world(spec)
    for controller, params in others:
        if unused and agent is not None:
            prediction = {**next(iter(first.values())).shared_params, **params}.get("prediction")
            accepted = accepted_params(resolve_controller(controller), agent, prediction)
            unused = set() if accepted is None else unused - accepted
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


class TrueFutures:
    """The moving obstacles' true futures for a controller whose predictor takes "futures"
    (prediction="given"): where they ignore the robot, one run of their own model from the
    episode's start (dcmppi.bench.episodes.futures.obstacle_tracks) is their future at every step.

    `at(step, robot_xy)`: (L, 1, N + 1, 2) their centres after step, step + 1, ..., step + N
    control steps (one future each). A replay's recorded people come and go: where one is
    absent its future stands AWAY beyond the reach of any rollout from the robot at robot_xy
    (2,), not where the physics parks it (a point that far would spread the planner's track
    cells over a kilometre). `visible(step, moving)`: the observation's moving obstacles
    (L, 4) with the rows of those that appear within the horizon (absent now: radius 0) given
    their radius, so that the controller keeps their futures (it drops radius-0 rows as
    padding).
    """

    AWAY = 5.0  # [m] beyond a rollout's reach and collision distance (obstacle margins too)

    def __init__(self, spec: EpisodeSpec, N: int):
        from dcmppi.bench.episodes.futures import (
            obstacle_presence,
            obstacle_radii,
            obstacle_tracks,
            reset_exogenous,
        )

        env = make_env(spec)
        world = reset_exogenous(env, spec.task, "prediction 'given' (the true futures)")
        steps = int(np.ceil(env.task.time_limit / env.control_timestep())) + N
        tracks, present = [world.moving[:, :2]], [world.moving[:, 3] > 0]
        for centres in obstacle_tracks(env, steps):  # (steps + 1) x (L, 2)
            tracks.append(centres)
            present.append(obstacle_presence(env))
        self.tracks = np.stack(tracks, axis=1)[:, None]  # (L, 1, steps + 1, 2)
        self.present = np.stack(present, axis=1)  # (L, steps + 1)
        self.radius = obstacle_radii(env)
        self.N = N
        reach = env.task.agent.max_speed * N * env.control_timestep() + env.task.robot_radius
        self.away = reach + float(self.radius.max(initial=0.0)) + self.AWAY

    def at(self, step: int, robot_xy) -> np.ndarray:
        futures = self.tracks[:, :, step : step + self.N + 1]
        absent = ~self.present[:, step : step + self.N + 1]
        if not absent.any():
            return futures
        futures = futures.copy()
        futures[:, 0][absent] = np.asarray(robot_xy, dtype=float)[:2] + [self.away, 0.0]
        return futures

    def visible(self, step: int, moving: np.ndarray) -> np.ndarray:
        coming = self.present[:, step : step + self.N + 1].any(axis=1) & (moving[:, 3] == 0)
        if not coming.any():
            return moving
        moving = moving.copy()
        moving[coming, 3] = self.radius[coming]
        return moving


def _wants_futures(controller) -> bool:
    return "futures" in getattr(getattr(controller, "predictor", None), "inputs", ())


class Episode:
    """A running episode of `spec`, advanced one control step at a time.

    Attributes: spec, env, controller, time_step (the latest dm_env TimeStep), poses (list of
    (3,) robot poses x, y, yaw, the start's and one per step), path (array (steps + 1, 2) of
    their positions), actions (the controller's action (nu,) of every step, before any control
    noise of the task), ctrl_s and env_s (seconds per step in the controller and in env.step),
    diagnosis (`Diagnosis` of every step), metrics (`FieldMetrics` of every step), plan_sides
    (in the task blocked, the side of the obstacle each step's plan takes, `PlanSides`, for
    controllers that plan; else None).
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
        self.actions: list[np.ndarray] = []
        self.diagnosis = Diagnosis()
        self.metrics = FieldMetrics(self.env)
        self.plan_sides = self._plan_sides()

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
        step, futures = len(self.poses) - 1, self.true_futures
        return {
            **observation,
            "moving_obstacles": futures.visible(step, observation["moving_obstacles"]),
            "moving_futures": futures.at(step, observation["robot_pose"]),
        }

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
        self.actions.append(action)
        self.diagnosis.read(self.controller, observation["robot_pose"])
        if self.plan_sides is not None:
            self.plan_sides.read(self.controller, observation["robot_pose"])
        self.poses.append(self.time_step.observation["robot_pose"].copy())
        self.metrics.read(self.env.physics)

    def result(self) -> EpisodeResult:
        """The metrics of the finished episode (see `run_episode`)."""
        from dcmppi.tasks.worlds.barn import navigation_score

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
        x, y, theta = (float(v) for v in self.poses[-1])
        values = {
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
            "spl": spl(
                outcome == "goal", world.start[:2], world.goal, self.env.task.goal_tolerance, length
            ),
            **self.metrics.result(),
            "min_clearance": float(self.env.task.min_clearance),
            "ctrl_ms_mean": float(ctrl_ms.mean()) if ctrl_ms.size else 0.0,
            "ctrl_ms_p95": float(np.percentile(ctrl_ms, 95)) if ctrl_ms.size else 0.0,
            "env_ms_mean": float(1e3 * np.mean(self.env_s)) if self.env_s else 0.0,
            **self.diagnosis.result(),
            "wall_s": time.perf_counter() - self.start,
            "final_x": x,
            "final_y": y,
            "final_theta": theta,
            "goal_distance": float(np.hypot(*(path[-1] - world.goal[:2]))),
            "trace": encode_trace(self.poses),
            **self._smoothness(path, length),
            **self._commitment(path),
            **self._human(path),
        }
        return EpisodeResult(values)

    def _smoothness(self, path, length) -> dict:
        """control_rate_linear [m/s^2] and control_rate_angular [rad/s^2] of the actions
        (`control_rates`; None where the agent has no such control), turn_sign_changes,
        indecision_per_m and indecision_per_s of the path (`indecision`)."""
        dt = self.env.control_timestep()
        controls = tuple(self.env.task.agent.controls)
        linear, angular = control_rates(self.actions, controls, dt)
        return {
            "control_rate_linear": linear,
            "control_rate_angular": angular,
            **indecision(path, dt, length),
        }

    def _blocked(self) -> bool:
        """Whether the task is `blocked` (one obstacle between start and goal)."""
        from dcmppi.tasks.worlds.two_valley import Blocked

        return isinstance(self.env.task, Blocked)

    def _plan_sides(self) -> PlanSides | None:
        """In the task blocked, a `PlanSides` for a controller that plans (not a classical
        one, whose drawn plan is its command held): a plan that draws level with the centre
        within the obstacle's radius plus the robot's runs into it and takes no side; else
        None."""
        from dcmppi.control.planners.classical import Classical

        if not self._blocked() or isinstance(self.controller, Classical):
            return None
        world = self.env.task.world
        dt = self.env.control_timestep()
        reach = float(world.static[0, 2]) + self.env.task.robot_radius  # hitting it: no side
        return PlanSides(world.start[:2], world.goal[:2], world.static[0, :2], dt, reach)

    def _commitment(self, path) -> dict:
        """In the task `blocked` (one obstacle between start and goal): commit_time [s],
        commit_delay [s] and side_switches of the path (`side_commitment`), and
        plan_commit_time [s], plan_commit_delay [s] and plan_side_switches of the plans
        (`PlanSides`; None for a controller without a plan); else None for each."""
        if not self._blocked():
            return {**NO_SIDES, **NO_PLAN_SIDES}
        world = self.env.task.world
        dt = self.env.control_timestep()
        planned = NO_PLAN_SIDES if self.plan_sides is None else self.plan_sides.result()
        return {
            **side_commitment(path, dt, world.start[:2], world.goal, world.static[0, :2]),
            **planned,
        }

    def _human(self, path) -> dict:
        """Where the robot replaces a recorded person (the task `replay`, its `human`): scene
        (the test scene of recordings.SCENES that holds the recording, e.g. "univ" for
        students001; else the recording's name), recording (the file's name), person (their
        id in it), human_time [s] and human_path_length [m] (their time to the goal region and
        path to it), frame_path_length [m] (the robot's path sampled alike, at the recording's
        frame period); else None for each."""
        human = getattr(self.env.task, "human", None)
        if human is None:
            names = "scene recording person human_time human_path_length frame_path_length"
            return dict.fromkeys(names.split())
        from dcmppi.tasks.replay import sampled_path_length
        from dcmppi.tasks.replay.recordings import SCENES

        times = np.arange(len(path)) * self.env.control_timestep()
        scene = next((k for k, files in SCENES.items() if human.recording in files), None)
        return {
            "scene": scene or human.recording,
            "recording": human.recording,
            "person": int(human.id),
            "human_time": human.time_to_goal,
            "human_path_length": human.path_length,
            "frame_path_length": sampled_path_length(times, path, human.period),
        }


def run_episode(
    spec: EpisodeSpec,
    on_step: Callable[[Episode], None] | None = None,
    keep_path: bool = False,
) -> EpisodeResult:
    """Run `spec` to termination and return its metrics.

    Args:
      spec: the episode.
      on_step: optional callback `on_step(episode)` after the reset and after every step
        (videos use it); it must not change the episode.
      keep_path: also return the robot's positions, array (steps + 1, 2), under "path".

    Returns:
      An `EpisodeResult`: a dict of one value per episode column (its name, unit and meaning
      declared in `dcmppi.bench.episodes.columns`; None where it does not apply: the task
      blocked's sides elsewhere, a recorded person's figures outside the task replay, the
      diagnostics a controller does not record), "path" too with keep_path.
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
