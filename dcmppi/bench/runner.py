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
    """The seed, the task's robot parameters (agent included) and the shared parameters."""
    from dcmppi.tasks import default_agent

    keys = robot_keys()
    clash = sorted(set(keys) & (set(spec.controller_params) | set(spec.shared_params)))
    if clash:
        raise ValueError(
            f"{', '.join(clash)}: robot parameters are task parameters (the plant and the "
            "planner share them); set them with --task-param / task_params"
        )
    shared = {k: spec.task_params[k] for k in keys if k in spec.task_params}
    shared.setdefault("agent", default_agent(spec.task))
    return {**shared, **spec.shared_params, "seed": spec.controller_seed()}


def controller_for(spec: EpisodeSpec):
    """The controller of `spec`, planning with the task's agent and robot parameters.

    It gets its own parameters, and of the seed, the robot parameters and the shared
    parameters those its class accepts (see `dcmppi.bench.plugins.build`).
    """
    from dcmppi.bench.plugins import build

    return build(spec.controller, spec.controller_params, _shared_args(spec))


def check_specs(specs) -> None:
    """Build the environment of the first spec and the controller of every distinct one, so
    that a bad name, parameter or missing dependency fails before anything is recorded. A
    shared parameter that none of the controllers takes is an error (a misspelt name)."""
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
        if i == 0:
            make_env(spec).close()
    if unused:
        names = ", ".join(dict.fromkeys(spec.controller for spec in first.values()))
        raise ValueError(
            f"parameter(s) {', '.join(sorted(unused))} set for every controller but taken by "
            f"none of them ({names}); check the names"
        )


def act(controller, observation) -> np.ndarray:
    """The controller's action for a task observation, as the task's action array (nu,).

    Calls act(state, goal, static, moving, obstacle_model) and passes the map's bounds as
    `bounds` to controllers whose act takes it (dcmppi's do; a user's may not)."""
    args = (
        observation["robot_pose"],
        observation["goal"],
        observation["static_obstacles"],
        observation["moving_obstacles"],
        observation["obstacle_model"],
    )
    if _takes_bounds(type(controller)):
        u = controller.act(*args, bounds=observation["map_bounds"])
    else:
        u = controller.act(*args)
    return np.asarray(u, dtype=np.float64).reshape(-1)


@functools.cache
def _takes_bounds(cls) -> bool:
    """Whether cls.act accepts a `bounds` keyword."""
    try:
        parameters = inspect.signature(cls.act).parameters.values()
    except (TypeError, ValueError):
        return False
    return any(p.name == "bounds" or p.kind == p.VAR_KEYWORD for p in parameters)


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
    return {k: v for k, v in spec.task_params.items() if k in robot_keys()}


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
            self.clusters.append(len(np.unique(labels[labels >= 0])))
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


class Episode:
    """A running episode of `spec`, advanced one control step at a time.

    Attributes: spec, env, controller, time_step (the latest dm_env TimeStep), path (list of
    (2,) robot positions, one per step and the start), ctrl_s and env_s (seconds per step
    in the controller and in env.step), diagnosis (`Diagnosis` of every step).
    """

    def __init__(self, spec: EpisodeSpec):
        self.start = time.perf_counter()
        self.spec = spec
        self.env = make_env(spec)
        self.controller = controller_for(spec)
        self.controller.reset()
        self.time_step = self.env.reset()
        warm_up(spec, self.time_step.observation)
        self.path = [self.time_step.observation["robot_pose"][:2].copy()]
        self.ctrl_s: list[float] = []
        self.env_s: list[float] = []
        self.diagnosis = Diagnosis()

    @property
    def done(self) -> bool:
        return self.time_step.last()

    def step(self) -> None:
        """One control step: the controller acts on the observation, the task steps."""
        observation = self.time_step.observation
        t0 = time.perf_counter()
        action = act(self.controller, observation)
        t1 = time.perf_counter()
        self.time_step = self.env.step(action)
        t2 = time.perf_counter()
        self.ctrl_s.append(t1 - t0)
        self.env_s.append(t2 - t1)
        self.diagnosis.read(self.controller, observation["robot_pose"])
        self.path.append(self.time_step.observation["robot_pose"][:2].copy())

    def result(self) -> dict:
        """The metrics of the finished episode (see `run_episode`)."""
        from dcmppi.tasks.barn import navigation_score

        path = np.asarray(self.path)
        outcome = self.env.task.outcome
        ctrl_ms = 1e3 * np.asarray(self.ctrl_s)
        elapsed = float(self.env.physics.data.time)
        optimal = getattr(self.env.task, "optimal_time", None)
        return {
            "outcome": outcome,
            "collision": outcome == "collision",
            "failure": outcome != "goal",
            "steps": len(self.ctrl_s),
            "time_to_goal": elapsed if outcome == "goal" else None,
            "nav_score": None
            if optimal is None
            else navigation_score(outcome == "goal", elapsed, optimal),
            "path_length": float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))),
            "min_clearance": float(self.env.task.min_clearance),
            "ctrl_ms_mean": float(ctrl_ms.mean()) if ctrl_ms.size else 0.0,
            "ctrl_ms_p95": float(np.percentile(ctrl_ms, 95)) if ctrl_ms.size else 0.0,
            "env_ms_mean": float(1e3 * np.mean(self.env_s)) if self.env_s else 0.0,
            **self.diagnosis.result(),
            "wall_s": time.perf_counter() - self.start,
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
      A dict: outcome ("goal" | "collision" | "left_map" | "time_limit"), collision, failure,
      steps, time_to_goal [s] (None unless reached), nav_score (BARN's navigation score where
      the task gives an `optimal_time`, i.e. a BARN world; else None), path_length [m],
      min_clearance [m], ctrl_ms_mean, ctrl_ms_p95 (controller time per step, first-call
      costs excluded by `warm_up`), env_ms_mean, the diagnostics ess_mean, clusters_mean,
      fallback_share, tube_deviation_p95 [m] (None where the controller records none; see
      `Diagnosis`), wall_s.
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
        result["path"] = np.asarray(episode.path)
    return result
