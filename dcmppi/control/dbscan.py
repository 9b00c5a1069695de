"""DBSCAN with scikit-learn's exact labels, compiled with numba for the points of one step.

`sklearn.cluster.DBSCAN(eps, min_samples).fit(X).labels_` takes about 2.5 ms for K = 500 points
(input validation, a tree, Python lists of neighbourhoods), more than a whole MPPI step. This
module returns the same labels for Clustered MPPI's few features (2 to 15) in a few tens of
microseconds, following sklearn's conventions:
- neighbours: points at squared Euclidean distance sum_f (x_f - y_f)^2 <= eps^2 (float64, summed
  over the features in order, as sklearn's KD-tree tests them; self included);
- core points: at least `min_samples` neighbours;
- labels: sklearn's `dbscan_inner` (sklearn/cluster/_dbscan_inner.pyx): points in index order,
  each unlabelled core point starts a new cluster that a depth-first search extends over its core
  neighbours and labels their non-core neighbours with; the rest is noise, -1.

Neighbourhoods come from cells of the first feature, a little wider than eps: a neighbour's gap
in the first feature alone is within eps (a larger gap makes the whole squared distance larger),
so the neighbours of a point in cell c lie in cells c - 1 .. c + 1, which a counting sort by cell
makes one window of consecutive positions. Three passes over the windows: neighbour counts,
components of the core points (union-find), labels of the non-core points. Points spread over
more than 4 cells per point or 10^6 cells, values that are not finite and radii whose square
is not a normal float (or bad parameters, which sklearn names) go to sklearn.

sklearn tests distances this way in its KD-tree, which its NearestNeighbors picks for at most
15 features and n // 2 > 5 points (5: the default n_neighbors). Otherwise (brute force) it
computes distances as |x|^2 - 2 x.y + |y|^2 with BLAS, which rounds differently at eps, so
those inputs (tiny n, or more than 15 features) go to sklearn itself.

The kernels compile at the first call (a few seconds) and are cached on disk by numba
(`cache=True`: __pycache__ next to this file, or NUMBA_CACHE_DIR), so later processes load them.
tests/test_dbscan.py checks the labels against sklearn on many random inputs.
"""

import numbers

import numba
import numpy as np
from sklearn.cluster import DBSCAN

KD_TREE_MIN_SAMPLES = 12  # sklearn.neighbors: n // 2 <= 5 points use brute force
KD_TREE_MAX_FEATURES = 15  # sklearn.neighbors: more features use brute force
CELL_MARGIN = 1e-9  # cells a little wider than eps: rounding never puts a neighbour two away
MAX_CELLS_PER_POINT = 4  # sparser points (far apart in x) go to sklearn, as do more cells than
MAX_CELLS = 10**6  # (cell indices then round by less than 1e-9 of a cell, within the margin)
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
    valid = isinstance(eps, numbers.Real) and isinstance(min_samples, numbers.Integral)
    eps2 = float(eps) * float(eps) if valid and eps > 0 and min_samples >= 1 else np.nan
    # eps^2 must be a normal number: a subnormal, 0 or inf square passes gaps beyond eps
    if n < KD_TREE_MIN_SAMPLES or d > KD_TREE_MAX_FEATURES or not _TINY <= eps2 < np.inf:
        return _sklearn(X, eps, min_samples)  # which also names bad parameters
    F = np.ascontiguousarray(np.asarray(X, dtype=np.float64).T)  # (d, n): one row per feature
    lo, span = _extent(F)
    width = float(eps) * (1.0 + CELL_MARGIN)
    if not span / width <= min(MAX_CELLS_PER_POINT * n, MAX_CELLS):
        return _sklearn(X, eps, min_samples)  # non-finite values, or too sparse for cells
    # counts never exceed n, so any larger min_samples acts as n + 1 (and fits an int64)
    return _dbscan(F, lo, 1.0 / width, eps2, int(min(min_samples, n + 1)))


def _sklearn(X, eps, min_samples):
    return DBSCAN(eps=eps, min_samples=min_samples).fit(X).labels_.astype(np.intp)


@numba.njit(cache=True)
def _extent(F):
    """min and max - min of the first feature F[0]; the span is nan when any value of F is not
    finite. F: (d, n)."""
    x = F[0]
    lo, hi, finite = np.inf, -np.inf, 0.0
    for k in range(len(x)):
        lo, hi = min(lo, x[k]), max(hi, x[k])
    for f in range(F.shape[0]):
        for k in range(len(x)):
            finite += F[f, k] - F[f, k]  # nan for inf or nan
    return lo, hi - lo + finite


@numba.njit(cache=True)
def _dbscan(F, lo, inv_width, eps2, min_samples):
    """Labels (n,) by original index of the points F (d, n), grouped in cells of F[0]."""
    order, start, end = _cells(F[0], lo, inv_width)
    F = F[:, order]
    core = _neighbour_counts(F, start, end, eps2) >= min_samples
    root = _components(F, end, eps2, core)
    return _labels(F, start, end, eps2, core, root, order)


@numba.njit(cache=True)
def _cells(x, lo, inv_width):
    """Counting sort of the points by cell c = floor((x - lo) / width) of x, width just over eps.

    Returns order (n,): original index of every position (cells ascending, original indices
    ascending within a cell), and the candidate neighbours of the point at position p:
    positions [start[p], end[p]), the cells c - 1 .. c + 1 (a neighbour's gap in x alone is
    within eps, so it is at most one cell away).
    """
    n = len(x)
    cell = np.empty(n, dtype=np.intp)
    for k in range(n):
        cell[k] = int((x[k] - lo) * inv_width)
    below = np.zeros(cell.max() + 4, dtype=np.intp)  # below[c]: points in cells < c - 1
    for k in range(n):
        below[cell[k] + 2] += 1
    for c in range(len(below) - 1):
        below[c + 1] += below[c]
    order = np.empty(n, dtype=np.intp)
    slot = below[1:].copy()  # next free position of each cell
    for k in range(n):
        order[slot[cell[k]]] = k
        slot[cell[k]] += 1
    start, end = np.empty(n, dtype=np.intp), np.empty(n, dtype=np.intp)
    for p in range(n):
        c = cell[order[p]]
        start[p] = below[c]
        end[p] = below[c + 3]
    return order, start, end


# The loops over windows below add or compare flags instead of branching on them: the pairs come
# in no predictable pattern, and mispredicted branches cost more than the arithmetic.


@numba.njit(inline="always")
def _distances(F, p, lo, hi, d2):
    """d2[:hi - lo] = squared distances from the point at position p to those at lo .. hi - 1,
    summed over the features in order as sklearn does (for two features the same operations as
    dx * dx + dy * dy); one vectorised pass per feature. F: (d, n)."""
    w = hi - lo
    x, xp = F[0, lo:hi], F[0, p]
    for i in range(w):
        dx = x[i] - xp
        d2[i] = dx * dx
    for f in range(1, F.shape[0]):
        x, xp = F[f, lo:hi], F[f, p]
        for i in range(w):
            dx = x[i] - xp
            d2[i] += dx * dx
    return d2[:w]


@numba.njit(cache=True)
def _neighbour_counts(F, start, end, eps2):
    """(n,) neighbours of the point at every position, self included. F: (d, n)."""
    n = F.shape[1]
    count = np.empty(n, dtype=np.intp)
    d2 = np.empty(n)
    for p in range(n):
        dw = _distances(F, p, start[p], end[p], d2)
        c = 0
        for i in range(len(dw)):
            c += dw[i] <= eps2
        count[p] = c
    return count


@numba.njit(inline="always")
def _find(parent, i):
    """Root of i in the union-find forest `parent`, halving the path on the way."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(cache=True)
def _components(F, end, eps2, core):
    """(n,) root of the point at every position: connected components of the core points
    (neighbour pairs of two core points join; the lower root stays), other points are their own.

    Sweeping the positions in order, core point p joins the core neighbours q > p in its window
    (so every pair is met once, from its lower position). A q that
    is still a singleton (parent[q] == q: no earlier point reached it) simply takes p's root, in
    the same vectorised pass that counts the neighbours already joined to another node; only
    those (two trees meeting, rare) need a second pass with finds and unions.
    """
    n = F.shape[1]
    parent = np.arange(n)
    d2 = np.empty(n)
    for p in range(n):
        if not core[p]:
            continue
        rp = _find(parent, p)
        lo = p + 1
        dw = _distances(F, p, lo, end[p], d2)
        cw, pw = core[lo : end[p]], parent[lo : end[p]]
        m = 0
        for i in range(len(dw)):
            join = (dw[i] <= eps2) & cw[i]
            single = pw[i] == lo + i
            m += join & (not single) & (pw[i] != rp)
            pw[i] = rp if join & single else pw[i]
        if m == 0:
            continue
        for i in range(len(dw)):
            if cw[i] and pw[i] != rp and dw[i] <= eps2:
                rq = _find(parent, lo + i)
                if rq < rp:
                    parent[rp] = rq
                    rp = rq
                elif rq > rp:
                    parent[rq] = rp
    for p in range(n):
        parent[p] = _find(parent, p)
    return parent


@numba.njit(cache=True)
def _labels(F, start, end, eps2, core, root, order):
    """sklearn's dbscan_inner labels from the components, without its depth-first search.

    dbscan_inner scans the points in original index order and labels a whole component (its core
    points and every unlabelled neighbour of them) when it meets the component's first core
    point. So clusters are numbered in the order of their lowest original core index, and a
    non-core point takes the lowest-numbered cluster among its core neighbours (the first that
    reached it), else -1. Returns labels by original index.
    """
    n = F.shape[1]
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
    outside = np.empty(n, dtype=np.intp)  # positions of the non-core points
    m = 0
    for p in range(n):
        label[p] = number[first[root[p]]] if core[p] else n
        outside[m] = p
        m += not core[p]
    labels = np.empty(n, dtype=np.intp)
    for p in range(n):
        labels[order[p]] = label[p] if core[p] else -1
    d2 = np.empty(n)
    for p in outside[:m]:  # the least label of its core neighbours
        dw = _distances(F, p, start[p], end[p], d2)
        lw = label[start[p] : end[p]]
        least = n
        for i in range(len(dw)):
            least = min(least, lw[i] if dw[i] <= eps2 else n)
        labels[order[p]] = least if least < n else -1
    return labels
