"""The safety shield: a planner's command filtered against the obstacles observed now.

    safety = Shield(agent, robot_radius, dt, time_horizon=1.5, margin=0.15, plan=True)
    u, changed = safety(state, u, static, moving, moving_velocity, bounds, plan)

With `plan` (the default) and a planner's plan, a command that the plan's later controls keep
clear of every obstacle for `time_horizon`, at the obstacles' velocities and with the radii and
edges widened by `margin`, comes back unchanged (the same array): the planner may pass in front
of a person on a curve that a constant velocity would not clear. Otherwise the command's
world-frame velocity v (agent.world_velocity) moves to the nearest velocity outside every
obstacle's velocity obstacle truncated at `time_horizon`: ORCA's half-planes
(van den Berg et al. 2011, linearised at v) with the robot taking all of the responsibility
(people may not see it), the moving obstacles at their latest velocities, the static cylinders
at rest, the map's edges as lines, each radius widened by `margin`; the nearest velocity within
the agent's top speed by RVO2's linear programs. The static half-planes are hard; where no
velocity satisfies the people's too, theirs give way alike (RVO2's third program). A command
whose velocity satisfies them all comes back unchanged (the same array). A velocity-obstacle
form of Shield-MPPI's repair step (Yin et al. 2023, a discrete-time barrier on the applied
control): the truncated cone keeps the gap above the radius sum for `time_horizon` at the
obstacles' velocities, where a distance barrier would only slow the approach.

The agents, by their answers: a holonomic one gets the safe velocity, its turn rate kept;
another turns towards it as the classical planners do (velocities.track, navground's way: at
heading error / TURN_TAU, clipped), at the forward speed nearest |v| cos(error) (0 facing
away) that keeps the step's chord within the half-planes where one does; an agent that steers
only keeps its speed and turns.
"""

import math

import numpy as np

from dcmppi.control.kernels.costs import valid_cylinders
from dcmppi.control.kernels.projection import bound
from dcmppi.control.planners.velocities import moving_obstacle_velocity, track
from dcmppi.control.validation import floats, positive

# chosen on square-orca's and corridor-visible's tuning environments (base seed + 7919)
TIME_HORIZON = 1.5  # [s] how long the command must stay clear at the obstacles' velocities
MARGIN = 0.15  # [m] added to every radius sum
PARAMS = {"time_horizon": TIME_HORIZON, "margin": MARGIN, "plan": True}
EPSILON = 1e-9  # parallel lines (RVO2's RVO_EPSILON, for metres and seconds)


def shield_param(value):
    """The `shield` option: None or False (off: None), True (the defaults) or a dict of
    time_horizon [s], margin [m] and plan (bool); returns None or the full, checked dict."""
    if value is None or value is False:
        return None
    if value is True:
        value = {}
    if not isinstance(value, dict) or set(value) - set(PARAMS):
        raise ValueError(
            f"shield must be true, false or a table of {', '.join(PARAMS)} "
            f"(e.g. shield = {{ time_horizon = 1.5 }}); got {value!r}"
        )
    full = {**PARAMS, **value}
    if not isinstance(full["plan"], bool):
        raise ValueError(f"shield plan must be true or false; got {full['plan']!r}")
    return {
        "time_horizon": positive("shield time_horizon", full["time_horizon"]),
        "margin": positive("shield margin", full["margin"], allow_zero=True),
        "plan": full["plan"],
    }


def make_shield(value, agent, robot_radius, dt):
    """The `shield` option `value` checked (shield_param) and its filter: (None, None) when
    off, else (the dict, a Shield of the robot)."""
    params = shield_param(value)
    return params, None if params is None else Shield(agent, robot_radius, dt, **params)


class Shield:
    """The filter of one robot (see the module docstring).

    Args: agent (an Agent), robot_radius [m], dt: the control period [s] (an overlap is to be
    left within it), time_horizon [s], margin [m], plan: whether a plan that keeps clear
    passes its command unchanged.
    """

    def __init__(self, agent, robot_radius, dt, time_horizon=TIME_HORIZON, margin=MARGIN,
                 plan=True):  # fmt: skip
        self.agent, self.dt, self.tau, self.margin = agent, dt, time_horizon, margin
        self.radius, self.use_plan = robot_radius + margin, plan

    def __call__(self, state, u, static, moving, velocity, bounds=None, plan=None):
        """The command u (nu,) filtered: (u', changed), u' the same array when unchanged.

        state (3,); static (M, 3) x, y, radius; moving (L, 4) x, y, heading, radius and their
        world-frame velocities (L, 2), finite; bounds (4,) xmin, ymin, xmax, ymax or None;
        plan (N, nu) the planner's controls from now (its first row replaced by u) or None.
        """
        if self.use_plan and plan is not None:
            if self._keeps_clear(state, u, plan, static, moving, velocity, bounds):
                return u, False
        heading = float(state[2])
        v, omega = self.agent.world_velocity(heading, u)
        v = (float(v[0]), float(v[1]))
        hard = self._walls(state, v, bounds) + self._discs(state, v, static, None)
        lines = hard + self._discs(state, v, moving[:, [0, 1, 3]], velocity)
        if not any(_outside(line, v) for line in lines):
            return u, False
        speed = self.agent.max_speed
        fail, safe = _program2(lines, speed, v, False)
        if fail < len(lines):
            safe = _program3(lines, len(hard), fail, speed, safe)
        if self.agent.holonomic:
            return bound(self.agent, self.agent.command(safe, omega)), True
        out = bound(self.agent, track(self.agent, heading, safe))
        if self.agent.steers_only:
            return out, True
        forward, turn = self.agent.world_velocity(heading, out)  # its speed along the chord:
        half = heading + 0.5 * self.dt * turn
        chord = (math.cos(half), math.sin(half))
        speed = _along(lines, chord, math.hypot(*forward), self.agent.max_speed)
        return bound(self.agent, self.agent.command((speed, 0.0), turn)), True

    def _keeps_clear(self, state, u, plan, static, moving, velocity, bounds):
        """Whether u, then plan[1:], keeps the robot's centre outside every widened disc (static
        ones at rest, moving ones at their velocities) and within the widened edges at each
        control step up to time_horizon."""
        steps = max(1, math.ceil(self.tau / self.dt - 1e-9))
        controls = np.vstack([u, np.asarray(plan, dtype=float)[1:]])  # the last one held:
        controls = controls[np.minimum(np.arange(steps), len(controls) - 1)]
        path = self.agent.rollout_one(state, controls, self.dt)[1:, :2]  # (steps, 2)
        t = self.dt * np.arange(1, steps + 1)[:, None, None]  # (steps, 1, 1)
        discs = np.vstack([static, moving[:, [0, 1, 3]]])
        drift = np.vstack([np.zeros((len(static), 2)), velocity])
        centres = discs[None, :, :2] + t * drift[None]  # (steps, n, 2)
        gaps = np.hypot(*(path[:, None] - centres).transpose(2, 0, 1)) - discs[:, 2] - self.radius
        if np.any(gaps < 0.0):
            return False
        if bounds is None:
            return True
        low, high = bounds[:2] + self.margin, bounds[2:] - self.margin
        return bool(np.all(path >= low) and np.all(path <= high))

    def _discs(self, state, v, discs, velocity):
        """ORCA's lines (point, direction) of discs (n, 3) x, y, radius moving at velocity
        (n, 2) (None: at rest) that a velocity within top speed could reach in time_horizon."""
        velocity = np.zeros((len(discs), 2)) if velocity is None else velocity
        offset = discs[:, :2] - state[:2]
        big = discs[:, 2] + self.radius
        reach = (self.agent.max_speed + np.hypot(*velocity.T)) * self.tau
        near = np.hypot(*offset.T) - big <= reach
        rows = zip(offset[near].tolist(), big[near].tolist(), velocity[near].tolist(), strict=True)
        return [
            _orca_line(dx, dy, v[0] - vx, v[1] - vy, b, self.tau, self.dt, v)
            for (dx, dy), b, (vx, vy) in rows
        ]

    def _walls(self, state, v, bounds):
        """The map's edges as lines: the speed towards each at most the centre's gap less the
        margin, over time_horizon."""
        if bounds is None:
            return []
        x0, y0, x1, y1 = (float(b) for b in bounds)
        x, y = float(state[0]), float(state[1])
        edges = (((1.0, 0.0), x1 - x), ((-1.0, 0.0), x - x0), ((0.0, 1.0), y1 - y),
                 ((0.0, -1.0), y - y0))  # fmt: skip
        reach = self.agent.max_speed * self.tau
        lines = []
        for (nx, ny), gap in edges:
            if gap - self.margin < reach:
                rate = (gap - self.margin) / self.tau
                lines.append(((nx * rate, ny * rate), (-ny, nx)))
        return lines


def _orca_line(dx, dy, wx, wy, big, tau, dt, v):
    """ORCA's half-plane (point, direction) for the obstacle at (dx, dy) from the robot,
    relative velocity (wx, wy) = v - its velocity, radius sum `big`, with all of the
    responsibility: the velocities on its left are allowed (RVO2's computeNewVelocity)."""
    dist2, big2 = dx * dx + dy * dy, big * big
    if dist2 > big2:
        cx, cy = wx - dx / tau, wy - dy / tau  # from the cut-off circle's centre
        c2, dot = cx * cx + cy * cy, cx * dx + cy * dy
        if dot < 0.0 and dot * dot > big2 * c2:  # nearest the cut-off circle
            c = math.sqrt(c2)
            ux, uy = cx / c, cy / c
            direction, push = (uy, -ux), big / tau - c
            u = (push * ux, push * uy)
        else:  # nearest a leg
            leg = math.sqrt(dist2 - big2)
            if dx * cy - dy * cx > 0.0:
                direction = ((dx * leg - dy * big) / dist2, (dx * big + dy * leg) / dist2)
            else:
                direction = (-(dx * leg + dy * big) / dist2, -(-dx * big + dy * leg) / dist2)
            along = wx * direction[0] + wy * direction[1]
            u = (along * direction[0] - wx, along * direction[1] - wy)
    else:  # overlapping: apart within one control period
        cx, cy = wx - dx / dt, wy - dy / dt
        c = math.hypot(cx, cy)
        ux, uy = (cx / c, cy / c) if c > EPSILON else (-dx, -dy)
        direction, push = (uy, -ux), big / dt - c
        u = (push * ux, push * uy)
    return (v[0] + u[0], v[1] + u[1]), direction


def _outside(line, v):
    """How far v lies on the forbidden (right) side of line (> 0: outside the half-plane)."""
    (px, py), (dx, dy) = line
    return dx * (py - v[1]) - dy * (px - v[0]) > 0.0


def _program1(lines, i, radius, opt, direction_opt):
    """The optimum on line i within the speed circle and lines[:i] (RVO2's linearProgram1):
    nearest opt, or furthest along it with direction_opt; None when there is none."""
    (px, py), (dx, dy) = lines[i]
    dot = px * dx + py * dy
    discriminant = dot * dot + radius * radius - (px * px + py * py)
    if discriminant < 0.0:
        return None
    root = math.sqrt(discriminant)
    left, right = -dot - root, -dot + root
    for (qx, qy), (ex, ey) in lines[:i]:
        denominator = dx * ey - dy * ex
        numerator = ex * (py - qy) - ey * (px - qx)
        if abs(denominator) <= EPSILON:
            if numerator < 0.0:
                return None
            continue
        t = numerator / denominator
        if denominator >= 0.0:
            right = min(right, t)
        else:
            left = max(left, t)
        if left > right:
            return None
    if direction_opt:
        t = right if opt[0] * dx + opt[1] * dy > 0.0 else left
    else:
        t = min(max(dx * (opt[0] - px) + dy * (opt[1] - py), left), right)
    return (px + t * dx, py + t * dy)


def _program2(lines, radius, opt, direction_opt):
    """(i, v): v the velocity within the speed circle nearest opt (furthest along it with
    direction_opt) that satisfies every line, i = len(lines); or where line i admits none, i
    and the optimum of lines[:i] (RVO2's linearProgram2)."""
    n = math.hypot(*opt)
    if direction_opt:
        result = (opt[0] * radius, opt[1] * radius)
    elif n > radius:
        result = (opt[0] * radius / n, opt[1] * radius / n)
    else:
        result = opt
    for i, line in enumerate(lines):
        if _outside(line, result):
            new = _program1(lines, i, radius, opt, direction_opt)
            if new is None:
                return i, result
            result = new
    return len(lines), result


def _program3(lines, hard, begin, radius, result):
    """The velocity that least violates lines[hard:] (the largest violation smallest) within
    lines[:hard] and the speed circle, from lines[begin] on (RVO2's linearProgram3)."""
    distance = 0.0
    for i in range(begin, len(lines)):
        (px, py), (dx, dy) = lines[i]
        if dx * (py - result[1]) - dy * (px - result[0]) <= distance:
            continue
        projected = list(lines[:hard])
        for (qx, qy), (ex, ey) in lines[hard:i]:
            determinant = dx * ey - dy * ex
            if abs(determinant) <= EPSILON:
                if dx * ex + dy * ey > 0.0:
                    continue  # the same direction
                point = (0.5 * (px + qx), 0.5 * (py + qy))
            else:
                t = (ex * (py - qy) - ey * (px - qx)) / determinant
                point = (px + t * dx, py + t * dy)
            nx, ny = ex - dx, ey - dy
            n = math.hypot(nx, ny)
            projected.append((point, (nx / n, ny / n)))
        fail, new = _program2(projected, radius, (-dy, dx), True)
        if fail == len(projected):  # else a rounding error: keep the result
            result = new
        distance = dx * (py - result[1]) - dy * (px - result[0])
    return result


def _along(lines, chord, speed, top):
    """The forward speed in [0, top] nearest `speed` whose velocity speed x chord (2,) satisfies
    every line; `speed` where none does."""
    low, high = 0.0, top
    for (px, py), (dx, dy) in lines:
        a = dx * chord[1] - dy * chord[0]  # the line's violation at s: dx (py - s cy) - ...
        b = dx * py - dy * px
        if abs(a) <= EPSILON:
            if b > 0.0:
                return speed
        elif a > 0.0:
            low = max(low, b / a)
        else:
            high = min(high, b / a)
    if low > high:
        return speed
    return min(max(speed, low), high)


def shielded(safety, diagnostics, state, u, static, moving, velocity, obstacle_model, bounds,
             plan=None):  # fmt: skip
    """u (nu,) through `safety` (a Shield), recording in `diagnostics` whether it changed the
    command (`shielded`). The arguments are Controller.act's: static
    (M, 3) or None, moving (L, 4) without padding rows and their observed velocities (L, 2)
    (nan: not observed; None), filled as the classical planners fill them
    (velocities.moving_obstacle_velocity); bounds (4,) or None; plan (N, nu) the plan this step
    made (its first row the planner's command), or None (a planner without one)."""
    moving = np.zeros((0, 4)) if moving is None else moving
    velocity = moving_obstacle_velocity(moving, velocity, obstacle_model)
    static = valid_cylinders(static, "static")
    bounds = None if bounds is None else floats("bounds", bounds).reshape(4)
    u, diagnostics.shielded = safety(state, u, static, moving, velocity, bounds, plan)
    return u
