"""`dcmppi timing [--json]`: median controller time per control step on fixed problems.

Problems (deterministic, built here, the defaults K = 500, N = 50):
- forest: a synthetic forest of clustered overlapping cylinders over 75 x 50 m; `mppi`,
  `clustered` and `tube` drive the analytic Dubins model across it.
- forest+push (tube): the same, but after every step the real state is pushed along and across
  its heading and turned by a fixed seeded offset sequence (`push`, zero mean), so Tube-MPPI's
  nominal state differs from the real one: every step rolls out both (2K rollouts), and with
  reset_threshold = 0 the nominal is kept whenever the push set the real state back (about 2
  steps in 3) and the LQR feedback runs too: Tube-MPPI's most expensive step. Without the push
  the nominal equals the real state after every reset, so one batch of K rollouts suffices and
  the feedback is zero.
- crowd: 100 moving cylinders as in the crowd task (radius 1 m, speeds U(0.5, 1.5) m/s,
  turn rates U(-0.5, 0.5) rad/s, reflecting off the boundary); `dc` with P = 25 (and the others
  for reference).
BLAS and OpenMP pools are limited to one thread; the figures are for one core. The cases of a
problem run interleaved in blocks of consecutive steps, so load changes on a shared machine hit
them alike.
"""

import argparse
import dataclasses
import hashlib
import json
import platform
import sys
import time

import numpy as np
from threadpoolctl import threadpool_limits

from dcmppi.control import defaults
from dcmppi.control.controllers import make_controller
from dcmppi.control.dynamics import dubins_step

FOREST_CLUSTERS = 60


def forest(seed=0):
    """(M, 3) cylinders: clusters of 2-5 overlapping cylinders of radius 0.3-1.5 m."""
    rng = np.random.default_rng(seed)
    w, h = defaults.MAP_SIZE
    rows = []
    for _ in range(FOREST_CLUSTERS):
        c = rng.uniform([0, 0], [w, h])
        for _ in range(rng.integers(2, 6)):
            rows.append([*(c + rng.normal(0, 1.0, 2)), rng.uniform(0.3, 1.5)])
    cyl = np.array(rows)
    start, goal = np.array([2.0, 25.0]), np.array([73.0, 25.0])
    clear = lambda p: np.hypot(*(cyl[:, :2] - p).T) > cyl[:, 2] + 3.0  # noqa: E731
    return cyl[clear(start) & clear(goal)], np.array([*start, 0.0]), goal


def crowd(seed=0):
    """(100, 4) moving obstacles x, y, heading, radius and their true (speed, turn rate)."""
    rng = np.random.default_rng(seed)
    w, h = defaults.MAP_SIZE
    L = 100
    moving = np.column_stack(
        [
            rng.uniform(0, w, L),
            rng.uniform(0, h, L),
            rng.uniform(0, 2 * np.pi, L),
            np.full(L, defaults.MOVING_OBSTACLE_RADIUS),
        ]
    )
    speed = rng.uniform(*defaults.OBSTACLE_SPEED_RANGE, L)
    turn = rng.uniform(*defaults.OBSTACLE_TURN_RATE_RANGE, L)
    return moving, speed, turn


def obstacle_model():
    """The known Gaussian (v_mean, v_std, omega_mean, omega_std) of the crowd (docs/design.md)."""
    return np.array(
        [
            *defaults.uniform_mean_std(*defaults.OBSTACLE_SPEED_RANGE),
            *defaults.uniform_mean_std(*defaults.OBSTACLE_TURN_RATE_RANGE),
        ]
    )


def move_crowd(moving, speed, turn, dt):
    """One control period of the true obstacle motion, reflecting off the map boundary."""
    nxt = dubins_step(moving[:, :3], turn, speed, dt)
    w, h = defaults.MAP_SIZE
    out_x = (nxt[:, 0] < 0) | (nxt[:, 0] > w)
    out_y = (nxt[:, 1] < 0) | (nxt[:, 1] > h)
    nxt[out_x, 2] = np.pi - nxt[out_x, 2]
    nxt[out_y, 2] = -nxt[out_y, 2]
    nxt[:, 0] = np.clip(nxt[:, 0], 0, w)
    nxt[:, 1] = np.clip(nxt[:, 1], 0, h)
    return np.column_stack([nxt, moving[:, 3]])


PUSH_STD = (0.15, 0.03, 0.01)  # std of the push along [m], across [m] and of the turn [rad]


def push(steps, seed=0):
    """(steps, 3) offsets (along, across, turn) of forest+push, from a seeded generator."""
    return np.random.default_rng(seed).normal(0.0, PUSH_STD, (steps, 3))


def pushed(state, offset):
    """state (3,) moved by offset[0] along its heading, offset[1] to its left, turned offset[2]."""
    c, s = np.cos(state[2]), np.sin(state[2])
    along, across, turn = offset
    return state + np.array([along * c - across * s, along * s + across * c, turn])


class ClosedLoop:
    """One controller driving the analytic model on a timing problem, one timed step at a time."""

    def __init__(self, name, problem, steps, **params):
        if problem == "forest+push":
            params = {"reset_threshold": 0.0, **params}
        self.ctrl = make_controller(name, seed=0, **params)
        self.offsets = push(steps) if problem == "forest+push" else None
        if problem in ("forest", "forest+push"):
            self.static, self.state, self.goal = forest()
            self.moving = self.model = None
        else:
            self.static, self.state = None, np.array([2.0, 25.0, 0.0])
            self.goal = np.array([73.0, 25.0])
            self.moving, self.speed, self.turn = crowd()
            self.model = obstacle_model()
        self.times = []

    def step(self):
        """One control step; its controller time is appended to `times` [s]. Returns the
        action."""
        ctrl = self.ctrl
        t0 = time.perf_counter()
        u = ctrl.act(self.state, self.goal, self.static, self.moving, self.model)
        self.times.append(time.perf_counter() - t0)
        self.state = ctrl.agent.step(self.state, u, ctrl.dt)
        if self.offsets is not None:
            self.state = pushed(self.state, self.offsets[len(self.times) - 1])
        if self.moving is not None:
            self.moving = move_crowd(self.moving, self.speed, self.turn, ctrl.dt)
        return u

    def summary(self):
        """Median and p95 ms per step, skipping the first steps (cost-map build, caches)."""
        times = np.array(self.times[3:]) * 1e3
        return float(np.median(times)), float(np.percentile(times, 95))


BLOCK = 10  # consecutive steps of one case before the next case's


def time_cases(cases, steps, block=BLOCK):
    """Median and p95 ms per step of every case (see CASES).

    The closed loops of one problem family (forest, crowd) run interleaved in blocks of
    `block` steps, each case in turn, so a change in machine load affects them alike and the
    ratios stay meaningful on a busy machine, while a block's steps find their data in the
    caches as consecutive control steps do (block = 1: every step after another controller's,
    cold, about 1.5 x slower); the families run one after the other.
    """
    loops = [ClosedLoop(c.controller, c.problem, steps, **c.params) for c in cases]
    families = {}
    for loop, case in zip(loops, cases, strict=True):
        families.setdefault(case.problem.split("+")[0], []).append(loop)
    for family in families.values():
        for start in range(0, steps, block):
            for loop in family:
                for _ in range(min(block, steps - start)):
                    loop.step()
    return [loop.summary() for loop in loops]


def time_controller(name, problem, steps, **params):
    """Median and p95 ms per step of one closed loop on the analytic model."""
    loop = ClosedLoop(name, problem, steps, **params)
    for _ in range(steps):
        loop.step()
    return loop.summary()


@dataclasses.dataclass(frozen=True)
class Case:
    """One timing row: a controller with parameters on a problem, its reference row (ratios are
    to its median) and its target (ms, or a ratio to the reference)."""

    label: str
    controller: str
    problem: str
    params: dict = dataclasses.field(default_factory=dict)
    reference: str = "mppi"
    target_ms: float | None = None
    target_ratio: float | None = None


TV, MIXED = {"perturbation": "time_varying"}, {"perturbation": "mixed"}
CASES = (
    Case("mppi", "mppi", "forest", target_ms=0.2),
    Case("mppi tv", "mppi", "forest", TV, target_ms=0.3),
    Case("mppi mixed", "mppi", "forest", MIXED),
    Case("clustered", "clustered", "forest", target_ratio=1.2),
    Case("tube", "tube", "forest", target_ratio=2.5),
    Case("tube", "tube", "forest+push", target_ratio=2.5),
    # agents: the same problem and perturbation kind as their dubins reference row
    Case(
        "mppi unicycle",
        "mppi",
        "forest",
        {"agent": "unicycle", "perturbation": "constant"},
        target_ratio=1.5,
    ),  # fmt: skip
    Case(
        "mppi holonomic",
        "mppi",
        "forest",
        {"agent": "holonomic", "perturbation": "constant"},
        target_ratio=1.5,
    ),  # fmt: skip
    Case(
        "mppi unicycle tv",
        "mppi",
        "forest",
        {"agent": "unicycle", **TV},
        "mppi tv",
        target_ratio=1.5,
    ),  # fmt: skip
    Case(
        "mppi holonomic mixed",
        "mppi",
        "forest",
        {"agent": "holonomic", **MIXED},
        "mppi mixed",
        target_ratio=1.5,
    ),  # fmt: skip
    Case("mppi", "mppi", "crowd"),
    Case("clustered", "clustered", "crowd"),
    Case("dc", "dc", "crowd", target_ms=2.0),
    Case(
        "dc holonomic",
        "dc",
        "crowd",
        {"agent": "holonomic", **MIXED, "Sigma": [1.0, 1.0, 0.1]},
        target_ms=2.0,
    ),  # fmt: skip
)


def main(argv=None):
    """Run the timing benchmark; print a table or JSON. Returns 0 (2: --against without its
    packages)."""
    parser = argparse.ArgumentParser(prog="dcmppi timing", description=__doc__.split("\n")[0])
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--steps", type=int, default=100, help="control steps per case")
    parser.add_argument(
        "--block", type=int, default=BLOCK, help="consecutive steps of a case (1: cold caches)"
    )
    parser.add_argument(
        "--against",
        choices=["pytorch_mppi"],
        help="time pytorch_mppi beside our mppi on the same problem (needs the extra `peer`)",
    )
    parser.add_argument(
        "--profile", action="store_true", help="where one step's time goes, in microseconds"
    )
    parser.add_argument(
        "--fingerprint",
        action="store_true",
        help="hash every closed loop's actions (identical before and after a speed change)",
    )
    args = parser.parse_args(argv)
    if args.steps < 5:
        parser.error("--steps must be >= 5")
    if args.block < 1:
        parser.error("--block must be >= 1")
    if args.against:
        return against(args)
    if args.profile:
        return profile(args)
    if args.fingerprint:
        return fingerprint(args)
    with threadpool_limits(1):
        times = time_cases(CASES, args.steps, args.block)
    rows = [
        {"case": c.label, "controller": c.controller, "problem": c.problem, "params": c.params,
         "median_ms": median, "p95_ms": p95}
        for c, (median, p95) in zip(CASES, times, strict=True)
    ]  # fmt: skip
    median = {(r["case"], r["problem"].split("+")[0]): r["median_ms"] for r in rows}
    for c, r in zip(CASES, rows, strict=True):
        r["ratio"] = r["median_ms"] / median[(c.reference, c.problem.split("+")[0])]
        r["reference"] = c.reference
        r["target"] = (
            f"<= {c.target_ms} ms" if c.target_ms
            else f"<= {c.target_ratio} x {c.reference}" if c.target_ratio else ""
        )  # fmt: skip
    info = {"K": defaults.K, "N": defaults.N, "P": defaults.P, "steps": args.steps}
    info["block"] = args.block
    info["machine"] = (
        f"{platform.processor() or platform.machine()}, python {platform.python_version()}"
    )
    if args.json:
        print(json.dumps({"settings": info, "results": rows}, indent=2))
        return 0
    print(
        f"dcmppi timing: K={info['K']} N={info['N']} P={info['P']}, one thread, {args.steps} steps "
        f"in blocks of {args.block}"
    )
    header = f"{'case':<21} {'problem':<11} {'median ms':>9} {'p95 ms':>7} {'ratio':>6}"
    print(f"{header}  target")
    for r in rows:
        print(
            f"{r['case']:<21} {r['problem']:<11} {r['median_ms']:9.3f} {r['p95_ms']:7.3f} "
            f"{r['ratio']:6.2f}  {r['target']}"
        )
    return 0


def against(args):
    """`--against pytorch_mppi`: our mppi (time-varying) and pytorch_mppi on the forest."""
    from dcmppi.bench import peer

    try:
        peer.require()
    except ImportError as e:
        print(f"dcmppi timing: {e}", file=sys.stderr)
        return 2
    ours = ClosedLoop("mppi", "forest", args.steps, perturbation="time_varying")
    with threadpool_limits(1):
        result = peer.compare(ours, args.steps, args.block)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    v, s = result["versions"], result["settings"]
    print(
        f"dcmppi timing --against pytorch_mppi {v['pytorch_mppi']} (torch {v['torch']}): forest, "
        f"K={s['K']} N={s['N']}, {s['perturbation']} noise, one thread, {args.steps} steps "
        f"interleaved in blocks of {args.block}"
    )
    print(f"{'controller':<20} {'median ms':>9} {'p95 ms':>7}")
    for name, key in (("mppi (dcmppi)", "ours"), ("pytorch_mppi", "theirs")):
        print(f"{name:<20} {result[key]['median_ms']:9.3f} {result[key]['p95_ms']:7.3f}")
    print(
        f"pytorch_mppi / ours = {result['theirs_over_ours']:.1f} (target >= 20), "
        f"ours / pytorch_mppi = {result['ours_over_theirs']:.3f}"
    )
    print(f"same problem: {result['same_problem']}")
    return 0


# `--fingerprint`: every row of the table and the variants that take other code paths
FINGERPRINT_CASES = CASES + (
    Case("dc ekf", "dc", "crowd", {"prediction": "ekf"}),
    Case("dc tv", "dc", "crowd", TV),
    Case("dc unicycle", "dc", "crowd", {"agent": "unicycle"}),
    Case("clustered unicycle", "clustered", "forest", {"agent": "unicycle"}),
    Case("clustered holonomic", "clustered", "forest", {"agent": "holonomic"}),
    Case("clustered tv", "clustered", "forest", TV),
    Case("clustered mixed", "clustered", "forest", MIXED),
    Case("tube unicycle", "tube", "forest+push", {"agent": "unicycle"}),
    Case("tube holonomic", "tube", "forest+push", {"agent": "holonomic"}),
    Case("mppi unicycle mixed", "mppi", "forest", {"agent": "unicycle", **MIXED}),
    Case("mppi holonomic tv", "mppi", "forest", {"agent": "holonomic", **TV}),
)


def fingerprint(args):
    """`--fingerprint`: the sha1 of every closed loop's action sequence (float64 bytes) over
    --steps steps. A change that keeps every plan bit-identical prints the same hashes."""
    rows = []
    with threadpool_limits(1):
        for case in FINGERPRINT_CASES:
            loop = ClosedLoop(case.controller, case.problem, args.steps, **case.params)
            actions = [loop.step() for _ in range(args.steps)]
            digest = hashlib.sha1(np.ascontiguousarray(actions, dtype=np.float64).tobytes())
            rows.append({"case": case.label, "problem": case.problem, "params": case.params,
                         "sha1": digest.hexdigest()})  # fmt: skip
    if args.json:
        print(json.dumps({"steps": args.steps, "results": rows}, indent=2))
        return 0
    print(f"dcmppi timing --fingerprint: sha1 of the actions of {args.steps} closed-loop steps")
    for r in rows:
        params = ",".join(f"{k}={v}" for k, v in r["params"].items())
        print(f"{r['sha1']}  {r['case']:<21} {r['problem']:<11} {params}")
    return 0


if __name__ == "__main__":
    sys.exit(main())


# The parts of a step that `--profile` times: (label, object, attribute) of the functions it
# wraps. Nested parts (under "evaluate") are also in their parent's time.
def _parts():
    from dcmppi.control import clustered, controllers, costs, mppi
    from dcmppi.control.agents import dubins, holonomic, unicycle

    return [
        ("sample", controllers.Controller, "sample"),
        ("controls (project)", controllers.Controller, "controls"),
        ("evaluate", controllers.Controller, "evaluate"),
        ("  rollout", dubins.Dubins, "rollout"),
        ("  rollout", unicycle.Unicycle, "rollout"),
        ("  rollout", holonomic.Holonomic, "rollout"),
        ("  goal distance", controllers, "goal_distance"),
        ("  goal + cost map", controllers, "static_costs"),
        ("  obstacle tracks", costs.TrackIndex, "count"),
        ("importance term", controllers.Controller, "importance"),
        ("Alg. 1 update", mppi, "mppi_update"),
        ("features", clustered, "features_of_sums"),
        ("DBSCAN", clustered, "cluster_labels"),
        ("cluster updates", clustered, "cluster_updates"),
    ]


PROFILE_CASES = (
    Case("mppi", "mppi", "forest"),
    Case("mppi tv", "mppi", "forest", TV),  # the peer's problem: nu x N x K normals per step
    Case("clustered", "clustered", "forest"),
    Case("dc", "dc", "crowd"),
    # the agents on mppi's problem and perturbation kind: their rollouts beside dubins'
    Case("mppi unicycle", "mppi", "forest", {"agent": "unicycle", "perturbation": "constant"}),
    Case("mppi holonomic", "mppi", "forest", {"agent": "holonomic", "perturbation": "constant"}),
    # the holonomic robot's default (mixed) beside the car's: 3 x the normals per step
    Case("mppi mixed", "mppi", "forest", MIXED),
    Case("mppi holonomic mixed", "mppi", "forest", {"agent": "holonomic", **MIXED}),
)


def profile(args):
    """`--profile`: the median over steps of the microseconds spent in each part of a step
    (the timers' own cost included), beside the median step, for mppi (constant and
    time-varying perturbations) and clustered on the forest, dc in the crowd, mppi with the
    unicycle and holonomic agents, and the car and the holonomic robot with mixed perturbations."""
    results = {}
    for case in PROFILE_CASES:
        loop = ClosedLoop(case.controller, case.problem, args.steps, **case.params)
        skip = 3  # the first steps build the cost map and load the compiled kernels
        steps = args.steps - skip
        timer = _timed(_parts(), steps)
        with threadpool_limits(1):
            for _ in range(skip):
                loop.step()
            with timer:
                for i in range(steps):
                    timer.step = i
                    loop.step()
        results[case.label] = {
            "problem": case.problem,
            "step_us": float(np.median(np.array(loop.times[skip:]) * 1e6)),
            "parts": {
                label: {"median_us_per_step": float(np.median(per_step) * 1e6), "calls": calls}
                for label, (per_step, calls) in timer.result().items()
            },
        }
    if args.json:
        print(json.dumps(results, indent=2))
        return 0
    print(f"dcmppi timing --profile: one thread, {args.steps} steps, median us per step")
    for label, r in results.items():
        print(f"{label} ({r['problem']}): step {r['step_us']:.0f} us")
        for name, part in r["parts"].items():
            us, calls = part["median_us_per_step"], part["calls"]
            print(f"  {name:<20} {us:7.1f} us ({calls} call{'s' if calls > 1 else ''})")
    return 0


class _timed:
    """Context manager: wraps each (label, owner, attribute) so that the durations of its calls
    add up per step (the step is `self.step`); restores the originals on exit."""

    def __init__(self, parts, steps):
        self.parts, self.step, self.saved = parts, 0, []
        self.spent = {label: np.zeros(steps) for label, _, _ in parts}
        self.calls = {label: np.zeros(steps, dtype=int) for label, _, _ in parts}

    def __enter__(self):
        for label, owner, name in self.parts:
            original = getattr(owner, name)
            self.saved.append((owner, name, original))
            setattr(owner, name, self._wrap(original, label))
        return self

    def _wrap(self, function, label):
        def timed(*args, **kwargs):
            t0 = time.perf_counter()
            out = function(*args, **kwargs)
            self.spent[label][self.step] += time.perf_counter() - t0
            self.calls[label][self.step] += 1
            return out

        return timed

    def __exit__(self, *exc):
        for owner, name, original in reversed(self.saved):
            setattr(owner, name, original)

    def result(self):
        """{label: (seconds per step (steps,), typical calls per step)} of the parts called."""
        return {
            label: (self.spent[label], int(np.median(self.calls[label])))
            for label in self.spent
            if self.calls[label].any()
        }
