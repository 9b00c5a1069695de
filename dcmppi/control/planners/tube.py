"""Tube-MPPI (Williams et al. 2018, "Robust Sampling Based Model Predictive Control with Sparse
Objective Information"), the paper's comparison.

Each step solves MPPI twice with the same perturbations and warm start: from the nominal state z
and from the real state x (one batch of 2K rollouts). When the real solve's best cost is below the
nominal's plus `reset_threshold`, the nominal state resets to the real one and the real solve's
plan is used; otherwise the nominal plan is kept. A time-varying LQR along the nominal trajectory
(the agent's exact step linearised, Riccati backward pass, Q_N = Q) gives the applied control
u = project(u_nom_0 - K_0 (x - z)) (heading error wrapped). The nominal state then moves exactly
one control period with u_nom_0 on the analytic model. A constant-speed car cannot correct an
along-track error, so the nominal also resets whenever |x - z| (position) exceeds `max_deviation`.

Units (one rule for every experiment and agent, never tuned on a table):
- LQR weights by Bryson's rule, the inverse square of the largest acceptable value:
  Q = diag(1 / e_pos^2, 1 / e_pos^2, 1 / e_theta^2) with e_pos = `tracking_position` = 0.1 m (one
  cost-map cell: the plans pass obstacles a few centimetres outside the inflated map, so the real
  robot must stay within about that of the nominal) and e_theta = `tracking_heading` = 0.2 rad;
  R = diag(1 / u_max_j^2), u_max_j the bound of control j (the whole range may be used).
- reset_threshold in the cost's units: alpha / 2 by default. The nominal is kept only when the
  real state's best rollout is worse by half a colliding state or more (it foresees a collision
  that the nominal does not); goal-distance differences from noise (0.1 m of progress is 5 cost
  units over 51 states) never decide it.
"""

import numba
import numpy as np

from dcmppi.control.agents.dubins import Dubins, jacobian_terms
from dcmppi.control.kernels.dynamics import wrap_angle
from dcmppi.control.kernels.projection import bound
from dcmppi.control.planners.controller import shifted
from dcmppi.control.planners.diagnostics import TubeDiagnostics
from dcmppi.control.planners.mppi import MPPI, effective_sample_size, mppi_update
from dcmppi.control.planners.registry import register
from dcmppi.control.validation import finite, positive

MAX_DEVIATION = 1.0  # [m]
TRACKING_POSITION = 0.1  # [m] largest acceptable real-to-nominal position error (Bryson)
TRACKING_HEADING = 0.2  # [rad] largest acceptable heading error (Bryson)


def tvlqr_gains(A, B, Q, R, Qf):
    """Time-varying LQR gains for x_{i+1} = A_i x_i + B_i u_i, u_i = -K_i x_i (any A, B), by the
    Riccati backward pass in compiled loops of a fixed order (no BLAS, whose order follows the
    processor: the same gains on every machine).

    Args:
      A: (N, n, n), B: (N, n, m); Q, Qf: (n, n); R: (m, m) or a number (m = 1).
    Returns:
      K: (N, m, n).
    """
    A, B = np.asarray(A, dtype=float), np.asarray(B, dtype=float)
    R = np.atleast_2d(np.asarray(R, dtype=float))
    Q, Qf = np.asarray(Q, dtype=float), np.asarray(Qf, dtype=float)
    N, n, m = B.shape if B.ndim == 3 else (0, 0, 0)
    if B.ndim != 3 or A.shape != (N, n, n) or {Q.shape, Qf.shape} != {(n, n)} or R.shape != (m, m):
        raise ValueError(
            "tvlqr_gains needs A (N, n, n), B (N, n, m), Q and Qf (n, n), R (m, m); got "
            f"{A.shape}, {B.shape}, {Q.shape}, {Qf.shape}, {R.shape}"
        )
    K = _riccati(A, B, Q, R, Qf)
    if not np.isfinite(K).all():
        raise ValueError("tvlqr_gains: R + B^T P B is not positive definite (R must be)")
    return K


@numba.njit(inline="always")
def _product(X, Y, out, transpose_x):
    """out = X Y (X^T Y with transpose_x), each entry's sum in index order."""
    for r in range(out.shape[0]):
        for c in range(out.shape[1]):
            s = 0.0
            for t in range(Y.shape[0]):
                s += (X[t, r] if transpose_x else X[r, t]) * Y[t, c]
            out[r, c] = s


@numba.njit(cache=True, error_model="numpy")
def _riccati(A, B, Q, R, Qf):
    """tvlqr_gains' pass: P_N = Qf; K_i = (R + B^T P B)^-1 B^T P A (Cholesky), P = Q + A^T P A -
    (B^T P A)^T K_i, symmetrised."""
    N, n, m = B.shape
    P, K = Qf.copy(), np.empty((N, m, n))
    PA, PB, H, M, L = (np.empty((n, n)), np.empty((n, m)), np.empty((m, n)), np.empty((m, m)),
                       np.zeros((m, m)))  # fmt: skip
    APA, HK = np.empty((n, n)), np.empty((n, n))
    for i in range(N - 1, -1, -1):
        a, b, k = A[i], B[i], K[i]
        _product(P, a, PA, False)
        _product(b, PA, H, True)  # B^T P A (m, n)
        _product(P, b, PB, False)
        _product(b, PB, M, True)
        for r in range(m):
            for c in range(m):
                M[r, c] += R[r, c]
        for c in range(m):  # M = L L^T
            d = M[c, c]
            for t in range(c):
                d -= L[c, t] * L[c, t]
            L[c, c] = np.sqrt(d)
            for r in range(c + 1, m):
                e = M[r, c]
                for t in range(c):
                    e -= L[r, t] * L[c, t]
                L[r, c] = e / L[c, c]
        for col in range(n):  # k = L^-T L^-1 H, column by column
            for r in range(m):
                e = H[r, col]
                for t in range(r):
                    e -= L[r, t] * k[t, col]
                k[r, col] = e / L[r, r]
            for r in range(m - 1, -1, -1):
                e = k[r, col]
                for t in range(r + 1, m):
                    e -= L[t, r] * k[t, col]
                k[r, col] = e / L[r, r]
        _product(a, PA, APA, True)
        _product(H, k, HK, True)
        for r in range(n):
            for c in range(n):
                P[r, c] = Q[r, c] + APA[r, c] - HK[r, c]
        for r in range(n):
            for c in range(r + 1, n):
                P[r, c] = P[c, r] = 0.5 * (P[r, c] + P[c, r])
    return K


def gain_times(gain, error):
    """gain (m, n) or (n,) times error (n,), each sum in index order (no BLAS). Returns (m,)."""
    rows = np.atleast_2d(gain).tolist()
    return np.array(
        [sum((g * e for g, e in zip(row, error.tolist(), strict=True)), 0.0) for row in rows]
    )


@numba.njit(cache=True)
def dubins_lqr_gain(c0, c1, b0, b1, b2, q_pos, q_theta, r):
    """K_0 of tvlqr_gains for the Dubins Jacobians (jacobian_terms), in scalar arithmetic.

    Same Riccati backward pass as tvlqr_gains with Q = Q_N = diag(q_pos, q_pos, q_theta) and
    R = r, written out for A_i = I + c0_i e_x e_theta^T + c1_i e_y e_theta^T, B_i = (b0_i, b1_i,
    b2): the six entries of the symmetric P as scalars, no small numpy products. Equal to
    tvlqr_gains(...)[0] up to rounding.

    Args:
      c0, c1, b0, b1: (N,) Jacobian entries; b2: dt; q_pos, q_theta, r: weights.
    Returns:
      (3,) gain K_0.
    """
    p00, p01, p02, p11, p12, p22 = q_pos, 0.0, 0.0, q_pos, 0.0, q_theta
    g0 = g1 = g2 = 0.0
    den = 1.0
    for i in range(len(c0) - 1, -1, -1):
        e0, e1, f0, f1 = c0[i], c1[i], b0[i], b1[i]
        m02 = e0 * p00 + e1 * p01 + p02  # third column of P A
        m12 = e0 * p01 + e1 * p11 + p12
        m22 = e0 * p02 + e1 * p12 + p22
        g0 = f0 * p00 + f1 * p01 + b2 * p02  # B^T P A
        g1 = f0 * p01 + f1 * p11 + b2 * p12
        h2 = f0 * p02 + f1 * p12 + b2 * p22
        g2 = e0 * g0 + e1 * g1 + h2
        den = r + f0 * g0 + f1 * g1 + b2 * h2  # R + B^T P B
        # P <- Q + A^T P A - (B^T P A)^T (B^T P A) / den
        p00, p01, p02, p11, p12, p22 = (
            q_pos + p00 - g0 * g0 / den,
            p01 - g0 * g1 / den,
            m02 - g0 * g2 / den,
            q_pos + p11 - g1 * g1 / den,
            m12 - g1 * g2 / den,
            q_theta + e0 * m02 + e1 * m12 + m22 - g2 * g2 / den,
        )
    return np.array([g0, g1, g2]) / den


@register("tube")
class TubeMPPI(MPPI):
    """Tube-MPPI: a nominal and a real solve, LQR tracking of the nominal (module docstring).

    Extra args: reset_threshold (None: alpha / 2), max_deviation, tracking_position,
    tracking_heading."""

    own_params = ("reset_threshold", "max_deviation", "tracking_position", "tracking_heading")
    diagnostics_class = TubeDiagnostics

    def __init__(
        self,
        *,
        reset_threshold=None,
        max_deviation=MAX_DEVIATION,
        tracking_position=TRACKING_POSITION,
        tracking_heading=TRACKING_HEADING,
        **params,
    ):
        super().__init__(**params)
        t = 0.5 * self.alpha if reset_threshold is None else reset_threshold
        self.reset_threshold = finite("reset_threshold", t)
        self.max_deviation = positive("max_deviation", max_deviation)
        self.tracking_position = positive("tracking_position", tracking_position)
        self.tracking_heading = positive("tracking_heading", tracking_heading)
        q_pos, q_theta = tracking_position**-2, tracking_heading**-2
        self._Q = np.diag([q_pos, q_pos, q_theta])
        u_max = np.maximum(np.abs(self.agent.lower), np.abs(self.agent.upper))
        self._R = np.diag(1.0 / np.maximum(u_max, 1e-12) ** 2)

    def reset(self, seed=None):
        super().reset(seed)
        self.nominal = None

    def _solve(self, state):
        z = state.copy() if self.nominal is None else self.nominal
        deviation = float(np.hypot(state[0] - z[0], state[1] - z[1]))  # the last step's error
        timer = self.timer
        eps, states, J, S, reset = self._two_solves(z, state, deviation)
        if reset:
            z = state.copy()
        lam = self.temperature(S)  # the chosen solve's (S does not depend on it)
        with timer("update"):
            plan, w = mppi_update(self.U, eps, S, lam)
        if self.speed_mean != "vector":  # the samples' controls: U0 + their projected eps
            plan = self.mean_speeds(plan, self.U[:, :, None] + eps, w)
        plan = self.smoothed(plan)  # when it has a filter
        self.record(eps, states, J, S)
        d = self.diagnostics
        d.weights, d.ess, d.lambda_ = w, effective_sample_size(w), lam
        d.nominal_reset = bool(reset)
        d.nominal_deviation = deviation
        feedback = self._feedback(z, state, plan)
        action = bound(self.agent, plan[0] - feedback)
        d.nominal_state = z
        self.nominal = self.agent.step(z, plan[0], self.dt)
        self.U = shifted(plan)
        d.plan = plan
        return action

    def _two_solves(self, z, state, deviation):
        """Rollouts from the nominal state z and the real state with the same perturbations
        (this step's draw); deviation: |x - z| of the positions.

        Returns the perturbations that remain after projection (N, nu, K), the chosen solve's
        states (3, N + 1, K), J (K,), S (K,) and the reset flag. When z equals the real state
        (after every reset on a noise-free model) both solves are the same computation, so one
        batch of K rollouts stands for both. Otherwise one batch of 2K rollouts from the two
        start states (heading increments and sinc terms shared).
        """
        if z.tolist() == state.tolist():
            r = self.perturbed_rollouts(state)
            S = r.J + r.importance
            m = S.min()
            return r.e, r.states, r.J, S, bool(m < m + self.reset_threshold)
        K = self.K
        r = self.perturbed_rollouts(np.column_stack([z, state]), starts=2)
        J_nom, J_real = r.J[:K], r.J[K:]
        S_nom, S_real = J_nom + r.importance, J_real + r.importance
        reset = S_real.min() < S_nom.min() + self.reset_threshold or (
            deviation > self.max_deviation
        )
        if reset:
            return r.e, r.states[:, :, K:], J_real, S_real, reset
        return r.e, r.states[:, :, :K], J_nom, S_nom, reset

    def _feedback(self, z, state, plan):
        """K_0 (x - z) (nu,) of the time-varying LQR along the nominal plan (0 when x is z)."""
        if state.tolist() == z.tolist():  # z after a reset: what follows would give 0 too
            return np.zeros(self.nu)
        error = state - z
        error[2] = wrap_angle(error[2])
        if not error.any():  # K_0 @ 0 = 0: the gains are not needed
            return np.zeros(self.nu)
        if isinstance(self.agent, Dubins):  # the scalar Riccati pass of the Dubins Jacobians
            # Nominal headings: the running sum of the rollout's heading increments.
            omega = plan[:, 0]
            theta = np.cumsum(np.concatenate([[wrap_angle(z[2])], omega * self.dt]))
            c0, c1, b0, b1 = jacobian_terms(theta, omega, self.agent.v, self.dt)
            q_pos, q_theta, r = self._Q[0, 0], self._Q[2, 2], self._R[0, 0]
            gain = dubins_lqr_gain(c0, c1, b0, b1, self.dt, q_pos, q_theta, r)
            return gain_times(gain, error)
        nominal = self.agent.rollout_one(z, plan, self.dt)
        A, B = self.agent.jacobians(nominal, plan, self.dt)
        return gain_times(tvlqr_gains(A, B, self._Q, self._R, self._Q)[0], error)
