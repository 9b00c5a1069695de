"""`dubins`: the constant-speed car of the static experiment (paper Sec. IV-A, Fig. 1-4).

State (x, y, theta); one control, the turn rate omega, |omega| <= v / r_min; the speed v is
fixed. Each control period is an exact arc (dcmppi.control.kernels.dynamics).
"""

import math

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.agents.base import Agent, register_agent
from dcmppi.control.kernels.dynamics import arc_columns, arc_rollout, dubins_step, sinc
from dcmppi.control.validation import positive


@register_agent("dubins")
class Dubins(Agent):
    """Constant speed `v` [m/s], minimum turning radius `r_min` [m]."""

    controls = ("omega",)
    param_names = ("v", "r_min")
    default_Sigma = (defaults.SIGMA,)
    default_perturbation = "constant"  # paper Sec. IV-A
    steers_only = True

    def __init__(self, v=defaults.V, r_min=defaults.R_MIN):
        self.v = positive("v", v)
        self.r_min = positive("r_min", r_min)
        self.omega_max = defaults.omega_max(self.v, self.r_min)
        self.set_bounds([-self.omega_max], [self.omega_max])

    @property
    def max_speed(self):
        return self.v

    def command(self, velocity, omega):
        return np.array([omega])

    def world_velocity(self, heading, u):
        return self.v * np.array([math.cos(heading), math.sin(heading)]), float(u[-1])

    def rollout(self, x0, u, dt, starts=1):
        return arc_rollout(x0, u, dt, self.v, starts)

    def rollout_columns(self, out, u, dt, cols=None):
        arc_columns(out, u, dt, self.v, cols)

    def step(self, state, u, dt):
        return dubins_step(state, np.asarray(u, dtype=float)[..., 0], self.v, dt)

    def jacobians(self, states, U, dt):
        c0, c1, b0, b1 = jacobian_terms(np.asarray(states)[:, 2], U[:, 0], self.v, dt)
        return arc_jacobians(c0, c1, b0[:, None], b1[:, None], np.full((len(U), 1), dt))


def jacobian_terms(theta, omega, v, dt):
    """The entries of the exact arc step's Jacobians that vary along a trajectory.

    A_i = I + c0_i e_x e_theta^T + c1_i e_y e_theta^T, and d x_{i+1} / d omega_i = (b0_i, b1_i,
    dt); v may be a number or (N,) per period.

    Args:
      theta: (N + 1,) or more headings (the first N are used); omega: (N,) turn rates.
    Returns:
      c0, c1, b0, b1: (N,) each.
    """
    a = 0.5 * omega * dt
    heading = theta[: len(omega)] + a
    s = sinc(a)
    ds = np.where(
        np.abs(a) < 1e-4, -a / 3.0, (a * np.cos(a) - np.sin(a)) / np.where(a == 0, 1, a) ** 2
    )
    c, sn = np.cos(heading), np.sin(heading)
    return (
        -v * dt * s * sn,
        v * dt * s * c,
        0.5 * dt * v * dt * (ds * c - s * sn),
        0.5 * dt * v * dt * (ds * sn + s * c),
    )


def arc_jacobians(c0, c1, bx, by, btheta):
    """A (N, 3, 3) = I + c0 e_x e_theta^T + c1 e_y e_theta^T and B (N, 3, nu) with rows bx, by,
    btheta (N, nu) each."""
    n = len(c0)
    A = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    A[:, 0, 2], A[:, 1, 2] = c0, c1
    return A, np.stack([bx, by, btheta], axis=1)
