"""The temperature chosen each step (`lambda_="auto"`): the Alg. 1 weights
w_k = exp(-(S_k - min S) / lambda) / eta keep an effective sample size 1 / sum w^2 near
ess_target x K.

S is the cost with the importance term at lambda = 1, S_k = J_k + gamma q_k
(q_k = sum_i u_i^T Sigma^-1 eps_ik): "auto" divides the whole of S by the step's lambda, so the
balance of cost and importance term is that of lambda = 1 and only the spread of the weights
changes. ESS(lambda) then rises monotonically from the number of ties of min S (lambda -> 0) to
K (lambda -> infinity), so every target is reached and its lambda is unique (with more ties of
min S than the target, the smallest lambda tried). Dividing by lambda inside the importance term
as well (S = J + gamma lambda q, weights exp(-J / lambda - gamma q)) would leave a factor
exp(-gamma q) that no lambda changes: with the holonomic crowd's q (mixed perturbations, a
spread of tens of units at gamma = 1) the ESS stays near 1 for every lambda, and ESS(lambda) has
several peaks.

lambda is at most alpha / COLLISION_NATS (alpha: the static collision weight, also the frozen
obstacles'): a rollout with one more colliding state always weighs e^-10 or less of an otherwise
equal one. Without that bound, where fewer than ess_target x K samples are free of collisions
(a 6 m corridor between walls), the target is met by averaging colliding samples in.

The search: safeguarded Newton (bisection when a step leaves the bracket) on
g(t) = log ESS(e^t) - log(ess_target K) with the analytic slope
dg/dt = 2 beta (E_w[S] - E_{w^2}[S]) (beta = 1 / lambda; E_{w^2}: under weights proportional to
w^2), until ESS is within ESS_BAND of the target or the bracket on log lambda is narrower than
LOG_LAMBDA_TOL. One compiled pass over the K samples per iteration, with an exp of its own
(pure arithmetic, so the loop vectorises; relative error 3e-10) and its sums by halving (one
order on every processor); the plan's weights still come from np.exp in mppi_weights.
"""

import math

import numba
import numpy as np

from dcmppi.control.kernels.sums import halve
from dcmppi.control.validation import positive

AUTO = "auto"  # lambda_ chosen each step

# Default share of K: about the ESS of the static forest at lambda = 1, where the paper's
# table is reproduced, and below the 16 % of the samples in one DBSCAN ball (one mode).
ESS_TARGET = 0.1
ESS_BAND = 0.1  # the search stops within this relative distance of the target ESS
LOG_LAMBDA_TOL = 0.05  # ... or when the bracket on log lambda is this narrow
# The bracket on log lambda around log(max S - min S): below it, differences at S's rounding
# (1e-16 relative) decide the weights; above it (lambda = 40 (max S - min S)), every weight is
# within e^(-1/40) of the largest.
BRACKET_LOW = 40.0
BRACKET_HIGH = math.log(40.0)
MAX_ITERATIONS = 60
COLLISION_NATS = 10.0  # lambda <= alpha / COLLISION_NATS

LOG2E = 1.4426950408889634
LN2_HI = 0.6931471803691238  # ln 2 in two parts (Cody and Waite): n ln 2 exact for |n| < 2^20
LN2_LO = 1.9082149292705877e-10
EXP_TAYLOR = (1.0 / 5040.0, 1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0)


def temperature_param(value):
    """lambda_ as a float, or "auto"; a ValueError for anything else."""
    if isinstance(value, str) and value == AUTO:
        return AUTO
    try:
        return positive("lambda_", value)
    except ValueError:
        raise ValueError(f"lambda_ must be a number > 0 or 'auto'; got {value!r}") from None


def choose_lambda(S, ess_target, guess=None, largest=math.inf):
    """The step's lambda: ESS of exp(-(S - min S) / lambda) within ESS_BAND of ess_target x K
    (at least 1 sample), or `largest` where that is smaller.

    Args:
      S: (K,) costs. ess_target: share of K in (0, 1]. guess: a lambda > 0 to start the search
        from (the last step's), or None. largest: the bound on lambda (alpha / COLLISION_NATS).
    Returns:
      lambda > 0 (1.0 when all S are equal: the weights do not depend on lambda then).
    """
    S = np.ascontiguousarray(S, dtype=float)
    if S.ndim != 1 or not len(S):
        raise ValueError(f"choose_lambda needs S of shape (K,), K >= 1; got {S.shape}")
    target = max(ess_target * len(S), 1.0)
    lam = _choose(S, math.log(target), -1.0 if guess is None else float(guess))
    if not lam > 0.0:
        raise ValueError("choose_lambda needs finite costs S; got inf or nan")
    return min(lam, largest)


@numba.njit(cache=True)
def _choose(S, log_target, guess):
    """choose_lambda's search; guess <= 0: none (start from the mean of S - min S). nan when S
    is not finite."""
    low, high, total = np.inf, -np.inf, 0.0
    for k in range(len(S)):
        low = min(low, S[k])
        high = max(high, S[k])
        total += S[k]
    if not math.isfinite(total):
        return np.nan
    if high == low:
        return 1.0
    spread = math.log(high - low)
    lo, hi = spread - BRACKET_LOW, spread + BRACKET_HIGH
    t = math.log(total / len(S) - low) if total / len(S) > low else spread
    if guess > 0.0 and lo < math.log(guess) < hi:
        t = math.log(guess)
    best_t, best_g = t, np.inf
    tol = math.log1p(ESS_BAND)
    for _ in range(MAX_ITERATIONS):
        g, slope = _log_ess(S, low, math.exp(-t))
        g -= log_target
        if abs(g) < best_g:
            best_t, best_g = t, abs(g)
        if abs(g) <= tol:
            break
        if g > 0.0:
            hi = t
        else:
            lo = t
        if hi - lo < LOG_LAMBDA_TOL:
            break
        t_next = t - g / slope if slope > 0.0 else lo  # Newton; no slope: bisection
        t = t_next if lo < t_next < hi else 0.5 * (lo + hi)
    return math.exp(best_t)


@numba.njit(cache=True)
def _log_ess(S, low, beta):
    """log ESS of the weights exp(-beta (S - low)) (S (K,) >= low) and its slope
    d/d log lambda = 2 beta (E_w[S] - E_{w^2}[S]).

    exp(x) = 2^n exp(f), |f| <= ln 2 / 2: exp(f) by its Taylor polynomial of degree 8, 2^n from
    the exponent bits; x below -300 counts as -300 (its square stays a normal number, beside the
    least cost's weight 1). The terms in one pass that vectorises, their four sums by halving
    (dcmppi.control.kernels.sums.halve): one order on every processor.
    """
    k = len(S)
    terms = np.empty((4, k))  # w, w^2, w S, w^2 S
    t0, t1, t2, t3 = terms[0], terms[1], terms[2], terms[3]
    for j in range(k):
        x = max(beta * (low - S[j]), -300.0)
        n = math.floor(x * LOG2E + 0.5)
        f = x - n * LN2_HI - n * LN2_LO
        p = 1.0 / 40320.0
        for c in EXP_TAYLOR:
            p = p * f + c
        w = p * np.int64((np.int64(n) + 1023) << 52).view(np.float64)
        ww = w * w
        t0[j] = w
        t1[j] = ww
        t2[j] = w * S[j]
        t3[j] = ww * S[j]
    s0, s1, s2, s3 = halve(t0, k), halve(t1, k), halve(t2, k), halve(t3, k)
    return 2.0 * math.log(s0) - math.log(s1), 2.0 * beta * (s2 / s0 - s3 / s1)
