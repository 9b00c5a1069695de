"""Tube-MPPI (Williams et al. 2018, "Robust Sampling Based Model Predictive Control with Sparse
Objective Information"), the paper's comparison.

Each step solves MPPI twice with the same perturbations and warm start: from the nominal state z
and from the real state x (one batch of 2K rollouts). When the real solve's best cost is below the
nominal's plus `reset_threshold`, the nominal state resets to the real one and the real solve's
plan is used; otherwise the nominal plan is kept. A time-varying LQR along the nominal trajectory
(Dubins model linearised about the exact discrete step, Riccati backward pass with weights
Q = diag(q_pos, q_pos, q_theta), R = r_omega, Q_N = Q) gives the applied control
u = clip(u_nom_0 - K_0 (x - z)) (heading error wrapped). The nominal state then moves exactly one
control period with u_nom_0 on the analytic model. Constant speed makes the along-track error
uncontrollable, so the nominal also resets whenever |x - z| (position) exceeds `max_deviation`.
"""

import numpy as np

from .controllers import _positive, register
from .dynamics import dubins_step, rollout_time_major, sinc, wrap_angle
from .mppi import MPPI, effective_sample_size, mppi_update

RESET_THRESHOLD = 5.0  # cost units (sum of N + 1 goal distances [m])
MAX_DEVIATION = 1.0  # [m]
Q_POS, Q_THETA, R_OMEGA = 1.0, 1.0, 1.0


def linearize(states, U, v, dt):
    """Jacobians of the exact discrete Dubins step along a trajectory.

    Args:
      states: (N + 1, 3) nominal states; U: (N,) nominal controls.
    Returns:
      A: (N, 3, 3), B: (N, 3).
    """
    a = 0.5 * U * dt
    heading = states[:-1, 2] + a
    s = sinc(a)
    ds = np.where(
        np.abs(a) < 1e-4, -a / 3.0, (a * np.cos(a) - np.sin(a)) / np.where(a == 0, 1, a) ** 2
    )
    c, sn = np.cos(heading), np.sin(heading)
    n = len(U)
    A = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    A[:, 0, 2] = -v * dt * s * sn
    A[:, 1, 2] = v * dt * s * c
    B = np.empty((n, 3))
    B[:, 0] = 0.5 * dt * v * dt * (ds * c - s * sn)
    B[:, 1] = 0.5 * dt * v * dt * (ds * sn + s * c)
    B[:, 2] = dt
    return A, B


def tvlqr_gains(A, B, Q, R, Qf):
    """Time-varying LQR gains for x_{i+1} = A_i x_i + B_i u_i, u_i = -K_i x_i.

    Args:
      A: (N, n, n), B: (N, n) single input; Q, Qf: (n, n); R: scalar.
    Returns:
      K: (N, n).
    """
    P = np.array(Qf, dtype=float)
    K = np.empty(B.shape)
    for i in range(len(B) - 1, -1, -1):
        a, b = A[i], B[i]
        PA = P @ a
        bPA = b @ PA
        K[i] = bPA / (R + b @ P @ b)
        P = Q + a.T @ PA - np.outer(bPA, K[i])
        P = 0.5 * (P + P.T)
    return K


@register("tube")
class TubeMPPI(MPPI):
    """Tube-MPPI. Extra args: reset_threshold, max_deviation, q_pos, q_theta, r_omega."""

    own_params = ("reset_threshold", "max_deviation", "q_pos", "q_theta", "r_omega")

    def __init__(
        self,
        *,
        reset_threshold=RESET_THRESHOLD,
        max_deviation=MAX_DEVIATION,
        q_pos=Q_POS,
        q_theta=Q_THETA,
        r_omega=R_OMEGA,
        **params,
    ):
        t = float(reset_threshold)
        if not np.isfinite(t):
            raise ValueError(f"reset_threshold must be finite; got {reset_threshold!r}")
        self.reset_threshold = t
        self.max_deviation = _positive("max_deviation", max_deviation)
        self.q_pos = _positive("q_pos", q_pos, allow_zero=True)
        self.q_theta = _positive("q_theta", q_theta, allow_zero=True)
        self.r_omega = _positive("r_omega", r_omega)
        self._Q = np.diag([self.q_pos, self.q_pos, self.q_theta])
        super().__init__(**params)

    def reset(self, seed=None):
        super().reset(seed)
        self.nominal = None

    def _solve(self, state):
        z = state.copy() if self.nominal is None else self.nominal
        u, eps = self.controls(self.U, self.sample())
        states, J, S, reset = self._two_solves(z, state, u, eps)
        if reset:
            z = state.copy()
        plan, w = mppi_update(self.U, eps, S, self.lambda_)
        self.record(eps, states, J, S)
        d = self.diagnostics
        d.weights, d.ess, d.nominal_reset = w, effective_sample_size(w), bool(reset)
        feedback = self._feedback(z, state, plan)
        omega = float(np.clip(plan[0] - feedback, -self.omega_max, self.omega_max))
        d.nominal_state = z
        self.nominal = dubins_step(z, plan[0], self.v, self.dt)
        self.U = np.concatenate([plan[1:], plan[-1:]])
        d.plan = plan
        return omega

    def _two_solves(self, z, state, u, eps):
        """Rollouts from the nominal state z and the real state with the same controls u (N, K).

        Returns the chosen solve's states (N + 1, 3, K), J (K,), S (K,) and the reset flag. When
        z equals the real state (after every reset on a noise-free model) both solves are the
        same computation, so one batch of K rollouts stands for both.
        """
        importance = self.importance(self.U, eps)
        if np.array_equal(z, state):
            states, J = self.evaluate(state, u)
            S = J + importance
            m = S.min()
            return states, J, S, bool(m < m + self.reset_threshold)
        K = self.K
        x0 = np.column_stack([np.repeat(z[:, None], K, 1), np.repeat(state[:, None], K, 1)])
        states, J = self.evaluate(x0, np.concatenate([u, u], axis=1))
        S = J + np.tile(importance, 2)
        reset = S[K:].min() < S[:K].min() + self.reset_threshold or (
            np.hypot(*(state[:2] - z[:2])) > self.max_deviation
        )
        half = slice(K, None) if reset else slice(None, K)
        return states[:, :, half], J[half], S[half], reset

    def _feedback(self, z, state, plan):
        """K_0 (x - z) of the time-varying LQR along the nominal plan (0 when x equals z)."""
        error = state - z
        error[2] = wrap_angle(error[2])
        if not error.any():  # K_0 @ 0 = 0: the gains are not needed
            return 0.0
        nominal = rollout_time_major(z, plan[:, None], self.v, self.dt)[:, :, 0]
        A, B = linearize(nominal, plan, self.v, self.dt)
        gain = tvlqr_gains(A, B, self._Q, self.r_omega, self._Q)[0]
        return gain @ error
