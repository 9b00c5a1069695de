"""The episode viewer: one self-contained HTML page that plays an episode in 2-D from its states.

    viewer = Viewer()
    run_episode(spec, on_step=viewer)       # reads the episode after its reset and every step
    viewer.write("episode.html", "forest / mppi / env 3")

The page (web/viewer.js) draws, at every control instant, the robot and its trail, the static
obstacles and walls, the goal, the people, the plan made there, a subsample of its sampled
rollouts coloured by cluster (the chosen cluster's darker) and of the people's sampled futures
(dc), with a time slider, play and pause, speed, and the instant's figures: the control applied,
the minimum gap to any obstacle, the plan's cost terms and the ESS.

To keep a page small, rollouts and futures are subsampled (ROLLOUTS of the K samples, FUTURES
per obstacle for the nearest OBSTACLES, each at POINTS of its N + 1 states) and their
coordinates, and the people's, rounded to 1 cm (16-bit centimetres); the robot's poses are kept
as the trace stores them (float32). A 60 s episode at 10 Hz among 100 people is about 4 MB.
"""

from __future__ import annotations

import base64
import html

import numpy as np

from dcmppi.control import Diagnostics
from dcmppi.control.kernels.costs import goal_distance
from dcmppi.control.objective import Objective
from dcmppi.render import overlay
from dcmppi.render.html import page, script_data

ROLLOUTS = 32  # sampled rollouts drawn per control instant, evenly spread over the K
FUTURES = 6  # sampled futures drawn per moving obstacle
OBSTACLES = 10  # moving obstacles whose futures are drawn, the nearest
POINTS = 11  # points of a drawn rollout or future (its N + 1 states subsampled)
PLAN_POINTS = 26  # points of the drawn plan
MARGIN = 2.0  # [m] around the path, start and goal in the first view
NOISE = 8  # the colour index of samples in no cluster (overlay.GREY)
CHOSEN = 16  # added to a colour index: a sample of the chosen cluster
IN_CM = ("people", "rollout", "future", "plan")  # coordinates kept to 1 cm (_encode)


def subsample(n: int, m: int) -> np.ndarray:
    """m indices spread evenly over 0..n-1, the first and the last included (some twice where
    n < m)."""
    return np.linspace(0, n - 1, m).round().astype(int)


def _cm(xy) -> np.ndarray:
    return np.round(np.asarray(xy, dtype=np.float64), 2).astype("<f4")


class Viewer:
    """Collects what the page draws, read from an episode (dcmppi.bench.episodes.runner.Episode
    or any object with its spec, env, controller, time_step, poses and actions) after its reset
    and after each step: call it then (run_episode's on_step).

    Control instant i holds the robot's pose, the people and the minimum gap at it, and the
    plan, rollouts, futures, cost terms and control of the step taken from it (read after that
    step); the last instant has none.
    """

    def __init__(self):
        self.world: dict | None = None
        self.meta: dict = {}
        self.poses, self.people, self.gaps = [], [], []
        self.controls, self.costs, self.ess = [], [], []
        self.rollouts, self.colours, self.plans, self.futures = [], [], [], []

    def __call__(self, episode) -> None:
        if self.world is None:
            self._begin(episode)
        else:
            self._step(episode)
        env = episode.env
        self.poses.append(np.asarray(episode.poses[-1], dtype="<f4"))
        moving = env.physics.moving_obstacles()
        self.people.append(_cm(moving[:, [0, 1, 3]]))
        self.gaps.append(float(episode.time_step.observation["clearance"][0]))
        self.meta["outcome"] = env.task.outcome or "running"

    def _begin(self, episode) -> None:
        env, obs = episode.env, episode.time_step.observation
        world = env.task.world
        static = obs["static_obstacles"]
        self.nu = len(env.task.agent.controls)
        self.world = {
            "bounds": [float(v) for v in obs["map_bounds"]],
            "goal": [float(v) for v in obs["goal"][:2]],
            "goal_tolerance": float(env.task.goal_tolerance),
            "start": [float(v) for v in world.start[:2]],
            "static": np.round(static[static[:, 2] > 0], 3).tolist(),
            "walls": np.round(np.asarray(world.walls).reshape(-1, 4), 3).tolist(),
            "robot_radius": float(env.task.robot_radius),
        }
        spec = episode.spec
        self.meta.update(task=spec.task, controller=spec.controller, noise=spec.noise)
        self.meta.update(seed=spec.seed, controls=list(env.task.agent.controls))
        self.dt = float(env.control_timestep())

    def _step(self, episode) -> None:
        """The step just taken from the last instant: its control, and what the controller
        planned there."""
        c = episode.controller
        self.controls.append(np.asarray(episode.actions[-1], dtype="<f4"))
        d = getattr(c, "diagnostics", None)
        d = d if isinstance(d, Diagnostics) else Diagnostics()
        plan = None
        if d.states is not None and d.plan is not None:
            plan = c.agent.rollout_one(d.states[0, 0], d.plan, c.dt)
            self.meta.setdefault("K", int(len(d.states)))
            self.meta.setdefault("N", int(d.states.shape[1] - 1))
        self._rollouts(d)
        self.costs.append(_terms(c, plan))
        if plan is not None:
            plan = _cm(plan[subsample(len(plan), PLAN_POINTS), :2])
        self.plans.append(plan)
        self.futures.append(self._futures(d, episode.poses[-2]))
        self.ess.append(float(d.ess))

    def _rollouts(self, d: Diagnostics) -> None:
        if d.states is None:
            self.rollouts.append(np.zeros((0, POINTS, 2), "<f4"))
            self.colours.append(np.zeros(0, np.uint8))
            return
        K, n = d.states.shape[:2]
        k = np.unique(subsample(K, ROLLOUTS))
        self.rollouts.append(_cm(d.states[k][:, subsample(n, POINTS), :2]))
        labels = overlay.cluster_labels(d)
        if labels is None:
            colour = np.full(len(k), NOISE, np.uint8)
        else:
            colour = np.where(labels[k] < 0, NOISE, labels[k] % len(overlay.PALETTE))
            chosen = (labels[k] == d.chosen) & (d.chosen >= 0)
            colour = (colour + CHOSEN * chosen).astype(np.uint8)
        self.colours.append(colour)

    def _futures(self, d: Diagnostics, pose) -> np.ndarray:
        """(F, POINTS, 2) the futures drawn: FUTURES of each of the OBSTACLES moving obstacles
        nearest the robot's `pose` at their first point."""
        samples = overlay.obstacle_futures(d)
        if samples is None:
            return np.zeros((0, POINTS, 2), "<f4")
        L, P, n, _ = samples.shape
        near = np.argsort(np.hypot(*(samples[:, 0, 0] - pose[:2]).T))[:OBSTACLES]
        chosen = samples[near][:, np.unique(subsample(P, FUTURES))][:, :, subsample(n, POINTS)]
        return _cm(chosen.reshape(-1, chosen.shape[2], 2))

    def data(self) -> dict:
        """What the page reads: meta, world, the view, and the arrays (base64)."""
        n = len(self.poses)
        pad = n - len(self.controls)  # the last instant: no step taken from it
        nan = np.float32("nan")
        controls = self.controls + [np.full(self.nu, nan, "<f4")] * pad
        costs = self.costs + [np.full(3, nan)] * pad
        plans = [p[None] for p in self.plans if p is not None]
        counts = {
            "rollout_count": [len(r) for r in self.rollouts] + [0] * pad,
            "future_count": [len(f) for f in self.futures] + [0] * pad,
            "plan_count": [int(p is not None) for p in self.plans] + [0] * pad,
        }
        arrays = {
            "pose": np.stack(self.poses),
            "people": np.stack(self.people),
            "gap": np.asarray(self.gaps, "<f4"),
            "control": np.stack(controls),
            "cost": np.asarray(costs, "<f4"),
            "ess": np.asarray(self.ess + [np.nan] * pad, "<f4"),
            "rollout": _concat(self.rollouts, (POINTS, 2)),
            "rollout_colour": np.concatenate([np.zeros(0, np.uint8), *self.colours]),
            "future": _concat(self.futures, (POINTS, 2)),
            "plan": _concat(plans, (PLAN_POINTS, 2)),
            **{k: np.asarray(v, "<u2") for k, v in counts.items()},
        }
        return {
            "frames": n,
            "dt": self.dt,
            "controls": self.meta["controls"],
            "people": int(arrays["people"].shape[1]),
            "points": {"rollout": POINTS, "future": POINTS, "plan": PLAN_POINTS},
            "meta": self.meta,
            "world": self.world,
            "view": self._view(arrays["pose"]),
            "colours": _colours(),
            "arrays": {k: _encode(v, k in IN_CM) for k, v in arrays.items()},
        }

    def _view(self, poses) -> list[float]:
        """The first view [x0, y0, x1, y1]: the path, start and goal with MARGIN, widened to
        a side ratio of at most 2, in the map."""
        points = np.vstack([poses[:, :2], [self.world["start"], self.world["goal"]]])
        lo, hi = points.min(axis=0) - MARGIN, points.max(axis=0) + MARGIN
        grow = np.maximum(0.0, (hi - lo).max() / 2 - (hi - lo)) / 2
        lo, hi = lo - grow, hi + grow
        b = self.world["bounds"]
        lo, hi = np.maximum(lo, b[:2]), np.minimum(hi, b[2:])
        return [float(v) for v in (*lo, *hi)]

    def write(self, path, title: str, notes: str = "") -> None:
        """Write the page to `path`; `title` heads it, `notes` (text) go below the figures."""
        data = self.data()
        meta = data["meta"]
        K = f"{meta['K']}" if "K" in meta else "no"
        sub = (
            f"Drawn from the episode's states at its {data['frames']} control instants "
            f"(dt {self.dt:g} s). Rollouts: {ROLLOUTS} of the K = {K} samples per instant, "
            f"futures: {FUTURES} per moving obstacle for the {OBSTACLES} nearest, each at "
            f"{POINTS} of its states; their coordinates, and the people's, rounded to 1 cm. "
            "The plan: the controls chosen there rolled out from the robot's state."
        )
        body = _BODY.format(
            title=html.escape(title),
            outcome=html.escape(meta["outcome"]),
            legend=_legend(),
            notes="".join(f"<p>{html.escape(line)}</p>" for line in notes.splitlines() if line),
            subsampled=html.escape(sub),
            data=script_data(data),
        )
        with open(path, "w") as f:
            f.write(page(f"dcmppi episode: {title}", body, ("viewer.js",)))


def _terms(controller, plan) -> np.ndarray:
    """(3,) the plan's cost under the step's objective: goal distance, static collisions
    (alpha per state in the static map) and the moving-obstacle term; nan without one."""
    objective = getattr(controller, "objective", None)
    if plan is None or not isinstance(objective, Objective):
        return np.full(3, np.nan)
    states = np.ascontiguousarray(plan.T[:, :, None])  # (3, N + 1, 1)
    x, y = states[0], states[1]
    goal = float(goal_distance(x, y, objective.goal)[0])
    static = 0.0
    if not objective.grid.empty and objective.alpha:
        static = float(objective.alpha * objective.grid.count(x, y)[0])
    return np.array([goal, static, float(objective.moving(states)[0])])


def _concat(parts, shape) -> np.ndarray:
    return np.concatenate([np.zeros((0, *shape), "<f4"), *parts]).astype("<f4")


def _encode(a: np.ndarray, cm: bool = False) -> dict:
    """The array for the page: its dtype and its bytes in base64; with cm, metres rounded to
    1 cm as 16-bit integer centimetres ("scale": 0.01) where they fit."""
    if cm and np.abs(a).max(initial=0.0) < 327.67:
        a, scale = np.round(a.astype(np.float64) * 100).astype("<i2"), {"scale": 0.01}
    else:
        scale = {}
    dtype = {"f": "f", "u": "u", "i": "i"}[a.dtype.kind] + str(a.dtype.itemsize)
    data = base64.b64encode(np.ascontiguousarray(a).tobytes()).decode()
    return {"dtype": dtype, **scale, "b64": data}


ROBOT, STATIC, PEOPLE = "rgb(31,78,121)", "rgb(107,107,107)", "rgb(128,60,170)"


def _rgb(c) -> str:
    return "rgb({},{},{})".format(*(round(255 * v) for v in c[:3]))


def _colours() -> dict:
    """The page's colours: the overlay's, as the videos draw them (RGB in 0..1), and CSS ones."""
    return {
        "palette": overlay.PALETTE.round(3).tolist(),
        "grey": overlay.GREY.tolist(),
        "plan": list(overlay.PLAN_RGBA[:3]),
        "trail": list(overlay.TRAIL_RGBA[:3]),
        "future": list(overlay.FUTURE_RGBA[:3]),
        "robot": ROBOT,
        "static": STATIC,
        "people": PEOPLE,
    }


def _legend() -> str:
    """The legend's entries, each line's colour and what it is."""
    entries = (
        (_rgb(overlay.PALETTE[0]), "rollouts by cluster (chosen darker)"),
        (_rgb(overlay.GREY), "in no cluster, or not clustered"),
        (_rgb(overlay.PLAN_RGBA), "plan"),
        (_rgb(overlay.TRAIL_RGBA), "trail"),
        (_rgb(overlay.FUTURE_RGBA), "people's futures"),
        (PEOPLE, "people"),
        (STATIC, "static obstacles"),
        (ROBOT, "robot"),
    )
    return "".join(f'<span><i style="background:{c}"></i>{text}</span>' for c, text in entries)


_BODY = """<h1>{title}</h1>
<p>Outcome: <b>{outcome}</b>. Space plays and pauses, the arrow keys step, the wheel zooms, a drag
pans, a double click fits the view.</p>
<div class=viewer>
<div class=stage>
<canvas id=stage></canvas>
<div class=bar><button id=play>Play</button>
<input id=slider type=range min=0 value=0 step=1 aria-label="control instant">
<label>speed <select id=speed><option value=0.25>0.25x</option><option value=0.5>0.5x</option>
<option value=1 selected>1x</option><option value=2>2x</option><option value=4>4x</option>
</select></label></div>
<div class="bar layers">
<label><input type=checkbox name=rollouts checked> rollouts</label>
<label><input type=checkbox name=futures checked> futures</label>
<label><input type=checkbox name=plan checked> plan</label>
<label><input type=checkbox name=trail checked> trail</label></div>
<div class=legend>{legend}</div>
</div>
<div class=side>
<p id=clock></p>
<table class=figures><tbody id=figures></tbody></table>
<p class=note>Minimum gap to any obstacle over the episode (0: contact); click to seek:</p>
<canvas id=chart></canvas>
{notes}
<p class=note>{subsampled}</p>
</div>
</div>
<script id=episode type="application/json">{data}</script>
"""
