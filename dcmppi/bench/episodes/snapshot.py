"""One planning step of several controllers from the same observation (paper Fig. 2 and 4).

The robot drives straight until an obstacle matters, then every controller plans that step with
the same seed, hence the same K perturbations. `dcmppi.render.figures` draws the result.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from dcmppi.bench.episodes.runner import EpisodeSpec, act, controller_for, make_env
from dcmppi.tasks.worlds.arcs import dubins_pose

FIGURE_CONTROLLERS = ("mppi", "clustered", "dc")


def straight_blocked(observation, controller, horizon: float) -> bool:
    """Whether the controller's first guess (dubins: straight ahead; holonomic: straight at the
    goal), held for `horizon` seconds, meets an obstacle.

    Static cylinders stay put; moving ones are predicted at the mean of the known Gaussian.
    """
    agent, dt = controller.agent, controller.dt
    state, goal = observation["robot_pose"], observation["goal"]
    steps = int(round(horizon / dt))
    robot = agent.rollout_one(state, agent.first_guess(state, goal, steps), dt)[:, :2]  # (T, 2)
    t = np.arange(steps + 1) * dt
    robot_radius = controller.robot_radius
    v_mean, _, omega_mean, _ = observation["obstacle_model"]
    static = observation["static_obstacles"]
    static = static[static[:, 2] > 0]
    d = np.linalg.norm(robot[:, None] - static[None, :, :2], axis=-1) - static[:, 2]
    if (d <= robot_radius).any():
        return True
    for ox, oy, heading, r in observation["moving_obstacles"]:
        pose = dubins_pose((ox, oy, heading), v_mean, omega_mean, t)
        if (np.hypot(*(robot - pose[:, :2]).T) <= r + robot_radius).any():
            return True
    return False


def first_step(spec: EpisodeSpec, controllers=FIGURE_CONTROLLERS, approach: int | None = None):
    """Each controller's first step on `spec`'s episode, once an obstacle matters.

    The robot first follows the agent's first guess (dubins: omega = 0, straight ahead) for
    `approach` control steps, by default until that would meet an obstacle within 60 % of the
    horizon: the moment of the paper's Fig. 2 and 4, when the straight reference runs into the
    obstacle. Then every controller plans from that same observation with the first guess as
    its warm start and the same seed.

    Returns:
      (observation, {name: (controller, action)}, steps driven straight), where action is
      the applied controls (nu,).
    """
    env = make_env(spec)
    time_step = env.reset()
    probe = controller_for(spec)
    horizon = probe.N * probe.dt
    steps = 0
    while not time_step.last() and (
        steps < approach if approach is not None
        else not straight_blocked(time_step.observation, probe, 0.6 * horizon)
    ):  # fmt: skip
        obs = time_step.observation
        time_step = env.step(probe.agent.first_guess(obs["robot_pose"], obs["goal"], 1)[0])
        steps += 1
    if time_step.last():
        raise ValueError(f"the episode ended ({env.task.outcome}) while approaching")
    observation = time_step.observation
    out = {}
    for name in controllers:
        controller = controller_for(dataclasses.replace(spec, controller=name))
        controller.reset()
        out[name] = (controller, act(controller, observation))
    return observation, out, steps
