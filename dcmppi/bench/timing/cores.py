"""What threads can gain on this machine: one kernel on T threads at once against one thread.

Three kernels bound a split over samples (dcmppi.control.kernels.threads) from above: scalar
multiply-adds in registers (`compute`), vector multiply-adds over an array in L1 (`vector`:
the throughput of a core's vector units, as the controllers' vectorised loops use them), and a
stream of arrays larger than a core's L2 cache (`stream`), as a controller's step streams its
controls and states at K = 2048, N = 100. Where two of the machine's CPUs are one core's two
hardware threads, they share its vector units: `vector` then gains about 1 x while `compute`
still gains nearly 2 x. On a machine whose cores share their L3 cache and memory bandwidth
`stream` gains less. A step's gain from `threads` lies near the three, by its share of each
(docs/performance.md).
"""

import threading
import time

import numba
import numpy as np

STREAM_BYTES = 4 * 2**20  # per thread, read and written: beyond L2, within a shared L3
VECTOR_SIZE = 512  # float64 values, 4 KB: in L1
REPEATS = 7


@numba.njit(nogil=True, cache=True)
def compute(n):
    """n rounds of eight independent multiply-adds, in registers; returns their sum."""
    a0, a1, a2, a3 = 1.0, 1.001, 1.002, 1.003
    a4, a5, a6, a7 = 1.004, 1.005, 1.006, 1.007
    for _ in range(n):
        a0, a1, a2, a3 = (
            a0 * 0.9999999 + 1e-7,
            a1 * 0.9999999 + 1e-7,
            a2 * 0.9999999 + 1e-7,
            a3 * 0.9999999 + 1e-7,
        )
        a4, a5, a6, a7 = (
            a4 * 0.9999999 + 1e-7,
            a5 * 0.9999999 + 1e-7,
            a6 * 0.9999999 + 1e-7,
            a7 * 0.9999999 + 1e-7,
        )
    return a0 + a1 + a2 + a3 + a4 + a5 + a6 + a7


@numba.njit(nogil=True, cache=True)
def vector(rounds):
    """rounds passes of y = 0.9999999 y + 1e-7 over VECTOR_SIZE values that stay in L1, which
    the compiler vectorises; returns their sum."""
    y = np.ones(VECTOR_SIZE)
    for _ in range(rounds):
        for i in range(VECTOR_SIZE):
            y[i] = y[i] * 0.9999999 + 1e-7
    return y.sum()


@numba.njit(nogil=True, cache=True)
def stream(x, y, rounds):
    """rounds passes of y = 0.5 x + 1 over the arrays; returns y[0]."""
    for _ in range(rounds):
        for i in range(x.size):
            y[i] = 0.5 * x[i] + 1.0
    return y[0]


def _at_once(fn, args):
    """Seconds until fn(*a) has returned for every a of args, each on a thread of its own."""
    workers = [threading.Thread(target=fn, args=a) for a in args]
    t0 = time.perf_counter()
    for w in workers:
        w.start()
    for w in workers:
        w.join()
    return time.perf_counter() - t0


def _gain(fn, args):
    """len(args) x the median seconds of one call alone over those of all calls at once."""
    fn(*args[0])  # compiled and warm
    alone, together = [], []
    for _ in range(REPEATS):
        alone.append(_at_once(fn, args[:1]))
        together.append(_at_once(fn, args))
    return len(args) * float(np.median(alone) / np.median(together))


def machine_gains(threads):
    """{"threads": T, "compute": gain, "vector": gain, "stream": gain}: the work of T threads
    at once over their time, in units of one thread's rate, for `compute`, `vector` and
    `stream` over STREAM_BYTES per thread."""
    n = STREAM_BYTES // 16
    arrays = [(np.ones(n), np.empty(n), 80 * 2**20 // STREAM_BYTES) for _ in range(threads)]
    return {
        "threads": threads,
        "compute": _gain(compute, [(10_000_000,)] * threads),
        "vector": _gain(vector, [(100_000,)] * threads),
        "stream": _gain(stream, arrays),
    }
