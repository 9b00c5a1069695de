"""Which episodes any controller could solve: the reachable set of an ideal robot among the
episode's own moving obstacles.

Where the moving obstacles ignore the robot (Dubins arcs, pedestrians with robot_visible false)
their paths are the same whatever the robot does, so one run of them decides, for every
controller at once, whether a collision-free way to the goal existed. The ideal robot is a disc
of the task's radius that sets its velocity at once, anywhere within the agent's top speed (a
Dubins car or a unicycle can do no better than that). Its reachable set is propagated on a grid:

  R(t + h) = {x free at t + h : |x - y| <= v_max h for some y in R(t)},

free = inside the map, outside every static cylinder and every moving one, each inflated by
the robot's radius; h is the control period. The grid's cell is v_max h / STEP_CELLS and a step
reaches the cells within STEP_REACH cell widths: over many steps the frontier moves at
0.984-1.020 x v_max in every direction (the convex hull of those lattice points).
An environment is `unavoidable` when R empties before it meets the goal region (the disc of
the task's goal_tolerance): every controller collides or leaves the map there; `solvable` when R
meets the goal region within the time limit.

Nearly all approximations favour the robot, so the count of unavoidable environments is a lower
bound: obstacles are checked at instants h apart (a graze between two instants is missed), a
cell is free when any point of it is (the inflation shrinks by half the cell's diagonal), and
the robot has no acceleration limit and no actuator lag; only its speed is within 2 %.
In a replay (the task `replay`) the recorded people appear and leave as recorded: one who
appears where the ideal robot could be removes those cells (the task holds such a person back
until the robot has moved), the one approximation that does not favour the robot.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from dcmppi.bench.episodes.futures import obstacle_radii, obstacle_tracks, reset_exogenous
from dcmppi.bench.episodes.runner import EpisodeSpec, make_env

STEP_CELLS = 5  # cells per control period at top speed
STEP_REACH = 5.1  # the reach of one step [cells]


@dataclasses.dataclass(frozen=True)
class Reach:
    """One environment: `solvable` (a collision-free way to the goal within the time limit),
    `unavoidable` (R emptied first), `time` [s]: when the goal region was first reached or R
    emptied (None if neither happened within the time limit), `goal_distance`: the least
    distance to the goal of a reachable cell [m] when it ended."""

    solvable: bool
    unavoidable: bool
    time: float | None
    goal_distance: float


def reach(spec: EpisodeSpec) -> Reach:
    """The reachable set of the ideal robot in the episode of `spec` (its task and seed; the
    controller plays no part). A ValueError where the moving obstacles react to the robot."""
    env = make_env(spec)
    world, task = reset_exogenous(env, spec.task, "reachability"), env.task
    dt = env.control_timestep()
    steps = int(math.ceil(task.time_limit / dt))
    return propagate(
        world.start[:2],
        world.goal,
        task.goal_tolerance,
        world.map_bounds,
        world.static[world.static[:, 2] > 0],
        obstacle_tracks(env, steps),
        obstacle_radii(env),
        task.robot_radius,
        task.agent.max_speed,
        dt,
    )


def propagate(start, goal, tolerance, bounds, static, tracks, radii, radius, v_max, dt) -> Reach:
    """The reachable set of a disc of `radius` with speed <= v_max from `start` (2,) to the
    disc of `tolerance` around `goal` (2,), within `bounds` (4,) xmin, ymin, xmax, ymax,
    outside `static` (M, 3) x, y, r and the moving discs of `radii` (L,) at `tracks`, an
    iterable of their centres (L, 2) after each step of dt (as many as the time limit has)."""
    cell = v_max * dt / STEP_CELLS
    xmin, ymin, xmax, ymax = bounds
    xs = np.arange(xmin + cell / 2, xmax, cell)
    ys = np.arange(ymin + cell / 2, ymax, cell)
    X, Y = np.meshgrid(xs, ys, indexing="ij")  # (nx, ny) cell centres
    slack = cell / math.sqrt(2.0)  # a cell is free when any of its points is
    free_static = np.ones(X.shape, dtype=bool)
    for x, y, r in static:
        free_static &= _outside(X, Y, x, y, r + radius - slack)
    to_goal = np.hypot(X - goal[0], Y - goal[1])
    R = np.zeros(X.shape, dtype=bool)
    R[_index(start[0], xmin, cell, len(xs)), _index(start[1], ymin, cell, len(ys))] = True
    for step, centres in enumerate(tracks, start=1):
        R = _dilate(R, STEP_REACH) & free_static
        for (x, y), r in zip(centres, radii, strict=True):
            d = r + radius - slack
            e = abs(d)  # a disc this far beyond the cells' box leaves every cell free
            if xmin - e < x < xmax + e and ymin - e < y < ymax + e:
                R &= _outside(X, Y, x, y, d)
        if not R.any():
            return Reach(False, True, step * dt, float("inf"))
        if (to_goal[R] <= tolerance).any():
            return Reach(True, False, step * dt, float(to_goal[R].min()))
    return Reach(False, False, None, float(to_goal[R].min()))


def _index(value, low, cell, n) -> int:
    return min(max(int((value - low) / cell), 0), n - 1)


def _dilate(R: np.ndarray, cells: float) -> np.ndarray:
    """Cells within `cells` cell widths (centre to centre) of a cell of R (not empty)."""
    from scipy.ndimage import distance_transform_edt

    margin = int(math.ceil(cells)) + 1
    i, j = np.flatnonzero(R.any(axis=1)), np.flatnonzero(R.any(axis=0))
    box = (
        slice(max(i[0] - margin, 0), i[-1] + margin + 1),
        slice(max(j[0] - margin, 0), j[-1] + margin + 1),
    )
    out = np.zeros_like(R)
    out[box] = distance_transform_edt(~R[box]) <= cells
    return out


def _outside(X, Y, x, y, distance) -> np.ndarray:
    return (X - x) ** 2 + (Y - y) ** 2 > distance * distance


def survey(exp, progress=None) -> dict[int, Reach]:
    """`reach` of every environment of experiment `exp` (its first row and noise profile: the
    obstacles' paths are the same for every row). progress(i, n) is called after each."""
    noise, label = exp.noises[0], exp.labels[0]
    found = {}
    for n, i in enumerate(exp.indices(), start=1):
        found[i] = reach(exp.spec(noise, label, i))
        if progress:
            progress(n, exp.episodes)
    return found


def summary(found: dict[int, Reach], rows=()) -> str:
    """Lines: how many environments are solvable, unavoidable or neither; with `rows` (a
    results database's episode rows), each label's collisions split by the environment's kind."""
    n = len(found)
    solvable = [r for r in found.values() if r.solvable]
    unavoidable = sum(r.unavoidable for r in found.values())
    times = sorted(r.time for r in solvable)
    lines = [
        f"{n} environments: {len(solvable)} solvable by the ideal robot"
        + (f" (time to the goal region: median {times[len(times) // 2]:.1f} s)" if times else "")
        + f", {unavoidable} where every controller collides, "
        f"{n - len(solvable) - unavoidable} with no way to the goal in time"
    ]
    labels = sorted({r["label"] for r in rows})
    for label in labels:
        mine = [r for r in rows if r["label"] == label and r["env_index"] in found]
        ended = [r for r in mine if r["status"] == "ok"]  # errors have no outcome
        hit = [r for r in ended if r["collision"]]
        forced = sum(found[r["env_index"]].unavoidable for r in hit)
        errors = (
            f" ({len(mine) - len(ended)} more ended in an error)" if len(ended) < len(mine) else ""
        )
        lines.append(
            f"  {label}: {len(hit)} of {len(ended)} episodes collided{errors}, {forced} of them "
            f"where every controller collides, {len(hit) - forced} avoidable"
        )
    return "\n".join(lines)
