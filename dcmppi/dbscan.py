"""DBSCAN with scikit-learn's exact labels, vectorised for the few hundred points of one step.

`sklearn.cluster.DBSCAN(eps, min_samples).fit(X).labels_` takes about 2.5 ms for K = 500 points
(input validation, a tree, Python lists of neighbourhoods), more than a whole MPPI step. This
module returns the same labels in a small fraction of that. Neighbours are points at Euclidean
distance <= eps (self included), tested as sum_d (x_d - y_d)^2 <= eps^2 like sklearn's trees;
core points have at least `min_samples` neighbours; clusters are the connected components of
core points, numbered by their lowest original index (the order of sklearn's scan); a border
point joins the lowest-numbered cluster among its core neighbours (the first cluster that reaches
it in sklearn's depth-first expansion, sklearn/cluster/_dbscan_inner.pyx); everything else is
noise, -1.

Two features (Clustered MPPI with constant perturbations: eps_k / sigma and the clipped scaled
cost), `_dbscan_2d`: most samples sit exactly at the cost clip, the largest second feature. When
at least MIN_LEVEL points share the largest second feature they form the "level", a 1-D problem:
neighbours are consecutive, so a window of the next min_samples - 1 points decides core points
and border points, and core points connect in runs of consecutive core points (no pair lists).
The other ("free") points, sorted by the second feature, and the few pairs between them and the
level are explicit pair lists from a band search. Components: hooking and pointer jumping over
original indices, so each cluster's root is its lowest index and numbering needs no sort. Cost
O(K log K + pairs off the level), about 70 numpy calls.

Other dimensions, `_dbscan_band`: after sorting by the first feature, the neighbours of point i
lie among the next `width` points; components by min-label propagation over that band.

tests/test_clustered.py checks the labels against sklearn on many random inputs.
"""

import numpy as np

MIN_LEVEL = 8  # points sharing the largest second feature handled as a 1-D level
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
    """dbscan for (n, 2) X, n >= 1: the level of the largest X[:, 1] plus explicit pairs."""
    n = len(X)
    eps2 = eps * eps
    order = np.lexsort((X[:, 0], X[:, 1]))  # free points by b = X[:, 1], then the level by a
    a, b = X[order, 0], X[order, 1]
    s = n - np.count_nonzero(b == b[-1])  # the level (largest b) is [s, n)
    if n - s < MIN_LEVEL:
        s = n
    # Neighbours (sorted positions): windows of followers and predecessors on the level (see
    # _level_window) and the explicit pairs u < v with a free point u.
    count = np.ones(n, dtype=np.intp)
    if s < n:
        after = _level_window(a[s:], eps2, min_samples)
        before = _before_edges(after)
        count[s:] += np.count_nonzero(after, axis=0)
        count[s:] += np.count_nonzero(before, axis=0)
    u, v = _pairs(a, b, s, eps, eps2)
    count += np.bincount(u, minlength=n)
    count += np.bincount(v, minlength=n)
    core = count >= min_samples
    labels = np.full(n, -1, dtype=np.intp)
    if not core.any():
        return labels
    # Clusters over original indices: level runs first, then the core-core pairs.
    root = _level_runs(a, core, order, s, eps2)
    cc = core[u] & core[v]
    root = _components(root, order[u[cc]], order[v[cc]])[order]
    # Number clusters by their lowest original index, which is their root.
    is_root = np.zeros(n + 1, dtype=bool)
    is_root[np.where(core, root, n)] = True
    lab = np.where(core, np.cumsum(is_root)[root] - 1, n)  # sorted positions, n: not core
    # Border points: the lowest cluster among core neighbours (pairs, then the level windows).
    border = np.full(n, n, dtype=np.intp)
    np.minimum.at(border, v, lab[u])
    np.minimum.at(border, u, lab[v])
    if s < n:
        w, level = len(after), lab[s:]
        tail = border[s:]
        np.minimum(tail, np.where(after, _after(level, w, n), n).min(axis=0), out=tail)
        np.minimum(tail, np.where(before, _before(level, w, n), n).min(axis=0), out=tail)
    lab = np.where(core, lab, border)
    lab[lab == n] = -1
    labels[order] = lab
    return labels


def _level_window(al, eps2, min_samples):
    """(w, m) neighbours among the next w points of a level (sorted values al), w < min_samples.

    [k, i]: al[i + k + 1] is within eps of al[i]. Neighbours on a level are consecutive, so the
    window holds min(neighbours after i, w); with w = min_samples - 1 that decides every core
    point, and a non-core point's core neighbours on the level lie within w places (otherwise the
    w points in between would be its neighbours too, making it core).
    """
    w = max(1, min(min_samples - 1, len(al) - 1))
    d = _after(al, w, np.inf) - al
    d *= d
    return d <= eps2


def _pairs(a, b, s, eps, eps2):
    """Neighbour pairs (u, v), u < v, u a free point (position < s), as sklearn tests them.

    Free points (sorted by b) pair with the free points after them within eps in b; those within
    eps of the level's b pair with the level points within the remaining half-width in a.
    """
    bf = b[:s]
    rows, first = np.arange(s), np.arange(1, s + 1)
    last = np.searchsorted(bf, bf + eps * _WIDEN, "right")
    if s < len(a):
        top, al = b[s], a[s:]
        k = np.searchsorted(bf, top - eps * _WIDEN, "left")
        db = top - bf[k:]
        half = np.sqrt(np.maximum(eps2 - db * db, 0.0) + 1e-12 * eps2) * _WIDEN
        rows = np.concatenate([rows, rows[k:]])
        first = np.concatenate([first, np.searchsorted(al, a[k:s] - half, "left") + s])
        last = np.concatenate([last, np.searchsorted(al, a[k:s] + half, "right") + s])
    # Expand the candidate ranges [first, last) of every row into pairs (u, v).
    length = np.maximum(last - first, 0)
    start = np.cumsum(length)
    start -= length
    u = np.repeat(rows, length)
    v = np.repeat(first - start, length)
    v += np.arange(len(v))
    da = a[v] - a[u]
    db = b[v] - b[u]
    da *= da
    db *= db
    keep = da + db <= eps2
    return u[keep], v[keep]


def _level_runs(a, core, order, s, eps2):
    """Parent pointers over original indices: level core runs point at their lowest index.

    A run is a maximal sequence of consecutive core points of the level (sorted by a), each
    within eps of the next. Returns root (n,) with root[i] <= i and root[root] == root.
    """
    root = np.arange(len(a))
    c = np.flatnonzero(core[s:]) + s
    if len(c) == 0:
        return root
    new_run = np.empty(len(c), dtype=bool)
    new_run[0] = True
    gap = a[c[1:]] - a[c[:-1]]
    np.greater(gap * gap, eps2, out=new_run[1:])
    oc = order[c]
    root[oc] = np.minimum.reduceat(oc, np.flatnonzero(new_run))[np.cumsum(new_run) - 1]
    return root


def _components(root, u, v):
    """Connected components by hooking and pointer jumping: the lowest node of each component.

    root: (n,) parent pointers with root[i] <= i and root[root] == root; edges (u, v).
    """
    while True:
        ru, rv = root[u], root[v]
        if not np.count_nonzero(ru != rv):
            return root
        m = np.minimum(ru, rv)
        np.minimum.at(root, ru, m)
        np.minimum.at(root, rv, m)
        while True:  # pointer jumping
            jumped = root[root]
            if not np.count_nonzero(jumped != root):
                break
            root = jumped


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
