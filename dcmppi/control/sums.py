"""The planners' sums over samples and steps, compiled in a fixed order.

BLAS's products sum in an order that follows the processor's kernel family (OpenBLAS picks
Haswell, SkylakeX, Zen, ... kernels at run time), so plans made with them differ in their last
bits from one machine to another. These loops fix the order in their source:
- `weighted_rows`: U0 + sum_k w_k eps_k (Alg. 1's update), each row's sum over k in LANES
  interleaved partial sums (lane l takes k = l, l + LANES, ..; the tail's k in order into a sum
  of its own) added as ((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7)) + tail: each lane is its
  own chain, so the loop vectorises without reassociation; the rows split over threads;
- `importance`: sum_c w_c sum_i U0[i, c] e[i, c, k] with i in order, per sample k (the draws'
  pass accumulates the same sums, dcmppi.control.perturbations.draw_box).
No fused multiply-add (numba compiles without fast-math): the same values on every machine and
for every number of threads (tests).
"""

import numba
import numpy as np

from .threads import parts, run

LANES = 8


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _weighted_rows(U0, eps, w, out, r0, r1):
    """out[r] = U0[r] + sum_k w[k] eps[r, k] for the rows r0:r1 of eps (R, K)."""
    k = eps.shape[1]
    whole = k - k % LANES
    for r in range(r0, r1):
        row = eps[r]
        s0 = s1 = s2 = s3 = s4 = s5 = s6 = s7 = 0.0
        for j in range(0, whole, LANES):
            s0 += w[j] * row[j]
            s1 += w[j + 1] * row[j + 1]
            s2 += w[j + 2] * row[j + 2]
            s3 += w[j + 3] * row[j + 3]
            s4 += w[j + 4] * row[j + 4]
            s5 += w[j + 5] * row[j + 5]
            s6 += w[j + 6] * row[j + 6]
            s7 += w[j + 7] * row[j + 7]
        tail = 0.0
        for j in range(whole, k):
            tail += w[j] * row[j]
        out[r] = U0[r] + ((((s0 + s1) + (s2 + s3)) + ((s4 + s5) + (s6 + s7))) + tail)


def weighted_rows(U0, eps, w, threads=1):
    """U0 + sum_k w_k eps[..., k] in the fixed order above, its rows split over `threads`.

    Args:
      U0: (N, nu). eps: (N, nu, K). w: (K,).
    Returns:
      (N, nu).
    """
    n, nu, k = eps.shape
    if np.shape(U0) != (n, nu) or np.shape(w) != (k,):
        raise ValueError(
            f"weighted_rows needs U0 (N, nu) and w (K,) for eps (N, nu, K) = {eps.shape}; got "
            f"{np.shape(U0)} and {np.shape(w)}"
        )
    flat = np.reshape(eps, (n * nu, k))
    u0 = np.ascontiguousarray(U0, dtype=float).reshape(n * nu)
    w = np.ascontiguousarray(w, dtype=float)
    out = np.empty(n * nu)
    run(lambda r0, r1: _weighted_rows(u0, flat, w, out, r0, r1), parts(n * nu, threads))
    return out.reshape(n, nu)


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _accumulate(U0, e, acc):
    """acc[c, k] += sum_i U0[i, c] e[i, c, k], i in order. e: (N, nu, k); acc: (nu, k)."""
    for i in range(e.shape[0]):
        for c in range(e.shape[1]):
            a, row, u = acc[c], e[i, c], U0[i, c]
            for j in range(len(a)):
                a[j] += u * row[j]


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _combine(acc, weight, out):
    """out[k] = sum_c weight[c] acc[c, k], c in order."""
    for j in range(len(out)):
        out[j] = weight[0] * acc[0, j]
    for c in range(1, acc.shape[0]):
        for j in range(len(out)):
            out[j] += weight[c] * acc[c, j]


def importance(U0, e, weight):
    """gamma lambda sum_i u_i^T Sigma^-1 e_i per sample: sum_c weight[c] sum_i U0[i, c] e[i, c]
    (weight = gamma lambda / Sigma), the sum over i in order.

    Args:
      U0: (N, nu). e: (N, nu, K) (a view of columns of a larger array too). weight: (nu,).
    Returns:
      (K,).
    """
    acc = np.zeros((e.shape[1], e.shape[2]))
    _accumulate(np.ascontiguousarray(U0, dtype=float), e, acc)
    return importance_of(acc, weight)


def importance_of(acc, weight):
    """importance's value from its sums over i, acc[c, k] = sum_i U0[i, c] e[i, c, k] (nu, K)
    (a view of columns too), as a pass that bounds the perturbations accumulates them
    (dcmppi.control.perturbations.draw_box). Returns (K,)."""
    out = np.empty(acc.shape[1])
    _combine(acc, np.asarray(weight, dtype=float), out)
    return out
