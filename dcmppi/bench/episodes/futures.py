"""The moving obstacles' own future, where they ignore the robot: their model stepped alone.

Used by the reachability analysis (dcmppi.bench.episodes.reachability) and by the runner's true
futures for prediction="given" (dcmppi.bench.episodes.runner.TrueFutures).
"""

import numpy as np


def exogenous(world) -> bool:
    """Whether the moving obstacles of `world` ignore the robot (their paths are the same for
    every controller): Dubins arcs, or pedestrians with robot_visible false."""
    return world.behavior == "constant" or not world.robot_visible


def reset_exogenous(env, task: str, use: str):
    """Reset `env` and return its world; a ValueError naming `use` (what needs the obstacles'
    own future) where its moving obstacles react to the robot."""
    env.reset()
    world = env.task.world
    if not exogenous(world):
        raise ValueError(
            f"{use} needs obstacles whose paths do not depend on the controller; the pedestrians "
            f"of {task} react to the robot (robot_visible=true): use robot_visible=false"
        )
    return world


def obstacle_tracks(env, steps):
    """The moving obstacles' centres (L, 2) after each of `steps` control steps of a freshly
    reset `env`, one step at a time, stepped by their own model without the robot: their true
    future where they ignore the robot (see `exogenous`)."""
    physics, world = env.physics, env.task.world
    moving = physics.obstacle_motion
    n_sub = int(round(env.control_timestep() / physics.timestep()))
    far, still = np.array([1e6, 1e6]), np.zeros(2)
    for _ in range(steps):
        if moving is None:
            yield np.empty((0, 2))
            continue
        advance = (n_sub,) if world.behavior == "constant" else (n_sub, far, still)
        z = moving.advance(*advance)[-1]
        yield np.stack([z.real, z.imag], axis=-1)
