"""DBSCAN with scikit-learn's exact labels, vectorised for the few hundred points of one step.

`sklearn.cluster.DBSCAN(eps, min_samples).fit(X).labels_` takes about 2.5 ms for K = 500 points
(input validation, a tree, Python lists of neighbourhoods), more than a whole MPPI step. This
module returns the same labels in a small fraction of that. Neighbours are points at Euclidean
distance <= eps (self included), tested as sum_d (x_d - y_d)^2 <= eps^2 like sklearn's trees;
core points have at least `min_samples` neighbours; clusters are the connected components of
core points, numbered by their lowest original index (the order of sklearn's scan); a border
point joins the lowest-numbered cluster among its core neighbours (the first cluster that reaches
it in sklearn); everything else is noise, -1.

Two features (Clustered MPPI with constant perturbations: eps_k / sigma and the clipped scaled
cost), `_dbscan_2d`: most samples sit exactly at the cost clip, so the points form "levels" of
equal second feature. A level of at least MIN_LEVEL points is a 1-D problem: neighbour ranges
come from binary search, its core points connect in runs of consecutive core points (no pair
lists). The remaining points and the few pairs between them and the levels are explicit pair
lists from a band search in the second feature. Cost O(K log K + pairs outside the levels).

Other dimensions, `_dbscan_band`: after sorting by the first feature, the neighbours of point i
lie among the next `width` points; components by min-label propagation over that band.

tests/test_clustered.py checks the labels against sklearn on many random inputs.
"""

import numpy as np

MIN_LEVEL = 8  # points with one equal second feature handled as a 1-D level
_WIDEN = 1.0 + 1e-9  # binary-search margins: a superset of candidates, then the exact test


def dbscan(X, eps, min_samples):
    """Cluster labels of the rows of X, identical to sklearn.cluster.DBSCAN(eps, min_samples).

    Args:
      X: (n, d) features.
      eps: neighbourhood radius (> 0).
      min_samples: neighbours (self included) that make a core point.
    Returns:
      (n,) int labels, -1 for noise.
    """
    X = np.asarray(X, dtype=float)
    if len(X) == 0:
        return np.full(0, -1, dtype=np.intp)
    if X.shape[1] == 2:
        return _dbscan_2d(X, eps, min_samples)
    return _dbscan_band(X, eps, min_samples)


def _dbscan_2d(X, eps, min_samples):
    """dbscan for (n, 2) X, n >= 1: levels of equal X[:, 1] plus explicit pairs elsewhere."""
    n = len(X)
    eps2 = eps * eps
    order = np.lexsort((X[:, 0], X[:, 1]))  # by b = X[:, 1], then a = X[:, 0]
    a, b = X[order, 0], X[order, 1]
    idx = np.arange(n)
    cut = np.flatnonzero(b[1:] != b[:-1]) + 1
    starts, ends = np.concatenate([[0], cut]), np.concatenate([cut, [n]])
    big = np.flatnonzero(ends - starts >= MIN_LEVEL)
    levels = list(zip(starts[big].tolist(), ends[big].tolist(), strict=True))
    on_level = np.zeros(n, dtype=bool)
    for s, e in levels:
        on_level[s:e] = True
    # Neighbours: own-level ranges [lo, hi) (just self off the levels) and explicit pairs (u, v).
    lo, hi = idx.copy(), idx + 1
    pairs = [_free_pairs(a, b, np.flatnonzero(~on_level), eps, eps2)]
    for s, e in levels:
        lo[s:e], hi[s:e] = _level_ranges(a[s:e], eps2, s)
        below = np.searchsorted(b, b[s] - eps * _WIDEN, "left")
        above = np.searchsorted(b, b[s] + eps * _WIDEN, "right")
        near = np.concatenate([np.arange(below, s), np.flatnonzero(~on_level[e:above]) + e])
        pairs.append(_level_pairs(a, b, near, s, e, eps2))
    u = np.concatenate([p[0] for p in pairs])
    v = np.concatenate([p[1] for p in pairs])
    count = hi - lo + np.bincount(u, minlength=n) + np.bincount(v, minlength=n)
    core = count >= min_samples
    labels = np.full(n, -1, dtype=np.intp)
    if not core.any():
        return labels
    # Clusters: runs of consecutive core points on each level (one node each, `rep`), joined
    # by the explicit core-core pairs.
    rep = idx.copy()
    for s, e in levels:
        c = np.flatnonzero(core[s:e]) + s
        new_run = np.ones(len(c), dtype=bool)
        new_run[1:] = (a[c[1:]] - a[c[:-1]]) ** 2 > eps2
        rep[c] = c[np.maximum.accumulate(np.where(new_run, np.arange(len(c)), 0))]
    cc = core[u] & core[v]
    root = _components(n, rep[u[cc]], rep[v[cc]])[rep]
    sorted_labels = _number(root, core, order)
    # Border points: the lowest cluster among core neighbours, from the pairs and the levels.
    lab = np.where(core, sorted_labels, n)
    border = np.full(n, n, dtype=np.intp)
    np.minimum.at(border, v, lab[u])
    np.minimum.at(border, u, lab[v])
    prev_core = np.maximum.accumulate(np.where(core, idx, -1))
    next_core = np.minimum.accumulate(np.where(core, idx, n)[::-1])[::-1]
    left = prev_core >= lo  # within the own-level range (self-only off the levels)
    right = next_core < hi
    np.minimum(border, np.where(left, lab[np.maximum(prev_core, 0)], n), out=border)
    np.minimum(border, np.where(right, lab[np.minimum(next_core, n - 1)], n), out=border)
    is_border = ~core & (border < n)
    sorted_labels[is_border] = border[is_border]
    labels[order] = sorted_labels
    return labels


def _level_ranges(al, eps2, offset):
    """Neighbour ranges [lo, hi) + offset of every point of a level (sorted values al)."""
    pad = np.sqrt(eps2) * _WIDEN + 1e-6 * np.sqrt(eps2)
    lo = np.searchsorted(al, al - pad, "left")
    hi = np.searchsorted(al, al + pad, "right")
    last = len(al) - 1
    while True:  # trim candidates outside the exact test (rare: within 1e-6 eps of the edge)
        bad_lo = (al[np.minimum(lo, last)] - al) ** 2 > eps2
        bad_hi = (al[hi - 1] - al) ** 2 > eps2
        if not (bad_lo.any() or bad_hi.any()):
            return lo + offset, hi + offset
        lo += bad_lo
        hi -= bad_hi


def _level_pairs(a, b, near, s, e, eps2):
    """Neighbour pairs (near point, level point) between points `near` and the level a[s:e]."""
    db2 = (b[s] - b[near]) ** 2
    half = np.sqrt(np.maximum(eps2 - db2, 0.0) + 1e-12 * eps2) * _WIDEN
    al = a[s:e]
    lo = np.searchsorted(al, a[near] - half, "left") + s
    hi = np.searchsorted(al, a[near] + half, "right") + s
    row, j = _expand(lo, hi)
    i = near[row]
    return _exact(a, b, i, j, eps2)


def _free_pairs(a, b, free, eps, eps2):
    """Neighbour pairs among the points `free` (sorted by b), from a band search in b."""
    bf = b[free]
    hi = np.searchsorted(bf, bf + eps * _WIDEN, "right")
    row, col = _expand(np.arange(1, len(free) + 1), hi)
    return _exact(a, b, free[row], free[col], eps2)


def _exact(a, b, i, j, eps2):
    """The pairs (i, j) within eps, tested as sklearn does."""
    da = a[j] - a[i]
    db = b[j] - b[i]
    keep = da * da + db * db <= eps2
    return i[keep], j[keep]


def _expand(lo, hi):
    """(row, j) for every j in [lo[row], hi[row]) (empty ranges allowed)."""
    length = np.maximum(hi - lo, 0)
    row = np.repeat(np.arange(len(lo)), length)
    start = np.cumsum(length) - length
    return row, np.arange(len(row)) - start[row] + lo[row]


def _components(n, u, v):
    """Connected components of nodes 0..n-1 with edges (u, v): a common root node per component."""
    root = np.arange(n)
    while len(u):
        m = np.minimum(root[u], root[v])
        new = root.copy()
        np.minimum.at(new, u, m)
        np.minimum.at(new, v, m)
        while True:  # pointer jumping
            jumped = new[new]
            if np.array_equal(jumped, new):
                break
            new = jumped
        if np.array_equal(new, root):
            break
        root = new
    return root


def _number(root, core, order):
    """Sorted-order labels: clusters numbered by the lowest original index of their core points."""
    n = len(root)
    lowest = np.full(n, n, dtype=np.intp)
    np.minimum.at(lowest, root[core], order[core])
    roots = np.flatnonzero(lowest < n)
    rank = np.empty(n, dtype=np.intp)
    rank[roots[np.argsort(lowest[roots])]] = np.arange(len(roots))
    labels = np.full(n, -1, dtype=np.intp)
    labels[core] = rank[root[core]]
    return labels


def _dbscan_band(X, eps, min_samples):
    """dbscan for any (n, d) X, n >= 1, over a band of neighbours in the first feature."""
    n = len(X)
    labels = np.full(n, -1, dtype=np.intp)
    if n == 0:
        return labels
    order = np.argsort(X[:, 0], kind="stable")
    xs = X[order]
    idx = np.arange(n)
    hi = np.searchsorted(xs[:, 0], xs[:, 0] + eps * (1.0 + 1e-9), side="right")
    w = max(int((hi - idx).max()) - 1, 1)  # followers within the band, self excluded
    d2 = np.zeros((w, n))
    for f in xs.T:  # one feature at a time; padding at infinity is never adjacent
        diff = _after(f, w, np.inf) - f
        diff *= diff
        d2 += diff
    adj_up = d2 <= eps * eps  # [k, i]: i and its (k + 1)-th follower are neighbours
    adj_down = _before_edges(adj_up)  # [k, i]: i and its (k + 1)-th predecessor
    core = 1 + adj_up.sum(axis=0) + adj_down.sum(axis=0) >= min_samples
    if not core.any():
        return labels
    # Connected components of the core points: each ends at its component's lowest sorted index.
    big = n
    cc_up = adj_up & _after(core, w, False) & core
    cc_down = adj_down & _before(core, w, False) & core
    root = idx.copy()
    while True:
        new = np.minimum(root, np.where(cc_up, _after(root, w, big), big).min(axis=0))
        np.minimum(new, np.where(cc_down, _before(root, w, big), big).min(axis=0), out=new)
        while True:  # pointer jumping
            jumped = new[new]
            if np.array_equal(jumped, new):
                break
            new = jumped
        if np.array_equal(new, root):
            break
        root = new
    # Number the components by the lowest original index among their core points.
    lowest = np.full(n, big, dtype=np.intp)
    np.minimum.at(lowest, root[core], order[core])
    roots = np.flatnonzero(lowest < big)
    rank = np.empty(n, dtype=np.intp)
    rank[roots[np.argsort(lowest[roots])]] = np.arange(len(roots))
    sorted_labels = np.full(n, -1, dtype=np.intp)
    sorted_labels[core] = rank[root[core]]
    # Border points: the lowest cluster among adjacent core points.
    lab = np.where(core, sorted_labels, big)
    border = np.minimum(
        np.where(adj_up, _after(lab, w, big), big).min(axis=0),
        np.where(adj_down, _before(lab, w, big), big).min(axis=0),
    )
    is_border = ~core & (border < big)
    sorted_labels[is_border] = border[is_border]
    labels[order] = sorted_labels
    return labels


def _view(buffer, offset, strides, shape):
    """Read-only strided view of a 1-D or C-contiguous buffer (offsets/strides in items)."""
    size = buffer.itemsize
    view = np.ndarray(
        shape, buffer.dtype, buffer, offset * size, tuple(st * size for st in strides)
    )
    view.flags.writeable = False
    return view


def _after(a, w, fill):
    """(w, n) view: [k, i] = a[i + k + 1], `fill` past the end."""
    padded = np.concatenate([a, np.full(w, fill, dtype=a.dtype)])
    return _view(padded, 1, (1, 1), (w, len(a)))


def _before(a, w, fill):
    """(w, n) view: [k, i] = a[i - k - 1], `fill` before the start."""
    padded = np.concatenate([np.full(w, fill, dtype=a.dtype), a])
    return _view(padded, w - 1, (-1, 1), (w, len(a)))


def _before_edges(adj_up):
    """Band adjacency from the far end: [k, i] = adj_up[k, i - k - 1] (False before the start)."""
    w, n = adj_up.shape
    padded = np.concatenate([np.zeros((w, w), dtype=bool), adj_up], axis=1)  # (w, n + w)
    # [k, i] -> padded[k, i + w - k - 1]: row stride n + w, minus one column per row.
    return _view(padded, w - 1, (n + w - 1, 1), (w, n))
