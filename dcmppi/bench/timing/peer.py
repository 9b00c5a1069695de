"""`dcmppi timing --against pytorch_mppi`: our `mppi` beside pytorch_mppi's MPPI on one problem.

Needs the optional extra `peer` (`pip install torch==2.13.0 pytorch-mppi`, or
`pip install "dcmppi[peer]"`); torch and pytorch_mppi are imported only when it runs.

The problem is built from our controller (`make_controller("mppi", seed=0,
perturbation="time_varying", K=K, N=N)`, the defaults otherwise; `--K`, `--N`, by default the
paper's 500 and 50) and its closed loop on timing's forest (the forest task's generator, seed 0),
so both planners see the same numbers. Identical in the two:
- dynamics: the exact Dubins arc per control period, a = omega dt / 2, x += v dt sinc(a)
  cos(theta + a), y += v dt sinc(a) sin(theta + a), theta += 2 a, v = 1 m/s, dt = 0.1 s
  (`PeerProblem.dynamics`, equal to our agent's step to 1e-9, tests/bench/test_peer.py);
- cost of a state: distance to the goal + alpha (1000) x the occupancy of the static cost map,
  looked up in our OccupancyGrid's boolean grid (robot radius 0.5 m, 0.1 m cells, same cell
  indexing: index = int(clip((x - origin) / resolution, 0, last cell))), not a disc test, so
  both pay the same conservative rasterised map; with the map's bounds (as timing passes them)
  its outer ring is occupied, so a state whose centre leaves the map costs alpha in both;
- K samples, N steps (num_samples, horizon), lambda = 1, Sigma = 0.1 (rad/s)^2 on omega
  (pytorch_mppi's noise_sigma is the covariance), |omega| <= 1 rad/s (u_min, u_max);
- time-varying perturbations: an independent N(0, Sigma) draw per sample and step;
- controls clipped into the bounds, and the clipped perturbation eps = clip(U + noise) - U kept
  for the control cost and the update;
- the control (importance) cost: pytorch_mppi's lambda sum_i U_i^T Sigma^-1 eps_i is our term
  gamma lambda sum_i U_i^T Sigma^-1 eps_i with gamma = 1 (noise_abs_cost=False);
- the weights exp(-(S - min S) / lambda) / eta, the update U += sum_k w_k eps_k, the first
  control applied, and the first warm start: zeros (U_init; our dubins agent's first guess);
- one thread: torch.set_num_threads(1), and threadpoolctl's limit of 1 for ours (numba's loops
  run serially).
Different:
- random numbers: torch.randn (seeded torch.manual_seed(0)) against our counter-based draws
  (dcmppi.control.kernels.perturbations, seed 0), so the two plans differ by their samples only;
  with the same perturbations the first plans agree to 1e-6 (test);
- cost of the start state x_0: pytorch_mppi's running cost sees x_1 .. x_N (terminal_state_cost
  None: our terminal cost is the running cost of x_N, already summed), ours x_0 .. x_N; c(x_0) is
  the same for every sample, so it shifts S by a constant and leaves weights and plan unchanged;
- the warm start's last control after the shift: u_init = 0 in pytorch_mppi, ours repeats the
  plan's last control (its API fixes u_init to a constant);
- arithmetic: both in float64; our rollouts take sin and cos from dcmppi.control.kernels.libm
  (within 2 ulp of libm's) and sinc from its series for small arcs;
- implementation: pytorch_mppi steps the batch through Python-level torch calls per horizon step,
  ours runs numba loops; our act() also checks its inputs every step. pytorch_mppi's optional
  MPPI.compile (torch.compile of the dynamics and cost) is not used: in one trial on the 2-core
  machine it took 25 s to compile and saved about 13 % per step.
Both controllers drive the analytic model (our agent's step) from the forest's start for the
same number of steps, interleaved one step each, so load changes on a shared machine hit both.
"""

import importlib
import importlib.metadata
import time

import numpy as np

from dcmppi.control.kernels.costs import OccupancyGrid

INSTALL = 'pip install torch==2.13.0 pytorch-mppi (or pip install "dcmppi[peer]")'


def require():
    """The modules (torch, pytorch_mppi); an ImportError naming the missing ones and the install
    command without them."""
    modules, missing = [], []
    for name in ("torch", "pytorch_mppi"):
        try:
            modules.append(importlib.import_module(name))
        except ImportError:
            missing.append(name)
    if missing:
        raise ImportError(
            f"--against pytorch_mppi needs torch and pytorch-mppi (missing: {', '.join(missing)})"
            f": {INSTALL}"
        )
    return tuple(modules)


class PeerProblem:
    """The Dubins problem of a controller in torch: dynamics, state cost and rollouts.

    Args:
      ctrl: our controller (dubins agent): v, dt, alpha, robot_radius, resolution come from it.
      static: (M, 3) static cylinders x, y, radius (radius-0 rows ignored); goal: (2,).
      bounds: (4,) xmin, ymin, xmax, ymax of the map, or None (as our act's `bounds`).
      dtype: torch dtype of the states and costs.
    """

    def __init__(self, ctrl, static, goal, bounds=None, dtype=None):
        torch, _ = require()
        self.torch = torch
        self.dtype = torch.float64 if dtype is None else dtype
        self.v, self.dt, self.alpha = ctrl.agent.v, ctrl.dt, ctrl.alpha
        grid = OccupancyGrid(static, ctrl.robot_radius, ctrl.resolution, bounds)
        # alpha x occupancy of every cell, flat; a state's cell index is int(clip((p - origin)
        # / resolution, 0, last cell)) along x and y, as in our lookup
        self.penalty = torch.from_numpy(self.alpha * grid.grid.ravel()).to(self.dtype)
        self.columns = grid.shape[1]
        self.origin = torch.tensor(grid.origin, dtype=self.dtype)
        self.inv = 1.0 / grid.resolution
        self.first = torch.zeros(2, dtype=self.dtype)
        self.last = torch.tensor(grid.shape, dtype=self.dtype) - 1.0
        self.goal = [float(g) for g in goal]

    def dynamics(self, state, u):
        """One exact arc. state: (R, 3); u: (R, 1) turn rates. Returns (R, 3)."""
        torch = self.torch
        a = u[:, 0] * (0.5 * self.dt)
        theta = state[:, 2]
        chord = (self.v * self.dt) * torch.sinc(a / torch.pi)
        heading = theta + a
        return torch.stack(
            (
                state[:, 0] + chord * torch.cos(heading),
                state[:, 1] + chord * torch.sin(heading),
                theta + 2.0 * a,
            ),
            dim=1,
        )

    def state_cost(self, state):
        """c(x) = |p - goal| + alpha occupancy(p). state: (..., 3). Returns (...)."""
        p = state[..., :2]
        cells = ((p - self.origin) * self.inv).clamp(self.first, self.last).long()
        distance = self.torch.hypot(p[..., 0] - self.goal[0], p[..., 1] - self.goal[1])
        return distance + self.penalty[cells[..., 0] * self.columns + cells[..., 1]]

    def running_cost(self, state, u):
        """pytorch_mppi's running cost of the state after each step: (R, 3), (R, 1) -> (R,)."""
        return self.state_cost(state)

    def rollout(self, x0, U):
        """States x_0 .. x_N (R, N + 1, 3) of controls U (R, N, 1) from x0 (3,)."""
        torch = self.torch
        state = torch.as_tensor(x0, dtype=self.dtype).expand(len(U), 3)
        states = [state]
        for i in range(U.shape[1]):
            state = self.dynamics(state, U[:, i])
            states.append(state)
        return torch.stack(states, dim=1)

    def cost(self, x0, U):
        """J (R,): the cost summed over x_0 .. x_N of controls U (R, N, 1) from x0 (3,)."""
        return self.state_cost(self.rollout(x0, U)).sum(dim=1)


def make_peer(ctrl, problem):
    """pytorch_mppi.MPPI configured as our controller `ctrl` (see the module docstring)."""
    if isinstance(ctrl.lambda_, str):
        raise ValueError(
            f"pytorch_mppi has a fixed temperature; our controller's lambda_ is {ctrl.lambda_!r}: "
            "build it with a number (e.g. lambda_=1.0)"
        )
    torch, pytorch_mppi = require()
    dtype = problem.dtype
    bound = torch.tensor(ctrl.agent.upper, dtype=dtype)
    return pytorch_mppi.MPPI(
        problem.dynamics,
        problem.running_cost,
        nx=3,
        noise_sigma=torch.tensor(np.diag(ctrl.Sigma), dtype=dtype),
        num_samples=ctrl.K,
        horizon=ctrl.N,
        lambda_=ctrl.lambda_,
        u_min=-bound,
        u_max=bound,
        U_init=torch.zeros(ctrl.N, ctrl.nu, dtype=dtype),
        terminal_state_cost=None,
        step_dependent_dynamics=False,
        noise_abs_cost=False,
    )


class PeerLoop:
    """pytorch_mppi driving our analytic model from a closed loop's start (same interface).

    ours: a timing.loop.ClosedLoop of our controller, before its first step.
    """

    def __init__(self, ours, seed=0):
        torch, _ = require()
        self.torch = torch
        torch.manual_seed(seed)
        self.agent, self.dt = ours.ctrl.agent, ours.ctrl.dt
        self.problem = PeerProblem(ours.ctrl, ours.static, ours.goal, ours.bounds)
        self.mppi = make_peer(ours.ctrl, self.problem)
        self.state = np.array(ours.state, dtype=float)
        self.times = []

    def step(self):
        """One control step; its controller time is appended to `times` [s]."""
        t0 = time.perf_counter()
        u = self.mppi.command(self.torch.from_numpy(self.state)).numpy()
        self.times.append(time.perf_counter() - t0)
        self.state = self.agent.step(self.state, u, self.dt)

    def summary(self):
        """Median and p95 ms per step, skipping the first 3 steps (warm-up), as timing's."""
        times = np.array(self.times[3:]) * 1e3
        return float(np.median(times)), float(np.percentile(times, 95))


def block_ratios(num, den, block, skip=3):
    """Quartiles (25, 50 and 75 %) of median(num's step times) / median(den's) over the blocks
    of `block` consecutive steps that the loops num and den ran interleaved, the first `skip`
    steps left out as the summaries leave them: how far the machine's drift moves the ratio."""
    ratios = [
        np.median(num.times[max(s, skip) : s + block])
        / np.median(den.times[max(s, skip) : s + block])
        for s in range(0, min(len(num.times), len(den.times)), block)
        if s + block > skip
    ]
    return [float(q) for q in np.percentile(ratios, [25, 50, 75])]


def compare(ours, steps, block=1, threaded=None):
    """Time our closed loop `ours` (timing.loop.ClosedLoop, not yet stepped) beside pytorch_mppi's.

    Both run `steps` control steps, interleaved in blocks of `block` consecutive steps each (as
    timing's table: a block's steps find their data in the caches as a controller's consecutive
    steps do; block = 1: every step after the other's, cold), with torch on one thread (the
    caller limits numpy's pools). `threaded`: the same loop with our `threads` > 1, not yet
    stepped, interleaved with the two. Returns a dict: settings, versions, ours and theirs
    (median_ms, p95_ms), both ratios, the first actions and first plans' costs under the shared
    cost, and `same_problem`: a short message that both solve the same problem; with `threaded`
    also "threaded" (threads, median_ms, p95_ms, speedup: ours' median over its, same_path:
    whether it drove the path of `ours` exactly, as equal plans do). The "..._blocks" entries
    are `block_ratios` of the same ratios.
    """
    torch, _ = require()
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        theirs = PeerLoop(ours)
        problem, start = theirs.problem, theirs.state.copy()
        paths, plans = _interleave(ours, theirs, threaded, steps, block)
    finally:
        torch.set_num_threads(threads)
    (mo, po), (mt, pt) = ours.summary(), theirs.summary()
    plans = np.stack(plans)
    costs = problem.cost(start, torch.from_numpy(np.vstack([plans, 0 * plans[:1]]))).tolist()
    first = plans[:, 0, 0].tolist()
    gap = float(np.hypot(*(ours.state[:2] - theirs.state[:2])))
    c = ours.ctrl
    return {
        "settings": {
            "controller": c.name,
            "perturbation": c.perturbation,
            "K": c.K,
            "N": c.N,
            "lambda": c.lambda_,
            "Sigma": c.Sigma.tolist(),
            "steps": steps,
            "block": block,
        },
        "versions": {
            "torch": torch.__version__,
            "pytorch_mppi": importlib.metadata.version("pytorch-mppi"),
        },
        "ours": {"median_ms": mo, "p95_ms": po},
        "theirs": {"median_ms": mt, "p95_ms": pt},
        "ours_over_theirs": mo / mt,
        "theirs_over_ours": mt / mo,
        "theirs_over_ours_blocks": block_ratios(theirs, ours, block),
        "first_actions": first,
        "first_plan_costs": costs[:2],
        "same_problem": (
            f"first step from the same start: omega {first[0]:+.3f} (ours) and {first[1]:+.3f} "
            f"(pytorch_mppi) rad/s, plan costs under the shared cost {costs[0]:.1f} and "
            f"{costs[1]:.1f} (zero turn rates {costs[2]:.1f}); "
            + passing(ours.static, start, ours.goal, ours.ctrl.robot_radius, paths[:2])
            + f"; after {steps} steps they are {100 * gap:.1f} cm apart"
        ),
        **({"threaded": _threaded(ours, threaded, block, paths, mo)} if threaded else {}),
    }


def _interleave(ours, theirs, threaded, steps, block):
    """Step the loops (ours, theirs, threaded if given) `steps` times, in turns of `block`
    steps each; returns (each loop's path [(2,)], the first plans of ours and theirs)."""
    loops = (ours, theirs) + ((threaded,) if threaded else ())
    paths, plans = [[] for _ in loops], []
    for block_start in range(0, steps, block):
        for loop, path in zip(loops, paths, strict=True):
            for i in range(block_start, min(block_start + block, steps)):
                loop.step()
                path.append(loop.state[:2])
                if i == 0 and loop is not threaded:
                    plan = loop.ctrl.diagnostics.plan if loop is ours else loop.mppi.U.numpy()
                    plans.append(np.array(plan))
    return paths, plans


def _threaded(ours, threaded, block, paths, ours_median) -> dict:
    """The "threaded" entry: threads, median_ms, p95_ms, speedup (ours' median over its),
    speedup_blocks, same_path (whether it drove the path of ours exactly)."""
    mp, pp = threaded.summary()
    return {
        "threads": threaded.ctrl.threads, "median_ms": mp, "p95_ms": pp,
        "speedup": ours_median / mp, "speedup_blocks": block_ratios(ours, threaded, block),
        "same_path": bool(np.array_equal(paths[0], paths[2])),
    }  # fmt: skip


def passing(static, start, goal, robot_radius, paths):
    """Which side of the first obstacle on the straight line start-goal each path passes.

    static: (M, 3) cylinders (radius-0 rows ignored); start: (3,); goal: (2,); paths: positions
    (T, 2) per controller, ours first. Returns a phrase.
    """
    static = static[static[:, 2] > 0]
    line = goal - start[:2]
    along = line / np.hypot(*line)
    left = np.array([-along[1], along[0]])
    rel = static[:, :2] - start[:2]
    s, d = rel @ along, rel @ left
    blocking = (np.abs(d) < static[:, 2] + robot_radius) & (s > 0) & (s < np.hypot(*line))
    if not blocking.any():
        return "no obstacle on the straight line to the goal"
    k = np.flatnonzero(blocking)[np.argmin(s[blocking])]
    centre = static[k, :2]
    sides = []
    for path in map(np.asarray, paths):
        past = np.flatnonzero((path - start[:2]) @ along >= s[k])
        if not len(past):
            return f"neither has reached the first obstacle on the way, {s[k]:.1f} m ahead"
        offset = (path[past[0]] - centre) @ left
        sides.append(f"{'left' if offset > 0 else 'right'} ({offset:+.3f} m)")
    return f"they pass the first obstacle on the way on its {sides[0]} and {sides[1]}"
