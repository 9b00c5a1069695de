"""Costs (docs/design.md) and the DC-MPPI collision term (paper Eq. 30-31).

Every state x_0 .. x_N of a rollout pays the same cost (the paper's running cost psi for
i = 0..N-1 and terminal cost phi = psi for x_N, Alg. 2):

    c(x_i) = |p_i - goal| + alpha 1[x_i in the static cost map]
             + alpha sum_l 1[|p_i - o_l(t_0)| <= r + r_l]   (moving obstacles as static)
             + beta sum_l sum_p theta 1[|p_i - o_l^p(t_i)| <= r + r_l], theta = 1/P   (DC-MPPI)

Static cylinders go into an occupancy grid built once, so their cost is one lookup per state.
The per-state sums over a batch of rollouts are numba loops: one pass over the (N + 1, K) states
instead of a numpy call per operation (their per-call cost dominates for the few rollouts of
Alg. 2's cluster controls), adding in step order.
"""

import numba
import numpy as np

from dcmppi.control.kernels.threads import in_cols, n_cols
from dcmppi.control.validation import floats

RESOLUTION = 0.1  # occupancy-grid cell size [m]
MAX_CELLS = 1e8  # occupancy-grid cells (100 MB)


def valid_cylinders(cylinders, name, columns=3, unobserved=None):
    """Rows of an (M, columns) cylinder array, radius last, with radius > 0 (0 rows are padding).

    unobserved: index of a column that may be nan (a value the sensor does not give, such as a
    moving obstacle's heading); every other entry must be finite.
    """
    if cylinders is None:
        return np.zeros((0, columns))
    cylinders = floats(name, cylinders)
    if cylinders.ndim != 2 or cylinders.shape[1] != columns:
        raise ValueError(f"{name} must have shape (rows, {columns}); got {cylinders.shape}")
    if not len(cylinders):  # no rows (a map without moving obstacles): nothing to check
        return cylinders
    finite = np.isfinite(cylinders)
    if unobserved is not None:
        finite[:, unobserved] |= np.isnan(cylinders[:, unobserved])
    bad = ~finite.all(axis=1) | (cylinders[:, -1] < 0)
    if bad.any():
        column = "" if unobserved is None else f" (column {unobserved} may be nan: not observed)"
        raise ValueError(
            f"{name} obstacles must be finite{column} with radius >= 0 (0 marks a padding "
            f"row); bad rows {np.flatnonzero(bad)}"
        )
    return cylinders[cylinders[:, -1] > 0]


def _same(values, reference):
    """Whether `values` as float64 have the shape and the bytes of the array `reference`."""
    try:
        values = np.asarray(values, dtype=float)
    except (TypeError, ValueError):
        return False
    return values.shape == reference.shape and values.tobytes() == reference.tobytes()


class OccupancyGrid:
    """Static cylinders inflated by the robot radius, rasterised conservatively.

    A cell is occupied when its square meets any inflated disc, so a point inside a disc always
    lands in an occupied cell (the map never misses a collision); a point at most one cell
    diagonal (resolution * sqrt(2) = 0.14 m at 0.1 m) outside a disc may also count as one.
    Without map bounds everything outside the grid is free: lookups clip indices to the grid's
    outer ring of cells, which stays free (a two-cell border; rasterising never writes the outer
    ring, where rounding could otherwise put the cell that only touches a disc and make a wall to
    infinity). With map bounds the robot's centre must stay on the map: every cell that reaches
    beyond the bounds is occupied, the outer ring and so everything outside the grid too.

    Args:
      static: (M, 3) x, y, radius of the cylinders; rows with radius 0 are ignored.
      inflation: robot radius added to every cylinder radius [m].
      resolution: cell size [m].
      bounds: (4,) xmin, ymin, xmax, ymax of the map, or None for an unbounded plane.
    """

    def __init__(self, static, inflation, resolution=RESOLUTION, bounds=None):
        if not resolution > 0:
            raise ValueError(f"resolution must be > 0 m; got {resolution}")
        self.source = None if static is None else np.array(floats("static", static))
        self.bounds = _check_bounds(bounds)
        cyl = valid_cylinders(static, "static")
        self.resolution = float(resolution)
        self.inflation = float(inflation)
        self.empty = len(cyl) == 0 and self.bounds is None
        radius = cyl[:, 2] + inflation
        extent = [] if self.bounds is None else [self.bounds[:2], self.bounds[2:]]
        if len(cyl):
            extent += [cyl[:, :2] - radius[:, None], cyl[:, :2] + radius[:, None]]
        extent = np.vstack(extent) if extent else np.zeros((1, 2))
        lo, hi = extent.min(axis=0), extent.max(axis=0)
        shape = np.floor((hi - lo) / resolution).astype(int) + 1
        if np.prod(shape.astype(float)) > MAX_CELLS:
            raise ValueError(
                f"static obstacles span {hi - lo} m: {int(shape[0])} x {int(shape[1])} cells at "
                f"resolution {resolution} m, more than {MAX_CELLS:.0e}; use a coarser resolution"
            )
        self.origin = lo - 2 * resolution  # corner of the outer ring's first cell
        if not np.isfinite(self.origin).all():
            raise ValueError(
                f"resolution {resolution} m is too coarse: the grid's corner overflows; use a "
                f"resolution below 1e300 m"
            )
        self.shape = (int(shape[0]) + 4, int(shape[1]) + 4)
        inner = np.array(self.shape) - 2  # last index inside the outer ring
        grid = np.zeros(self.shape, dtype=bool)
        _rasterise(grid, cyl, radius, self.origin, float(resolution), inner)
        if self.bounds is not None:  # cells reaching beyond the map, the outer ring included
            tol = 1e-9 * resolution  # an edge on a bound up to rounding stays inside
            for axis in (0, 1):
                edges = self.origin[axis] + np.arange(self.shape[axis] + 1) * resolution
                out = (edges[:-1] < self.bounds[axis] - tol) | (
                    edges[1:] > self.bounds[axis + 2] + tol
                )
                grid[(slice(None), out) if axis else out] = True
        self.grid = grid
        limit = np.array(self.shape, dtype=float) - 1.0  # last cell index along x and y
        # cells as bytes: numba's loops over uint8 vectorise where those over bool do not
        flat = grid.ravel().view(np.uint8)
        self._cells = (flat, self.shape[1], self.origin, limit, 1.0 / resolution)

    def matches(self, static, bounds=None):
        """True when `static` and `bounds` are those this grid was built from: the same shapes
        and bytes (a zero of the other sign gives False: the same grid is built again)."""
        if (bounds is None) != (self.bounds is None) or (static is None) != (self.source is None):
            return False
        return (bounds is None or _same(bounds, self.bounds)) and (
            static is None or _same(static, self.source)
        )

    def count(self, x, y):
        """Occupied states of every rollout. x, y: (N + 1, R) coordinates [m]. Returns (R,) int."""
        _check_steps(x, y)
        return _occupied_steps(*self._cells, x, y)


@numba.njit(cache=True)
def _rasterise(grid, cyl, radius, origin, resolution, inner):
    """Sets the cells of `grid` that meet a disc (cyl[k, :2], radius[k]), within the cells
    1..inner (the outer ring stays free): a cell whose nearest point to the centre is within
    the radius."""
    for k in range(len(cyl)):
        cx, cy, r = cyl[k, 0], cyl[k, 1], radius[k]
        i0 = int(max(np.floor((cx - r - origin[0]) / resolution), 1.0))
        j0 = int(max(np.floor((cy - r - origin[1]) / resolution), 1.0))
        i1 = int(min(np.floor((cx + r - origin[0]) / resolution), inner[0]))
        j1 = int(min(np.floor((cy + r - origin[1]) / resolution), inner[1]))
        for i in range(i0, i1 + 1):
            x = origin[0] + i * resolution  # the cell's lower edges
            nx = min(max(cx, x), x + resolution) - cx  # its nearest point to the centre
            for j in range(j0, j1 + 1):
                y = origin[1] + j * resolution
                ny = min(max(cy, y), y + resolution) - cy
                if nx * nx + ny * ny <= r * r:
                    grid[i, j] = True


def _check_bounds(bounds):
    """Map bounds as a (4,) array xmin, ymin, xmax, ymax with min < max, or None."""
    if bounds is None:
        return None
    b = np.array(floats("bounds", bounds)).reshape(-1)
    if b.shape != (4,) or not np.isfinite(b).all() or not (b[:2] < b[2:]).all():
        raise ValueError(
            f"bounds must be 4 finite numbers xmin, ymin, xmax, ymax with min < max; got {bounds}"
        )
    return b


@numba.njit(inline="always")
def _index(x, origin, inv, limit):
    """Cell index of coordinate x clipped to [0, limit]; nan goes to 0 (selects, not min/max,
    whose nan handling depends on the argument order). Truncated to 32 bits, then widened: the
    same index (limit < MAX_CELLS < 2^31), but AVX2 converts four floats to 32-bit integers at
    once and 64-bit ones only one at a time, so the loops vectorise."""
    v = (x - origin) * inv
    v = v if v > 0.0 else 0.0
    return np.int64(np.int32(v if v < limit else limit))


@numba.njit(cache=True)
def _occupied_steps(flat, columns, origin, limit, inv, x, y):
    """Occupied states summed over the steps. x, y: (N + 1, R). Returns (R,) int."""
    counts = np.zeros(x.shape[1], dtype=np.intp)
    cells = np.empty(x.shape[1], dtype=np.intp)
    for i in range(x.shape[0]):
        _add_hits(counts, cells, x[i], y[i], flat, columns, origin, limit, inv)
    return counts


@numba.njit(inline="always")
def _add_hits(counts, cells, x, y, flat, columns, origin, limit, inv):
    """counts += occupancy of the points x, y (R,); cells: (R,) scratch. The cells' indices first
    (a loop that vectorises), then the lookups (scalar loads, no index arithmetic left)."""
    ox, oy, lx, ly = origin[0], origin[1], limit[0], limit[1]
    for k in range(len(x)):
        cells[k] = _index(x[k], ox, inv, lx) * columns + _index(y[k], oy, inv, ly)
    for k in range(len(x)):
        counts[k] += flat[cells[k]]


def goal_distance(x, y, goal, cols=None):
    """Sum over steps of the distance to the goal. x, y: (N + 1, K); cols: (j0, j1), the
    columns to sum (None: all). Returns (j1 - j0,)."""
    return _goal_distance(x, y, float(goal[0]), float(goal[1]), _columns(x, y, cols))


def static_costs(x, y, goal, grid, alpha, cols=None):
    """goal_distance plus alpha per occupied state of `grid` (OccupancyGrid), in one pass: the
    same values as goal_distance(x, y, goal) + alpha * grid.count(x, y). x, y: (N + 1, R);
    cols: (j0, j1) as in goal_distance. Returns (j1 - j0,)."""
    cols = _columns(x, y, cols)
    return _static_costs(x, y, float(goal[0]), float(goal[1]), float(alpha), *grid._cells, cols)


@numba.njit(cache=True, nogil=True)
def _static_costs(x, y, gx, gy, alpha, flat, columns, origin, limit, inv, cols):
    """Per step, the goal distances then the cell lookups (loops that vectorise apart), over
    the columns cols (threads.in_cols)."""
    r = n_cols(x.shape[1], cols)
    J = np.zeros(r)
    hits = np.zeros(r, dtype=np.intp)
    cells = np.empty(r, dtype=np.intp)
    for i in range(x.shape[0]):
        xi, yi = in_cols(x[i], cols), in_cols(y[i], cols)
        for k in range(r):
            dx = xi[k] - gx
            dy = yi[k] - gy
            J[k] += np.sqrt(dx * dx + dy * dy)
        _add_hits(hits, cells, xi, yi, flat, columns, origin, limit, inv)
    for k in range(r):
        J[k] += alpha * hits[k]
    return J


def _check_steps(x, y):
    """The numba sums index x and y alike without bounds checks."""
    if x.ndim != 2 or x.shape != y.shape:
        raise ValueError(f"x and y must be (N + 1, R) alike; got {x.shape} and {y.shape}")


def _columns(x, y, cols):
    """The checked column range (j0, j1) of x, y (N + 1, R), or None (all)."""
    _check_steps(x, y)
    if cols is None:
        return None
    j0, j1 = cols = int(cols[0]), int(cols[1])
    if not 0 <= j0 <= j1 <= x.shape[1]:
        raise ValueError(f"cols must be (j0, j1) with 0 <= j0 <= j1 <= {x.shape[1]}; got {cols}")
    return j0, j1


@numba.njit(cache=True, nogil=True)
def _goal_distance(x, y, gx, gy, cols):
    J = np.zeros(n_cols(x.shape[1], cols))
    for i in range(x.shape[0]):
        xi, yi = in_cols(x[i], cols), in_cols(y[i], cols)
        for k in range(len(J)):
            dx = xi[k] - gx
            dy = yi[k] - gy
            J[k] += np.sqrt(dx * dx + dy * dy)
    return J


class TrackIndex:
    """Obstacle tracks sorted into cells at every step, for collision counts of many rollouts.

    Tracks are any set of obstacle futures (DC-MPPI's P samples of each relevant obstacle) or of
    frozen positions; a rollout state at step i collides with track j when |p_i - o_j(t_i)| <=
    distance_j. Each step's track positions are sorted into square cells as wide as the largest
    distance, so a state meets only the tracks of its own and the 8 surrounding cells: no loop
    over K x P x L pairs, and the cost stays additive in P and K. Built once per control step,
    it serves the sampled rollouts and the cluster controls alike.

    Args:
      tracks: (T, N + 1, 2) obstacle positions per step; distance: (T,) collision distances.
    """

    def __init__(self, tracks, distance):
        tracks = np.asarray(tracks, dtype=float)
        distance = np.asarray(distance, dtype=float)
        if tracks.ndim != 3 or tracks.shape[2] != 2 or distance.shape != tracks.shape[:1]:
            raise ValueError(
                f"tracks must be (T, N + 1, 2) and distance (T,); got {tracks.shape} and "
                f"{distance.shape}"
            )
        self.steps = tracks.shape[1]
        self.empty = len(tracks) == 0
        if self.empty:
            return
        width = float(distance.max()) * (1.0 + 1e-9)  # rounding never puts a hit two cells away
        width = width if width > 0 else 1.0
        tracks = np.ascontiguousarray(tracks)
        self._index = (1.0 / width, *_sort_tracks(tracks, distance * distance, 1.0 / width))

    def count(self, x, y, cols=None):
        """Collisions (j1 - j0,) int of the rollouts x, y (N + 1, R) in columns cols = (j0, j1)
        (None: all) with the tracks, summed over steps."""
        cols = _columns(x, y, cols)
        if x.shape[0] != self.steps:
            raise ValueError(f"rollouts have {x.shape[0]} steps, the tracks {self.steps}")
        if self.empty:
            return np.zeros(n_cols(x.shape[1], cols), dtype=np.intp)
        return _count_hits(x, y, cols, *self._index)


@numba.njit(cache=True)
def _sort_tracks(tracks, d2, inv):
    """Counting sort of every step's track positions into cells of width 1 / inv.

    tracks: (T, N + 1, 2); d2: (T,) squared collision distances. Returns the cells' lower
    corner (N + 1, 2), their counts along x and y (N + 1, 2), each step's offset into `start`
    (N + 2,), start: per cell the first position of its tracks (cells of a step plus one end
    entry, steps concatenated), and the tracks' x, y, d2 in cell order (N + 1, T, 3), so the
    tracks of neighbouring cells of one column are one contiguous run."""
    T, steps = tracks.shape[0], tracks.shape[1]
    flat = tracks.reshape(T, 2 * steps)
    lo, hi = flat[0].copy(), flat[0].copy()  # bounding box of each step, x and y interleaved
    for t in range(1, T):
        row = flat[t]
        for a in range(2 * steps):  # selects, not min/max: a loop that vectorises
            lo[a] = row[a] if row[a] < lo[a] else lo[a]
            hi[a] = row[a] if row[a] > hi[a] else hi[a]
    corner = lo.reshape(steps, 2)
    shape = np.empty((steps, 2), dtype=np.intp)
    offset = np.zeros(steps + 1, dtype=np.intp)
    for i in range(steps):
        shape[i, 0] = int((hi[2 * i] - lo[2 * i]) * inv) + 1
        shape[i, 1] = int((hi[2 * i + 1] - lo[2 * i + 1]) * inv) + 1
        offset[i + 1] = offset[i] + shape[i, 0] * shape[i, 1] + 1
    start = np.zeros(offset[steps], dtype=np.intp)
    cell = np.empty(T, dtype=np.intp)
    out = np.empty((steps, T, 3))
    for i in range(steps):
        s = start[offset[i] : offset[i + 1]]
        ny = shape[i, 1]
        for t in range(T):
            cell[t] = int((tracks[t, i, 0] - corner[i, 0]) * inv) * ny + int(
                (tracks[t, i, 1] - corner[i, 1]) * inv
            )
            s[cell[t]] += 1
        total = 0  # s[c] = the end of cell c's run, then (back to front) its start
        for c in range(len(s) - 1):
            total += s[c]
            s[c] = total
        s[len(s) - 1] = T
        o = out[i]
        for t in range(T - 1, -1, -1):
            s[cell[t]] -= 1
            j = s[cell[t]]
            o[j, 0], o[j, 1], o[j, 2] = tracks[t, i, 0], tracks[t, i, 1], d2[t]
    return corner, shape, offset, start, out


@numba.njit(cache=True, nogil=True)
def _count_hits(x, y, cols, inv, corner, shape, offset, start, sorted_tracks):
    """(R,) hits of the states x, y (N + 1, :) in columns cols (R of them, threads.in_cols)
    with the sorted tracks (see _sort_tracks).

    A state meets the tracks of the three columns of cells around its own. The states of one
    step crowd into a few cells (about 6 for K = 500), so they are sorted by cell first and each
    cell's candidate tracks are gathered once into one contiguous run that all its states then
    scan: per state one loop instead of three short ones, and a loop of the same length as the
    previous state's, whose end the branch predictor foresees."""
    steps, R = x.shape[0], n_cols(x.shape[1], cols)
    T = sorted_tracks.shape[1]
    counts = np.zeros(R, dtype=np.intp)
    cx, cy = np.empty(R, dtype=np.intp), np.empty(R, dtype=np.intp)
    cell, order = np.empty(R, dtype=np.intp), np.empty(R, dtype=np.intp)
    bins = 0  # the most cells a step's states can fall in
    for i in range(steps):
        bins = max(bins, (shape[i, 0] + 2) * (shape[i, 1] + 2))
    first = np.empty(bins + 1, dtype=np.intp)
    bx, by, bd2 = np.empty(T), np.empty(T), np.empty(T)
    for i in range(steps):
        nx, ny = shape[i, 0], shape[i, 1]
        s = start[offset[i] : offset[i + 1]]
        o = sorted_tracks[i]
        xi, yi = in_cols(x[i], cols), in_cols(y[i], cols)
        x0, y0, x1, y1 = nx, ny, -1, -1  # bounding box of the states' cells
        for k in range(R):
            fx, fy = (xi[k] - corner[i, 0]) * inv, (yi[k] - corner[i, 1]) * inv
            if not (-1.0 <= fx < nx + 1.0 and -1.0 <= fy < ny + 1.0):
                cx[k] = nx + 1  # no cell within one of the state's
                continue
            cx[k], cy[k] = int(np.floor(fx)), int(np.floor(fy))
            x0, x1 = min(x0, cx[k]), max(x1, cx[k])
            y0, y1 = min(y0, cy[k]), max(y1, cy[k])
        if x1 < x0:
            continue
        rows = y1 - y0 + 1
        used = (x1 - x0 + 1) * rows
        first[: used + 1] = 0  # counting sort of the states by cell, as in _sort_tracks
        for k in range(R):
            if cx[k] <= nx:
                cell[k] = (cx[k] - x0) * rows + cy[k] - y0
                first[cell[k]] += 1
        total = 0
        for c in range(used):
            total += first[c]
            first[c] = total
        first[used] = total
        for k in range(R - 1, -1, -1):
            if cx[k] <= nx:
                first[cell[k]] -= 1
                order[first[cell[k]]] = k
        for c in range(used):
            if first[c] == first[c + 1]:
                continue
            gx, gy = x0 + c // rows, y0 + c % rows
            r0, r1 = max(gy - 1, 0), min(gy + 1, ny - 1)
            n = 0
            for g in range(max(gx - 1, 0), min(gx + 2, nx)):
                for j in range(s[g * ny + r0], s[g * ny + r1 + 1]):
                    bx[n], by[n], bd2[n] = o[j, 0], o[j, 1], o[j, 2]
                    n += 1
            for q in range(first[c], first[c + 1]):
                k = order[q]
                px, py = xi[k], yi[k]
                hits = 0
                for j in range(n):
                    dx = px - bx[j]
                    dy = py - by[j]
                    hits += dx * dx + dy * dy <= bd2[j]
                counts[k] += hits
    return counts
