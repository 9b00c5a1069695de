"""Baseline MPPI (paper Alg. 1) over an analytic agent model, the base of the other planners.

The update's mean of a norm-bounded velocity (option speed_mean):
- "vector": the paper's U = U0 + sum_k w_k e_k. Its velocity is a weighted mean of samples inside
  the disc |v| <= v_max: samples that spread in direction average to a speed below the top one,
  so a plan that should go straight at full speed cannot reach it.
- "polar": each step's velocity keeps the vector mean's direction, at the weighted mean of the
  samples' speeds sum_k w_k |v_k| (at most v_max: feasible), so samples at the top speed in
  spread directions average to the top speed. Other controls keep the vector mean. It also
  drops the vector mean's slowing where the weighted samples disagree in direction (an
  obstacle ahead with ways round on both sides).
"""

import numba
import numpy as np

from dcmppi.control.kernels.libm import nan_min
from dcmppi.control.kernels.sums import pairwise, sum_of_squares, weighted_rows
from dcmppi.control.planners.controller import Controller
from dcmppi.control.planners.registry import register

SPEED_MEANS = ("vector", "polar")


def mppi_weights(S, lambda_):
    """Alg. 1 weights: w_k = exp(-(S_k - rho) / lambda) / eta with rho = min S. S: (K,).

    The values of numpy's np.exp((S.min() - S) / lambda_) divided by its np.sum: the exponents
    and the normalisation compiled (the sum in numpy's order, dcmppi.control.kernels.sums.pairwise),
    the exp numpy's own."""
    S = np.ascontiguousarray(S, dtype=float)
    if not len(S):
        raise ValueError("mppi_weights needs at least one cost")
    w = _exponents(S, float(lambda_))
    np.exp(w, out=w)
    _normalise(w)
    return w


@numba.njit(cache=True, error_model="numpy")
def _exponents(S, lambda_):
    """(min S - S) / lambda_ (K,); min S is nan when any S is (numpy's min)."""
    rho = nan_min(S)
    out = np.empty(len(S))
    for k in range(len(S)):
        out[k] = (rho - S[k]) / lambda_
    return out


@numba.njit(cache=True, error_model="numpy")
def _normalise(w):
    """w /= np.sum(w), in place."""
    total = pairwise(w)
    for k in range(len(w)):
        w[k] = w[k] / total


def mppi_update(U0, eps, S, lambda_):
    """Alg. 1: U = U0 + sum_k w_k eps_k (the sum in dcmppi.control.kernels.sums' fixed order).

    Args:
      U0: (N, nu) reference controls. eps: (N, nu, K) perturbations (time-major). S: (K,) costs.
    Returns:
      U (N, nu), weights (K,).
    """
    w = mppi_weights(S, lambda_)
    return weighted_rows(U0, eps, w), w


def speed_mean_param(value, agent):
    """One of SPEED_MEANS; "polar" only for an agent with a norm-bounded pair of controls (a
    ValueError names the fix otherwise)."""
    if value not in SPEED_MEANS:
        raise ValueError(f"speed_mean must be one of {SPEED_MEANS}; got {value!r}")
    if value == "polar" and (agent.norm_axes is None or len(agent.norm_axes) != 2):
        raise ValueError(
            f"speed_mean='polar' needs an agent with a norm-bounded velocity (holonomic); "
            f"agent {agent.name!r} has none: use speed_mean='vector'"
        )
    return value


def polar_means(U, u, w, axes, labels=None):
    """U (N, nu) (or (M, N, nu), one per cluster) with each step's velocity, controls `axes`
    (2,), scaled to the weighted mean speed of the samples u (N, nu, K) under weights w (K,)
    (with labels (K,): cluster m's samples, labels == m, each cluster's weights summing to 1).
    A zero velocity stays zero."""
    single = np.ndim(U) == 2
    U = np.array(U[None] if single else U, dtype=float)
    labels = np.zeros(len(w), dtype=np.intp) if labels is None else np.asarray(labels, np.intp)
    _scale_speeds(U, np.asarray(u, dtype=float), np.asarray(w, dtype=float), labels, *axes)
    return U[0] if single else U


@numba.njit(cache=True)
def _scale_speeds(U, u, w, labels, a, b):
    """polar_means in place on U (M, N, nu): one pass over the samples per step."""
    m, n = U.shape[0], U.shape[1]
    mean = np.zeros((m, n))
    for i in range(n):
        for k in range(len(w)):
            c = labels[k]
            if 0 <= c < m:
                mean[c, i] += w[k] * np.sqrt(u[i, a, k] ** 2 + u[i, b, k] ** 2)
    for c in range(m):
        for i in range(n):
            norm = np.sqrt(U[c, i, a] ** 2 + U[c, i, b] ** 2)
            scale = mean[c, i] / norm if norm > 0 else 0.0
            U[c, i, a] *= scale
            U[c, i, b] *= scale


def effective_sample_size(w):
    """1 / sum w^2 of normalised weights (the sum in dcmppi.control.kernels.sums' fixed order)."""
    return float(1.0 / sum_of_squares(np.ascontiguousarray(w, dtype=float)))


@register("mppi")
class MPPI(Controller):
    """Model Predictive Path Integral control, paper Alg. 1 (see Controller for parameters).

    Each step: sample K perturbations, roll out clip(U0 + eps), S = J + importance term,
    U = U0 + sum w eps (w at the step's lambda, Controller.temperature), apply U[0], shift U as
    the next warm start.

    Extra arg: speed_mean, how the update averages a norm-bounded velocity (module docstring):
    "vector" (the paper's, the default) or "polar" (holonomic agents).
    """

    own_params = ("speed_mean",)

    def __init__(self, *, speed_mean=None, **params):
        super().__init__(**params)
        self.speed_mean = speed_mean_param(
            self.option("speed_mean", speed_mean, "vector"), self.agent
        )

    def mean_speeds(self, U, u, w, labels=None):
        """The updates U (N, nu), or (M, N, nu) one per cluster of `labels` (K,), with
        speed_mean "polar" at the weighted mean speeds of the samples' controls u (N, nu, K)
        (weights w (K,), each cluster's summing to 1); U itself with "vector"."""
        if self.speed_mean == "vector":
            return U
        with self.timer("update"):
            return polar_means(U, u, w, self.agent.norm_axes, labels)

    def record(self, eps, states, J, S):
        d = self.diagnostics
        d.eps, d.states, d.J, d.S = eps.transpose(2, 0, 1), states.transpose(2, 1, 0), J, S
        d.warm_start = self.U

    def _solve(self, state):
        r = self.perturbed_rollouts(state)
        S = r.J + r.importance
        lam = self.temperature(S)
        with self.timer("update"):
            plan, w = mppi_update(self.U, r.e, S, lam)
        plan = self.mean_speeds(plan, r.u, w)
        self.record(r.e, r.states, r.J, S)
        d = self.diagnostics
        d.weights, d.ess, d.lambda_ = w, effective_sample_size(w), lam
        return self.finish(plan)
