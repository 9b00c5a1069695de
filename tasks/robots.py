"""The MuJoCo plant of each agent (docs/design.md): its MJCF and how controls become commands.

The planners' analytic model of an agent is `dcmppi.control.agents` (names, bounds, defaults);
its plant here is a robot file in models/robots/ attached to the arena, with three velocity
actuators (forward, lateral and turn in the robot frame for `dubins` and `unicycle`; x, y and
turn in the world frame for `holonomic`), whose targets `command` computes from the controls.
"""

import dataclasses
from collections.abc import Callable

import numpy as np


@dataclasses.dataclass(frozen=True)
class Plant:
    """The MuJoCo side of one agent.

    model: file name in dcmppi.models/robots.
    command: (agent, u (nu,)) -> the three actuator targets.
    moving_start: whether the robot starts at its speed (the constant-speed car) or at rest.
    """

    model: str
    command: Callable
    moving_start: bool = False


PLANTS = {
    "dubins": Plant("dubins.xml", lambda agent, u: (agent.v, 0.0, u[0]), moving_start=True),
    "unicycle": Plant("unicycle.xml", lambda agent, u: (u[0], 0.0, u[1])),
    "holonomic": Plant("holonomic.xml", lambda agent, u: (u[0], u[1], u[2])),
}


def plant(agent) -> Plant:
    """The plant of an agent (an Agent instance); a ValueError names the agents that have one."""
    if agent.name not in PLANTS:
        raise ValueError(
            f"agent {agent.name!r} has no MuJoCo plant; the tasks simulate {', '.join(PLANTS)}"
        )
    return PLANTS[agent.name]


def start_velocity(agent, yaw) -> np.ndarray:
    """World-frame (vx, vy, yaw rate) of the robot at the episode start."""
    if not plant(agent).moving_start:
        return np.zeros(3)
    return np.array([agent.max_speed * np.cos(yaw), agent.max_speed * np.sin(yaw), 0.0])
