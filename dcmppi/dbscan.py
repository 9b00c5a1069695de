"""DBSCAN with scikit-learn's exact labels, vectorised for the few hundred points of one step.

`sklearn.cluster.DBSCAN(eps, min_samples).fit(X).labels_` takes about 2.5 ms for K = 500 points
(input validation, a tree, Python lists of neighbourhoods), more than a whole MPPI step. This
function returns the same labels in a small fraction of that:

- neighbours (Euclidean distance <= eps, self included) come from a band search: after sorting
  by the first feature, the neighbours of point i lie among the next `width` points;
- core points have at least `min_samples` neighbours;
- clusters are the connected components of core points (min-label propagation over the band with
  pointer jumping), numbered by their lowest original index, as sklearn's depth-first scan does;
- a border point joins the lowest-numbered cluster among its core neighbours (the first cluster
  that reaches it in sklearn); everything else is noise, -1.

tests/test_clustered.py checks the labels against sklearn on many random inputs.
"""

import numpy as np


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
