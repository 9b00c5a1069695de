"""Helbing & Molnar's social force, compiled: the pedestrians of the tasks and the `social`
predictor's futures run this one code.

Force on agent i (an acceleration, unit mass):

    f_i = (desired_i - v_i) / tau
          + sum_j A exp((r_i + r_j - d_ij) / B) n_ij        other agents, pushing agents included
          + sum_w A exp((r_i - d_iw) / B) n_iw              wall segments

with d the centre distance (to the wall segment's nearest point) and n the unit vector away
from the other agent (the wall). This is the circular form of the force (no field of view, no
velocity-dependent ellipse): the same A, B for agents and walls. A = 10 m/s^2, B = 0.3 m, not
the first prototype's A = 2, B = 0.5: with those, two pedestrians meeting head-on at 1.2 m/s
overlapped by 0.37 m and a pedestrian walked 0.2 m into a visible robot standing in its way
(in a 12-pedestrian corridor 21 % of steps had an overlap over 1 cm, the worst 0.44 m); with
A = 10, B = 0.3 no pedestrians overlapped in the same corridor runs and they kept 0.89 of their
preferred speed (docs/design.md, Pedestrians).
Semi-implicit Euler: v += dt f, |v| capped at the agent's max_speed, p += dt v.

Interactions whose surface distance exceeds B ln(1 / FORCE_CUTOFF) (2.07 m for B = 0.3) are
skipped: their force is below FORCE_CUTOFF A. Agents are kept sorted by x (an insertion sort,
near-linear from one step to the next) and each sweeps only the agents ahead of it within that
reach, so a step costs O(n) for a sparse crowd and O(n^2) at most, each pair evaluated once.
A pair at the very same point pushes along x (the lower index towards +x), an agent centred on
a wall along the wall's left normal.
"""

import math

import numba
import numpy as np

from dcmppi.control.validation import array, positive

A = 10.0  # interaction strength [m/s^2]
B = 0.3  # interaction range [m]
TAU = 0.5  # relaxation time towards the desired velocity [s]
MAX_SPEED_FACTOR = 1.3  # speed cap / preferred speed
FORCE_CUTOFF = 1e-3  # interactions weaker than this share of A are skipped


def step(
    pos,
    vel,
    desired,
    radius,
    max_speed,
    dt,
    others_pos,
    others_radius,
    walls,
    A=A,
    B=B,
    tau=TAU,
):
    """One step of n agents pushed by each other, by m agents that are not moved, and by walls.

    Args:
      pos, vel, desired: (n, 2) positions, velocities, desired (preferred) velocities.
      radius, max_speed: (n,).
      dt: step [s].
      others_pos, others_radius: (m, 2), (m,) agents that push but are not moved (the robot).
      walls: (W, 4) segments x0, y0, x1, y1.
      A, B, tau: the force's constants.
    Returns:
      new positions and velocities, (n, 2) each.
    """
    pos, vel, desired = _agents(pos, vel, desired, "(n, 2)")
    n = len(pos)
    radius, max_speed = array("radius", radius, (n,)), array("max_speed", max_speed, (n,))
    others_pos = array("others_pos", others_pos, ("m", 2))
    others_radius = array("others_radius", others_radius, (len(others_pos),))
    walls = _walls(walls)
    dt, a, b, tau = _constants(dt, A, B, tau)
    new_pos, new_vel = np.empty_like(pos), np.empty_like(vel)
    order = np.arange(n)
    _step(
        pos, vel, desired, radius, max_speed, dt, others_pos, others_radius, walls, a, b, tau,
        order, np.empty_like(pos), new_pos, new_vel,
    )  # fmt: skip
    return new_pos, new_vel


def rollout(
    pos,
    vel,
    desired,
    radius,
    max_speed,
    dt,
    steps,
    others_path,
    others_radius,
    walls,
    A=A,
    B=B,
    tau=TAU,
):
    """P independent futures of n agents, each `steps` repeated `step` calls.

    Args:
      pos, vel, desired: (P, n, 2) per future; desired is held over the horizon.
      radius, max_speed: (n,) shared by the futures.
      dt: step [s]; steps: number of steps.
      others_path: (steps + 1, m, 2) positions of the pushing agents (e.g. the robot's plan);
        row k pushes during step k -> k + 1 (the last row is the plan's end, not used).
      others_radius: (m,).
      walls: (W, 4) segments x0, y0, x1, y1.
    Returns:
      (P, n, steps + 1, 2) positions, index 0 = pos.
    """
    pos, vel, desired = _agents(pos, vel, desired, "(P, n, 2)")
    n = pos.shape[1]
    radius, max_speed = array("radius", radius, (n,)), array("max_speed", max_speed, (n,))
    steps = int(steps)
    if steps < 0:
        raise ValueError(f"steps must be >= 0; got {steps}")
    others_path = array("others_path", others_path, (steps + 1, "m", 2))
    others_radius = array("others_radius", others_radius, (others_path.shape[1],))
    walls = _walls(walls)
    dt, a, b, tau = _constants(dt, A, B, tau)
    return _rollout(
        pos, vel, desired, radius, max_speed, dt, steps, others_path, others_radius, walls,
        a, b, tau,
    )  # fmt: skip


def _agents(pos, vel, desired, expected):
    """pos, vel, desired as float64 arrays of one shape, `expected`: "(n, 2)" or "(P, n, 2)"."""
    arrays = [np.ascontiguousarray(x, dtype=np.float64) for x in (pos, vel, desired)]
    shape = arrays[0].shape
    if (
        len(shape) != expected.count(",") + 1
        or shape[-1] != 2
        or any(x.shape != shape for x in arrays)
    ):
        shapes = ", ".join(str(x.shape) for x in arrays)
        raise ValueError(f"pos, vel and desired must share a shape {expected}; got {shapes}")
    return arrays


def _walls(walls):
    """walls as a float64 (W, 4) array of segments with distinct end points."""
    walls = array("walls", np.zeros((0, 4)) if walls is None else walls, ("W", 4))
    flat = np.flatnonzero((walls[:, 0] == walls[:, 2]) & (walls[:, 1] == walls[:, 3]))
    if len(flat):
        raise ValueError(f"walls {flat} have zero length: give segments x0, y0, x1, y1")
    return walls


def _constants(dt, a, b, tau):
    """dt, A, B, tau as floats; each must be a finite number > 0."""
    return positive("dt", dt), positive("A", a), positive("B", b), positive("tau", tau)


@numba.njit(cache=True)
def _rollout(pos, vel, desired, radius, max_speed, dt, steps, others_path, others_radius, walls,
             a, b, tau):  # fmt: skip
    """rollout: the futures one after the other, each future's agents sorted once."""
    futures, n = pos.shape[0], pos.shape[1]
    out = np.empty((futures, n, steps + 1, 2))
    p, v = np.empty((n, 2)), np.empty((n, 2))
    p_next, v_next, force = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 2))
    order = np.empty(n, dtype=np.int64)
    for f in range(futures):
        p[:] = pos[f]
        v[:] = vel[f]
        out[f, :, 0] = p
        for i in range(n):
            order[i] = i
        for k in range(steps):
            _step(
                p, v, desired[f], radius, max_speed, dt, others_path[k], others_radius, walls,
                a, b, tau, order, force, p_next, v_next,
            )  # fmt: skip
            p, p_next = p_next, p
            v, v_next = v_next, v
            out[f, :, k + 1] = p
    return out


@numba.njit(cache=True)
def _sort_by_x(pos, order):
    """Insertion sort of `order` by (x, index): near-linear when order is almost sorted."""
    for a in range(1, len(order)):
        i = order[a]
        x = pos[i, 0]
        c = a - 1
        while c >= 0 and (pos[order[c], 0] > x or (pos[order[c], 0] == x and order[c] > i)):
            order[c + 1] = order[c]
            c -= 1
        order[c + 1] = i


@numba.njit(cache=True)
def _step(pos, vel, desired, radius, max_speed, dt, others, others_radius, walls, a, b, tau,
          order, force, new_pos, new_vel):  # fmt: skip
    """step into new_pos, new_vel; order (n,) is the agents sorted by x (updated in place),
    force (n, 2) scratch."""
    n = pos.shape[0]
    cut = b * math.log(1.0 / FORCE_CUTOFF)  # surface distance beyond which forces are skipped
    r_max = 0.0
    for i in range(n):
        force[i, 0] = (desired[i, 0] - vel[i, 0]) / tau
        force[i, 1] = (desired[i, 1] - vel[i, 1]) / tau
        r_max = max(r_max, radius[i])
    _sort_by_x(pos, order)
    reach = cut + 2.0 * r_max
    for s in range(n):
        i = order[s]
        for t in range(s + 1, n):
            j = order[t]
            dx = pos[i, 0] - pos[j, 0]
            if -dx > reach:
                break
            dy = pos[i, 1] - pos[j, 1]
            contact = radius[i] + radius[j]
            d2 = dx * dx + dy * dy
            if d2 >= (cut + contact) ** 2:
                continue
            d = math.sqrt(d2)
            if d > 0.0:
                nx, ny = dx / d, dy / d
            else:
                nx, ny = (1.0 if i < j else -1.0), 0.0
            push = a * math.exp((contact - d) / b)
            force[i, 0] += push * nx
            force[i, 1] += push * ny
            force[j, 0] -= push * nx
            force[j, 1] -= push * ny
    for i in range(n):
        px, py = pos[i, 0], pos[i, 1]
        for k in range(others.shape[0]):
            dx, dy = px - others[k, 0], py - others[k, 1]
            contact = radius[i] + others_radius[k]
            d2 = dx * dx + dy * dy
            if d2 >= (cut + contact) ** 2:
                continue
            d = math.sqrt(d2)
            nx, ny = (dx / d, dy / d) if d > 0.0 else (1.0, 0.0)
            push = a * math.exp((contact - d) / b)
            force[i, 0] += push * nx
            force[i, 1] += push * ny
        for w in range(walls.shape[0]):
            x0, y0 = walls[w, 0], walls[w, 1]
            ex, ey = walls[w, 2] - x0, walls[w, 3] - y0
            u = min(max(((px - x0) * ex + (py - y0) * ey) / (ex * ex + ey * ey), 0.0), 1.0)
            dx, dy = px - (x0 + u * ex), py - (y0 + u * ey)
            d2 = dx * dx + dy * dy
            if d2 >= (cut + radius[i]) ** 2:
                continue
            d = math.sqrt(d2)
            if d > 0.0:
                nx, ny = dx / d, dy / d
            else:
                length = math.sqrt(ex * ex + ey * ey)
                nx, ny = -ey / length, ex / length
            push = a * math.exp((radius[i] - d) / b)
            force[i, 0] += push * nx
            force[i, 1] += push * ny
    for i in range(n):
        vx = vel[i, 0] + dt * force[i, 0]
        vy = vel[i, 1] + dt * force[i, 1]
        speed = math.sqrt(vx * vx + vy * vy)
        if speed > max_speed[i]:
            vx *= max_speed[i] / speed
            vy *= max_speed[i] / speed
        new_vel[i, 0], new_vel[i, 1] = vx, vy
        new_pos[i, 0] = pos[i, 0] + dt * vx
        new_pos[i, 1] = pos[i, 1] + dt * vy
