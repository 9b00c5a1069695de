"""`holonomic`: a robot that commands its planar velocity and yaw rate (paper Sec. IV-B).

State (x, y, theta); controls u = (u_x, u_y, u_theta), the velocity in the world frame [m/s]
with |(u_x, u_y)| <= v_max, and the yaw rate |u_theta| <= omega_max [rad/s]. The model
integrates the commanded velocity over each control period; the MuJoCo plant follows the
commands through velocity actuators (lag).
"""

import numba
import numpy as np

from dcmppi.control import defaults
from dcmppi.control.agents.base import Agent, register_agent
from dcmppi.control.kernels.dynamics import _wrap
from dcmppi.control.kernels.threads import in_cols
from dcmppi.control.validation import positive


@register_agent("holonomic")
class Holonomic(Agent):
    """Top planar speed `v_max` [m/s] (a norm bound), top yaw rate `omega_max` [rad/s]."""

    controls = ("u_x", "u_y", "u_theta")
    param_names = ("v_max", "omega_max")
    default_Sigma = (defaults.SIGMA_VELOCITY, defaults.SIGMA_VELOCITY, defaults.SIGMA)
    default_perturbation = "mixed"  # docs/design.md, Experiments
    norm_axes = (0, 1)
    holonomic = True

    def __init__(self, v_max=defaults.HOLONOMIC_V_MAX, omega_max=defaults.HOLONOMIC_OMEGA_MAX):
        self.v_max = positive("v_max", v_max)
        self.omega_max = positive("omega_max", omega_max)
        bound = [self.v_max, self.v_max, self.omega_max]
        self.set_bounds(-np.array(bound), bound, norm_limit=self.v_max)

    @property
    def max_speed(self):
        return self.v_max

    def first_guess(self, state, goal, N):
        """Full speed straight at the goal, no turning."""
        d = np.asarray(goal, dtype=float)[:2] - np.asarray(state, dtype=float)[:2]
        n = np.hypot(*d)
        direction = d / n if n > 0 else np.zeros(2)
        return np.tile([*(self.v_max * direction), 0.0], (N, 1))

    def command(self, velocity, omega):
        return np.array([velocity[0], velocity[1], omega])

    def world_velocity(self, heading, u):
        return np.array([u[0], u[1]]), float(u[2])

    def rollout(self, x0, u, dt, starts=1):
        n, _, k = u.shape
        out = np.empty((3, n + 1, starts, k))
        out[:, 0] = np.reshape(x0, (3, starts, -1))
        _integrate(out, u, dt, None)
        return out.reshape(3, n + 1, starts * k)

    def rollout_columns(self, out, u, dt, cols=None):
        _integrate(out, u, dt, cols)

    def step(self, state, u, dt):
        return np.asarray(state, dtype=float) + dt * np.asarray(u, dtype=float)

    def jacobians(self, states, U, dt):
        n = len(U)
        return np.broadcast_to(np.eye(3), (n, 3, 3)).copy(), np.broadcast_to(
            dt * np.eye(3), (n, 3, 3)
        ).copy()


@numba.njit(cache=True, nogil=True)
def _integrate(out, u, dt, cols):
    """out[i + 1] = out[i] + dt u_i for the samples cols (threads.in_cols), their start
    headings wrapped.
    out: (3, n + 1, S, K); u: (n, 3, K)."""
    n, starts = u.shape[0], out.shape[2]
    for s in range(starts):
        first = in_cols(out[2, 0, s], cols)
        for j in range(len(first)):
            first[j] = _wrap(first[j])
    for c in range(3):
        for i in range(n):
            step = in_cols(u[i, c], cols)
            for s in range(starts):
                now, nxt = in_cols(out[c, i, s], cols), in_cols(out[c, i + 1, s], cols)
                for j in range(len(step)):
                    nxt[j] = now[j] + dt * step[j]
