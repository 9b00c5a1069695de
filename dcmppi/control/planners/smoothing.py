"""The plan's post-processing, off by default (the paper's algorithms) and on with
`preset="smooth"` (dcmppi.control.defaults.PRESETS, docs/design.md): every planner's filter of
the plan (PlanFilter) and the clustered planners' choice of cluster with hysteresis (Hysteresis).

- filter: the plan's rows smoothed by the Savitzky-Golay filter of a window and polynomial order
  (nav2's MPPI: 9 and 2), the window's first half reaching back over the controls applied at
  the last steps (the plan's first row at an episode's start), its last half past the plan's
  end over the last row repeated; then projected into the agent's bounds. The filtered plan is
  both applied (its first row) and the next step's warm start (shifted).
- hysteresis: the candidate that continues the warm start (continuing) is kept unless another's
  noise-free cost J is lower by more than a margin.
"""

import collections
from fractions import Fraction

import numba
import numpy as np

from dcmppi.control.kernels.projection import bound_rows
from dcmppi.control.validation import positive


class PlanFilter:
    """The Savitzky-Golay filter of a plan (N, nu), the controls applied at the last steps
    before it, projected into the agent's bounds.

    Args: agent; window: 0 (no filter: the plan passes unchanged) or odd >= 3; order: of the
    polynomial, 0 <= order < window. A ValueError names a bad window or order.
    """

    def __init__(self, agent, window, order):
        self.agent = agent
        self.window, self.order = filter_params(window, order)
        self.coefficients = filter_coefficients(self.window, self.order) if self.window else None
        self.reset()

    def reset(self):
        """Forget the applied controls (a new episode)."""
        self.applied = collections.deque(maxlen=max(1, self.window // 2))

    def record(self, u):
        """Keep the control u (nu,) applied at this step (the next steps' windows reach it)."""
        self.applied.append(u)

    def __call__(self, plan):
        """The plan (N, nu) filtered and bounded (N, nu); the plan itself without a filter."""
        if not self.window:
            return plan
        history = np.array(self.applied).reshape(-1, self.agent.nu)
        return bound_rows(self.agent, savitzky_golay(plan, history, self.coefficients))


def filter_params(window, order):
    """(window, order) as ints: a window 0 (no filter) or odd >= 3, an order 0 <= order <
    window; a ValueError naming filter_window or filter_order for anything else."""
    window = positive("filter_window", window, integer=True, allow_zero=True)
    order = positive("filter_order", order, integer=True, allow_zero=True)
    if window and (window < 3 or window % 2 == 0):
        raise ValueError(f"filter_window must be 0 (no filter) or odd and >= 3; got {window}")
    if window and order >= window:
        raise ValueError(f"filter_order must be below filter_window ({window}); got {order}")
    return window, order


def filter_coefficients(window, order):
    """The Savitzky-Golay smoothing coefficients (window,) of the centre point (symmetric): the
    value at 0 of the least-squares polynomial of degree `order` through the points x = -h..h
    (h = window // 2), c_j = sum_k y_k x_j^k for (A^T A) y = e_0, A_jk = x_j^k. Solved in exact
    fractions (the same floats on every machine; scipy.signal.savgol_coeffs' up to rounding)."""
    half = window // 2
    xs = range(-half, half + 1)
    m = order + 1
    rows = [[Fraction(sum(x ** (a + b) for x in xs)) for b in range(m)] + [Fraction(a == 0)]
            for a in range(m)]  # fmt: skip
    for col in range(m):  # Gauss-Jordan on the (symmetric positive definite) normal equations
        pivot = next(r for r in range(col, m) if rows[r][col] != 0)
        rows[col], rows[pivot] = rows[pivot], rows[col]
        head = rows[col][col]
        rows[col] = [v / head for v in rows[col]]
        for r in range(m):
            if r != col and rows[r][col] != 0:
                factor = rows[r][col]
                rows[r] = [v - factor * w for v, w in zip(rows[r], rows[col], strict=True)]
    y = [rows[k][m] for k in range(m)]
    return np.array([float(sum(y[k] * x**k for k in range(m))) for x in xs])


def savitzky_golay(plan, history, coefficients):
    """The plan (N, nu) filtered along its steps by the symmetric `coefficients` (window,).

    history: (H, nu) the controls applied before the plan's first row, oldest first (H >= 0);
    the window's half before the plan takes its last rows, repeating the oldest (or the plan's
    first row when H = 0) where there are too few; the half past the plan's end repeats its last
    row. Returns (N, nu): row i is sum_j coefficients[j] padded[i + j], summed in order of j.
    """
    plan = np.ascontiguousarray(plan, dtype=float)
    history = np.ascontiguousarray(history, dtype=float).reshape(-1, plan.shape[1])
    return _filter(plan, history, np.ascontiguousarray(coefficients, dtype=float))


@numba.njit(cache=True)
def _filter(plan, history, coefficients):
    """savitzky_golay's rows, the padded sequence read in place."""
    n, nu = plan.shape
    half = len(coefficients) // 2
    h = min(len(history), half)
    out = np.zeros((n, nu))
    for i in range(n):
        for j in range(len(coefficients)):
            t = i + j - half  # the padded row's step: < 0 in the history, >= n past the end
            for c in range(nu):
                if t >= n:
                    v = plan[n - 1, c]
                elif t >= 0:
                    v = plan[t, c]
                elif h == 0:
                    v = plan[0, c]
                else:
                    v = history[len(history) + max(t, -h), c]
                out[i, c] += coefficients[j] * v
    return out


def continuing(U, U0, Sigma):
    """The index of the candidate sequence among U (M, N, nu) that continues the warm start
    U0 (N, nu): the least sum over steps and controls of (U_m - U0)^2 / Sigma, the nearest in
    sampling variances (every candidate is U0 plus a weighted mean of its samples'
    perturbations, so this is the cluster whose perturbations average nearest to none)."""
    gap = (np.asarray(U) - np.asarray(U0)[None]) ** 2 / np.asarray(Sigma)
    return int(np.argmin(gap.sum(axis=(1, 2))))


class Hysteresis:
    """The clustered planners' choice among candidate sequences: the one that continues the warm
    start (continuing) unless another's noise-free cost J is lower by more than `margin`, then
    the least J; margin 0: the least J. Sigma: (nu,) the sampling variances."""

    def __init__(self, margin, Sigma):
        self.margin, self.Sigma = margin, Sigma

    def __call__(self, J, U, U0):
        """(chosen, continuing) among the candidates U (M, N, nu) of costs J (M,), for the warm
        start U0 (N, nu); continuing is -1 with margin 0."""
        best = int(np.argmin(J))
        if not self.margin:
            return best, -1
        kept = continuing(U, U0, self.Sigma)
        return (kept if J[kept] <= J[best] + self.margin else best), kept
