"""`dcmppi timing --fingerprint`: the sha1 of every closed loop's actions.

A change that keeps every plan bit-identical prints the same hashes (docs/performance.md) on
one machine; another machine's kernels (numpy's SIMD level, the BLAS's), printed with them, may
give other hashes at the same code.
"""

import hashlib

import numpy as np
from threadpoolctl import threadpool_limits

from dcmppi.bench.timing.loop import ClosedLoop


def fingerprint(cases, steps):
    """Rows {case, problem, params, sha1}: the sha1 of each case's actions (steps, nu) as float64
    bytes over `steps` closed-loop steps."""
    rows = []
    with threadpool_limits(1):
        for case in cases:
            rows.append(
                {
                    "case": case.label,
                    "problem": case.problem,
                    "params": case.params,
                    "sha1": sha1(loop_actions(case, steps)),
                }
            )
    return rows


def loop_actions(case, steps):
    """The actions (steps, nu) float64 of a case's closed loop over `steps` steps."""
    loop = ClosedLoop(case.controller, case.problem, steps, **case.params)
    return np.array([loop.step() for _ in range(steps)], dtype=np.float64)


def sha1(actions) -> str:
    """The sha1 of actions (steps, nu) as contiguous float64 bytes."""
    return hashlib.sha1(np.ascontiguousarray(actions, dtype=np.float64).tobytes()).hexdigest()


def print_fingerprint(rows, steps, kernels):
    """The rows as text, one hash per line, after the machine's kernels (provenance.kernels)."""
    print(f"dcmppi timing --fingerprint: sha1 of the actions of {steps} closed-loop steps")
    print(f"on {kernels}: compare hashes from machines with the same kernels")
    for r in rows:
        params = ",".join(f"{k}={v}" for k, v in r["params"].items())
        print(f"{r['sha1']}  {r['case']:<21} {r['problem']:<11} {params}")
