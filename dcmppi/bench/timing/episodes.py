"""`dcmppi timing --profile EXPERIMENT`: where a bench episode's time goes, end to end.

The first `environments` environments of every row and noise profile of an experiment run in
this process as a bench worker runs them (dcmppi.bench.episodes.runner.Episode), timed:
- per step: the controller's act(), split by its timer hook (dcmppi.control.timer) into its
  parts and the Python between them; the task's env.step, split into MuJoCo's substeps (the
  physics' substep loop), the moving obstacles' motion (their own model: arcs, pedestrians'
  behaviours), the clearances and collision switches, the task's before_step, after_step and
  observation, and the rest (dm_control's step, the physics' own Python); the runner's
  bookkeeping between two steps (the diagnostics, the field metrics, and the rest: the pose,
  the observation with any true futures);
- per episode: its set-up (the environment, world and reset, the controller, the warm-up), its
  result, and its hand-off to the parent (the result pickled and unpickled) and row in a
  results database.
These parts are timed by wrapping those methods on the episode's own objects (instance
attributes), so the bench's code runs unchanged; the wrappers' cost (well under a
microsecond each) is in the times. From the means per row it projects the whole experiment on W
workers that never wait, and its floor: the controllers' parts and the substep loop alone.
"""

import collections
import itertools
import pickle
import tempfile
import time
from pathlib import Path

from threadpoolctl import threadpool_limits

from dcmppi.bench.episodes.runner import Episode
from dcmppi.bench.results.database import ResultsDB
from dcmppi.bench.timing.profile import LABELS, NESTED
from dcmppi.control.timer import StepTimer

# (key, owner, method) timed inside env.step and, by the runner, between two steps; owners:
# the env's "physics" and "task", the physics' obstacle "motion" (None without moving
# obstacles: nothing to time), the episode's "diagnosis" and field "metrics"
ENV_PARTS = (
    ("substeps", "physics", "_substeps"),
    ("obstacle motion", "motion", "advance"),
    ("clearances", "physics", "_update_clearance"),
    ("collision switches", "physics", "_activate_near"),
    ("before_step", "task", "before_step"),
    ("after_step", "task", "after_step"),
    ("observation", "task", "get_observation"),
)
RUNNER_PARTS = (("diagnostics", "diagnosis", "read"), ("field metrics", "metrics", "read"))
EPISODE_PARTS = ("set-up", "result", "hand-off and record")


def _timed(method, sums, key):
    """`method` with its seconds added to sums[key]."""
    clock = time.perf_counter

    def timed(*args, **kwargs):
        t0 = clock()
        try:
            return method(*args, **kwargs)
        finally:
            sums[key] += clock() - t0

    return timed


def profile_episode(spec, db, key):
    """Run one episode of `spec` as a worker does and record it in `db` (a ResultsDB) under `key`.

    Returns {"steps": int, "step": {part: seconds summed over the steps}, "episode": {part:
    seconds}, "labels": {timer label: seconds}}; "step" holds "controller", "controller parts"
    (the timed labels' sum), "env.step", ENV_PARTS' keys, "runner" and RUNNER_PARTS' keys."""
    t0 = time.perf_counter()
    episode = Episode(spec)
    setup = time.perf_counter() - t0
    sums = collections.defaultdict(float)
    env = episode.env
    owners = {
        "physics": env.physics,
        "motion": env.physics.obstacle_motion,
        "task": env.task,
        "diagnosis": episode.diagnosis,
        "metrics": episode.metrics,
    }
    for name, owner, method in ENV_PARTS + RUNNER_PARTS:
        if owners[owner] is not None:
            target = owners[owner]
            setattr(target, method, _timed(getattr(target, method), sums, name))
    timer = episode.controller.timer = StepTimer()
    walls = 0.0
    while not episode.done:
        t0 = time.perf_counter()
        episode.step()
        walls += time.perf_counter() - t0
    t0 = time.perf_counter()
    result = episode.result()
    t1 = time.perf_counter()
    db.record(key, spec, pickle.loads(pickle.dumps(result)))
    t2 = time.perf_counter()
    parts = {label: seconds for label, (seconds, _) in timer.take().items()}
    controller, env_step = sum(episode.ctrl_s), sum(episode.env_s)
    step = {
        "controller": controller,
        "controller parts": sum(s for label, s in parts.items() if NESTED.get(label) not in parts),
        "env.step": env_step,
        **{name: sums[name] for name, _, _ in ENV_PARTS},
        "runner": walls - controller - env_step,
        **{name: sums[name] for name, _, _ in RUNNER_PARTS},
    }
    episode_parts = {"set-up": setup, "result": t1 - t0, "hand-off and record": t2 - t1}
    return {
        "steps": len(episode.ctrl_s),
        "step": step,
        "episode": episode_parts,
        "labels": parts,
    }


def profile_experiment(exp, environments, workers):
    """Profile `environments` environments of `exp` (an Experiment) in this process, one thread.

    Returns {"experiment", "environments", "workers", "rows": {label: {"episodes",
    "steps_per_episode", "per_step_us": {part: us}, "parts_us": {timer label: us per step},
    "per_episode_ms": {part: ms}, "episode_s"}}, "projection": {"episodes", "minutes",
    "floor_minutes"}}: the experiment's exp.count() episodes at these means per row, on `workers`
    workers that never wait, and with only the controllers' parts and MuJoCo's substeps.
    """
    sample = exp.select(episodes=min(environments, exp.episodes))
    sums = {}
    with threadpool_limits(1), tempfile.TemporaryDirectory() as tmp:
        db = ResultsDB(Path(tmp) / "profile.db", sample.config())
        try:
            _warm_up(sample)
            for key, spec in sample.specs():
                one = profile_episode(spec, db, key)
                row = sums.setdefault(key[1], _empty())
                row["episodes"] += 1
                row["steps"] += one["steps"]
                for group in ("step", "episode", "labels"):
                    for part, seconds in one[group].items():
                        row[group][part] += seconds
        finally:
            db.close()
    rows = {label: _means(row) for label, row in sums.items()}
    each = exp.episodes * len(exp.noises)  # the whole experiment's episodes of one row
    whole = each * sum(r["episode_s"] for r in rows.values())
    floor = (
        each
        * sum(
            r["steps_per_episode"]
            * (r["per_step_us"]["controller parts"] + r["per_step_us"]["substeps"])
            for r in rows.values()
        )
        * 1e-6
    )
    return {
        "experiment": exp.name,
        "environments": sample.episodes,
        "workers": workers,
        "rows": rows,
        "projection": {
            "episodes": exp.count(),
            "minutes": whole / workers / 60,
            "floor_minutes": floor / workers / 60,
        },
    }


def _warm_up(exp):
    """One untimed step of every row and noise profile of `exp`'s first environment: a worker
    pays the first calls (compilation caches, imports) once, not once per episode."""
    for _, spec in itertools.islice(exp.specs(), len(exp.noises) * len(exp.labels)):
        Episode(spec).step()


def _empty():
    return {
        "episodes": 0,
        "steps": 0,
        "step": collections.defaultdict(float),
        "episode": collections.defaultdict(float),
        "labels": collections.defaultdict(float),
    }


def _means(row):
    steps, episodes = row["steps"], row["episodes"]
    per_step = {part: 1e6 * s / steps for part, s in row["step"].items()}
    per_episode = {part: 1e3 * s / episodes for part, s in row["episode"].items()}
    whole = sum(row["step"][p] for p in ("controller", "env.step", "runner"))
    return {
        "episodes": episodes,
        "steps_per_episode": steps / episodes,
        "per_step_us": per_step,
        "parts_us": {label: 1e6 * s / steps for label, s in row["labels"].items()},
        "per_episode_ms": per_episode,
        "episode_s": (whole + sum(row["episode"].values())) / episodes,
    }


def print_profile_experiment(report):
    """The report of profile_experiment as a table: a column per row, a line per part."""
    rows = report["rows"]
    labels = list(rows)
    seen = {label for r in rows.values() for label in r["parts_us"]}
    parts = [label for label in LABELS if label in seen] + sorted(seen - set(LABELS))
    print(
        f"dcmppi timing --profile {report['experiment']}: {report['environments']} "
        f"environment{'s' if report['environments'] > 1 else ''} of every row and noise profile, "
        "run as a worker runs them, one thread"
    )
    width = max(11, *(len(label) + 2 for label in labels))
    print(f"{'':<34}" + "".join(f"{label:>{width}}" for label in labels))

    def line(name, values, fmt):
        print(f"{name:<34}" + "".join(f"{v:>{width}{fmt}}" for v in values))

    line("episodes", [r["episodes"] for r in rows.values()], "d")
    line("steps per episode", [r["steps_per_episode"] for r in rows.values()], ".1f")
    print("per step, us")
    step = [r["per_step_us"] for r in rows.values()]
    line("controller", [s["controller"] for s in step], ".1f")
    line("  its timed parts", [s["controller parts"] for s in step], ".1f")
    for part in parts:
        indent = "      " if NESTED.get(part) in seen else "    "
        line(f"{indent}{part}", [r["parts_us"].get(part, 0.0) for r in rows.values()], ".1f")
    line("  between its parts", [s["controller"] - s["controller parts"] for s in step], ".1f")
    line("env.step", [s["env.step"] for s in step], ".1f")
    for name, _, _ in ENV_PARTS:
        line(
            f"  {name}{' (MuJoCo, its loop)' if name == 'substeps' else ''}",
            [s[name] for s in step],
            ".1f",
        )
    rest = [s["env.step"] - sum(s[name] for name, _, _ in ENV_PARTS) for s in step]
    line("  the rest (dm_control, physics)", rest, ".1f")
    line("runner, between steps", [s["runner"] for s in step], ".1f")
    for name, _, _ in RUNNER_PARTS:
        line(f"  {name}", [s[name] for s in step], ".1f")
    rest = [s["runner"] - sum(s[name] for name, _, _ in RUNNER_PARTS) for s in step]
    line("  the rest (pose, observation)", rest, ".1f")
    print("per episode, ms")
    for part in EPISODE_PARTS:
        line(part, [r["per_episode_ms"][part] for r in rows.values()], ".2f")
    line("whole episode, s", [r["episode_s"] for r in rows.values()], ".3f")
    p = report["projection"]
    print(
        f"the experiment's {p['episodes']} episodes on {report['workers']} workers: "
        f"{p['minutes']:.1f} min; with only the controllers' parts and the substep loop: "
        f"{p['floor_minutes']:.1f} min"
    )
