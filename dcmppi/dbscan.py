"""DBSCAN with scikit-learn's exact labels, compiled with numba for the points of one step.

`sklearn.cluster.DBSCAN(eps, min_samples).fit(X).labels_` takes about 2.5 ms for K = 500 points
(input validation, a tree, Python lists of neighbourhoods), more than a whole MPPI step. This
module returns the same labels in a few tens of microseconds, following sklearn's conventions:
- neighbours: points at squared Euclidean distance sum_d (x_d - y_d)^2 <= eps^2 (float64, summed
  over the features in order, as sklearn's KD-tree tests them; self included);
- core points: at least `min_samples` neighbours;
- labels: sklearn's `dbscan_inner` (sklearn/cluster/_dbscan_inner.pyx): points in index order,
  each unlabelled core point starts a new cluster that a depth-first search extends over its core
  neighbours and labels their non-core neighbours with; the rest is noise, -1.

Neighbourhoods come from sorting on the first feature: the neighbours after sorted position i
lie within the window of followers whose first-feature gap g has g * g <= eps^2 (a larger gap
makes the whole squared distance larger), so a pass over those windows finds every pair once.

sklearn tests distances this way in its KD-tree, which its NearestNeighbors picks for at most
15 features and n // 2 > 5 points (5: the default n_neighbors). Otherwise (brute force) it
computes distances as |x|^2 - 2 x.y + |y|^2 with BLAS, which rounds differently at eps, so
those inputs (tiny n, or the N + 1 features of time-varying perturbations) go to sklearn itself.

The kernels compile at the first call (about a second) and are cached on disk by numba
(`cache=True`: __pycache__ next to this file, or NUMBA_CACHE_DIR), so later processes load them.
tests/test_dbscan.py checks the labels against sklearn on many random inputs.
"""

import numba
import numpy as np
from sklearn.cluster import DBSCAN

KD_TREE_MAX_FEATURES = 15  # sklearn.neighbors: more features, or n // 2 <= 5, use brute force
KD_TREE_MIN_SAMPLES = 12


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
    if n < KD_TREE_MIN_SAMPLES or d > KD_TREE_MAX_FEATURES:  # sklearn's brute-force distances
        return DBSCAN(eps=eps, min_samples=min_samples).fit(X).labels_.astype(np.intp)
    columns = np.ascontiguousarray(np.asarray(X, dtype=np.float64).T)  # (d, n), no copy for F
    return _dbscan(columns, float(eps) * float(eps), int(min_samples))


@numba.njit(cache=True)
def _dbscan(columns, eps2, min_samples):
    """Labels (n,) of the n points whose (d, n) C-contiguous coordinates are `columns`."""
    n = columns.shape[1]
    order = np.argsort(columns[0], kind="mergesort")
    xs = np.empty((n, columns.shape[0]))  # sorted points, one row each
    for p in range(n):
        xs[p] = columns[:, order[p]]
    u, v, count = _pairs(xs, order, eps2)
    core = count >= min_samples
    root = _components(core, u, v)
    return _labels(core, root, u, v)


@numba.njit(cache=True)
def _pairs(xs, order, eps2):
    """Neighbour pairs among the (n, d) points xs sorted by their first feature.

    Args:
      xs: (n, d) sorted points. order: (n,) their original indices.
    Returns:
      u, v: (pairs,) original indices of each pair (once, self excluded);
      count: (n,) neighbours of each original index, self included.
    """
    n, d = xs.shape
    # Windows [p + 1, end[p]) of followers whose first-feature gap alone is within eps.
    end = np.empty(n, dtype=np.intp)
    q = 0
    for p in range(n):
        q = max(q, p + 1)
        while q < n and (xs[q, 0] - xs[p, 0]) * (xs[q, 0] - xs[p, 0]) <= eps2:
            q += 1
        end[p] = q
    candidates = 0
    for p in range(n):
        candidates += end[p] - p - 1
    u = np.empty(candidates, dtype=np.intp)
    v = np.empty(candidates, dtype=np.intp)
    count = np.ones(n, dtype=np.intp)
    m = 0
    for p in range(n):
        for q in range(p + 1, end[p]):
            dist2 = 0.0
            for k in range(d):
                diff = xs[p, k] - xs[q, k]
                dist2 += diff * diff
            if dist2 <= eps2:
                u[m] = order[p]
                v[m] = order[q]
                count[order[p]] += 1
                count[order[q]] += 1
                m += 1
    return u[:m], v[:m], count


@numba.njit(cache=True)
def _find(parent, i):
    """Root of i in the union-find forest `parent`, halving the path on the way."""
    while parent[i] != i:
        parent[i] = parent[parent[i]]
        i = parent[i]
    return i


@numba.njit(cache=True)
def _components(core, u, v):
    """Connected components of the core points over the pairs (u, v): (n,) roots, each the
    lowest index of its component (a union always keeps the lower root)."""
    parent = np.arange(len(core))
    for m in range(len(u)):
        if core[u[m]] and core[v[m]] and parent[u[m]] != parent[v[m]]:
            ru, rv = _find(parent, u[m]), _find(parent, v[m])
            if ru < rv:
                parent[rv] = ru
            elif rv < ru:
                parent[ru] = rv
    for i in range(len(core)):
        parent[i] = _find(parent, i)
    return parent


@numba.njit(cache=True)
def _labels(core, root, u, v):
    """sklearn's dbscan_inner labels from the components, without its depth-first search.

    dbscan_inner scans the points in index order and labels a whole component (its core points
    and every unlabelled neighbour of them) when it meets the component's first core point. So
    clusters are numbered by their lowest core index (`root`), and a non-core point takes the
    lowest-numbered cluster among its core neighbours (the first that reached it), else -1.
    """
    n = len(core)
    labels = np.full(n, n, dtype=np.intp)  # n: not (yet) in a cluster
    clusters = 0
    for i in range(n):
        if core[i]:
            if root[i] == i:
                labels[i] = clusters
                clusters += 1
            else:
                labels[i] = labels[root[i]]  # root[i] < i: labelled already
    for m in range(len(u)):
        a, b = u[m], v[m]
        if core[a] and not core[b]:
            labels[b] = min(labels[b], labels[a])
        elif core[b] and not core[a]:
            labels[a] = min(labels[a], labels[b])
    for i in range(n):
        if labels[i] == n:
            labels[i] = -1
    return labels
