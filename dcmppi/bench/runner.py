"""Run one episode: a `dcmppi.tasks` environment driven by a `dcmppi` controller.

This is the only module that joins the two sides: tasks know no controller, controllers
import no MuJoCo. An episode is fully determined by its `EpisodeSpec`; the same spec
gives the same outcome, path and clearance on every run, worker and executor.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np


@dataclasses.dataclass(frozen=True)
class EpisodeSpec:
    """One episode: which task, world, noise and controller, with all parameters.

    `seed` fixes the world and the noise sequence (the task's `random`) and, through a
    separate stream, the controller's sampling. Every controller of a paired comparison
    runs with the same `seed` for the same environment.
    """

    task: str
    controller: str
    noise: str = "none"
    seed: int = 0
    task_params: dict = dataclasses.field(default_factory=dict)
    controller_params: dict = dataclasses.field(default_factory=dict)

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


def make_controller(spec: EpisodeSpec):
    """The controller of `spec`, planning with the task's agent and robot parameters."""
    from dcmppi import make_controller as _make
    from dcmppi.tasks import default_agent

    keys = robot_keys()
    clash = sorted(set(keys) & set(spec.controller_params))
    if clash:
        raise ValueError(
            f"{', '.join(clash)}: robot parameters are task parameters (the plant and the "
            "planner share them); set them with --task-param / task_params"
        )
    shared = {k: spec.task_params[k] for k in keys if k in spec.task_params}
    shared.setdefault("agent", default_agent(spec.task))
    params = {**shared, **spec.controller_params, "seed": spec.controller_seed()}
    return _make(spec.controller, **params)


def act(controller, observation) -> np.ndarray:
    """The controller's action for a task observation, as the task's action array (nu,)."""
    u = controller.act(
        observation["robot_pose"],
        observation["goal"],
        observation["static_obstacles"],
        observation["moving_obstacles"],
        observation["obstacle_model"],
        observation["map_bounds"],
    )
    return np.asarray(u, dtype=np.float64).reshape(-1)


class Episode:
    """A running episode of `spec`, advanced one control step at a time.

    Attributes: spec, env, controller, time_step (the latest dm_env TimeStep), path (list of
    (2,) robot positions, one per step and the start), ctrl_s and env_s (seconds per step
    in the controller and in env.step).
    """

    def __init__(self, spec: EpisodeSpec):
        self.start = time.perf_counter()
        self.spec = spec
        self.env = make_env(spec)
        self.controller = make_controller(spec)
        self.controller.reset()
        self.time_step = self.env.reset()
        self.path = [self.time_step.observation["robot_pose"][:2].copy()]
        self.ctrl_s: list[float] = []
        self.env_s: list[float] = []

    @property
    def done(self) -> bool:
        return self.time_step.last()

    def step(self) -> None:
        """One control step: the controller acts on the observation, the task steps."""
        t0 = time.perf_counter()
        action = act(self.controller, self.time_step.observation)
        t1 = time.perf_counter()
        self.time_step = self.env.step(action)
        t2 = time.perf_counter()
        self.ctrl_s.append(t1 - t0)
        self.env_s.append(t2 - t1)
        self.path.append(self.time_step.observation["robot_pose"][:2].copy())

    def result(self) -> dict:
        """The metrics of the finished episode (see `run_episode`)."""
        path = np.asarray(self.path)
        outcome = self.env.task.outcome
        ctrl_ms = 1e3 * np.asarray(self.ctrl_s)
        return {
            "outcome": outcome,
            "collision": outcome == "collision",
            "failure": outcome != "goal",
            "steps": len(self.ctrl_s),
            "time_to_goal": float(self.env.physics.data.time) if outcome == "goal" else None,
            "path_length": float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1))),
            "min_clearance": float(self.env.task.min_clearance),
            "ctrl_ms_mean": float(ctrl_ms.mean()) if ctrl_ms.size else 0.0,
            "ctrl_ms_p95": float(np.percentile(ctrl_ms, 95)) if ctrl_ms.size else 0.0,
            "env_ms_mean": float(1e3 * np.mean(self.env_s)) if self.env_s else 0.0,
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
      A dict: outcome ("goal" | "collision" | "time_limit"), collision, failure, steps,
      time_to_goal [s] (None unless reached), path_length [m], min_clearance [m],
      ctrl_ms_mean, ctrl_ms_p95, env_ms_mean, wall_s.
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
