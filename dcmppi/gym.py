"""Gymnasium environments of the dcmppi tasks (optional extra: pip install "dcmppi[gym]").

    import gymnasium as gym
    import dcmppi.gym  # registers the ids below

    env = gym.make("dcmppi/Blocked-v0", agent="unicycle", noise="control")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Ids: dcmppi/Forest-v0, dcmppi/Crowd-v0, dcmppi/Corridor-v0, dcmppi/Square-v0,
dcmppi/Blocked-v0, dcmppi/Crossing-v0, dcmppi/Layout-v0 (`path=...`, `world=...`) and
dcmppi/Replay-v0 (recorded ETH/UCY crowds: `scene=...`, the files' folder as `path=...` or
$DCMPPI_CROWDS), one per task of `dcmppi.tasks`; every other keyword of `gymnasium.make` is a
task kwarg (`agent`, its parameters, `noise`, `n_clusters`, `behavior`, ...).

- Observation: a Dict of the task's observation arrays (float64, unbounded; shapes from the
  task's observation_spec, e.g. static_obstacles (M, 3), moving_velocity (L, 2)); with
  obstacle_measurement_std > 0 the obstacles' headings and velocities, which the task gives
  as nan (not observed), are 0 here (a Box holds no nan); `flatten_observation=True` gives
  one flat Box instead, in the order of `env.unwrapped.dict_observation_space`
  (`gymnasium.spaces.unflatten` undoes it).
- Action: a Box in [-1, 1] per control (float32), mapped affinely onto the task's action
  bounds (dubins: omega; unicycle: v, omega; holonomic: u_x, u_y, u_theta); values outside
  [-1, 1] are clipped, as the task clips actions outside its bounds.
- Reward: the task's, 1 on the step that reaches the goal, else 0.
- terminated: the outcome is goal, collision or left_map; truncated: time_limit (the task's
  own limit, so there is no TimeLimit wrapper). Step again only after reset().
- info: outcome (None while running), clearance (m, now) and min_clearance (m, this episode).
- Seeding: reset(seed=s) seeds gymnasium's `np_random`; every reset draws the task's seed
  as `np_random.integers(2**31 - 1)` and reseeds the task's RandomState with it, which draws
  the world and the noise sequence. So the same seed gives the same world, noise and steps;
  reset() without a seed goes on to the next world of the sequence.
- render_mode="rgb_array": frames (render_height, render_width, 3) uint8 from
  `render_camera` ("scene", "top" or "chase", see dcmppi.render.video), 640 x 360 by default.
"""

from __future__ import annotations

import collections

try:
    import gymnasium
    from gymnasium import spaces
except ImportError as e:
    raise ImportError(
        'dcmppi.gym needs gymnasium: pip install "dcmppi[gym]" (or pip install gymnasium)'
    ) from e
import numpy as np

from dcmppi import tasks
from dcmppi.control.defaults import DT
from dcmppi.render import CAMERAS
from dcmppi.render.video import Renderer, scene_region

IDS = {
    "dcmppi/Forest-v0": "forest",
    "dcmppi/Crowd-v0": "crowd",
    "dcmppi/Corridor-v0": "corridor",
    "dcmppi/Square-v0": "square",
    "dcmppi/CrowdNav-v0": "crowdnav",
    "dcmppi/CrowdNavPlus-v0": "crowdnav_plus",
    "dcmppi/Blocked-v0": "blocked",
    "dcmppi/Crossing-v0": "crossing",
    "dcmppi/Layout-v0": "layout",
    "dcmppi/Replay-v0": "replay",
}
TERMINAL = ("goal", "collision", "left_map")


class NavigationEnv(gymnasium.Env):
    """A dcmppi task (`dcmppi.tasks.load(task, task_kwargs)`) as a Gymnasium environment.

    Args:
      task: the task's name (see dcmppi.tasks.TASKS).
      render_mode: None or "rgb_array".
      render_camera: "scene", "top" or "chase".
      render_width, render_height: frame size in pixels (even, at most 1920 x 1080).
      flatten_observation: one flat Box instead of the Dict of arrays.
      **task_kwargs: the task's kwargs, except `random` (seed with reset(seed=...)).

    Attributes: dm_env (the dm_control Environment it steps), task (its task),
    dict_observation_space (the Dict space, also when the observation is flattened).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 1.0 / DT}  # real time

    def __init__(
        self,
        task: str,
        render_mode: str | None = None,
        render_camera: str = "scene",
        render_width: int = 640,
        render_height: int = 360,
        flatten_observation: bool = False,
        **task_kwargs,
    ):
        if "random" in task_kwargs:
            raise ValueError("random: seed the episodes with env.reset(seed=...) instead")
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        if render_camera not in CAMERAS:
            raise ValueError(
                f"render_camera must be one of {', '.join(CAMERAS)}; got {render_camera!r}"
            )
        self.render_mode = render_mode
        self.render_camera = render_camera
        self.render_size = (int(render_width), int(render_height))
        self.flatten_observation = flatten_observation
        self.dm_env = tasks.load(task, task_kwargs)
        bounds = self.dm_env.action_spec()
        shape = bounds.shape
        self._low = np.broadcast_to(bounds.minimum, shape).astype(np.float64)
        self._high = np.broadcast_to(bounds.maximum, shape).astype(np.float64)
        self.action_space = spaces.Box(-1.0, 1.0, shape, np.float32)
        self.dict_observation_space = spaces.Dict(
            collections.OrderedDict(
                (name, spaces.Box(-np.inf, np.inf, array.shape, np.float64))
                for name, array in self.dm_env.observation_spec().items()
            )
        )
        self.observation_space = (
            spaces.flatten_space(self.dict_observation_space)
            if flatten_observation
            else self.dict_observation_space
        )
        self._renderer = None
        self._region = None  # what the scene camera frames, set by reset()
        self._done = True  # step() needs a reset() first
        self._closed = False

    @property
    def task(self):
        """The dm_control task (dcmppi.tasks.Navigation): world, outcome, agent."""
        return self.dm_env.task

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.dm_env.task.random.seed(int(self.np_random.integers(2**31 - 1)))
        time_step = self.dm_env.reset()
        self._done = False
        self._region = scene_region(time_step.observation)
        if self._renderer is not None:
            self._renderer.look_at(self._region)
        return self._observation(time_step.observation), self._info(time_step.observation)

    def step(self, action):
        if self._done:
            raise RuntimeError("the episode has ended (or not started): call reset() first")
        a = np.clip(np.asarray(action, dtype=np.float64).reshape(self._low.shape), -1.0, 1.0)
        u = self._low + 0.5 * (a + 1.0) * (self._high - self._low)
        time_step = self.dm_env.step(u)
        outcome = self.dm_env.task.outcome
        terminated, truncated = outcome in TERMINAL, outcome == "time_limit"
        self._done = terminated or truncated
        return (
            self._observation(time_step.observation),
            float(time_step.reward),
            terminated,
            truncated,
            self._info(time_step.observation),
        )

    def render(self):
        if self.render_mode is None:
            gymnasium.logger.warn(
                "render() without a render_mode: make the environment with render_mode='rgb_array'"
            )
            return None
        if self._region is None:
            raise RuntimeError("call reset() before render()")
        if self._renderer is None:
            self._renderer = Renderer(self.dm_env.physics.model.ptr, *self.render_size)
            self._renderer.look_at(self._region)
        return self._renderer.render(self.dm_env.physics, self.render_camera)

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        if not self._closed:
            self._closed = True
            self.dm_env.close()

    def _observation(self, observation):
        names = self.dict_observation_space.spaces
        obs = {name: np.array(observation[name], dtype=np.float64) for name in names}
        if self.task.obstacle_measurement_std > 0:  # not observed: 0, as a Box holds no nan
            obs["moving_obstacles"][:, 2] = 0.0
            obs["moving_velocity"][:] = 0.0
        if self.flatten_observation:
            return spaces.flatten(self.dict_observation_space, obs)
        return obs

    def _info(self, observation) -> dict:
        return {
            "outcome": self.dm_env.task.outcome,
            "clearance": float(observation["clearance"][0]),
            "min_clearance": float(self.dm_env.task.min_clearance),
        }


for _id, _task in IDS.items():
    gymnasium.register(id=_id, entry_point="dcmppi.gym:NavigationEnv", kwargs={"task": _task})
