"""What the classical planners and the safety shield share: the moving obstacles' velocities
and a velocity tracked by any agent."""

import math

import numpy as np

from dcmppi.control.validation import floats

TURN_TAU = 0.5  # [s] heading error -> turn rate (navground's default rotation_tau)


def moving_obstacle_velocity(moving, velocity, obstacle_model):
    """World-frame velocities (L, 2) of the moving obstacles: the observed ones; where a row is
    not observed (nan, or no moving_velocity) the model's mean speed along the observed heading,
    else at rest."""
    out = np.zeros((len(moving), 2))
    known = np.zeros(len(moving), dtype=bool)
    if velocity is not None:
        known = np.isfinite(velocity).all(axis=1)
        out[known] = velocity[known]
    if obstacle_model is not None:
        speed = float(floats("obstacle_model", obstacle_model).reshape(-1)[0])
        heading = moving[:, 2]
        fill = ~known & np.isfinite(heading) & math.isfinite(speed)
        out[fill, 0] = speed * np.cos(heading[fill])
        out[fill, 1] = speed * np.sin(heading[fill])
    return out


def track(agent, heading, velocity):
    """Controls (nu,) that follow a desired world-frame velocity (2,): a holonomic agent
    commands it (keeping its heading); the others turn towards it at error / TURN_TAU (clipped
    to their turn rate) at the desired speed times the cosine of the heading error (0 when
    facing away; an agent that steers only keeps its own)."""
    vx, vy = float(velocity[0]), float(velocity[1])
    if agent.holonomic:
        return agent.command((vx, vy), 0.0)
    speed = math.hypot(vx, vy)
    error = 0.0 if speed == 0.0 else wrap(math.atan2(vy, vx) - heading)
    return agent.command((speed * max(math.cos(error), 0.0), 0.0), error / TURN_TAU)


def wrap(angle):
    """angle wrapped to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi
