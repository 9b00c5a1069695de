"""A control step's per-sample work over threads: the K samples split into contiguous parts.

A part is a range j0:j1 of the samples. Its controls, rollouts, costs and importance terms
depend on its samples alone, and the kernels do the same arithmetic for every sample, so the
parts give the values of the whole batch, bit for bit: the part boundaries are multiples of
ALIGN samples, where the perturbation draws' streams begin (dcmppi.control.perturbations: the
draws are split the same way). The cross-sample work (the weights, the updates, DBSCAN) stays
on the calling thread, in its order. The compiled kernels release the GIL (numba's nogil), as
numpy's loops do.
"""

import concurrent.futures
import functools

from numba import types
from numba.extending import overload

ALIGN = 64  # samples: whole cache lines per part


@functools.cache
def parts(k, threads):
    """At most `threads` ranges (j0, j1) that cover 0..k in order, the boundaries at multiples
    of ALIGN (one range when k <= ALIGN)."""
    size = -(-k // threads)
    size = -(-size // ALIGN) * ALIGN
    return tuple((j, min(j + size, k)) for j in range(0, k, size))


@functools.cache
def _pool(workers):
    """One pool per number of workers, shared by the controllers (its threads idle between
    steps)."""
    return concurrent.futures.ThreadPoolExecutor(workers, thread_name_prefix="dcmppi")


def run(fn, ranges):
    """[fn(j0, j1) for (j0, j1) in ranges]: the first on this thread, the others on a pool's
    threads at the same time."""
    if len(ranges) == 1:
        return [fn(*ranges[0])]
    futures = [_pool(len(ranges) - 1).submit(fn, *r) for r in ranges[1:]]
    try:
        first = fn(*ranges[0])
    finally:
        concurrent.futures.wait(futures)  # no part is still writing when this returns or raises
    return [first, *(f.result() for f in futures)]


def in_cols(row, cols):
    """The columns cols = (j0, j1) of a 1-D row, or the whole row for None. Compiled kernels
    call it: for None it is the row itself, with no slice to compute (a slice per row costs a
    few percent of a kernel)."""
    return row if cols is None else row[cols[0] : cols[1]]


def n_cols(n, cols):
    """The number of columns of a row of n in cols (in_cols)."""
    return n if cols is None else cols[1] - cols[0]


@overload(in_cols, inline="always")
def _in_cols(row, cols):
    if isinstance(cols, types.NoneType):
        return lambda row, cols: row
    return lambda row, cols: row[cols[0] : cols[1]]


@overload(n_cols, inline="always")
def _n_cols(n, cols):
    if isinstance(cols, types.NoneType):
        return lambda n, cols: n
    return lambda n, cols: cols[1] - cols[0]
