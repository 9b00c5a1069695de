"""`dcmppi timing --scaling`: ms per step as one size grows at a time from the paper's point.

The paper's point (BASE): K = 500 samples, N = 50 steps, P = 25 futures, on each controller's
problem (HOME: `dc` on the crowd task's world of 100 moving cylinders, the others on the forest
task's world of 65 clusters of cylinders). Each axis (AXES) changes one size, the others stay:
- K, N: the controller's parameters, on its own problem;
- static: the forest's clusters (generate_forest's n_clusters, worlds.dense_forest: above the
  task's 65 the map grows to keep the forest's density); the curve's x is the cylinders drawn;
- moving: the crowd's obstacles (generate_crowd's n_obstacles), every controller on the crowd;
- P: the futures per obstacle of `dc` (the only controller whose predictor samples them).
The loops of an axis run interleaved in blocks (loop.interleave), one thread, so a change in
load hits its points alike. `fits` turns the medians into ns per unit of work: per state-step
(K x N, from the K and N axes), per cylinder-, obstacle- and future-state-step.
"""

import dataclasses
import time

import numpy as np
from threadpoolctl import threadpool_limits

from dcmppi.bench.timing.loop import BLOCK, ClosedLoop, interleave
from dcmppi.bench.timing.worlds import dense_forest, world
from dcmppi.control import defaults
from dcmppi.tasks.worlds import paper as task_worlds

CONTROLLERS = ("mppi", "clustered", "dc", "tube")
HOME = {"mppi": "forest", "clustered": "forest", "tube": "forest", "dc": "crowd"}
STEPS = 200  # control steps per point by default (the first loop.SKIP not timed)


@dataclasses.dataclass(frozen=True)
class Axis:
    """One size grown from BASE: its key in BASE and the JSON, the x label, the sizes set (static:
    the forest's clusters), the point's key plotted on x, and the controllers it applies to."""

    name: str
    label: str
    values: tuple
    size: str
    controllers: tuple = CONTROLLERS


AXES = (
    Axis("K", "samples K", (250, 500, 1000, 2000, 4000, 8000), "K"),
    Axis("N", "horizon N (steps)", (25, 50, 100, 200), "N"),
    Axis("static", "static cylinders (forest)", (0, 16, 65, 160, 400), "cylinders"),
    Axis("moving", "moving obstacles (crowd)", (0, 25, 50, 100, 200), "obstacles"),
    Axis("P", "futures per obstacle P (crowd)", (5, 10, 25, 50, 100), "P", ("dc",)),
)
BASE = {
    "K": defaults.K,
    "N": defaults.N,
    "static": task_worlds.FOREST_CLUSTERS,
    "moving": task_worlds.CROWD_SIZE,
    "P": defaults.P,
}
# ns per unit of work: (JSON key, the axes fitted together, the point's sizes multiplied)
FITS = (
    ("ns_per_state_step", ("K", "N"), ("K", "N")),
    ("ns_per_cylinder_state_step", ("static",), ("K", "N", "cylinders")),
    ("ns_per_obstacle_state_step", ("moving",), ("K", "N", "obstacles")),
    ("ns_per_future_state_step", ("P",), ("K", "N", "obstacles", "P")),
)


def problem(controller, axis):
    """The problem family ("forest" or "crowd") of `controller`'s points on `axis` (its name)."""
    return {"static": "forest", "moving": "crowd"}.get(axis, HOME[controller])


def point_loop(controller, axis, value, steps):
    """The ClosedLoop of `controller` at BASE with `axis` (its name) set to `value`; its world
    drawn by the task's generator with those counts."""
    base = {**BASE, axis: value}
    family = problem(controller, axis)
    if family == "forest":
        w = dense_forest(base["static"])
    else:
        w = world("crowd", n_obstacles=base["moving"])
    params = {key: base[key] for key in ("K", "N", "P")}
    return ClosedLoop(controller, family, steps, world=w, **params)


def sizes(loop):
    """A point's sizes: K, N, P, cylinders (radius > 0) and obstacles of its loop."""
    c = loop.ctrl
    cylinders = int(np.count_nonzero(loop.static[:, 2] > 0))
    return {"K": c.K, "N": c.N, "P": c.P, "cylinders": cylinders, "obstacles": len(loop.moving)}


def scaling(steps=STEPS, block=BLOCK):
    """{axis name: {controller: {"problem", "points": [{"value", K, N, P, "cylinders",
    "obstacles", "median_ms", "p95_ms"}]}}} of AXES: every point timed on one thread, the loops
    of an axis interleaved."""
    results = {}
    with threadpool_limits(1):
        for axis in AXES:
            loops = {
                c: [point_loop(c, axis.name, v, steps) for v in axis.values]
                for c in axis.controllers
            }
            interleave([loop for row in loops.values() for loop in row], steps, block)
            results[axis.name] = {}
            for c, row in loops.items():
                points = []
                for value, loop in zip(axis.values, row, strict=True):
                    median, p95 = loop.summary()
                    points.append({"value": value, **sizes(loop), "median_ms": median,
                                   "p95_ms": p95})  # fmt: skip
                results[axis.name][c] = {"problem": problem(c, axis.name), "points": points}
    return results


def fit_line(work, ms):
    """(intercept ms, slope ns per unit of work) of ms = a + b work, least squares on the
    relative error (each point weighs 1 / ms), so the small sizes count as much as the large.
    work, ms: (n,) with at least two distinct works."""
    work, ms = np.asarray(work, dtype=float), np.asarray(ms, dtype=float)
    if len(np.unique(work)) < 2:
        raise ValueError("a fit needs at least two different sizes")
    A = np.column_stack([1.0 / ms, work / ms])
    (a, b), *_ = np.linalg.lstsq(A, np.ones_like(ms), rcond=None)
    return float(a), float(b * 1e6)


def fits(results):
    """{controller: {FITS key: {"ns", "intercept_ms"} or None}}: each fit over its axes' points
    (None where the controller has fewer than two distinct works there)."""
    controllers = dict.fromkeys(c for curves in results.values() for c in curves)
    out = {}
    for c in controllers:
        out[c] = {}
        for key, axes, factors in FITS:
            points = [p for a in axes for p in results.get(a, {}).get(c, {}).get("points", [])]
            work = [float(np.prod([p[f] for f in factors])) for p in points]
            if len(set(work)) < 2:
                out[c][key] = None
                continue
            a, ns = fit_line(work, [p["median_ms"] for p in points])
            out[c][key] = {"ns": ns, "intercept_ms": a}
    return out


def figure_data(report):
    """The plot's panels (render.plots.scaling_figure) of a report (`run`): {axis label:
    {"base": x at the paper's point or None, "curves": {controller: (x list, median ms list)}}}."""
    base = report["settings"]["base"]
    panels = {}
    for name, axis in report["axes"].items():
        panel = {"curves": {}, "base": None}
        for c, curve in report["results"][name].items():
            points = curve["points"]
            panel["curves"][c] = ([p[axis["x"]] for p in points], [p["median_ms"] for p in points])
            at_base = [p[axis["x"]] for p in points if p["value"] == base[name]]
            panel["base"] = at_base[0] if at_base else panel["base"]
        panels[axis["label"]] = panel
    return panels


def run(steps, block, machine):
    """The command's JSON object: settings (the run's seconds among them), axes, results, fits."""
    t0 = time.perf_counter()
    results = scaling(steps, block)
    return {
        "settings": {"base": dict(BASE), "steps": steps, "block": block, "threads": 1,
                     "machine": machine, "seconds": time.perf_counter() - t0},
        "axes": {a.name: {"label": a.label, "values": list(a.values), "x": a.size,
                          "controllers": list(a.controllers)} for a in AXES},
        "results": results,
        "fits": fits(results),
    }  # fmt: skip


def write(report, out):
    """scaling.json (the report) and scaling.png (render.plots.scaling_figure) in the folder
    `out` (made if missing). Returns their paths."""
    import json
    import os

    from dcmppi.render.draw import save_figure
    from dcmppi.render.plots import scaling_figure

    os.makedirs(out, exist_ok=True)
    paths = os.path.join(out, "scaling.json"), os.path.join(out, "scaling.png")
    with open(paths[0], "w") as f:
        json.dump(report, f, indent=2)
    panels = figure_data(report)
    s = report["settings"]
    title = f"ms per control step, one thread ({s['steps']} steps per point; dotted: the paper's)"
    save_figure(scaling_figure(panels, title), paths[1])
    return paths


def print_scaling(report):
    """The report as text: per axis a table of median ms (a row per size, a column per
    controller), then the fits."""
    s = report["settings"]
    print(
        f"dcmppi timing --scaling: median ms per step, one thread, {s['steps']} steps per point "
        f"in blocks of {s['block']}, from K={s['base']['K']} N={s['base']['N']} "
        f"P={s['base']['P']}; {s['seconds']:.0f} s"
    )
    for name, axis in report["axes"].items():
        curves = report["results"][name]
        print(f"\n{axis['label']:<32}" + "".join(f"{c:>10}" for c in curves))
        first = next(iter(curves.values()))["points"]
        for i in range(len(first)):
            cells = "".join(f"{curve['points'][i]['median_ms']:10.3f}" for curve in curves.values())
            print(f"{first[i][axis['x']]:<32}{cells}")
    print()
    for c, fitted in report["fits"].items():
        parts = [f"{key[7:].replace('_', '-')} {f['ns']:.2f}" for key, f in fitted.items() if f]
        print(f"{c}: ns per " + ", ".join(parts))
