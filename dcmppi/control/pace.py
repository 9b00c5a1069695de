"""Terms of the objective for time to the goal, off by default (the paper's objective).

The paper's cost sums each state's distance to the goal: far from the goal a sideways step
costs almost nothing (a lateral offset y at distance D adds about y^2 / 2D), so plans weave.
Pace adds, per rollout of states p_0 .. p_N (p_0 the step's position, goal g):

    cost_to_go  * |p_N - g|                            (the distance left at the horizon)
    path_align  * sum_i dist(p_i, line p_0 -> g)        (nav2's PathAlignCritic on the straight
                                                         path to the goal)
    speed_weight * sum_i (v_max - |p_{i+1} - p_i| / dt) (speed below the top speed)

in the cost's units (the goal term: 1 per metre per state). Weights are >= 0; 0 turns a term
off.
"""

import dataclasses

import numpy as np

from dcmppi.control.validation import positive

PACE_PARAMS = ("cost_to_go", "path_align", "speed_weight")


@dataclasses.dataclass(frozen=True)
class Pace:
    """The weights of the terms above, the agent's top speed v_max [m/s] and the period dt [s].

    Build with Pace.of(cost_to_go=..., ...), which checks the weights."""

    cost_to_go: float = 0.0
    path_align: float = 0.0
    speed_weight: float = 0.0
    v_max: float = 1.0
    dt: float = 0.1

    @classmethod
    def of(cls, v_max, dt, **weights):
        """Pace of the weights (None: 0), each a number >= 0 (a ValueError names a bad one)."""
        checked = {
            n: positive(n, 0.0 if weights.get(n) is None else weights[n], allow_zero=True)
            for n in PACE_PARAMS
        }
        return cls(**checked, v_max=float(v_max), dt=float(dt))

    @property
    def on(self):
        """Whether any term has a weight."""
        return bool(self.cost_to_go or self.path_align or self.speed_weight)

    def __call__(self, x, y, start, goal, cols=None):
        """The terms' sum (R,) for the rollouts x, y (N + 1, R) from the step's position
        start (2,) to goal (2,); only the columns cols = (j0, j1) when given."""
        if cols is not None:
            x, y = x[:, cols[0] : cols[1]], y[:, cols[0] : cols[1]]
        gx, gy = float(goal[0]), float(goal[1])
        out = np.zeros(x.shape[1])
        if self.cost_to_go:
            out += self.cost_to_go * np.hypot(x[-1] - gx, y[-1] - gy)
        if self.path_align:
            x0, y0 = float(start[0]), float(start[1])
            ex, ey = gx - x0, gy - y0
            norm = np.hypot(ex, ey)
            if norm > 0:
                lateral = np.abs((x - x0) * (ey / norm) - (y - y0) * (ex / norm))
                out += self.path_align * lateral.sum(axis=0)
        if self.speed_weight:
            speed = np.hypot(np.diff(x, axis=0), np.diff(y, axis=0)) / self.dt
            out += self.speed_weight * (self.v_max - speed).sum(axis=0)
        return out
