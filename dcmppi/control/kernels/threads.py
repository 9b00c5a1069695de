"""A control step's per-sample work over threads: the K samples split into contiguous parts.

A part is a range j0:j1 of the samples. Its controls, rollouts, costs and importance terms
depend on its samples alone, and the kernels do the same arithmetic for every sample, so the
parts give the values of the whole batch, bit for bit: the part boundaries are multiples of
ALIGN samples, where the perturbation draws' streams begin (dcmppi.control.kernels.perturbations:
the draws are split the same way). The cross-sample work (the weights, the updates, DBSCAN) stays
on the calling thread, in its order. The compiled kernels release the GIL (numba's nogil), as
numpy's loops do.
"""

import functools
import os
import queue
import threading

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


# The workers: daemon threads that take parts from one queue. A bare queue.SimpleQueue (a C
# lock) hands a part over about four times faster than a ThreadPoolExecutor, with its Future and
# Condition per part (docs/performance.md).
_JOBS = queue.SimpleQueue()
_WORKERS = []
_STARTING = threading.Lock()


def _forget_workers():
    """In a forked child: the parent's workers do not exist there; start afresh."""
    global _JOBS, _STARTING
    _JOBS, _STARTING = queue.SimpleQueue(), threading.Lock()
    _WORKERS.clear()


os.register_at_fork(after_in_child=_forget_workers)


def _work():
    while True:
        fn, j0, j1, done, i = _JOBS.get()
        try:
            done.put((i, fn(j0, j1), None))
        except BaseException as error:  # handed to the caller, which raises it
            done.put((i, None, error))


def _start_workers(n):
    """At least n workers, started once (they idle between steps)."""
    with _STARTING:
        while len(_WORKERS) < n:
            worker = threading.Thread(target=_work, name=f"dcmppi-{len(_WORKERS)}", daemon=True)
            worker.start()
            _WORKERS.append(worker)


def run(fn, ranges):
    """[fn(j0, j1) for (j0, j1) in ranges]: the first on this thread, the others on the workers
    at the same time. Returns when every part is done (none is still writing), raising the
    first part's error, else the first that a worker reports."""
    if len(ranges) == 1:
        return [fn(*ranges[0])]
    _start_workers(len(ranges) - 1)
    done = queue.SimpleQueue()
    for i, (j0, j1) in enumerate(ranges[1:], 1):
        _JOBS.put((fn, j0, j1, done, i))
    results, error = [None] * len(ranges), None
    try:
        results[0] = fn(*ranges[0])
    except BaseException as raised:
        error = raised
    for _ in ranges[1:]:
        i, value, failed = done.get()
        results[i] = value
        if error is None:
            error = failed
    if error is not None:
        raise error
    return results


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
