"""Baseline MPPI (paper Alg. 1) over an analytic agent model."""

import numba
import numpy as np

from dcmppi.control.kernels.libm import nan_min
from dcmppi.control.kernels.sums import pairwise, sum_of_squares, weighted_rows
from dcmppi.control.planners.controller import Controller
from dcmppi.control.planners.registry import register


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


def effective_sample_size(w):
    """1 / sum w^2 of normalised weights (the sum in dcmppi.control.kernels.sums' fixed order)."""
    return float(1.0 / sum_of_squares(np.ascontiguousarray(w, dtype=float)))


@register("mppi")
class MPPI(Controller):
    """Model Predictive Path Integral control, paper Alg. 1 (see Controller for parameters).

    Each step: sample K perturbations, roll out clip(U0 + eps), S = J + importance term,
    U = U0 + sum w eps (w at the step's lambda, Controller.temperature), apply U[0], shift U as
    the next warm start.
    """

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
