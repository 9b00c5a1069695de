"""DBSCAN with scikit-learn's exact labels, compiled with numba for the 2-D points of one step.

`sklearn.cluster.DBSCAN(eps, min_samples).fit(X).labels_` takes about 2.5 ms for K = 500 points
(input validation, a tree, Python lists of neighbourhoods), more than a whole MPPI step. This
module returns the same labels for two features (Clustered MPPI's) in a few tens of
microseconds, following sklearn's conventions:
- neighbours: points at squared Euclidean distance (x_0 - y_0)^2 + (x_1 - y_1)^2 <= eps^2
  (float64, summed over the features in order, as sklearn's KD-tree tests them; self included);
- core points: at least `min_samples` neighbours;
- labels: sklearn's `dbscan_inner` (sklearn/cluster/_dbscan_inner.pyx): points in index order,
  each unlabelled core point starts a new cluster that a depth-first search extends over its core
  neighbours and labels their non-core neighbours with; the rest is noise, -1.

Neighbourhoods come from sorting on the first feature: the neighbours of sorted point p lie
within the window of points whose first-feature gap g has g * g <= eps^2 (a larger gap makes the
whole squared distance larger). Three passes over the windows: neighbour counts, components of
the core points (union-find), labels of the non-core points.

sklearn tests distances this way in its KD-tree, which its NearestNeighbors picks for at most
15 features and n // 2 > 5 points (5: the default n_neighbors). Otherwise (brute force) it
computes distances as |x|^2 - 2 x.y + |y|^2 with BLAS, which rounds differently at eps, so
those inputs (tiny n), and other numbers of features (the N + 1 of time-varying perturbations),
go to sklearn itself.

The kernels compile at the first call (a few seconds) and are cached on disk by numba
(`cache=True`: __pycache__ next to this file, or NUMBA_CACHE_DIR), so later processes load them.
tests/test_dbscan.py checks the labels against sklearn on many random inputs.
"""

import numba
import numpy as np
from sklearn.cluster import DBSCAN

KD_TREE_MIN_SAMPLES = 12  # sklearn.neighbors: n // 2 <= 5 points use brute force


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
    if n < KD_TREE_MIN_SAMPLES or d != 2:
        return DBSCAN(eps=eps, min_samples=min_samples).fit(X).labels_.astype(np.intp)
    X = np.asarray(X, dtype=np.float64)
    order = np.argsort(X[:, 0])  # numpy's sort: several times faster than numba's
    x, y = X[:, 0].take(order), X[:, 1].take(order)
    return _dbscan(x, y, order, float(eps) * float(eps), int(min_samples))


@numba.njit(cache=True)
def _dbscan(x, y, order, eps2, min_samples):
    """Labels (n,) by original index of 2-D points (x, y) sorted by x, (x[p], y[p]) =
    X[order[p]]. The labels do not depend on how ties in x are ordered."""
    start, end = _windows(x, eps2)
    core = _neighbour_counts(x, y, start, end, eps2) >= min_samples
    root = _components(x, y, end, eps2, core)
    return _labels(x, y, start, end, eps2, core, root, order)


@numba.njit(cache=True)
def _windows(x, eps2):
    """The candidate neighbours of sorted point p: positions [start[p], end[p]) (p included),
    the points whose gap in x alone is within eps. (x_p - x_s)^2 <= eps2 is symmetric and
    monotone in the gap, so start[p] is the first s whose window reaches p: the number of
    windows that end at or before p."""
    n = len(x)
    end = np.empty(n, dtype=np.intp)
    q = 0
    for p in range(n):
        q = max(q, p + 1)
        while q < n and (x[q] - x[p]) * (x[q] - x[p]) <= eps2:
            q += 1
        end[p] = q
    start = np.zeros(n + 1, dtype=np.intp)  # start[p] = #{s: end[s] <= p}, without branches
    for s in range(n):
        start[end[s]] += 1
    for p in range(n):
        start[p + 1] += start[p]
    return start[:n], end


# The loops over windows below index slices from 0 (numba then knows the index is not negative
# and vectorises the loop) and add or compare flags instead of branching on them: the pairs come
# in no predictable pattern, and mispredicted branches cost more than the arithmetic.


@numba.njit(inline="always")
def _near(xp, yp, x, y, i, eps2):
    """(xp - x_i)^2 + (yp - y_i)^2 <= eps^2, summed in feature order as sklearn does."""
    dx = xp - x[i]
    dy = yp - y[i]
    return dx * dx + dy * dy <= eps2


@numba.njit(cache=True)
def _neighbour_counts(x, y, start, end, eps2):
    """(n,) neighbours of every sorted point, self included."""
    n = len(x)
    count = np.empty(n, dtype=np.intp)
    for p in range(n):
        xw, yw = x[start[p] : end[p]], y[start[p] : end[p]]
        c = 0
        for i in range(len(xw)):
            c += _near(x[p], y[p], xw, yw, i, eps2)
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
def _components(x, y, end, eps2, core):
    """(n,) root of every sorted point: connected components of the core points (neighbour
    pairs of two core points join; the lower root stays), other points are their own root.

    Sweeping in x order, core point p joins the core neighbours q > p in its window. A q that
    is still a singleton (parent[q] == q: no earlier point reached it) simply takes p's root, in
    the same vectorised pass that counts the neighbours already joined to another node; only
    those (two trees meeting, rare) need a second pass with finds and unions.
    """
    n = len(x)
    parent = np.arange(n)
    for p in range(n):
        if not core[p]:
            continue
        rp = _find(parent, p)
        lo = p + 1
        xw, yw, cw, pw = x[lo : end[p]], y[lo : end[p]], core[lo : end[p]], parent[lo : end[p]]
        m = 0
        for i in range(len(xw)):
            join = _near(x[p], y[p], xw, yw, i, eps2) & cw[i]
            single = pw[i] == lo + i
            m += join & (not single) & (pw[i] != rp)
            pw[i] = rp if join & single else pw[i]
        if m == 0:
            continue
        for i in range(len(xw)):
            if cw[i] and pw[i] != rp and _near(x[p], y[p], xw, yw, i, eps2):
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
def _labels(x, y, start, end, eps2, core, root, order):
    """sklearn's dbscan_inner labels from the components, without its depth-first search.

    dbscan_inner scans the points in original index order and labels a whole component (its core
    points and every unlabelled neighbour of them) when it meets the component's first core
    point. So clusters are numbered in the order of their lowest original core index, and a
    non-core point takes the lowest-numbered cluster among its core neighbours (the first that
    reached it), else -1. Returns labels by original index.
    """
    n = len(x)
    first = np.full(n, n)  # per root: the lowest original index of its component's core points
    for p in range(n):
        if core[p]:
            first[root[p]] = min(first[root[p]], order[p])
    number = np.full(n, -1)  # per original index: the number of the cluster it starts
    for p in range(n):
        if core[p] and root[p] == p:
            number[first[p]] = 0
    clusters = 0
    for i in range(n):
        if number[i] == 0:
            number[i] = clusters
            clusters += 1
    label = np.full(n, n)  # per sorted point: its cluster number if core, else n
    for p in range(n):
        if core[p]:
            label[p] = number[first[root[p]]]
    labels = np.empty(n, dtype=np.intp)
    for p in range(n):
        least = label[p]
        if not core[p]:  # the least label of its core neighbours
            xw, yw, lw = x[start[p] : end[p]], y[start[p] : end[p]], label[start[p] : end[p]]
            for i in range(len(xw)):
                least = min(least, lw[i] if _near(x[p], y[p], xw, yw, i, eps2) else n)
        labels[order[p]] = least if least < n else -1
    return labels
