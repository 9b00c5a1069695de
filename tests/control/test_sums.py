"""The planners' sums in a fixed order: their values bit for bit, and under any BLAS kernel
family."""

import json
import os
import platform
import subprocess
import sys

import numpy as np
import pytest

from dcmppi.control.kernels.sums import importance, pairwise, weighted_rows
from dcmppi.control.planners.mppi import effective_sample_size, mppi_update, mppi_weights
from dcmppi.control.planners.tube import tvlqr_gains


def halving_reference(U0, eps, w):
    """weighted_rows' order in Python floats: the upper half onto the lower until one is left."""
    n, nu, k = eps.shape
    out = np.empty((n, nu))
    for i in range(n):
        for c in range(nu):
            p = [float(a) * float(b) for a, b in zip(w, eps[i, c], strict=True)]
            while len(p) > 1:
                half = len(p) // 2
                keep = len(p) - half
                p = [p[j] + p[keep + j] for j in range(half)] + p[half:keep]
            out[i, c] = float(U0[i, c]) + (p[0] if p else 0.0)
    return out


@pytest.mark.parametrize("k", [2, 3, 7, 8, 13, 64, 200, 517])
def test_weighted_rows_sum_in_their_order(k):
    rng = np.random.default_rng(k)
    U0, eps = rng.normal(size=(70, 2)), rng.normal(size=(70, 2, k)) * 10.0 ** rng.integers(-3, 4)
    w = mppi_weights(rng.exponential(50.0, k), 7.0)
    want = halving_reference(U0, eps, w)
    assert weighted_rows(U0, eps, w).tobytes() == want.tobytes()
    wide = np.repeat(eps, 2, axis=2)[..., ::2]  # a strided view of the same values
    assert weighted_rows(U0, wide, w).tobytes() == want.tobytes()
    np.testing.assert_allclose(want, U0 + eps @ w, rtol=1e-12, atol=1e-14)  # the same sum
    U, w2 = mppi_update(U0, eps, rng.exponential(5.0, k), 3.0)
    assert U.tobytes() == halving_reference(U0, eps, w2).tobytes()
    assert effective_sample_size(w) == 1.0 / halving_reference(np.zeros((1, 1)), w[None, None], w)
    with pytest.raises(ValueError, match="needs U0"):
        weighted_rows(U0[:-1], eps, w)


def test_weighted_rows_of_no_samples_and_of_one():
    U0 = np.array([[0.5, -2.0]])
    assert np.array_equal(weighted_rows(U0, np.zeros((1, 2, 0)), np.zeros(0)), U0)
    got = weighted_rows(U0, np.array([[[3.0], [0.25]]]), np.array([0.5]))
    assert got.tolist() == [[2.0, -1.875]]


def test_importance_sums_the_steps_in_order():
    rng = np.random.default_rng(1)
    U0, e, weight = rng.normal(size=(40, 2)), rng.normal(size=(40, 2, 300)), np.array([0.3, 7.0])
    want = np.empty(300)
    for k in range(300):
        sums = [0.0, 0.0]
        for i in range(40):
            for c in range(2):
                sums[c] += float(U0[i, c]) * float(e[i, c, k])
        want[k] = float(weight[0]) * sums[0] + float(weight[1]) * sums[1]
    assert importance(U0, e, weight).tobytes() == want.tobytes()
    assert importance(U0, e[:, :, 64:200], weight).tobytes() == want[64:200].tobytes()  # a view
    with pytest.raises(ValueError, match="importance needs U0"):
        importance(U0, e, weight[:1])


def numpys_order(p):
    """numpy's pairwise_sum in Python floats: runs of up to 128 terms by eight running sums
    (fewer than 8 terms in order), longer ones as two halves, the first a multiple of 8."""
    n = len(p)
    if n < 8:
        total = 0.0
        for v in p:
            total += float(v)
        return total
    if n <= 128:
        r = [float(v) for v in p[:8]]
        end = n - n % 8
        for i in range(8, end, 8):
            r = [r[j] + float(p[i + j]) for j in range(8)]
        total = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
        for v in p[end:]:
            total += float(v)
        return total
    half = n // 2 - (n // 2) % 8
    return numpys_order(p[:half]) + numpys_order(p[half:])


@pytest.mark.parametrize("n", [0, 1, 7, 8, 9, 127, 128, 129, 136, 255, 500, 517, 2048, 4099])
def test_pairwise_sums_in_numpys_order(n):
    rng = np.random.default_rng(n)
    p = rng.exponential(1.0, n) * 10.0 ** rng.uniform(-12, 0, n)  # magnitudes that show the order
    assert pairwise(p) == numpys_order(p)
    assert pairwise(p) == p.sum()  # numpy's own, which mppi_weights keeps
    if n >= 2048:
        assert pairwise(p) != sum(p.tolist())  # the order in which the terms are added shows


def test_weights_are_numpys_expression_bit_for_bit():
    rng = np.random.default_rng(5)
    for k in (1, 7, 500, 2048):
        S = rng.exponential(30.0, k) + 1e3
        S[:: max(1, k // 5)] = S.min()  # ties at the minimum
        for lam in (0.01, 1.0, 300.0):
            want = np.exp((S.min() - S) / lam)
            want /= want.sum()
            assert mppi_weights(S, lam).tobytes() == want.tobytes()
    assert np.isnan(mppi_weights(np.array([1.0, np.nan, 2.0]), 1.0)).all()  # numpy's min: nan
    with pytest.raises(ValueError, match="at least one cost"):
        mppi_weights(np.zeros(0), 1.0)


def test_lqr_gains_of_several_controls_equal_the_linear_algebra():
    """The compiled Riccati pass (Cholesky, two controls) against numpy's products and solve."""
    rng = np.random.default_rng(2)
    N, n, m = 30, 3, 2
    A = np.eye(n) + 0.1 * rng.normal(size=(N, n, n))
    B = 0.1 * rng.normal(size=(N, n, m))
    Q, R = np.diag([3.0, 2.0, 0.5]), np.array([[1.0, 0.2], [0.2, 0.7]])
    P, want = Q.copy(), np.empty((N, m, n))
    for i in range(N - 1, -1, -1):
        H = B[i].T @ P @ A[i]
        want[i] = np.linalg.solve(R + B[i].T @ P @ B[i], H)
        P = Q + A[i].T @ P @ A[i] - H.T @ want[i]
        P = 0.5 * (P + P.T)
    np.testing.assert_allclose(tvlqr_gains(A, B, Q, R, Q), want, rtol=1e-10, atol=1e-13)
    with pytest.raises(ValueError, match=r"R \(m, m\)"):
        tvlqr_gains(A, B, Q, 1.0, Q)  # one weight for two controls
    with pytest.raises(ValueError, match="not positive definite"):
        tvlqr_gains(A, B, Q, -np.eye(2), Q)


_KERNELS = """
import json, sys
from dcmppi.bench.results.provenance import kernels
from dcmppi.bench.timing.cases import FINGERPRINT_CASES
from dcmppi.bench.timing.fingerprint import fingerprint
cases = [c for c in FINGERPRINT_CASES if c.label in sys.argv[1:]]
print(json.dumps([kernels(), [r["sha1"] for r in fingerprint(cases, 40)]]))
"""


@pytest.mark.slow
@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86 kernel names")
def test_plans_do_not_depend_on_the_blas_kernels():
    """The same closed loops under OpenBLAS's kernels for this processor and under its plain SSE
    ones (OPENBLAS_CORETYPE): the planners' sums and the LQR gains take no BLAS, so the hashes
    are the same."""
    labels = ["mppi tv", "clustered", "tube unicycle", "mppi unicycle mixed"]

    def run(**env):
        out = subprocess.run(
            [sys.executable, "-c", _KERNELS, *labels],
            env={**os.environ, **env},
            capture_output=True,
            text=True,
            check=True,
        )
        return json.loads(out.stdout.strip().splitlines()[-1])

    (here, hashes), (plain, plain_hashes) = run(), run(OPENBLAS_CORETYPE="Prescott")
    if here == plain:
        pytest.skip(f"this machine's BLAS kernels are the plain ones already ({here})")
    assert len(hashes) >= len(labels) and hashes == plain_hashes, (here, plain)
