"""`unicycle`: a differential-drive robot (the BARN worlds' robots).

State (x, y, theta); controls the forward speed v in [0, v_max] and the turn rate omega in
[-omega_max, omega_max]. Each control period is an exact arc with both held.
"""

import math

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.agents.base import Agent, register_agent
from dcmppi.control.agents.dubins import arc_jacobians, jacobian_terms
from dcmppi.control.kernels.dynamics import arc_columns, arc_rollout, dubins_step, sinc
from dcmppi.control.validation import positive


@register_agent("unicycle")
class Unicycle(Agent):
    """Top speed `v_max` [m/s], top turn rate `omega_max` [rad/s]; it never reverses."""

    controls = ("v", "omega")
    param_names = ("v_max", "omega_max")
    default_Sigma = (defaults.SIGMA_VELOCITY, defaults.SIGMA)
    # With constant (and mixed) perturbations the unicycle stops in front of an obstacle: every
    # sample is one arc held for 5 s, none of which turns away and then drives on, and with the
    # speed at a bound the importance term favours slowing down (tests/control/test_controllers.py).
    default_perturbation = "time_varying"

    def __init__(self, v_max=defaults.UNICYCLE_V_MAX, omega_max=defaults.UNICYCLE_OMEGA_MAX):
        self.v_max = positive("v_max", v_max)
        self.omega_max = positive("omega_max", omega_max)
        self.set_bounds([0.0, -self.omega_max], [self.v_max, self.omega_max])

    @property
    def max_speed(self):
        return self.v_max

    def first_guess(self, state, goal, N):
        """Full speed straight ahead."""
        return np.tile([self.v_max, 0.0], (N, 1))

    def command(self, velocity, omega):
        return np.array([velocity[0], omega])

    def world_velocity(self, heading, u):
        return float(u[0]) * np.array([math.cos(heading), math.sin(heading)]), float(u[-1])

    def rollout(self, x0, u, dt, starts=1):
        return arc_rollout(x0, u, dt, None, starts)  # u: (N, 2, K) speeds, turn rates

    def rollout_columns(self, out, u, dt, cols=None):
        arc_columns(out, u, dt, None, cols)

    def step(self, state, u, dt):
        u = np.asarray(u, dtype=float)
        return dubins_step(state, u[..., 1], u[..., 0], dt)

    def jacobians(self, states, U, dt):
        v, omega = U[:, 0], U[:, 1]
        c0, c1, b0, b1 = jacobian_terms(np.asarray(states)[:, 2], omega, v, dt)
        a = 0.5 * omega * dt
        heading = np.asarray(states)[: len(U), 2] + a
        chord = dt * sinc(a)  # d x_{i+1} / d v = chord (cos, sin) of the mid heading
        bx = np.column_stack([chord * np.cos(heading), b0])
        by = np.column_stack([chord * np.sin(heading), b1])
        btheta = np.column_stack([np.zeros(len(U)), np.full(len(U), dt)])
        return arc_jacobians(c0, c1, bx, by, btheta)
