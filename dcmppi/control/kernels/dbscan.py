"""DBSCAN with scikit-learn's exact labels, compiled with numba for the points of one step.

`sklearn.cluster.DBSCAN(eps, min_samples).fit(X).labels_` spends longer than a whole MPPI step
on input validation, a tree and Python lists of neighbourhoods (docs/performance.md). This module
returns the same labels for Clustered MPPI's few features (2 to 15), following sklearn's
conventions:
- neighbours: points at squared Euclidean distance sum_f (x_f - y_f)^2 <= eps^2 (float64, summed
  over the features in order, as sklearn's KD-tree tests them; self included);
- core points: at least `min_samples` neighbours;
- labels: sklearn's `dbscan_inner` (sklearn/cluster/_dbscan_inner.pyx): points in index order,
  each unlabelled core point starts a new cluster that a depth-first search extends over its core
  neighbours and labels their non-core neighbours with; the rest is noise, -1.

Neighbourhoods come from cells of one feature x, of width a little over eps / 2: a neighbour's
gap in x alone is within eps (a larger gap makes the whole squared distance larger), so the
neighbours of a point in cell c lie in cells c - 2 .. c + 2, which a counting sort by cell makes
one window of consecutive positions. x is the feature whose cells hold the fewest candidate pairs
(counted from the histograms of cells). One sweep over the windows counts the neighbours and
joins the components of the core points (union-find); a second pass labels the non-core points.
Points spread over more than 4 eps per point or 10^6 eps in every feature, values that are not
finite and radii whose square is not a normal float (or bad parameters, which sklearn names) go
to sklearn.

sklearn tests distances this way in its KD-tree, which its NearestNeighbors picks for at most
15 features and n // 2 > 5 points (5: the default n_neighbors). Otherwise (brute force) it
computes distances as |x|^2 - 2 x.y + |y|^2 with BLAS, which rounds differently at eps, so
those inputs (tiny n, or more than 15 features) go to sklearn itself.

The kernels compile at the first call (about 8 s) and are cached on disk by numba
(`cache=True`: __pycache__ next to this file, or NUMBA_CACHE_DIR), so later processes load them.
tests/control/test_dbscan.py checks the labels against sklearn on many random inputs.
"""

import numbers

import numba
import numpy as np
from numba.core import types
from numba.extending import overload

KD_TREE_MIN_SAMPLES = 12  # sklearn.neighbors: n // 2 <= 5 points use brute force
KD_TREE_MAX_FEATURES = 15  # sklearn.neighbors: more features use brute force
SPLIT = 2  # cells of eps / SPLIT: neighbours are SPLIT cells away at most, windows 2.5 eps wide
CELL_MARGIN = 1e-9  # cells a little wider: rounding never puts a neighbour SPLIT + 1 cells away
MAX_CELLS_PER_POINT = 4  # spreads over more eps per point in every feature go to sklearn, as
MAX_CELLS = 10**6  # do those over more eps (cell indices round by less than 1e-9 of a cell then)
BLOCK = 32  # positions a vectorised loop takes at once (8 float64 of AVX-512, 4 interleaved)
_TINY = np.finfo(float).tiny  # the least normal float64


def dbscan(X, eps, min_samples):
    """Cluster labels of the rows of X, identical to sklearn.cluster.DBSCAN(eps, min_samples).

    Args:
      X: (n, d) features.
      eps: neighbourhood radius (> 0).
      min_samples: neighbours (self included) that make a core point.
    Returns:
      (n,) int labels, -1 for noise.
    """
    n, d = np.shape(X)
    if n == 0:
        return np.full(0, -1, dtype=np.intp)
    real, integral = (float, numbers.Real), (int, numbers.Integral)  # the builtins checked first
    valid = isinstance(eps, real) and isinstance(min_samples, integral)
    eps2 = float(eps) * float(eps) if valid and eps > 0 and min_samples >= 1 else np.nan
    # eps^2 must be a normal number: a subnormal, 0 or inf square passes gaps beyond eps
    if n < KD_TREE_MIN_SAMPLES or d > KD_TREE_MAX_FEATURES or not _TINY <= eps2 < np.inf:
        return _sklearn(X, eps, min_samples)  # which also names bad parameters
    # counts never exceed n, so any larger min_samples acts as n + 1 (and fits an int64)
    ms = int(min(min_samples, n + 1))
    labels = _dbscan(np.asarray(X, dtype=np.float64), float(eps), eps2, ms)
    return labels if len(labels) else _sklearn(X, eps, min_samples)


def _sklearn(X, eps, min_samples):
    from sklearn.cluster import DBSCAN  # the rare fallback: scikit-learn loads in 0.5 s

    return DBSCAN(eps=eps, min_samples=min_samples).fit(X).labels_.astype(np.intp)


@numba.njit(cache=True)
def _dbscan(X, eps, eps2, min_samples):
    """Labels (n,) of the rows of X (n, d), or none (values not finite, or points too sparse for
    cells in every feature) for sklearn."""
    n = len(X)
    max_cells = min(MAX_CELLS_PER_POINT * n, MAX_CELLS)
    cells = _cells(X, 1.0 / (eps * (1.0 + CELL_MARGIN)), max_cells)
    if cells is None:
        return np.zeros(0, dtype=np.intp)
    F, order, start, end = cells
    if len(F) == 2:  # compiled apart, without partial sums
        return _clusters(F, start, end, eps2, min_samples, order, None)
    return _clusters(F, start, end, eps2, min_samples, order, np.empty(n))


@numba.njit(cache=True)
def _clusters(F, start, end, eps2, min_samples, order, d2):
    """Labels (n,) by original index of the points F (d, n) in cell order; d2: (n,) scratch for
    partial sums of squares, None for two features."""
    core, root = _components(F, start, end, eps2, min_samples, d2)
    return _labels(F, start, end, eps2, core, root, order, d2)


@numba.njit(cache=True)
def _cells(X, inv_width, max_cells):
    """Counting sort of the points X (n, d) by cell c = floor((x - min x) / width), width just
    over eps / SPLIT (1 / inv_width: just over eps), of the feature x whose cells hold the fewest
    candidate pairs (pairs of points at most SPLIT cells apart).

    Returns F (max(d, 2), n): the features of the points in cell order (cells ascending, original
    indices ascending within a cell; a row of zeros after a single feature), order (n,): their
    original indices, and the candidate neighbours of the point at position p: positions
    [start[p], end[p]), the cells c - SPLIT .. c + SPLIT (a neighbour's gap in x alone is within
    eps). None when a value is not finite or every feature spans more than max_cells times eps.
    """
    n, d = X.shape
    inv = inv_width * SPLIT
    fewest, cell, count = np.inf, np.empty(n, dtype=np.intp), np.empty(0, dtype=np.intp)
    c = np.empty(n, dtype=np.intp)
    for f in range(d):
        x = X[:, f]
        lo, hi, finite = np.inf, -np.inf, True
        for k in range(n):
            lo, hi = min(lo, x[k]), max(hi, x[k])
            finite &= x[k] - x[k] == 0.0  # not for inf or nan
        if not finite:
            return None
        if not (hi - lo) * inv_width <= max_cells:
            continue
        h = np.zeros(int((hi - lo) * inv) + 2 * SPLIT + 1, dtype=np.intp)  # cell c at c + SPLIT
        for k in range(n):
            c[k] = int((x[k] - lo) * inv)
            h[c[k] + SPLIT] += 1
        pairs, s = 0, h[: 2 * SPLIT].sum()  # s: points in the cells around j
        for j in range(SPLIT, len(h) - SPLIT):
            s += h[j + SPLIT]
            pairs += h[j] * s
            s -= h[j - SPLIT]
        if pairs < fewest:
            fewest, cell, c, count = pairs, c, cell, h
    if fewest == np.inf:
        return None
    below = np.zeros(len(count) + 1, dtype=np.intp)  # below[c]: points in cells < c - SPLIT
    for j in range(len(count)):
        below[j + 1] = below[j] + count[j]
    order = np.empty(n, dtype=np.intp)
    slot = below[SPLIT:].copy()  # next free position of each cell
    for k in range(n):
        order[slot[cell[k]]] = k
        slot[cell[k]] += 1
    F = np.zeros((max(d, 2), n))
    for f in range(d):
        for p in range(n):
            F[f, p] = X[order[p], f]
    start, end = np.empty(n, dtype=np.intp), np.empty(n, dtype=np.intp)
    for p in range(n):
        j = cell[order[p]]
        start[p] = below[j]
        end[p] = below[j + 2 * SPLIT + 1]
    return F, order, start, end


# The loops over windows below add, compare and select flags instead of branching on them: the
# pairs come in no predictable pattern, and mispredicted branches cost more than the arithmetic.
# They compute the squared distance over the last two features themselves, after the sums over
# the others that _head writes to d2 just before (one vectorised pass per feature). The helpers
# below are compiled apart for two features (d2 None: no partial sums), whose short windows are
# also widened to whole BLOCKs, into cells farther away (no neighbours there), so that no scalar
# loop takes the remainder; for more features the windows are long and widening costs more.


def _blocks(w, d2):
    """w positions, rounded up to whole BLOCKs for two features (d2 None)."""


def _head(F, p, lo, hi, d2):
    """d2[:hi - lo] = squared distances from the point at position p to those at lo .. hi - 1
    over the features but the last two, summed in order as sklearn does; nothing for d2 None."""


def _sq(d2, i, dx, dy):
    """Squared distance (d2[i] + dx^2) + dy^2, in sklearn's order; dx^2 + dy^2 for d2 None."""


@overload(_blocks, inline="always")
def _blocks_typed(w, d2):
    if isinstance(d2, types.NoneType):
        return lambda w, d2: (w + BLOCK - 1) // BLOCK * BLOCK
    return lambda w, d2: w


@overload(_head, inline="always")
def _head_typed(F, p, lo, hi, d2):
    if isinstance(d2, types.NoneType):
        return lambda F, p, lo, hi, d2: None

    def head(F, p, lo, hi, d2):
        w = hi - lo
        x, xp = F[0, lo:hi], F[0, p]
        for i in range(w):
            dx = x[i] - xp
            d2[i] = dx * dx
        for f in range(1, F.shape[0] - 2):
            x, xp = F[f, lo:hi], F[f, p]
            for i in range(w):
                dx = x[i] - xp
                d2[i] += dx * dx

    return head


@overload(_sq, inline="always")
def _sq_typed(d2, i, dx, dy):
    if isinstance(d2, types.NoneType):
        return lambda d2, i, dx, dy: dx * dx + dy * dy
    return lambda d2, i, dx, dy: (d2[i] + dx * dx) + dy * dy


@numba.njit(inline="always")
def _dist2(F, p, q):
    """Squared distance of the points at positions p and q, summed over the features in order."""
    s = 0.0
    for f in range(F.shape[0]):
        dx = F[f, q] - F[f, p]
        s += dx * dx
    return s


@numba.njit(inline="always")
def _find(parent, i):
    """Root of i in the union-find forest `parent`, halving the path on the way."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(cache=True)
def _components(F, start, end, eps2, min_samples, d2):
    """Core flags (n,) and roots (n,) of the points at every position: connected components of
    the core points (neighbour pairs of two core points), other points are their own root.

    One sweep over the positions in order: point p counts its neighbours below it in its window
    (and above, unless that already makes it core) and, if core, joins the components of its core
    neighbours below it (so every pair of core points is met once, from its upper position).
    Those usually all have one parent: the loop over the window finds the least and the greatest,
    writing nothing; only where they differ (components meeting, rare) a second loop unions their
    roots. p - 1 is left out of that loop and tested alone: its flag and parent were written just
    before, and a vector load of them would wait.
    """
    d, n = F.shape
    x, y = F[d - 2], F[d - 1]
    core, parent = np.zeros(n, dtype=np.bool_), np.arange(n)
    for p in range(n):
        mid = max(start[p], p - 1)
        lo = max(0, mid - _blocks(mid - start[p], d2))
        hi = min(n, mid + _blocks(end[p] - mid, d2))
        _head(F, p, lo, mid, d2)
        xp, yp = x[p], y[p]
        xw, yw, cw, pw = x[lo:mid], y[lo:mid], core[lo:mid], parent[lo:mid]
        c, least, most = 0, n, -1  # below p - 1: neighbours, least and greatest parent of cores
        for i in range(mid - lo):
            near = _sq(d2, i, xw[i] - xp, yw[i] - yp) <= eps2
            c += near
            join = near & cw[i]
            least = min(least, pw[i] if join else n)
            most = max(most, pw[i] if join else -1)
        if c + 1 < min_samples:  # not core with p itself: the neighbours from p - 1 on
            _head(F, p, mid, hi, d2)
            xw, yw = x[mid:hi], y[mid:hi]
            for i in range(hi - mid):
                c += _sq(d2, i, xw[i] - xp, yw[i] - yp) <= eps2
            if c < min_samples:
                continue
        core[p] = True
        if mid < p and core[mid] and _dist2(F, p, mid) <= eps2:
            least, most = min(least, parent[mid]), max(most, parent[mid])
        if least == most:
            parent[p] = _find(parent, least)
        elif least < most:  # p joins several trees: union of their roots, the least stays
            for q in range(start[p], p):
                if core[q] and _dist2(F, p, q) <= eps2:
                    rp, rq = _find(parent, p), _find(parent, q)
                    parent[max(rp, rq)] = min(rp, rq)
    for p in range(n):
        parent[p] = _find(parent, p)
    return core, parent


@numba.njit(cache=True)
def _labels(F, start, end, eps2, core, root, order, d2):
    """sklearn's dbscan_inner labels from the components, without its depth-first search.

    dbscan_inner scans the points in original index order and labels a whole component (its core
    points and every unlabelled neighbour of them) when it meets the component's first core
    point. So clusters are numbered in the order of their lowest original core index, and a
    non-core point takes the lowest-numbered cluster among its core neighbours (the first that
    reached it), else -1. Returns labels by original index.
    """
    d, n = F.shape
    # Flags select values instead of guarding branches (core and non-core points alternate
    # unpredictably); index n is a scratch entry.
    first = np.full(n + 1, n)  # per root: the lowest original index of its component's cores
    for p in range(n):
        first[root[p]] = min(first[root[p]], order[p] if core[p] else n)
    number = np.full(n + 1, -1)  # per original index: the number of the cluster it starts
    for p in range(n):
        number[first[p]] = 0  # first[p] < n only for the root of a component
    clusters = 0
    for i in range(n):
        starts = number[i] == 0
        number[i] = clusters if starts else number[i]
        clusters += starts
    label = np.empty(n, dtype=np.intp)  # per position: its cluster number if core, else n
    labels = np.empty(n, dtype=np.intp)
    outside = np.empty(n, dtype=np.intp)  # positions of the non-core points
    m = 0
    for p in range(n):
        label[p] = number[first[root[p]]] if core[p] else n
        labels[order[p]] = label[p] if core[p] else -1
        outside[m] = p
        m += not core[p]
    x, y = F[d - 2], F[d - 1]
    for p in outside[:m]:  # the least label of its core neighbours
        lo = start[p]
        hi = min(n, lo + _blocks(end[p] - lo, d2))
        _head(F, p, lo, hi, d2)
        xw, yw, lw = x[lo:hi], y[lo:hi], label[lo:hi]
        least = n
        for i in range(hi - lo):
            least = min(least, lw[i] if _sq(d2, i, xw[i] - x[p], yw[i] - y[p]) <= eps2 else n)
        labels[order[p]] = least if least < n else -1
    return labels
