"""Cost map (never misses a cylinder), goal distance and the moving-obstacle collision count."""

import numpy as np
import pytest

from dcmppi.control.kernels.costs import OccupancyGrid, TrackIndex, goal_distance, static_costs


def occupied(grid, x, y):
    """Occupancy (...) bool of the points x, y (...): `count` of one step of many rollouts."""
    x, y = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(y, dtype=float))
    row = [np.ascontiguousarray(v.reshape(1, -1)) for v in (x, y)]
    return grid.count(*row).reshape(x.shape) > 0


def cells(grid, x, y):
    """The occupancy of the cells int(clip((x - origin) / resolution, 0, last)) along each
    axis, as numpy computes them."""
    limit = np.array(grid.shape) - 1.0
    inv = 1.0 / grid.resolution
    ix = np.clip((x - grid.origin[0]) * inv, 0.0, limit[0]).astype(np.int64)
    iy = np.clip((y - grid.origin[1]) * inv, 0.0, limit[1]).astype(np.int64)
    return grid.grid[ix, iy]


def test_grid_is_conservative_and_tight():
    rng = np.random.default_rng(1)
    static = np.column_stack([rng.uniform(0, 20, (30, 2)), rng.uniform(0.2, 2.0, 30)])
    static = np.vstack([static, [[5.0, 5.0, 0.0]]])  # padding row
    grid = OccupancyGrid(static, inflation=0.5, resolution=0.1)
    p = rng.uniform(-5, 25, (200000, 2))
    d = np.hypot(p[:, None, 0] - static[:30, 0], p[:, None, 1] - static[:30, 1]) - static[:30, 2]
    clearance = d.min(axis=1) - 0.5
    occ = occupied(grid, p[:, 0], p[:, 1])
    assert occ[clearance <= 0].all()  # inside an inflated disc: always occupied
    assert not occ[clearance > 0.1 * np.sqrt(2)].any()  # beyond one cell diagonal: always free
    assert not occupied(grid, np.array([-100.0, 100.0]), np.array([0.0, 50.0])).any()


def test_grid_is_free_beyond_its_edges():
    """No strip of occupied cells runs out of the map: rounding once put the cell that only
    touches a disc on the border, which lookups outside the grid clip to (about half of random
    forests had such a wall to infinity through a disc's centre)."""
    rng = np.random.default_rng(6)
    for _ in range(200):
        static = np.column_stack([rng.uniform(-50, 150, (3, 2)), rng.uniform(0.1, 3.0, 3)])
        grid = OccupancyGrid(static, rng.uniform(0.0, 1.0), float(rng.choice([0.1, 0.05, 0.3])))
        along = np.concatenate([static[:, 0], static[:, 1]])[:, None] + np.linspace(-4, 4, 81)
        far = np.full_like(along, 1e4)
        for x, y in ((far, along), (-far, along), (along, far), (along, -far)):
            assert not occupied(grid, x, y).any()


def test_grid_cell_of_nan_is_free():
    grid = OccupancyGrid(np.array([[0.0, 0.0, 1.0]]), 0.5)
    assert not occupied(
        grid, np.array([np.nan, 0.0, np.nan]), np.array([0.0, np.nan, np.nan])
    ).any()
    assert occupied(grid, np.array([0.0]), np.array([0.0]))[0]


def test_grid_cell_is_the_clipped_truncated_cell():
    """Lookups index the cell int(clip((x - origin) / resolution, 0, last)) along each axis,
    as numpy computes it, for points inside, on cell edges and far outside the grid."""
    rng = np.random.default_rng(3)
    static = np.column_stack([rng.uniform(0, 30, (40, 2)), rng.uniform(0.2, 2.0, 40)])
    grid = OccupancyGrid(static, 0.5, 0.1)
    edges = grid.origin[0] + np.arange(grid.shape[0] + 1) * 0.1
    far = rng.uniform(-1e12, 1e12, 2000)  # beyond 32-bit cell indices
    x = np.concatenate([far, rng.uniform(-5, 35, 20000), edges])
    y = rng.uniform(-5, 35, len(x))
    assert np.array_equal(occupied(grid, x, y), cells(grid, x, y))


def test_grid_ignores_padding_and_matches():
    static = np.array([[0.0, 0.0, 0.0], [3.0, 3.0, 1.0]])
    grid = OccupancyGrid(static, 0.5)
    assert not occupied(grid, np.array([0.0]), np.array([0.0]))[0]
    assert occupied(grid, np.array([3.0]), np.array([4.4]))[0]
    assert grid.matches(static.copy()) and not grid.matches(static + 1)
    assert grid.matches(static.tolist()) and not grid.matches(static.reshape(3, 2))
    assert not grid.matches(static[:1]) and not grid.matches(None)
    assert not grid.matches(static, [-5.0, -5.0, 5.0, 5.0])
    assert occupied(OccupancyGrid(None, 0.5), np.zeros(3), np.zeros(3)).sum() == 0


def _numpy_grid(cyl, inflation, resolution, origin, shape):
    """The rasterisation as numpy expressions, one disc at a time (the reference)."""
    grid = np.zeros(shape, dtype=bool)
    inner = np.array(shape) - 2
    for cx, cy, r0 in cyl:
        r = r0 + inflation
        centre = np.array([cx, cy])
        i0, j0 = np.maximum(np.floor((centre - r - origin) / resolution), 1).astype(int)
        i1, j1 = np.minimum(np.floor((centre + r - origin) / resolution), inner).astype(int)
        xs = origin[0] + np.arange(i0, i1 + 1) * resolution
        ys = origin[1] + np.arange(j0, j1 + 1) * resolution
        nx = np.clip(cx, xs, xs + resolution) - cx
        ny = np.clip(cy, ys, ys + resolution) - cy
        grid[i0 : i1 + 1, j0 : j1 + 1] |= nx[:, None] ** 2 + ny[None, :] ** 2 <= r * r
    return grid


def test_compiled_rasterisation_equals_the_numpy_expressions():
    rng = np.random.default_rng(4)
    for trial in range(200):
        m = rng.integers(1, 60)
        cyl = np.column_stack([rng.uniform(-20, 20, (m, 2)), rng.uniform(0.0, 2.0, m)])
        cyl[rng.random(m) < 0.1, 2] = 0.0  # padding rows
        cyl[: m // 4, :2] = np.round(cyl[: m // 4, :2], 1)  # centres on cell edges
        resolution = [0.1, 0.05, 0.3, 1.0 / 3.0][trial % 4]
        inflation = [0.0, 0.5, 0.25][trial % 3]
        grid = OccupancyGrid(cyl, inflation, resolution)
        want = _numpy_grid(cyl[cyl[:, 2] > 0], inflation, resolution, grid.origin, grid.shape)
        assert np.array_equal(grid.grid, want)


def test_a_resolution_that_overflows_the_grid_is_one_clear_error():
    with pytest.raises(ValueError, match="too coarse"):
        OccupancyGrid(np.array([[0.0, 0.0, 1.0]]), 0.5, resolution=1e308)


def test_goal_distance_sums_steps():
    x = np.array([[0.0, 3.0], [0.0, 0.0]])
    y = np.array([[4.0, 4.0], [0.0, 0.0]])
    np.testing.assert_allclose(goal_distance(x, y, np.array([0.0, 0.0])), [4.0, 5.0])


def test_collision_counts_equal_brute_force():
    rng = np.random.default_rng(2)
    n, R, T = 12, 40, 15
    x = np.cumsum(rng.normal(0, 0.5, (n + 1, R)), axis=0)
    y = np.cumsum(rng.normal(0, 0.5, (n + 1, R)), axis=0)
    tracks = rng.normal(0, 2.0, (T, n + 1, 2))
    dist = rng.uniform(0.5, 2.0, T)
    brute = np.zeros(R, dtype=int)
    for r in range(R):
        for i in range(n + 1):
            for j in range(T):
                brute[r] += (
                    np.hypot(x[i, r] - tracks[j, i, 0], y[i, r] - tracks[j, i, 1]) <= dist[j]
                )
    assert brute.sum() > 0
    np.testing.assert_array_equal(TrackIndex(tracks, dist).count(x, y), brute)


def test_grid_count_sums_the_cells_over_steps():
    rng = np.random.default_rng(4)
    static = np.column_stack([rng.uniform(0, 20, (30, 2)), rng.uniform(0.2, 1.5, 30)])
    grid = OccupancyGrid(static, 0.5)
    x, y = rng.uniform(-5, 25, (2, 11, 40))  # inside and outside the grid
    counts = grid.count(x, y)
    np.testing.assert_array_equal(counts, cells(grid, x, y).sum(axis=0))
    assert 0 < counts.sum() < x.size
    np.testing.assert_array_equal(OccupancyGrid(None, 0.5).count(x, y), np.zeros(40))


@pytest.mark.parametrize("bounds", [None, (-2.0, -1.0, 22.0, 18.0)])
def test_static_costs_equal_goal_distance_plus_alpha_count(bounds):
    rng = np.random.default_rng(5)
    static = np.column_stack([rng.uniform(0, 20, (30, 2)), rng.uniform(0.2, 1.5, 30)])
    grid = OccupancyGrid(static, 0.5, bounds=bounds)
    x, y = rng.uniform(-5, 25, (2, 11, 40))  # inside and outside the grid
    x[3, 7] = np.nan  # a nan state: nan cost in both
    goal = np.array([18.0, 3.0])
    expected = goal_distance(x, y, goal) + 1e3 * grid.count(x, y)
    assert (grid.count(x, y) > 0).sum() > 10
    np.testing.assert_array_equal(static_costs(x, y, goal, grid, 1e3), expected)
    with pytest.raises(ValueError, match="alike"):
        static_costs(x, y[:-1], goal, grid, 1e3)


def test_mismatched_steps_raise():
    grid = OccupancyGrid(np.array([[0.0, 0.0, 1.0]]), 0.5)
    with pytest.raises(ValueError, match="alike"):
        grid.count(np.zeros((5, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError, match="alike"):
        goal_distance(np.zeros((5, 3)), np.zeros((5, 2)), np.zeros(2))


def test_map_bounds_make_everything_beyond_them_occupied():
    bounds = np.array([0.0, 0.0, 10.0, 8.0])
    grid = OccupancyGrid(np.array([[5.0, 5.0, 1.0]]), 0.5, bounds=bounds)
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-5, 15, 20000), rng.uniform(-5, 13, 20000)
    outside = (x < 0) | (x > 10) | (y < 0) | (y > 8)
    assert occupied(grid, x, y)[outside].all()  # the robot's centre never leaves unnoticed
    inner = (x > 0.1) & (x < 9.9) & (y > 0.1) & (y < 7.9) & (np.hypot(x - 5, y - 5) > 1.65)
    assert not occupied(grid, x, y)[inner].any()  # at most one cell of the map is lost per edge
    empty = OccupancyGrid(None, 0.5, bounds=bounds)
    assert not empty.empty and occupied(empty, 11.0, 4.0) and not occupied(empty, 5.0, 4.0)
    assert grid.matches(np.array([[5.0, 5.0, 1.0]]), bounds)
    assert not grid.matches(np.array([[5.0, 5.0, 1.0]]), None)
    for bad in ([0, 0, 10], [0, 0, -1, 5], [0, np.nan, 1, 1]):
        with pytest.raises(ValueError, match="bounds"):
            OccupancyGrid(None, 0.5, bounds=bad)


def test_planner_keeps_the_robot_on_the_map():
    """The car 2 m from the map's edge, heading out, the goal behind it: with the bounds it turns
    back before the edge (its turning radius is 1 m); without them it drives out first."""
    import dcmppi

    state, goal = np.array([5.0, 6.0, np.pi / 2]), np.array([5.0, 4.0])
    bounds = np.array([0.0, 0.0, 20.0, 8.0])
    for with_bounds in (True, False):
        ctrl = dcmppi.make_controller("clustered", seed=0)
        s = state.copy()
        highest = s[1]
        for _ in range(80):
            u = ctrl.act(s, goal, None, None, None, bounds if with_bounds else None)
            s = ctrl.agent.step(s, u, ctrl.dt)
            highest = max(highest, s[1])
        assert (highest <= 8.0) == with_bounds


def _brute_counts(x, y, tracks, distance):
    counts = np.zeros(x.shape[1], dtype=np.intp)
    for i in range(x.shape[0]):
        dx = x[i, :, None] - tracks[:, i, 0]
        dy = y[i, :, None] - tracks[:, i, 1]
        counts += np.count_nonzero(dx * dx + dy * dy <= distance * distance, axis=1)
    return counts


@pytest.mark.parametrize("seed", range(3))
def test_track_index_counts_equal_all_pairs(seed):
    """Cells as wide as the largest distance lose no pair: equal counts to testing every state
    against every track, ties at the distance and states far outside the cells included."""
    from dcmppi.control.kernels.costs import TrackIndex

    rng = np.random.default_rng(seed)
    for _ in range(100):
        n, R, T = rng.integers(1, 30), rng.integers(1, 200), rng.integers(0, 60)
        x = np.cumsum(rng.normal(0, 0.3, (n, R)), 0) + rng.uniform(-5, 5)
        y = np.cumsum(rng.normal(0, 0.3, (n, R)), 0)
        tracks = np.cumsum(rng.normal(0, 0.3, (T, n, 2)), 1) + rng.uniform(-4, 4, (T, 1, 2))
        if rng.random() < 0.3:
            tracks, x, y = np.round(tracks, 1), np.round(x, 1), np.round(y, 1)
        distance = rng.choice([1.5, 1.0, 0.5, 0.0], T)
        if T and rng.random() < 0.3:  # ties: distances equal to some state-track distances
            distance = np.hypot(x[0, 0] - tracks[:, 0, 0], y[0, 0] - tracks[:, 0, 1])
        index = TrackIndex(tracks, distance)
        np.testing.assert_array_equal(index.count(x, y), _brute_counts(x, y, tracks, distance))
        np.testing.assert_array_equal(
            index.count(x[:, :3], y[:, :3]), _brute_counts(x[:, :3], y[:, :3], tracks, distance)
        )
    with pytest.raises(ValueError, match="tracks"):
        TrackIndex(np.zeros((3, 5)), np.zeros(3))
    with pytest.raises(ValueError, match="steps"):
        TrackIndex(np.zeros((2, 5, 2)), np.ones(2)).count(np.zeros((4, 3)), np.zeros((4, 3)))
