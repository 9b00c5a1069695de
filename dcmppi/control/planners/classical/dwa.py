"""`dwa`: a dynamic-window planner in the manner of nav2's DWB local planner (Fox et al. 1997).

Each step it samples velocities within the window the robot can reach in one control period
from its last command (acceleration limits), simulates each held over sim_time, and scores the
trajectories with DWB's critics that need no global path:

    goal_dist     GoalDist: distance from the trajectory's end to the goal, in cost-map cells
    goal_align    GoalAlign: the same for the point forward_point_distance ahead of the end pose
                  (the holonomic robot: ahead along its velocity), i.e. the heading to the goal
    obstacle      BaseObstacle: the inflation layer's cost 252 exp(-cost_scaling_factor (d - r))
                  at the pose nearest an obstacle (d: the centre's distance to the nearest
                  obstacle surface, r: the robot radius; 0 beyond r + inflation); a pose with
                  d < r, or outside the map, makes the trajectory illegal
    speed         -speed_scale v / v_max (Fox et al.'s velocity term; 0 by default: DWB has no
                  speed critic, its GoalDist rewards progress)

Moving obstacles are extrapolated at their observed velocities (velocities.moving_obstacle_velocity)
and checked at each simulated instant. The cost is the sum of the scaled critics; the best legal
trajectory's velocity is the command. When every trajectory is illegal (DWB would report no
valid command) the one whose first collision comes latest is taken.

Departures from DWB, for this setting: no global path, so PathDist and PathAlign (which follow
one) are left out, and GoalDist is the straight-line distance, not a distance on the grid;
BaseObstacle scores the worst pose rather than the last (DWB's sum_scores=false default), since
a moving obstacle may cross a trajectory in its middle; the costs come from the obstacles'
geometry, not a rasterised cost map (costmap_resolution only converts metres to cells).
"""

import math

import numba
import numpy as np

from dcmppi.control.planners.classical.base import Classical
from dcmppi.control.planners.registry import register
from dcmppi.control.validation import positive

INSCRIBED_COST = 252.0  # nav2's inflation: cost just outside the inscribed radius (253 - 1)


@register("dwa")
class DWA(Classical):
    """Dynamic window, sampled velocities scored by nav2 DWB's critics (Fox et al. 1997).

    Args (keywords; the robot's as `Classical`), defaults and their sources (nav2 DWB's
    defaults, nav2_params.yaml and dwb_plugins/dwb_critics):
      sim_time: 1.7 s, how long each velocity is simulated.
      vx_samples: 20 speeds (the holonomic robot: 20 per axis of its world-frame velocity);
        vtheta_samples: 20 turn rates.
      acc_lim_x: 2.5 m/s^2 (the holonomic robot: per axis), decel_lim_x: 2.5 m/s^2 (DWB's
        -2.5), acc_lim_theta: 3.2 rad/s^2: the window is the last command +- limit x dt.
      linear_granularity: 0.05 m, the longest simulated step at top speed.
      goal_dist_scale: 24, goal_align_scale: 24 (GoalDist, GoalAlign), forward_point_distance:
        0.325 m (GoalAlign's), obstacle_scale: 0.02 (BaseObstacle).
      cost_scaling_factor: 3.0 /m (nav2's inflation layer); inflation: 0.33 m, the band beyond
        the robot radius where obstacles cost (nav2's inflation_radius 0.55 m less its default
        robot_radius 0.22 m).
      footprint_padding: 0.01 m, added to the robot radius where a pose counts as a collision
        (nav2's cost map).
      costmap_resolution: 0.05 m, the cell size of GoalDist's and GoalAlign's distances (nav2's
        local cost map).
      speed_scale: 0 (see the module's docstring).
    """

    samples = True

    def __init__(
        self,
        *,
        sim_time=1.7,
        vx_samples=20,
        vtheta_samples=20,
        acc_lim_x=2.5,
        decel_lim_x=2.5,
        acc_lim_theta=3.2,
        linear_granularity=0.05,
        goal_dist_scale=24.0,
        goal_align_scale=24.0,
        forward_point_distance=0.325,
        obstacle_scale=0.02,
        cost_scaling_factor=3.0,
        inflation=0.33,
        footprint_padding=0.01,
        costmap_resolution=0.05,
        speed_scale=0.0,
        agent="dubins",
        **robot,
    ):
        super().__init__(agent=agent, **robot)  # robot_radius, dt, seed, the agent's limits
        self.sim_time = positive("sim_time", sim_time)
        self.vx_samples = positive("vx_samples", vx_samples, integer=True)
        self.vtheta_samples = positive("vtheta_samples", vtheta_samples, integer=True)
        self.acc_lim_x = positive("acc_lim_x", acc_lim_x)
        self.decel_lim_x = positive("decel_lim_x", decel_lim_x)
        self.acc_lim_theta = positive("acc_lim_theta", acc_lim_theta)
        self.linear_granularity = positive("linear_granularity", linear_granularity)
        self.goal_dist_scale = positive("goal_dist_scale", goal_dist_scale, allow_zero=True)
        self.goal_align_scale = positive("goal_align_scale", goal_align_scale, allow_zero=True)
        self.forward_point_distance = positive(
            "forward_point_distance", forward_point_distance, allow_zero=True
        )
        self.obstacle_scale = positive("obstacle_scale", obstacle_scale, allow_zero=True)
        self.cost_scaling_factor = positive("cost_scaling_factor", cost_scaling_factor)
        self.inflation = positive("inflation", inflation, allow_zero=True)
        self.footprint_padding = positive("footprint_padding", footprint_padding, allow_zero=True)
        self.costmap_resolution = positive("costmap_resolution", costmap_resolution)
        self.speed_scale = positive("speed_scale", speed_scale, allow_zero=True)
        self.steps = max(1, math.ceil(self.sim_time * self.agent.max_speed / linear_granularity))

    def window(self):
        """The sampled velocities (S, 2): (u_x, u_y) world-frame for a holonomic robot, else
        (v, omega) (an agent that steers only: v its speed)."""
        a, dt = self.agent, self.dt
        top = a.max_speed
        if a.holonomic:
            axes = [
                _span(c - self.acc_lim_x * dt, c + self.acc_lim_x * dt, -top, top,
                      self.vx_samples)
                for c in self.velocity
            ]  # fmt: skip
            grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 2)
            inside = np.hypot(*grid.T) <= top * (1.0 + 1e-12)
            return grid[inside] if inside.any() else self.velocity[None].copy()
        limit = a.omega_max
        w = self.omega
        omegas = _span(w - self.acc_lim_theta * dt, w + self.acc_lim_theta * dt, -limit, limit,
                       self.vtheta_samples)  # fmt: skip
        if a.steers_only:
            speeds = np.array([top])
        else:
            v = float(np.hypot(*self.velocity))
            speeds = _span(v - self.decel_lim_x * dt, v + self.acc_lim_x * dt, 0.0, top,
                           self.vx_samples)  # fmt: skip
        return np.stack(np.meshgrid(speeds, omegas, indexing="ij"), axis=-1).reshape(-1, 2)

    def _solve(self, obs):
        samples = self.window()
        # within reach an obstacle's surface can meet a trajectory
        reach = self.agent.max_speed * self.sim_time + self.robot_radius + 0.1 + self.inflation
        fastest = float(np.max(np.hypot(*obs.moving_velocity.T), initial=0.0))
        static, moving, velocity = obs.near(reach + fastest * self.sim_time)
        bounds = np.array([-np.inf, -np.inf, np.inf, np.inf]) if obs.bounds is None else obs.bounds
        holonomic = self.agent.holonomic
        cost, hit, states = _evaluate(
            obs.state, samples, holonomic, self.steps, self.sim_time / self.steps,
            np.ascontiguousarray(static), np.ascontiguousarray(moving[:, :2]),
            np.ascontiguousarray(velocity), np.ascontiguousarray(moving[:, 3]), bounds,
            obs.goal, self.robot_radius + self.footprint_padding, self.inflation,
            self.cost_scaling_factor, self.obstacle_scale,
            self.goal_dist_scale / self.costmap_resolution,
            self.goal_align_scale / self.costmap_resolution, self.forward_point_distance,
            self.speed_scale / self.agent.max_speed,
        )  # fmt: skip
        best = _choose(cost, hit)
        d = self.diagnostics
        d.states, d.J = states, cost
        self.legal = int(np.sum(hit > self.steps))
        u = samples[best]
        if holonomic:
            return self.agent.command(u, 0.0)
        return self.agent.command((u[0], 0.0), u[1])


def _span(lo, hi, low, high, n):
    """n values evenly from max(lo, low) to min(hi, high) (one when the range is a point)."""
    lo, hi = max(lo, low), min(hi, high)
    if hi <= lo:
        return np.array([min(max(lo, low), high)])
    return np.linspace(lo, hi, n)


def _choose(cost, hit):
    """The index of the cheapest legal trajectory; without one, the cheapest of those whose
    first collision comes latest."""
    latest = hit.max()
    return int(np.flatnonzero(hit == latest)[np.argmin(cost[hit == latest])])


@numba.njit(cache=True)
def _evaluate(x0, samples, holonomic, steps, h, static, mpos, mvel, mrad, bounds, goal, r,
              inflation, k, obstacle_scale, dist_scale, align_scale, forward,
              speed_scale):  # fmt: skip
    """Simulate and score every sample: cost (S,), the step of its first collision (S,)
    (steps + 1: none) and the states (S, steps + 1, 3). Each trajectory checks only the
    obstacles that can come within r + inflation of its bounding box (the others cost nothing)."""
    n = samples.shape[0]
    cost = np.empty(n)
    hit = np.full(n, steps + 1, dtype=np.int64)
    states = np.empty((n, steps + 1, 3))
    near_static = np.empty(static.shape[0], dtype=np.int64)
    near_moving = np.empty(mpos.shape[0], dtype=np.int64)
    reach = r + inflation
    duration = steps * h
    for s in range(n):
        a, b = samples[s, 0], samples[s, 1]
        x, y, th = x0[0], x0[1], x0[2]
        states[s, 0, 0], states[s, 0, 1], states[s, 0, 2] = x, y, th
        for i in range(1, steps + 1):
            if holonomic:
                x += h * a
                y += h * b
            else:
                half = 0.5 * b * h
                chord = a * h * (math.sin(half) / half if half != 0.0 else 1.0)
                x += chord * math.cos(th + half)
                y += chord * math.sin(th + half)
                th = th + b * h
            states[s, i, 0], states[s, i, 1], states[s, i, 2] = x, y, th
        x_lo, x_hi = states[s, :, 0].min() - reach, states[s, :, 0].max() + reach
        y_lo, y_hi = states[s, :, 1].min() - reach, states[s, :, 1].max() + reach
        ns = 0
        for j in range(static.shape[0]):
            c = static[j, 2]
            if (static[j, 0] + c > x_lo and static[j, 0] - c < x_hi
                    and static[j, 1] + c > y_lo and static[j, 1] - c < y_hi):  # fmt: skip
                near_static[ns] = j
                ns += 1
        nm = 0
        for j in range(mpos.shape[0]):
            c = mrad[j]
            sx, sy = mpos[j, 0], mpos[j, 1]  # its path's box over the horizon
            ex, ey = sx + duration * mvel[j, 0], sy + duration * mvel[j, 1]
            if (max(sx, ex) + c > x_lo and min(sx, ex) - c < x_hi
                    and max(sy, ey) + c > y_lo and min(sy, ey) - c < y_hi):  # fmt: skip
                near_moving[nm] = j
                nm += 1
        worst = 0.0
        for i in range(steps + 1):
            x, y = states[s, i, 0], states[s, i, 1]
            if x < bounds[0] or x > bounds[2] or y < bounds[1] or y > bounds[3]:
                hit[s] = i
                break
            d = np.inf
            for q in range(ns):
                j = near_static[q]
                d = min(d, math.hypot(x - static[j, 0], y - static[j, 1]) - static[j, 2])
            t = i * h
            for q in range(nm):
                j = near_moving[q]
                ox, oy = mpos[j, 0] + t * mvel[j, 0], mpos[j, 1] + t * mvel[j, 1]
                d = min(d, math.hypot(x - ox, y - oy) - mrad[j])
            if d < r:
                hit[s] = i
                break
            if d < reach:
                worst = max(worst, INSCRIBED_COST * math.exp(-k * (d - r)))
        x, y, th = states[s, steps, 0], states[s, steps, 1], states[s, steps, 2]
        if holonomic:
            speed = math.hypot(a, b)
            ax, ay = (a / speed, b / speed) if speed > 0.0 else (math.cos(th), math.sin(th))
        else:
            speed = a
            ax, ay = math.cos(th), math.sin(th)
        cost[s] = (
            obstacle_scale * worst
            + dist_scale * math.hypot(x - goal[0], y - goal[1])
            + align_scale * math.hypot(x + forward * ax - goal[0], y + forward * ay - goal[1])
            - speed_scale * speed
        )
    return cost, hit, states
