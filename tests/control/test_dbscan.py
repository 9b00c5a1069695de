"""dcmppi.control.kernels.dbscan: labels identical to scikit-learn's DBSCAN, edge cases included."""

import numpy as np
import pytest
from sklearn.cluster import DBSCAN

from dcmppi.control.kernels.dbscan import SPLIT, _cells, dbscan
from dcmppi.control.planners.clustered import DBSCAN_MIN_SAMPLES, dbscan_radius


def assert_like_sklearn(X, eps, min_samples):
    expected = DBSCAN(eps=eps, min_samples=min_samples).fit(X).labels_
    np.testing.assert_array_equal(dbscan(X, eps, min_samples), expected)


@pytest.mark.parametrize("seed", range(4))
def test_random_features(seed):
    rng = np.random.default_rng(seed)
    for _ in range(60):
        n, d = int(rng.integers(1, 300)), int(rng.integers(1, 5))
        X = rng.standard_normal((n, d)) * rng.uniform(0.2, 3.0)
        if rng.random() < 0.3:
            X = np.round(X, 1)  # duplicates and ties on the window edge
        assert_like_sklearn(X, rng.uniform(0.05, 1.0), int(rng.integers(1, 10)))


@pytest.mark.parametrize("seed", range(3))
def test_levels(seed):
    """Clustered MPPI's features: most points share the clipped cost exactly (1-D levels)."""
    rng = np.random.default_rng(seed)
    for _ in range(60):
        n = int(rng.integers(1, 400))
        X = rng.standard_normal((n, 2))
        X[:, 1] = np.minimum(np.abs(X[:, 1]) * rng.uniform(1, 8), rng.uniform(0.2, 3.0))
        if rng.random() < 0.3:
            X = np.round(X, 1)  # several levels, duplicates, ties at eps
        assert_like_sklearn(X, rng.uniform(0.05, 1.0), int(rng.integers(1, 10)))


@pytest.mark.parametrize("seed", range(3))
def test_level_edge_cases(seed):
    """Small and full levels, large min_samples, grids with exact ties at eps, points just below
    the level."""
    rng = np.random.default_rng(10 + seed)
    for _ in range(80):
        n = int(rng.integers(1, 120))
        X = np.column_stack([rng.standard_normal(n), rng.uniform(0.0, 1.0, n)])
        top = rng.uniform(0.5, 1.0)
        X[rng.random(n) < rng.uniform(0.0, 1.0), 1] = top
        X[:, 1] = np.minimum(X[:, 1], top)
        kind = rng.integers(4)
        if kind == 1:
            X[:, 0] = rng.integers(-8, 8, n) * 0.1  # ties exactly at eps = 0.1 * k
        elif kind == 2:
            X[:, 1] = top  # everything on the level
        elif kind == 3:
            X[:, 1] = np.where(X[:, 1] < top, top - rng.uniform(0, 0.3, n), top)
        eps = float(rng.choice([0.1, 0.2, rng.uniform(0.05, 0.6)]))
        assert_like_sklearn(X, eps, int(rng.integers(1, 30)))


@pytest.mark.parametrize("eps", [0.1, 0.2, 0.3, 0.5, 1.0])
def test_points_exactly_at_eps(eps):
    """Grids of spacing eps (and of 3-4-5 triangles scaled by eps / 5): distances equal to eps
    up to rounding, on both sides of it."""
    rng = np.random.default_rng(int(eps * 10))
    for _ in range(40):
        n = int(rng.integers(2, 200))
        step = eps if rng.random() < 0.5 else eps / 5
        scale = np.array([1, 1]) if step == eps else np.array([3, 4])
        X = rng.integers(-6, 6, (n, 2)) * scale * step
        assert_like_sklearn(X, eps, int(rng.integers(1, 8)))


def test_duplicates_all_noise_and_one_cluster():
    rng = np.random.default_rng(5)
    X = np.repeat(rng.standard_normal((20, 2)), 4, axis=0)  # every point four times
    for ms in (1, 3, 4, 5, 8):
        assert_like_sklearn(X, 0.05, ms)
    far = np.column_stack([np.arange(50.0), np.zeros(50)])  # spacing 1 > eps: all noise
    assert_like_sklearn(far, 0.5, 2)
    assert (dbscan(far, 0.5, 2) == -1).all()
    tight = rng.uniform(0, 0.1, (300, 2))  # everything within eps: one cluster
    assert_like_sklearn(tight, 0.2, 5)
    assert (dbscan(tight, 0.2, 5) == 0).all()
    assert_like_sklearn(np.zeros((1, 2)), 0.2, 1)
    assert dbscan(np.zeros((0, 2)), 0.2, 5).shape == (0,)


@pytest.mark.parametrize("seed", range(4))
def test_controller_features(seed):
    """Features as Clustered MPPI builds them: nu horizon-mean perturbations in std units (1 to
    3 controls, samples stacked at a bound) and the cost with collision levels."""
    rng = np.random.default_rng(20 + seed)
    for _ in range(30):
        K, nu = 500, int(rng.integers(1, 4))
        raw = rng.standard_normal((K, nu))
        raw[rng.random(K) < 0.2, 0] = rng.uniform(1, 3)  # a stack of clipped samples
        modes = rng.uniform(-2, 2, (3, nu))
        S = np.min(((raw[:, None] - modes) ** 2).sum(-1), axis=1) * rng.uniform(10, 500)
        S += 1e3 * rng.integers(0, 3, K) * (rng.random(K) < 0.3)  # collisions
        radius = dbscan_radius(nu)
        X = np.column_stack([raw, (S - S.min()) * 5 * radius / 1e3])
        assert_like_sklearn(X, radius, DBSCAN_MIN_SAMPLES)


def cell_features(X, eps):
    """The features by whose cells the sort puts the points in order."""
    F, order, _, _ = _cells(np.asarray(X, dtype=float), 1.0 / eps, 4 * len(X))
    np.testing.assert_array_equal(F[: X.shape[1]], X[order].T)
    cells = ((F - F.min(axis=1, keepdims=True)) * (1.0 / eps * SPLIT)).astype(int)
    return np.flatnonzero((np.diff(cells, axis=1) >= 0).all(axis=1))


@pytest.mark.parametrize("seed", range(4))
def test_cells_of_any_feature(seed):
    """Cells of the feature with the fewest candidate pairs, wherever it is (first, middle, last,
    the cost of a level set), with ties at eps in it and in the others."""
    rng = np.random.default_rng(40 + seed)
    for _ in range(60):
        n, d = int(rng.integers(12, 400)), int(rng.integers(2, 6))
        eps = float(rng.uniform(0.1, 0.6))
        X = rng.standard_normal((n, d)) * rng.choice([0.01, 0.3, 1.0, 4.0, 30.0], d)
        if rng.random() < 0.4:  # clipped levels in one feature
            f = rng.integers(d)
            X[:, f] = np.minimum(np.abs(X[:, f]), rng.uniform(0.1, 3.0))
        if rng.random() < 0.5:  # grid steps of eps, eps / 2, eps / 5 in one feature: ties at eps
            f = rng.integers(d)
            X[:, f] = np.round(X[:, f] / eps) * eps / rng.choice([1, 2, 5])
        assert_like_sklearn(X, eps, int(rng.integers(1, 12)))


@pytest.mark.parametrize("f", [0, 1, 2])
def test_cells_sort_the_spread_feature(f):
    """One feature spread, the others within a cell (all pairs candidates): cells of the spread
    one, with points exactly eps apart across its cell edges."""
    rng = np.random.default_rng(f)
    eps = 0.2
    X = np.zeros((300, 3))
    X[:, f] = rng.integers(0, 60, 300) * eps
    X[:, (f + 1) % 3] = rng.integers(0, 2, 300) * eps * 0.5
    assert f in cell_features(X, eps)
    for ms in (1, 3, 5, 9):
        assert_like_sklearn(X, eps, ms)
        assert_like_sklearn(X[:, [f, (f + 1) % 3]], eps, ms)


@pytest.mark.parametrize("d", [2, 3, 4])
def test_one_populated_cell(d):
    """Every feature within one cell, so every pair a candidate, neighbours or not."""
    rng = np.random.default_rng(d)
    eps = 0.5
    for ms in (2, 5, 20, 60):
        X = rng.uniform(0.0, 0.99 * eps, (200, d))
        X[::3] = X[::3].round(1)  # duplicates
        assert_like_sklearn(X, eps, ms)


def test_wide_spread_in_one_feature():
    """A cost feature over thousands of radii (colliding samples far off), or too sparse for cells
    (then the other's cells); both features too sparse go to sklearn."""
    rng = np.random.default_rng(9)
    eps = 0.2
    for far in (1e2, 1e3, 1e6, 1e12):
        X = np.column_stack([rng.standard_normal(400), np.abs(rng.standard_normal(400))])
        hit = rng.random(400) < 0.3
        X[hit, 1] += far * rng.integers(1, 4, hit.sum())
        X[rng.random(400) < 0.05, 1] = far * rng.random()
        if far >= 1e3:
            assert list(cell_features(X, eps)) == [0]
        for ms in (3, 5):
            assert_like_sklearn(X, eps, ms)
            assert_like_sklearn(X[:, ::-1], eps, ms)
    sparse = np.column_stack([np.r_[np.zeros(20), 1e4], np.r_[np.zeros(20), -1e4]])
    assert _cells(sparse, 1 / eps, 4 * len(sparse)) is None  # to sklearn
    assert_like_sklearn(sparse, eps, 5)
    assert (dbscan(sparse, eps, 5) == np.r_[np.zeros(20), -1]).all()


@pytest.mark.parametrize("swap", [False, True])
def test_components_meeting_in_the_sweep(swap):
    """Arms of core points, separate until a point joins two trees: a bridge at their far end, or
    two arms crossing halfway (in the middle of a cell)."""
    eps = 0.2
    t = np.arange(0, 6, 0.1)
    arms = [np.column_stack([t, np.zeros_like(t)]), np.column_stack([t, np.ones_like(t)])]
    bridge = np.column_stack([np.full(10, 6.0), np.linspace(0, 1, 10)])
    cross = [np.column_stack([t, 0.5 * t]), np.column_stack([t, 3 - 0.5 * t])]
    for X in (np.vstack(arms + [bridge]), np.vstack([bridge] + arms), np.vstack(cross)):
        X = X[:, ::-1] if swap else X
        assert int(swap) in cell_features(X, eps)
        for ms in (2, 3, 4):
            assert_like_sklearn(X, eps, ms)
            assert_like_sklearn(X[np.random.default_rng(ms).permutation(len(X))], eps, ms)


def test_border_point_first_in_the_sweep():
    """A non-core point that two clusters both reach first (it comes before them in the sweep,
    with a noise point between): it bridges nothing, and takes the first cluster's label."""
    t = np.arange(0.05, 1.0, 0.05)
    ends = [[-0.1, 0.0], [0.0, 5.0]]
    X = np.vstack(
        [ends, np.column_stack([t, np.full_like(t, 0.12)]), np.c_[t, np.full_like(t, -0.12)]]
    )
    assert 0 in cell_features(X, 0.2)
    for ms in (4, 5, 6):
        assert_like_sklearn(X, 0.2, ms)
        assert dbscan(X, 0.2, ms).max() == 1


@pytest.mark.parametrize("d", [3, 4, 5])
def test_squares_summed_in_order(d):
    """Gaps whose squares, summed over the features in order, fall on the other side of eps^2
    than summed with the last two first: the neighbour test must add them in sklearn's order."""
    rng = np.random.default_rng(d)
    eps = 0.5
    found = 0
    while found < 12:
        g = rng.uniform(0.0, eps / np.sqrt(d), d)
        g[-1] = np.sqrt(eps * eps - np.sum(g[:-1] ** 2)) * (1 + int(rng.integers(-4, 5)) * 2.0**-53)
        ordered = 0.0
        for v in g:
            ordered += v * v
        regrouped = sum(v * v for v in g[:-2]) + (g[-2] ** 2 + g[-1] ** 2)
        if (ordered <= eps * eps) == (regrouped <= eps * eps):
            continue
        found += 1
        X = np.vstack([np.zeros(d), g, 10.0 + np.arange(10.0)[:, None] * np.ones(d)])
        expected = DBSCAN(eps=eps, min_samples=2).fit(X).labels_
        assert (expected[0] == 0) == (ordered <= eps * eps)
        np.testing.assert_array_equal(dbscan(X, eps, 2), expected)
        np.testing.assert_array_equal(dbscan(X[::-1], eps, 2), expected[::-1])


def test_neighbours_eps_apart_at_cell_edges():
    """Pairs of points just within eps, the lower one at or just off a cell edge (x multiples of
    eps / 2 give or take a few 1e-9): the cells are wide enough that both are in the window."""
    eps = 0.3
    offsets = np.array([-4e-9, -2e-9, -1e-9, -5e-10, 0.0, 5e-10, 1e-9, 2e-9, 4e-9])
    a = 10 * np.arange(1, 301) * (eps / 2) * (1 + np.resize(offsets, 300))
    x = np.r_[0.0, a, a + eps * (1 - 1e-13)]
    X = np.column_stack([x, np.zeros_like(x)])
    assert 0 in cell_features(X, eps)
    assert_like_sklearn(X, eps, 2)
    assert (dbscan(X, eps, 2)[1:] >= 0).all()


@pytest.mark.parametrize("d", [3, 5, 8, 15])
def test_more_features(d):
    rng = np.random.default_rng(d)
    for _ in range(20):
        n = int(rng.integers(12, 300))
        X = rng.standard_normal((n, d))
        if rng.random() < 0.4:
            X = np.round(X, 1)
        assert_like_sklearn(X, rng.uniform(0.3, 3.0), int(rng.integers(1, 8)))


def test_far_from_origin_and_sparse_points():
    """Cells are counted from the least value, so they stay exact far from the origin; points
    spread in x over more cells than the counting sort takes are sorted by cells of y."""
    rng = np.random.default_rng(7)
    for offset in (1e3, 1e6, -1e6):
        X = rng.integers(-20, 20, (300, 2)) * 0.1 + offset
        for eps in (0.1, 0.2, 0.3):
            assert_like_sklearn(X, eps, 3)
    sparse = np.column_stack([np.r_[np.zeros(20), 1e4], np.zeros(21)])
    assert _cells(sparse, 1 / 0.2, 4 * len(sparse)) is not None  # not to sklearn
    assert_like_sklearn(sparse, 0.2, 5)
    assert (dbscan(sparse, 0.2, 5) == np.r_[np.zeros(20), -1]).all()


@pytest.mark.parametrize("column", [0, 1])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_features_raise(column, bad):
    X = np.random.default_rng(3).standard_normal((50, 2))
    X[4, column] = bad
    with pytest.raises(ValueError, match="NaN|infinity"):
        dbscan(X, 0.2, 5)


@pytest.mark.parametrize("eps", [1e160, 1e-160, 1e-170])
def test_radii_whose_square_is_not_a_normal_float(eps):
    """eps^2 overflowing, subnormal or 0: sklearn's test then passes gaps of several eps, which
    cells of width eps would miss; such radii go to sklearn (12 points 3 eps apart in pairs)."""
    x = np.repeat(np.arange(6) * 4.0, 2) * eps + np.tile([0.0, 1.0 + 1e-6], 6) * eps
    X = np.column_stack([x, np.zeros(12)])
    assert_like_sklearn(X, eps, 2)


@pytest.mark.parametrize("eps, min_samples", [(-0.2, 5), (0.0, 5), (0.2, 0), (0.2, 2.5)])
def test_bad_parameters_raise_sklearns_error(eps, min_samples):
    X = np.random.default_rng(4).standard_normal((50, 2))
    with pytest.raises(ValueError, match="eps|min_samples"):
        dbscan(X, eps, min_samples)


def test_min_samples_beyond_the_points_is_all_noise():
    X = np.random.default_rng(8).standard_normal((40, 2))
    assert_like_sklearn(X, 0.5, 41)
    assert (dbscan(X, 0.5, 10**30) == -1).all()
