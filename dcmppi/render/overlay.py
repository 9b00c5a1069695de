"""Draw a controller's last step into a MuJoCo scene: what the algorithm is thinking.

- sampled rollouts (a subsample), coloured by DBSCAN cluster (the chosen cluster's opaque),
  grey for noise points and for `mppi` / `tube`, which do not cluster;
- the chosen plan, thick, rolled out without noise from the robot's state;
- the executed path as a trail;
- for `dc`, the sampled futures of the nearby moving obstacles, faint.

`Overlay.legend()` names the colours of what it draws, for the video's legend.

Every geom goes through `dcmppi.render.video.add_polyline`, which stops at `scene.maxgeom`; the
subsampling below keeps one frame to about 1,500 geoms whatever K, N and P are.
"""

from __future__ import annotations

import numpy as np

from dcmppi.control import ClusteredDiagnostics, Diagnostics
from dcmppi.render.video import add_polyline

# Tableau-like cluster colours; noise and unclustered samples are grey.
PALETTE = np.array(
    [
        [0.12, 0.47, 0.71], [0.17, 0.63, 0.17], [0.58, 0.40, 0.74], [0.09, 0.75, 0.81],
        [0.74, 0.74, 0.13], [0.55, 0.34, 0.29], [0.89, 0.47, 0.76], [0.50, 0.50, 0.00],
    ]
)  # fmt: skip
GREY = np.array([0.45, 0.45, 0.45])
PLAN_RGBA = (1.0, 0.85, 0.0, 1.0)
TRAIL_RGBA = (0.85, 0.1, 0.85, 0.9)
FUTURE_RGBA = (0.95, 0.55, 0.1, 0.25)


def cluster_labels(d: Diagnostics) -> np.ndarray | None:
    """(K,) DBSCAN labels of a clustering planner's step (clustered, dc); None otherwise."""
    return d.labels if isinstance(d, ClusteredDiagnostics) else None


def obstacle_futures(d: Diagnostics) -> np.ndarray | None:
    """(L', P, N + 1, 2) the step's sampled obstacle futures (dc's prior and ekf predictors),
    or None where the predictor samples none."""
    futures = None if d.prediction is None else d.prediction.futures
    return futures if futures is not None and len(futures) else None


def cluster_rgb(labels: np.ndarray | None, K: int) -> np.ndarray:
    """Colour (K, 3) of every sample: its cluster's palette entry, grey for noise (-1)."""
    if labels is None:
        return np.tile(GREY, (K, 1))
    rgb = PALETTE[np.maximum(labels, 0) % len(PALETTE)]
    rgb[labels < 0] = GREY
    return rgb


class Overlay:
    """Scene decorator for `dcmppi.render.video.Renderer.render(..., decorate=overlay)`.

    Args:
      controller: a dcmppi controller; its `diagnostics` are read at every frame (a user's
        controller without them gets the trail only).
      rollouts: how many sampled rollouts to draw (evenly spread over the K samples).
      segments: polyline segments per rollout (the horizon is subsampled to this).
      futures: sampled futures drawn per moving obstacle (dc), for at most `obstacles`.
    """

    def __init__(self, controller, rollouts=48, segments=10, futures=6, obstacles=10):
        self.controller = controller
        self.rollouts, self.segments = rollouts, segments
        self.futures, self.obstacles = futures, obstacles
        self.trail: list[np.ndarray] = []

    def record(self, robot_pose: np.ndarray) -> None:
        """Append the robot's pose (3,) to the trail (call once per control step)."""
        self.trail.append(np.array(robot_pose[:2], dtype=float))

    def _diagnostics(self) -> Diagnostics:
        d = getattr(self.controller, "diagnostics", None)
        return d if isinstance(d, Diagnostics) else Diagnostics()

    def __call__(self, scene, physics) -> None:
        d = self._diagnostics()
        if d.states is not None:
            self._rollouts(scene, d)
            self._plan(scene, d)
        futures = obstacle_futures(d)
        if futures is not None:
            self._futures(scene, futures)
        if len(self.trail) > 1:
            trail = np.asarray(self.trail)
            stride = max(1, len(trail) // 200)
            add_polyline(scene, np.vstack([trail[::stride], trail[-1:]]), TRAIL_RGBA, 0.08, 0.04)

    def legend(self) -> list[tuple[tuple, str]]:
        """[(rgba, label)] for each kind of line the overlay draws now, from the controller's
        latest diagnostics (for `dcmppi.render.video.Renderer.render(legend=...)`)."""
        d = self._diagnostics()
        out = []
        if d.states is not None:
            if cluster_labels(d) is not None:
                out += [((*PALETTE[0], 1.0), "rollouts by cluster"),
                        ((*GREY, 1.0), "in no cluster")]  # fmt: skip
            else:
                out.append(((*GREY, 1.0), "sampled rollouts"))
            out.append((PLAN_RGBA, "plan"))
        if len(self.trail) > 1:
            out.append((TRAIL_RGBA, "trail"))
        if obstacle_futures(d) is not None:
            out.append(((*FUTURE_RGBA[:3], 1.0), "obstacle futures"))
        return out

    def _steps(self, n: int) -> np.ndarray:
        """Indices 0..n-1 subsampled to at most `segments` + 1 points, last included."""
        return np.unique(np.linspace(0, n - 1, min(n, self.segments + 1)).round().astype(int))

    def _rollouts(self, scene, d) -> None:
        K = len(d.states)
        labels = cluster_labels(d)
        rgb = cluster_rgb(labels, K)
        steps = self._steps(d.states.shape[1])
        for k in np.linspace(0, K - 1, min(K, self.rollouts)).round().astype(int):
            chosen = labels is not None and d.chosen >= 0 and labels[k] == d.chosen
            rgba = (*rgb[k], 0.9 if chosen else 0.45)
            add_polyline(scene, d.states[k, steps, :2], rgba, 1.5, 0.06, line=True)

    def _plan(self, scene, d) -> None:
        c = self.controller
        x0 = d.states[0, 0]
        path = c.agent.rollout_one(x0, d.plan, c.dt)[:, :2]
        add_polyline(scene, path[self._steps(len(path))], PLAN_RGBA, 0.1, 0.08)

    def _futures(self, scene, samples: np.ndarray) -> None:
        L, P, n, _ = samples.shape
        steps = self._steps(n)
        for l in range(min(L, self.obstacles)):
            for p in np.linspace(0, P - 1, min(P, self.futures)).round().astype(int):
                add_polyline(scene, samples[l, p, steps], FUTURE_RGBA, 1.0, 0.07, line=True)
