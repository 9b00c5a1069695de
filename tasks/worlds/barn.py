"""BARN's navigation score, and the shortest collision-free path length that it needs.

The BARN challenge scores an episode by

    score = success * optimal_time / clip(actual_time, 2 * optimal_time, 8 * optimal_time),
    optimal_time = (planned path length) / (the robot's top speed),

so a run at least as fast as half the top speed along the planned path scores 0.5, one that
takes 8 x optimal_time or longer scores 0.125, and a failure 0. The challenge reads its path
lengths from path files planned on its own 0.15 m grid; `shortest_path_length` plans one here,
for the robot's own collision radius:

1. Nodes: the centres of a `resolution` grid over the map bounds whose distance to every
   cylinder exceeds the cylinder's radius plus the robot's radius (the free configuration
   space of a disc robot, sampled exactly at the nodes).
2. Edges: the 16 moves to the 8 neighbours and the 8 knight's moves (length h, h sqrt 2,
   h sqrt 5). An edge of length L joins free nodes whose clearances c1 + c2 > L: clearance is
   1-Lipschitz, so every point of the edge is then free (certified, never optimistic).
3. Dijkstra (scipy.sparse.csgraph) from the node nearest the start to the node nearest the goal;
   the path runs start, nodes, goal.
4. The grid path's directions come in multiples of 26.6 degrees, so it is up to 2.7 % too
   long; it is shortened to the shortest polyline through a subsequence of its vertices (in
   order) whose every segment clears each inflated cylinder (exact segment-disc distance).

The result is the length of a collision-free path, so it never undercuts the true shortest
length; on a disc around which the true answer is known it exceeds it by less than 0.5 %
(tests/tasks/test_barn.py).
"""

import functools
import math

import numpy as np

RESOLUTION = 0.05  # [m] grid of the shortest-path search
MOVES = np.array(
    [(1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2)]
)  # half of the 16 moves; edges are undirected
_CLEARANCE_CAP = 1.0  # [m] clearances beyond this (> the longest move) are not needed


def navigation_score(success: bool, actual_time: float, optimal_time: float) -> float:
    """BARN's score of one episode: success * optimal / clip(actual, 2 optimal, 8 optimal)."""
    if not success:
        return 0.0
    return optimal_time / float(np.clip(actual_time, 2.0 * optimal_time, 8.0 * optimal_time))


def shortest_path_length(cylinders, robot_radius, start, goal, bounds, resolution=RESOLUTION):
    """Length [m] of the shortest collision-free path of a disc robot (see the module docstring).

    Args:
      cylinders: (M, 3) x, y, radius; radius-0 rows (padding) are ignored.
      robot_radius: the robot's collision radius [m].
      start, goal: (2,) points (x, y); a longer array's first two entries are used.
      bounds: (4,) xmin, ymin, xmax, ymax: the path stays inside.
      resolution: grid cell size [m].

    Returns:
      The length, or math.inf when no free path joins start and goal.

    Raises:
      ValueError: when the start or the goal itself is in collision or off the map.
    """
    return _cached(
        _key(np.asarray(cylinders, dtype=np.float64).reshape(-1, 3)),
        float(robot_radius),
        _key(np.asarray(start, dtype=np.float64)[:2]),
        _key(np.asarray(goal, dtype=np.float64)[:2]),
        _key(np.asarray(bounds, dtype=np.float64)),
        float(resolution),
    )


def _key(array):
    return tuple(map(tuple, array)) if array.ndim == 2 else tuple(array)


@functools.lru_cache(maxsize=512)
def _cached(cylinders, robot_radius, start, goal, bounds, resolution):
    """shortest_path_length on hashable arguments: each world is planned once per process."""
    cyl = np.array(cylinders, dtype=np.float64).reshape(-1, 3)
    cyl = cyl[cyl[:, 2] > 0]
    start, goal, bounds = np.array(start), np.array(goal), np.array(bounds)
    for name, point in (("start", start), ("goal", goal)):
        inside = (bounds[:2] <= point).all() and (point <= bounds[2:]).all()
        if not inside or _clearance(point[None], cyl, robot_radius)[0] <= 0:
            raise ValueError(
                f"shortest path: the {name} {tuple(point)} is off the map or within "
                f"{robot_radius} m of a cylinder"
            )
    vertices = _grid_path(cyl, robot_radius, start, goal, bounds, resolution)
    if vertices is None:
        return math.inf
    return _shortcut(vertices, cyl, robot_radius)


def _clearance(points, cyl, robot_radius):
    """(P,) distance of each point (P, 2) to the nearest cylinder inflated by robot_radius."""
    d = np.hypot(points[:, None, 0] - cyl[:, 0], points[:, None, 1] - cyl[:, 1]) - cyl[:, 2]
    return d.min(axis=1, initial=np.inf) - robot_radius


def _clearance_field(cyl, robot_radius, xs, ys):
    """(nx, ny) clearance at the grid nodes, capped at _CLEARANCE_CAP: one window per cylinder."""
    field = np.full((len(xs), len(ys)), _CLEARANCE_CAP)
    for x, y, r in cyl:
        reach = r + robot_radius + _CLEARANCE_CAP
        i0, i1 = np.searchsorted(xs, [x - reach, x + reach])
        j0, j1 = np.searchsorted(ys, [y - reach, y + reach])
        if i0 >= i1 or j0 >= j1:
            continue
        d = np.hypot(xs[i0:i1, None] - x, ys[None, j0:j1] - y) - r - robot_radius
        np.minimum(field[i0:i1, j0:j1], d, out=field[i0:i1, j0:j1])
    return field


def _grid_path(cyl, robot_radius, start, goal, bounds, h):
    """(V, 2) start, the grid nodes of the shortest 16-connected path, goal; None if none."""
    # here, not at the top: loading the tasks does not load scipy
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import dijkstra

    xs = np.arange(bounds[0] + h / 2, bounds[2], h)
    ys = np.arange(bounds[1] + h / 2, bounds[3], h)
    field = _clearance_field(cyl, robot_radius, xs, ys)
    nx, ny = field.shape
    index = np.arange(nx * ny).reshape(nx, ny)
    rows, cols, weights = [], [], []
    for dx, dy in MOVES:
        length = h * math.hypot(dx, dy)
        a = (slice(max(0, -dx), nx - max(0, dx)), slice(max(0, -dy), ny - max(0, dy)))
        b = (slice(max(0, dx), nx - max(0, -dx)), slice(max(0, dy), ny - max(0, -dy)))
        ok = (field[a] > 0) & (field[b] > 0) & (field[a] + field[b] > length)
        rows.append(index[a][ok])
        cols.append(index[b][ok])
        weights.append(np.full(ok.sum(), length))
    graph = coo_matrix(
        (np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))),
        shape=(nx * ny, nx * ny),
    ).tocsr()
    ends = []
    for point in (start, goal):  # the nearest free node that the point sees directly
        i = np.clip(np.round((point[0] - xs[0]) / h).astype(int), 0, nx - 1)
        j = np.clip(np.round((point[1] - ys[0]) / h).astype(int), 0, ny - 1)
        near = [(i + di, j + dj) for di in (-1, 0, 1) for dj in (-1, 0, 1)]
        near = [(a, b) for a, b in near if 0 <= a < nx and 0 <= b < ny and field[a, b] > 0]
        near.sort(key=lambda ab: math.hypot(xs[ab[0]] - point[0], ys[ab[1]] - point[1]))
        seen = [
            ab
            for ab in near
            if _visible(point, np.array([xs[ab[0]], ys[ab[1]]]), cyl, robot_radius)
        ]
        if not seen:
            return None
        ends.append(index[seen[0]])
    dist, pred = dijkstra(graph, directed=False, indices=ends[0], return_predecessors=True)
    if not np.isfinite(dist[ends[1]]):
        return None
    nodes = [ends[1]]
    while nodes[-1] != ends[0]:
        nodes.append(pred[nodes[-1]])
    nodes = np.array(nodes[::-1])
    points = np.column_stack([xs[nodes // ny], ys[nodes % ny]])
    return np.vstack([start, points, goal])


def _visible(a, b, cyl, robot_radius):
    """Whether the segment a-b (2,) clears every cylinder inflated by robot_radius."""
    return bool(_segments_clear(a, b[None], cyl, robot_radius)[0])


def _segments_clear(a, bs, cyl, robot_radius):
    """(B,) whether each segment from a (2,) to bs (B, 2) clears every inflated cylinder."""
    if not len(cyl):
        return np.ones(len(bs), dtype=bool)
    d = bs - a  # (B, 2)
    rel = cyl[:, :2] - a  # (M, 2)
    dd = np.maximum((d * d).sum(axis=1), 1e-300)  # (B,)
    t = np.clip((d @ rel.T) / dd[:, None], 0.0, 1.0)  # (B, M) closest point's parameter
    gap_x = t * d[:, 0:1] - rel[:, 0]
    gap_y = t * d[:, 1:2] - rel[:, 1]
    return (np.hypot(gap_x, gap_y) > cyl[:, 2] + robot_radius).all(axis=1)


def _shortcut(vertices, cyl, robot_radius):
    """Length of the shortest polyline through an ordered subsequence of `vertices` (V, 2),
    first and last included, whose segments clear every inflated cylinder (DP over the DAG)."""
    n = len(vertices)
    best = np.full(n, np.inf)
    best[0] = 0.0
    for i in range(n - 1):
        j = np.arange(i + 1, n)
        seen = _segments_clear(vertices[i], vertices[j], cyl, robot_radius)
        seen[0] = True  # consecutive grid vertices are joined by a certified edge
        step = np.hypot(*(vertices[j] - vertices[i]).T)
        best[j[seen]] = np.minimum(best[j[seen]], best[i] + step[seen])
    return float(best[-1])
