"""The perturbation draws (counter-based Box-Muller) and the branch-free libm under them."""

import functools

import numba
import numpy as np
import pytest
from fused_cabs import needs_fused_cabs
from scipy import stats

from dcmppi.control import make_controller
from dcmppi.control.kernels.libm import cabs, log_unit, log_unit32, sincos, sincos_turn32
from dcmppi.control.kernels.perturbations import (
    _GAMMA,
    _ULP,
    BLOCK,
    Draw,
    _block_bases,
    _mix,
    _unit,
    draw_box,
    draw_normals,
)
from dcmppi.control.kernels.projection import NO_SUMS, project_columns
from dcmppi.control.kernels.sums import _accumulate, importance
from dcmppi.control.kernels.threads import parts
from dcmppi.control.planners.mppi import MPPI


@numba.njit
def _sincos_all(x):
    s, c = np.empty_like(x), np.empty_like(x)
    for j in range(x.size):
        s[j], c[j] = sincos(x[j])
    return s, c


@numba.njit
def _units(z):
    out = np.empty(z.size)
    for j in range(z.size):
        out[j] = _unit(z[j])
    return out


@numba.njit
def _words(base, n):
    out = np.empty(n, dtype=np.uint64)
    for j in range(n):
        out[j] = _mix(base + np.uint64(j) * _GAMMA)
    return out


def project_perturbed(agent, U0, eps):
    """project_columns of all the samples: u, e (N, nu, K) and the horizon sums of e (nu, K)."""
    u, e, sums = np.empty(eps.shape), np.empty(eps.shape), np.zeros((agent.nu, eps.shape[2]))
    project_columns(agent, U0, eps, u, e, sums)
    return u, e, sums


def test_unit_floats_are_the_top_53_bits_exactly():
    """_unit builds (z >> 11) 2^-53 from bits (AVX2 has no vector conversion of 64-bit integers);
    it must equal numpy's exact conversion for every word, at the ends of [0, 1) too."""
    ends = [0, 1, 2**11 - 1, 2**11, 2**12, 2**12 + 2**11, 2**63, 2**64 - 2**11, 2**64 - 1]
    z = np.concatenate([np.array(ends, dtype=np.uint64), _words(np.uint64(12345), 100_000)])
    exact = (z >> np.uint64(11)).astype(np.float64) * _ULP
    got = _units(z)
    assert np.array_equal(got, exact)
    assert got[len(ends) - 1] == 1.0 - _ULP and got[0] == 0.0
    assert np.array_equal(got + _ULP, ((z >> np.uint64(11)) + np.uint64(1)).astype(float) * _ULP)


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


@numba.njit
def _float32_all(u):
    ln, s, c = np.empty_like(u), np.empty_like(u), np.empty_like(u)
    for j in range(u.size):
        ln[j] = log_unit32(u[j])
        s[j], c[j] = sincos_turn32(u[j])
    return ln, s, c


def test_float32_log_and_turns_are_within_one_float32_ulp():
    """log_unit32 and sincos_turn32 (the draws' float32 kernels) against float64 numpy: within
    1 ulp of float32 (of the result for ln, of 1 for the sine and cosine of 2 pi u)."""
    powers = [1.0, 0.5, 0.25, 0.125, 2.0**-24, 2.0**-126]
    ends = [0.75, np.nextafter(np.float32(1), 0), *powers]
    u = np.concatenate([np.random.default_rng(4).uniform(0, 1, 500_000), ends]).astype(np.float32)
    u = u[u > 0]
    ln, s, c = _float32_all(u)
    assert ln.dtype == s.dtype == np.float32
    exact = u.astype(float)
    want = np.log(exact)
    assert (np.abs(ln - want) <= np.spacing(np.abs(want).astype(np.float32))).all()
    last = slice(len(u) - len(powers), len(u))  # e ln 2, rounded once
    assert ln[last].tolist() == want[last].astype(np.float32).tolist()
    one = float(np.spacing(np.float32(1)))
    assert np.abs(s - np.sin(2 * np.pi * exact)).max() <= one
    assert np.abs(c - np.cos(2 * np.pi * exact)).max() <= one
    _, s, c = _float32_all(np.float32([0.0, 0.25, 0.5, 0.75, 1.0]))  # every quadrant's signs
    assert s.tolist() == [0, 1, 0, -1, 0] and c.tolist() == [1, 0, -1, 0, 1]


def test_draws_are_box_muller_of_the_streams_words():
    """Each normal is float64 Box-Muller of its pair of words to float32's precision: sample j
    and BLOCK / 2 + j of a row of a block share words first + 2 j and first + 2 j + 1."""
    key, draw, shape = 21, 3, (3, 2, 2 * BLOCK + 10)
    z = draw_normals(key, draw, shape, np.ones(2))
    bases = _block_bases(np.uint64(key), np.uint64(draw), 0, shape[2])
    for i, c, b in np.ndindex(3, 2, len(bases)):
        first = (i * 2 + c) * BLOCK + 1
        k = min(BLOCK, shape[2] - b * BLOCK)
        h = (k + 1) // 2
        with np.errstate(over="ignore"):  # uint64 arithmetic wraps, as in the kernels
            words = _words(bases[b] + np.uint64(first) * _GAMMA, 2 * h)
        u1, u2 = _units(words[0::2]) + _ULP, _units(words[1::2])
        r = np.sqrt(-2 * np.log(u1))
        want = np.concatenate([r * np.cos(2 * np.pi * u2), r * np.sin(2 * np.pi * u2)])[:k]
        got = z[i, c, b * BLOCK : b * BLOCK + k]
        assert np.abs(got - want).max() < 1e-6 * (1 + np.abs(want).max())


@numba.njit
def _cabs_all(x, y):
    out = np.empty_like(x)
    for j in range(x.size):
        out[j] = cabs(x[j], y[j])
    return out


@needs_fused_cabs
def test_cabs_gives_numpys_complex_absolute_bit_for_bit():
    rng = np.random.default_rng(2)
    n = 200_000
    x = rng.normal(size=n) * 10.0 ** rng.integers(-300, 300, n)
    y = rng.normal(size=n) * 10.0 ** rng.integers(-300, 300, n)
    y[: n // 2] = rng.normal(size=n // 2) * np.abs(x[: n // 2])  # parts of similar size
    special = [0.0, -0.0, 5e-324, -5e-324, 1e308, -1e308, np.inf, -np.inf, np.nan]
    sx, sy = np.meshgrid(special, special)
    x, y = np.concatenate([x, sx.ravel()]), np.concatenate([y, sy.ravel()])
    z = np.empty(x.size, complex)
    z.real, z.imag = x, y  # (x + 1j * y would turn inf + nan i into nan + nan i)
    got, want = _cabs_all(x, y), np.abs(z)
    assert np.array_equal(got.view(np.int64), want.view(np.int64))


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


@pytest.mark.parametrize("k", [1, 65, 500])
@pytest.mark.parametrize("a", [0.5, 0.9])
def test_correlated_draws_are_an_ar1_sequence_of_the_draws(k, a):
    """With a correlation a: row 0 the independent draw, row i a row_{i-1} + sqrt(1 - a^2) times
    the independent draw (exactly), the same for every split; per-row variance scale^2 and
    correlation a^|i - i'| between rows."""
    scale = np.array([0.5, 2.0])
    unit = draw_normals(5, 9, (6, 2, k), scale)
    want = unit.copy()
    for i in range(1, 6):
        want[i] = a * want[i - 1] + np.sqrt(1.0 - a * a) * unit[i]
    got = draw_normals(5, 9, (6, 2, k), scale, correlation=a)
    assert np.array_equal(got, want)
    assert np.array_equal(draw_normals(5, 9, (6, 2, k), scale, None, 2, a), got)
    z = draw_normals(3, 1, (8, 1, 40000), np.ones(1), correlation=a)[:, 0]
    np.testing.assert_allclose(z.var(axis=1), 1.0, rtol=0.03)
    for lag in (1, 3):
        np.testing.assert_allclose((z[2] * z[2 + lag]).mean(), a**lag, atol=0.03)


@pytest.mark.parametrize("k", [3, 64, 130, 500])
@pytest.mark.parametrize("mixed", [False, True, "correlated"])
def test_draws_into_a_box_are_the_draws_then_the_projection(k, mixed):
    """draw_box, whole or in threads' parts, gives the values of draw_normals then the box
    projection, the horizon sums included."""
    agent = make_controller("mppi", agent="unicycle").agent  # two controls, box bounds
    rng = np.random.default_rng(3)
    U0 = rng.uniform(agent.lower, agent.upper, (7, 2))
    scale, add = np.array([0.6, 1.5]), (rng.normal(size=(2, k)) if mixed is True else None)
    a = 0.8 if mixed == "correlated" else 0.0
    eps = draw_normals(8, 4, (7, 2, k), scale, add, correlation=a)
    want = project_perturbed(agent, U0, eps)
    assert 0 < (want[0] == agent.upper[1]).mean() < 0.5  # some controls are bounded
    for cols in (None, *parts(k, 2)):
        u, e, sums = np.zeros((7, 2, k)), np.zeros((7, 2, k)), np.zeros((2, k))
        draw_box(8, 4, scale, add, U0, agent.lower, agent.upper, u, e, sums, cols, correlation=a)
        j = slice(*(cols or (0, k)))
        for got, ref in zip((u, e, sums), want, strict=True):
            assert np.array_equal(got[..., j], ref[..., j])
    u, e = np.empty((7, 2, k)), np.empty((7, 2, k))
    draw_box(8, 4, scale, add, U0, agent.lower, agent.upper, u, e, NO_SUMS, correlation=a)
    assert np.array_equal(u, want[0]) and np.array_equal(e, want[1])


@pytest.mark.parametrize("k", [3, 64, 130, 500])
@pytest.mark.parametrize("mixed", [False, True, "correlated"])
def test_draws_into_a_box_and_disc_are_the_draws_then_the_projection(k, mixed):
    """draw_box with the holonomic base's disc, whole or in threads' parts: the values of
    draw_normals then Agent.project's box and disc, the horizon and importance sums included."""
    agent = make_controller("mppi", agent="holonomic").agent  # vx, vy in a disc; a turn rate
    disc = (*agent.norm_axes, agent.norm_limit)
    rng = np.random.default_rng(5)
    U0 = rng.uniform(-0.7, 0.7, (6, 3)) * agent.upper
    scale, add = np.array([1.2, 0.9, 0.3]), (rng.normal(size=(3, k)) if mixed is True else None)
    a = 0.8 if mixed == "correlated" else 0.0
    eps = draw_normals(8, 4, (6, 3, k), scale, add, correlation=a)
    want = project_perturbed(agent, U0, eps)
    np.testing.assert_array_equal(want[0], agent.project(U0[:, :, None] + eps, axis=1))
    speed = np.hypot(want[0][:, 0], want[0][:, 1])
    assert 0.1 < (speed > agent.norm_limit * (1 - 1e-12)).mean() < 0.9  # some on the disc
    products = np.zeros((3, k))
    _accumulate(U0, want[1], products)
    for cols in (None, *parts(k, 2)):
        u, e, sums, prods = (np.zeros((6, 3, k)), np.zeros((6, 3, k)), np.zeros((3, k)),
                             np.zeros((3, k)))  # fmt: skip
        draw_box(8, 4, scale, add, U0, agent.lower, agent.upper, u, e, sums, cols, prods, disc,
                 a)  # fmt: skip
        j = slice(*(cols or (0, k)))
        for got, ref in zip((u, e, sums, prods), (*want, products), strict=True):
            assert np.array_equal(got[..., j], ref[..., j])


@pytest.mark.parametrize("agent", ["unicycle", "holonomic"])
@pytest.mark.parametrize("perturbation", ["time_varying", "mixed", "correlated"])
def test_a_step_drawn_in_its_pass_equals_the_draw_made_first(agent, perturbation):
    """perturbed_rollouts of sample()'s Draw (made in the pass that bounds it) equals it of the
    same perturbations made first: the same draw numbers, values and outputs, on one thread and
    two; the Draw's array is draw_normals' and the same for every number of threads."""
    for threads in (1, 2):
        runs = []
        for made in (False, True):
            ctrl = make_controller(
                "mppi", agent=agent, K=200, N=12, seed=4, perturbation=perturbation,
                threads=threads,
            )  # fmt: skip
            ctrl.act(np.zeros(3), np.array([5.0, 1.0]))
            draw = ctrl.sample()
            assert isinstance(draw, Draw) and draw.shape == (12, ctrl.nu, 200)
            eps = np.asarray(draw) if made else draw
            assert np.array_equal(np.asarray(draw), draw.array(threads=3))
            r = ctrl.perturbed_rollouts(np.zeros(3), eps, sums=True)
            runs.append(
                (r.u, r.e, r.sums, r.products, r.states, r.J, r.importance, ctrl.sampler.draws)
            )
        for a, b in zip(*runs, strict=True):
            assert np.array_equal(a, b)


def test_a_replaced_sample_is_used():
    """A subclass's or an instance's own sample() gives the step's perturbations, an array
    in place of the Draw made in the projection's pass."""

    class Fixed(MPPI):
        def sample(self):
            return np.full((self.N, self.nu, self.K), 0.125)

    goal = np.array([5.0, 1.0])
    ctrl = Fixed(agent="unicycle", K=70, N=9, seed=1, perturbation="time_varying")
    ctrl.act(np.zeros(3), goal)
    e = ctrl.diagnostics.eps  # (K, N, nu): what remains after the bounds
    assert (e == e[:1]).all() and (e == 0.125).any() and (e <= 0.125).all()  # every sample's
    ctrl = make_controller("mppi", agent="unicycle", K=70, N=9, seed=1, perturbation="mixed")
    ctrl.sample = lambda: np.zeros((ctrl.N, ctrl.nu, ctrl.K))
    ctrl.act(np.zeros(3), goal)
    assert not ctrl.diagnostics.eps.any()


def test_a_replaced_controls_may_take_a_draw_and_leave_it_unbounded():
    """A subclass's own controls() gets sample()'s Draw, here made into an array and applied
    unbounded, on one thread and two alike."""

    class Unbounded(MPPI):
        def controls(self, r, cols):
            j = slice(*cols)
            eps = np.asarray(r.eps)[:, :, j]
            r.u[:, :, j], r.e[:, :, j] = r.U0[:, :, None] + eps, eps
            for i in range(self.N):  # the importance term's sums, in order
                r.products[:, j] += r.U0[i, :, None] * eps[i]

    plans = []
    for threads in (1, 2):
        ctrl = Unbounded(K=200, N=9, seed=1, Sigma=1.0, perturbation="time_varying",
                         threads=threads)  # fmt: skip
        ctrl.act(np.zeros(3), np.array([5.0, 1.0]))
        d = ctrl.diagnostics
        assert (np.abs(d.warm_start[None] + d.eps) > ctrl.agent.upper[0]).mean() > 0.1
        assert np.array_equal(d.S - d.J, importance(d.warm_start, d.eps.transpose(1, 2, 0),
                                                    ctrl._importance_weight))  # fmt: skip
        plans.append(d.plan)
    assert np.array_equal(*plans)


def test_a_replaced_importance_is_used():
    """A subclass's or an instance's own importance() gives the step's importance terms, on one
    thread or two."""

    class Without(MPPI):
        def importance(self, r, cols):
            r.importance[cols[0] : cols[1]] = 0.0

    goal = np.array([5.0, 1.0])
    for threads in (1, 2):
        params = dict(agent="unicycle", K=200, N=9, seed=1, perturbation="time_varying")
        ctrl = make_controller("mppi", threads=threads, **params)
        ctrl.act(np.zeros(3), goal)
        assert not np.array_equal(ctrl.diagnostics.S, ctrl.diagnostics.J)  # a term to replace
        ctrl = Without(threads=threads, **params)
        ctrl.act(np.zeros(3), goal)
        assert np.array_equal(ctrl.diagnostics.S, ctrl.diagnostics.J)
        ctrl = make_controller("mppi", threads=threads, **params)
        ctrl.importance = functools.partial(Without.importance, ctrl)
        ctrl.act(np.zeros(3), goal)
        assert np.array_equal(ctrl.diagnostics.S, ctrl.diagnostics.J)


@pytest.mark.parametrize("agent", ["dubins", "unicycle", "holonomic"])
def test_the_importance_summed_in_the_bounding_pass_is_importances(agent):
    """With one constant draw per sample, or perturbations given, the pass that bounds the
    controls sums the importance term over the steps too: the values of
    dcmppi.control.kernels.sums.importance(U0, e), on one thread and two."""
    for threads in (1, 2):
        ctrl = make_controller(
            "mppi", agent=agent, K=200, N=12, seed=4, perturbation="constant", threads=threads
        )
        ctrl.act(np.zeros(3), np.array([5.0, 1.0]))
        for eps in (None, 3.0 * ctrl.sample()):  # drawn in the step; three sigmas: many bounded
            r = ctrl.perturbed_rollouts(np.zeros(3), eps)
            assert np.array_equal(r.importance, importance(ctrl.U, r.e, ctrl._importance_weight))
    eps = 3.0 * ctrl.sample()
    u, e, got, want = (
        np.empty(eps.shape),
        np.empty(eps.shape),
        np.zeros((3, 200)),
        np.zeros((3, 200)),
    )
    project_columns(ctrl.agent, ctrl.U, eps, u, e, NO_SUMS, None, got[: ctrl.nu])
    _accumulate(ctrl.U, e, want[: ctrl.nu])
    assert (e != eps).any() and np.array_equal(got, want) and got.any()


def test_a_constant_draw_is_one_read_only_block_for_every_step():
    ctrl = make_controller("mppi", agent="holonomic", K=100, N=7, seed=1, perturbation="constant")
    eps = ctrl.sample()
    assert eps.shape == (7, 3, 100) and eps.strides[0] == 0 and not eps.flags.writeable
    assert eps.tobytes() == np.broadcast_to(ctrl.sampler.raw, (7, 3, 100)).tobytes()
    with pytest.raises(ValueError, match="read-only"):
        eps[0, 0, 0] = 1.0
