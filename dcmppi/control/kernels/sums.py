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
  pass accumulates the same sums, dcmppi.control.kernels.perturbations.draw_box);
- `pairwise`: numpy's own order for np.sum of a contiguous float64 array (numpy's pairwise
  summation), so that the compiled weights (dcmppi.control.planners.mppi) keep the values of numpy's
  expression they replaced.
No fused multiply-add (numba compiles without fast-math): the same values on every machine, and
for every split of the samples over threads (tests). `halve` is the halving sum itself (the
temperature search's sums, dcmppi.control.planners.temperature).
"""

import numba
import numpy as np

PAIRWISE_BLOCK = 128  # numpy's PW_BLOCKSIZE
_STACK = 200  # pairwise's runs: over twice the halvings of any array that fits in memory


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
def pairwise(p):
    """np.sum(p) of a contiguous float64 (n,) in numpy's order (pairwise_sum in numpy's
    _core/src/umath/loops_utils.h.src): a run of n <= PAIRWISE_BLOCK terms is summed by
    `_block`; a longer one is the sum of its two halves, the first n // 2 rounded down to a
    multiple of 8 long. The halves are walked here with a stack, left before right."""
    runs = np.empty((_STACK, 3), dtype=np.int64)  # start, length, 1: add the last two sums
    sums = np.empty(_STACK)
    runs[0, 0], runs[0, 1], runs[0, 2] = 0, len(p), 0
    top, count = 1, 0
    while top:
        top -= 1
        lo, n, join = runs[top, 0], runs[top, 1], runs[top, 2]
        if join:
            count -= 1
            sums[count - 1] = sums[count - 1] + sums[count]
        elif n <= PAIRWISE_BLOCK:
            sums[count] = _block(p, lo, n)
            count += 1
        else:
            half = n // 2
            half -= half % 8
            runs[top, 2] = 1  # after both halves
            runs[top + 1, 0], runs[top + 1, 1], runs[top + 1, 2] = lo + half, n - half, 0
            runs[top + 2, 0], runs[top + 2, 1], runs[top + 2, 2] = lo, half, 0
            top += 3
    return sums[0]


@numba.njit(inline="always")
def _block(p, lo, n):
    """numpy's sum of p[lo:lo + n], n <= PAIRWISE_BLOCK: fewer than 8 terms added in order to
    0.0; else eight running sums of every eighth term, joined as ((r0 + r1) + (r2 + r3)) +
    ((r4 + r5) + (r6 + r7)), then the terms left over in order."""
    if n < 8:
        total = 0.0
        for i in range(lo, lo + n):
            total += p[i]
        return total
    r0, r1, r2, r3 = p[lo], p[lo + 1], p[lo + 2], p[lo + 3]
    r4, r5, r6, r7 = p[lo + 4], p[lo + 5], p[lo + 6], p[lo + 7]
    end = lo + n - n % 8
    for i in range(lo + 8, end, 8):
        r0, r1, r2, r3 = r0 + p[i], r1 + p[i + 1], r2 + p[i + 2], r3 + p[i + 3]
        r4, r5, r6, r7 = r4 + p[i + 4], r5 + p[i + 5], r6 + p[i + 6], r7 + p[i + 7]
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(end, lo + n):
        total += p[i]
    return total


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
    (dcmppi.control.kernels.perturbations.draw_box). Returns (K,)."""
    out = np.empty(acc.shape[1])
    _combine(acc, np.asarray(weight, dtype=float), out)
    return out
