"""The moving obstacles' own future, where they ignore the robot: their model stepped alone.

Used by the reachability analysis (dcmppi.bench.episodes.reachability) and by the runner's true
futures for prediction="given" (dcmppi.bench.episodes.runner.TrueFutures).
"""

import numpy as np


def exogenous(world) -> bool:
    """Whether the moving obstacles of `world` ignore the robot (their paths are the same for
    every controller): Dubins arcs, pedestrians with robot_visible false, recorded people
    (replay without reactive)."""
    return world.behavior == "constant" or not world.robot_visible


def reset_exogenous(env, task: str, use: str):
    """Reset `env` and return its world; a ValueError naming `use` (what needs the obstacles'
    own future) where its moving obstacles react to the robot."""
    env.reset()
    world = env.task.world
    if not exogenous(world):
        setting = "reactive" if task == "replay" else "robot_visible"
        raise ValueError(
            f"{use} needs obstacles whose paths do not depend on the controller; the pedestrians "
            f"of {task} react to the robot ({setting}=true): use {setting}=false"
        )
    return world


def obstacle_radii(env) -> np.ndarray:
    """(L,) the radius of each moving obstacle's disc: world.moving's, or where rows come and go
    (a replay's recorded people: the physics' motion has `present`) the motion's, also for the
    rows that hold no one at the start."""
    motion = env.physics.obstacle_motion
    if hasattr(motion, "present"):
        return np.asarray(motion.radius, dtype=np.float64)
    return env.task.world.moving[:, 3]


def obstacle_presence(env) -> np.ndarray:
    """(L,) bool: which rows hold an obstacle now (all but a replay's absent people, whose rows
    are parked far away)."""
    motion = env.physics.obstacle_motion
    if hasattr(motion, "present"):
        return np.array(motion.present, dtype=bool)
    return np.ones(len(env.task.world.moving), dtype=bool)


def obstacle_tracks(env, steps):
    """The moving obstacles' centres (L, 2) after each of `steps` control steps of a freshly
    reset `env`, one step at a time, stepped by their own model without the robot: their true
    future where they ignore the robot (see `exogenous`). A replay's people come and go: the
    rows of those absent are parked far away (`obstacle_presence` says which, after each)."""
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
