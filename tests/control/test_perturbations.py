"""The perturbation draws (counter-based Box-Muller) and the branch-free libm under them."""

import numba
import numpy as np
import pytest
from scipy import stats

from dcmppi.control.libm import log_unit, sincos
from dcmppi.control.perturbations import BLOCK, draw_normals


@numba.njit
def _sincos_all(x):
    s, c = np.empty_like(x), np.empty_like(x)
    for j in range(x.size):
        s[j], c[j] = sincos(x[j])
    return s, c


@numba.njit
def _log_all(u):
    out = np.empty_like(u)
    for j in range(u.size):
        out[j] = log_unit(u[j])
    return out


def test_sincos_is_within_two_ulp_of_numpy():
    rng = np.random.default_rng(0)
    for bound in (np.pi / 4, 10.0, 1e5):
        x = np.concatenate([rng.uniform(-bound, bound, 200_000), [0.0, -0.0, np.pi / 4]])
        s, c = _sincos_all(x)
        # |error| <= 2 ulp of 1 (the reduced argument's own error grows with |x| / (pi / 2))
        tol = 2 * np.spacing(1.0) * max(1.0, bound * 1e-5)
        assert np.abs(s - np.sin(x)).max() <= tol and np.abs(c - np.cos(x)).max() <= tol
    s, c = _sincos_all(np.array([0.5 * np.pi, np.pi, -0.5 * np.pi]))  # every quadrant's sign
    np.testing.assert_allclose(s, [1.0, 0.0, -1.0], atol=1e-15)
    np.testing.assert_allclose(c, [0.0, -1.0, 0.0], atol=1e-15)


def test_log_unit_is_within_one_ulp_of_numpy():
    u = np.concatenate([np.random.default_rng(1).uniform(0, 1, 200_000), [1.0, 2.0**-53, 0.5]])
    u = u[u > 0]
    got, want = _log_all(u), np.log(u)
    assert got[-3:].tolist() == want[-3:].tolist()  # 0 at 1, exact powers of two
    assert (np.abs(got - want) <= np.spacing(np.abs(want))).all()


def test_draws_are_standard_normal_and_independent():
    z = draw_normals(11, 1, (100, 2, 2048), np.ones(2))
    flat = z.ravel()
    assert abs(flat.mean()) < 0.01 and abs(flat.std() - 1.0) < 0.01
    assert stats.kstest(flat, "norm").pvalue > 1e-3
    assert abs(stats.kurtosis(flat)) < 0.05
    # the tails: P(|z| > 3) = 0.0027
    assert abs((np.abs(flat) > 3).mean() - 0.0027) < 0.0006
    # neighbours in every direction: samples, blocks, steps, controls, the pairs' halves
    for a, b in [
        (z[:, :, :-1], z[:, :, 1:]),
        (z[:, :, :BLOCK], z[:, :, BLOCK : 2 * BLOCK]),
        (z[:-1], z[1:]),
        (z[:, 0], z[:, 1]),
        (z[:, :, : BLOCK // 2], z[:, :, BLOCK // 2 : BLOCK]),
    ]:
        assert abs(np.corrcoef(a.ravel(), b.ravel())[0, 1]) < 4 / np.sqrt(a.size)  # 4 sigma
    # the squares of a pair's halves (Box-Muller's common radius) are uncorrelated too
    h = z[:, :, : BLOCK // 2] ** 2, z[:, :, BLOCK // 2 : BLOCK] ** 2
    assert abs(np.corrcoef(h[0].ravel(), h[1].ravel())[0, 1]) < 4 / np.sqrt(h[0].size)
    other = draw_normals(11, 2, (100, 2, 2048), np.ones(2))
    assert abs(np.corrcoef(flat, other.ravel())[0, 1]) < 4 / np.sqrt(flat.size)  # next draw
    assert not np.array_equal(draw_normals(12, 1, (3, 2, 64), np.ones(2)), z[:3, :, :64])


@pytest.mark.parametrize("k", [1, 3, 63, 64, 65, 130, 500])
def test_draws_are_the_same_for_every_split_and_keep_whole_blocks(k):
    scale, add = np.array([0.5, 2.0]), np.arange(2.0 * k).reshape(2, k)
    one = draw_normals(5, 9, (4, 2, k), scale, add)
    assert np.isfinite(one).all()
    for threads in (2, 3):
        assert np.array_equal(draw_normals(5, 9, (4, 2, k), scale, add, threads), one)
    unit = draw_normals(5, 9, (4, 2, k), np.ones(2))
    assert np.array_equal(one, unit * scale[:, None] + add)
    whole = (k // BLOCK) * BLOCK  # whole blocks do not depend on K
    longer = draw_normals(5, 9, (4, 2, k + BLOCK), np.ones(2))
    assert np.array_equal(unit[..., :whole], longer[..., :whole])
