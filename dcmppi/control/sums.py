"""The planners' sums over samples and steps, compiled in a fixed order.

BLAS's products sum in an order that follows the processor's kernel family (OpenBLAS picks
Haswell, SkylakeX, Zen, ... kernels at run time), so plans made with them differ in their last
bits from one machine to another. These loops fix the order in their source:
- `weighted_rows`: U0 + sum_k w_k eps_k (Alg. 1's update), each row's sum by halving, the
  upper half added to the lower half until one term remains: every pass is a loop over
  contiguous memory that vectorises as written, where a sum in index order would not vectorise
  and a reassociated one would take the order of the processor's vector width (on the calling
  thread: handing rows to a second thread costs these VMs about as long as the whole sum,
  docs/performance.md);
- `importance`: sum_c w_c sum_i U0[i, c] e[i, c, k] with i in order, per sample k (the draws'
  pass accumulates the same sums, dcmppi.control.perturbations.draw_box).
No fused multiply-add (numba compiles without fast-math): the same values on every machine, and
for every split of the samples over threads (tests). `halve` is the halving sum itself (the
temperature search's sums, dcmppi.control.temperature).
"""

import numba
import numpy as np


@numba.njit(inline="always")
def halve(p, n):
    """sum(p[:n]) by halving, in place: with h = n // 2, p_i += p_(n - h + i) for i < h, then
    n -= h, until n = 1 (an odd n keeps its middle term for the next pass). 0.0 for n = 0."""
    while n > 1:
        half = n // 2
        a, b = p[:half], p[n - half : n]
        for i in range(half):
            a[i] = a[i] + b[i]
        n -= half
    return p[0] if n else 0.0


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _weighted_rows(U0, eps, w, out):
    """out[r] = U0[r] + sum_k w[k] eps[r, k] for every row of eps (R, K), each sum by `halve`,
    its first pass on the products (w_i eps_i + w_(m + i) eps_(m + i), m = K - K // 2)."""
    k = eps.shape[1]
    p = np.empty(k)
    h = k // 2
    m = k - h
    w_low, w_high = w[:h], w[m:]
    for r in range(eps.shape[0]):
        row = eps[r]
        low, high, first = row[:h], row[m:], p[:h]
        for i in range(h):
            first[i] = w_low[i] * low[i] + w_high[i] * high[i]
        if m > h:
            p[h] = w[h] * row[h]
        out[r] = U0[r] + halve(p, m)


def weighted_rows(U0, eps, w):
    """U0 + sum_k w_k eps[..., k] in the fixed order above.

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
    out = np.empty(n * nu)
    _weighted_rows(
        np.ascontiguousarray(U0, dtype=float).reshape(n * nu),
        np.reshape(eps, (n * nu, k)),
        np.ascontiguousarray(w, dtype=float),
        out,
    )
    return out.reshape(n, nu)


@numba.njit(cache=True)
def sum_of_squares(w):
    """sum w_k^2 of a (K,) array by `halve` (the values of weighted_rows(0, w, w))."""
    p = w * w
    return halve(p, len(p))


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
    n, nu, k = e.shape
    if np.shape(U0) != (n, nu) or np.shape(weight) != (nu,):
        raise ValueError(
            f"importance needs U0 (N, nu) and weight (nu,) for e (N, nu, K) = {e.shape}; got "
            f"{np.shape(U0)} and {np.shape(weight)}"
        )
    acc = np.zeros((nu, k))
    _accumulate(np.ascontiguousarray(U0, dtype=float), e, acc)
    return importance_of(acc, weight)


def importance_of(acc, weight):
    """importance's value from its sums over i, acc[c, k] = sum_i U0[i, c] e[i, c, k] (nu, K)
    (a view of columns too), as a pass that bounds the perturbations accumulates them
    (dcmppi.control.perturbations.draw_box). Returns (K,)."""
    out = np.empty(acc.shape[1])
    _combine(acc, np.asarray(weight, dtype=float), out)
    return out
