"""Statistics of episode rows: failure rates with Wilson intervals, paired McNemar tests,
percentile-bootstrap intervals of mean navigation scores (BARN), alone and paired, the
crowd-navigation field's metrics with their intervals, smoothness and indecision (the task
blocked's commitment to a side too), and replays of recorded people per scene against the
people the robot replaced, and the controller diagnostics. A declared column's figure follows its
declaration (dcmppi.bench.episodes.columns: mean, median or mean over steps, over which episodes,
in %).

Shared by the report's tables and its plots.
"""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np

from dcmppi.bench.episodes import columns
from dcmppi.bench.episodes.columns import Column
from dcmppi.tasks import NOISE_PROFILES, task_class

Z95 = 1.959963984540054
BOOTSTRAP = 10_000  # resamples of a bootstrap interval


def wilson(k: int, n: int, z: float = Z95) -> tuple[float, float]:
    """95 % Wilson score interval for a proportion k / n, as fractions."""
    if n == 0:
        return (math.nan, math.nan)
    p = k / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo = 0.0 if k == 0 else max(0.0, centre - half)  # exact at the ends, not 1 - 1e-16
    hi = 1.0 if k == n else min(1.0, centre + half)
    return lo, hi


def bootstrap_mean(values, resamples: int = BOOTSTRAP, seed: int = 0) -> tuple[float, float]:
    """95 % percentile-bootstrap interval of the mean of `values` (n,); the same values give the
    same interval (fixed seed). (nan, nan) for no values."""
    return _bootstrap(values, np.mean, resamples, seed)


def bootstrap_median(values, resamples: int = BOOTSTRAP, seed: int = 0) -> tuple[float, float]:
    """95 % percentile-bootstrap interval of the median of `values` (n,), which may hold inf
    (then so may the bounds); fixed seed as `bootstrap_mean`. (nan, nan) for no values."""
    return _bootstrap(values, np.median, resamples, seed, method="inverted_cdf")


def _bootstrap(values, statistic, resamples, seed, method="linear") -> tuple[float, float]:
    x = np.asarray(values, dtype=np.float64)
    if not x.size:
        return (math.nan, math.nan)
    rng = np.random.default_rng(seed)
    chunk = max(1, 2_000_000 // x.size)  # resamples per draw: bounded memory
    stats = np.concatenate(
        [
            statistic(x[rng.integers(0, x.size, (min(chunk, resamples - i), x.size))], axis=1)
            for i in range(0, resamples, chunk)
        ]
    )
    lo, hi = np.quantile(stats, [0.025, 0.975], method=method)
    return float(lo), float(hi)


def mcnemar_exact(b: int, c: int) -> float:
    """Two-sided exact McNemar p-value for discordant pair counts b and c."""
    n = b + c
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(min(b, c) + 1)) / 2**n
    return min(1.0, 2 * tail)


def summarize(rows: list[dict]) -> dict[tuple[str, str], dict]:
    """Per (noise, row label): episodes, errors, outcome counts and rates with the failure and
    success (goal) rates' CIs, controller ms/step; and the number of episodes with a navigation
    score, their mean score and its bootstrap CI (None without scores)."""
    groups = defaultdict(list)
    for r in rows:
        groups[(r["noise"], r["label"])].append(r)
    out = {}
    for key, group in groups.items():
        ok = [r for r in group if r["status"] == "ok"]
        n = len(ok)
        failures = sum(r["failure"] for r in ok)
        goals = sum(r["outcome"] == "goal" for r in ok)
        scores = [r["nav_score"] for r in ok if r["nav_score"] is not None]
        out[key] = {
            "episodes": n,
            "errors": len(group) - n,
            "collisions": sum(r["collision"] for r in ok),
            "goals": goals,
            "goal_pct": 100 * goals / n if n else math.nan,
            "left_map": sum(r["outcome"] == "left_map" for r in ok),
            "time_limit": sum(r["outcome"] == "time_limit" for r in ok),
            "failures": failures,
            "failure_pct": 100 * failures / n if n else math.nan,
            "failure_ci_pct": tuple(100 * x for x in wilson(failures, n)),
            "ctrl_ms": per_step(ok, "ctrl_ms_mean"),
            "goal_time_s": mean([r["time_to_goal"] for r in ok if r["outcome"] == "goal"]),
            "path_m": mean([r["path_length"] for r in ok if r["outcome"] == "goal"]),
            "success_ci_pct": tuple(100 * x for x in wilson(goals, n)),
            "scored": len(scores),
            "nav_score": mean(scores) if scores else None,
            "nav_score_ci": bootstrap_mean(scores) if scores else None,
        }
    return out


def values(ok: list[dict], column: Column) -> list[float]:
    """The values of `column` in the shown unit (x 100 for a percent) over the finished episodes
    `ok` that record it (of the successful ones where column.over is "goal")."""
    name, scale = column.name, column.scale
    return [
        scale * r[name]
        for r in ok
        if r.get(name) is not None and (column.over == "all" or r["outcome"] == "goal")
    ]


def interval(ok: list[dict], column: Column) -> tuple | None:
    """(figure, lo, hi, n) of `column` over the finished episodes `ok` (`values`): its mean or
    median (column.statistic) with the 95 % bootstrap interval, and the episodes with a value;
    None where none has one."""
    xs = values(ok, column)
    if not xs:
        return None
    if column.statistic == "median":
        return (float(np.median(xs)), *bootstrap_median(xs), len(xs))
    return (mean(xs), *bootstrap_mean(xs), len(xs))


def figure(ok: list[dict], column: Column) -> float | None:
    """A row's figure of `column` over its finished episodes `ok`, without an interval: the
    mean over all steps (statistic "per_step"), else `interval`'s figure; None where none
    records it."""
    if column.statistic == "per_step":
        x = per_step(ok, column.name)
        return None if x is None else column.scale * x
    xs = values(ok, column)
    if not xs:
        return None
    return float(np.median(xs)) if column.statistic == "median" else mean(xs)


def field_metrics(rows: list[dict]) -> dict[tuple[str, str], dict]:
    """The field's metrics per (noise, row label) over its finished episodes: `episodes`; the
    success, pedestrian-collision, static-collision and timeout rates in % with their Wilson
    intervals, each (pct, lo, hi) (the collision kinds None when a collided episode lacks its
    kind, an older database); per column of the report's metrics table (columns.shown) its
    `interval` (min_ttc's median may be inf)."""
    groups = finished_by_row(rows)
    out = {}
    for key, ok in groups.items():
        n = len(ok)
        kinds = [r["collision_kind"] for r in ok if r["collision"]]
        known = None not in kinds
        s = {
            "episodes": n,
            "success": rate(sum(r["outcome"] == "goal" for r in ok), n),
            "pedestrian": rate(kinds.count("pedestrian"), n) if known else None,
            "static": rate(kinds.count("static"), n) if known else None,
            "timeout": rate(sum(r["outcome"] == "time_limit" for r in ok), n),
        }
        out[key] = {**s, **{c.name: interval(ok, c) for c in columns.shown("metrics")}}
    return out


COMMIT_WITHIN = 1.0  # [s] the task blocked: commitment to a side this soon counts as prompt


def smoothness(rows: list[dict]) -> dict[tuple[str, str], dict]:
    """Smoothness and indecision per (noise, row label) over its finished episodes: `episodes`;
    per column of the report's smoothness table (columns.shown) its `interval`.

    Where episodes record a side of the obstacle (the task blocked: side_switches not NULL;
    `blocked` counts them, else 0): commit_time (mean, lo, hi, n) over the episodes that took a
    side; and (pct, lo, hi) with Wilson intervals over the blocked episodes: committed
    (commit_time <= COMMIT_WITHIN), settled (commit_delay <= COMMIT_WITHIN: it kept a side
    within that long of first taking one), never_switched (took a side and never changed it).
    An episode that never took a side counts as none of these. The same of the side the plans
    take, over the episodes that record it (plan_side_switches not NULL: a controller that
    plans; `planned` counts them): plan_commit_time, plan_committed, plan_settled and
    plan_never_switched."""
    groups = finished_by_row(rows)
    out = {}
    for key, ok in groups.items():
        s = {"episodes": len(ok), **{c.name: interval(ok, c) for c in columns.shown("smoothness")}}
        s["blocked"], sides = _sides(ok, "")
        s["planned"], plan_sides = _sides(ok, "plan_")
        out[key] = {**s, **sides, **plan_sides}
    return out


def _sides(ok: list[dict], prefix: str) -> tuple[int, dict]:
    """The episodes of `ok` that record a side (column prefix + "side_switches" not NULL) and
    smoothness's commit_time, committed, settled and never_switched of them, each key with
    `prefix`."""
    sided = [r for r in ok if r.get(prefix + "side_switches") is not None]
    took = [r for r in sided if r.get(prefix + "commit_time") is not None]
    n = len(sided)
    times = [r[prefix + "commit_time"] for r in took]
    prompt = sum(r[prefix + "commit_time"] <= COMMIT_WITHIN for r in took)
    settled = sum(r[prefix + "commit_delay"] <= COMMIT_WITHIN for r in took)
    kept = sum(r[prefix + "side_switches"] == 0 for r in took)
    return n, {
        prefix + "commit_time": (mean(times), *bootstrap_mean(times), len(times))
        if times
        else None,
        prefix + "committed": rate(prompt, n) if n else None,
        prefix + "settled": rate(settled, n) if n else None,
        prefix + "never_switched": rate(kept, n) if n else None,
    }


def diagnostics(rows: list[dict]) -> dict[tuple[str, str], dict]:
    """Per (noise, row label) with finished episodes: the `figure` of each column of the report's
    diagnostics table (columns.shown) over them."""
    return {
        key: {c.name: figure(ok, c) for c in columns.shown("diagnostics")}
        for key, ok in finished_by_row(rows).items()
    }


FREEZE_MARGIN = 1.0  # [m] a timeout within this of the goal region froze near the goal
SCENE_ORDER = ("eth", "hotel", "univ", "zara1", "zara2")  # the test scenes, in this order
ALL_SCENES = "all"


def replay_scenes(rows: list[dict]) -> dict[tuple[str, str, str], dict]:
    """Replays of recorded people per (noise, row label, scene) over the finished episodes with
    a scene (the task replay), and per (noise, row label, ALL_SCENES) over all of them:
    `episodes`; success, collision and timeout rates (pct, lo, hi) with Wilson intervals;
    path_ratio and time_ratio (mean, lo, hi, n) with bootstrap intervals, over the successful
    episodes, of frame_path_length / human_path_length (both paths sampled at the recording's
    frame period) and time_to_goal / human_time; frozen and elsewhere (pct, lo, hi) of the
    episodes: timeouts that ended within the task's goal tolerance + FREEZE_MARGIN of the goal's
    centre (goal_distance), and the other timeouts (None where goal_distance is not recorded). {}
    without replays."""
    groups = defaultdict(list)
    for r in rows:
        if r["status"] == "ok" and r.get("scene") is not None:
            groups[(r["noise"], r["label"], r["scene"])].append(r)
            groups[(r["noise"], r["label"], ALL_SCENES)].append(r)
    out = {}
    for key, ok in groups.items():
        n = len(ok)
        goals = [r for r in ok if r["outcome"] == "goal"]
        paths = [
            r["frame_path_length"] / r["human_path_length"]
            for r in goals
            if r["frame_path_length"] is not None and r["human_path_length"]
        ]
        times = [
            r["time_to_goal"] / r["human_time"]
            for r in goals
            if r["time_to_goal"] is not None and r["human_time"]
        ]
        timeouts = [r for r in ok if r["outcome"] == "time_limit"]
        known = all(r.get("goal_distance") is not None for r in timeouts)
        near = sum(r["goal_distance"] <= frozen_within(r["task"]) for r in timeouts) if known else 0
        out[key] = {
            "episodes": n,
            "success": rate(len(goals), n),
            "collision": rate(sum(bool(r["collision"]) for r in ok), n),
            "timeout": rate(len(timeouts), n),
            "path_ratio": (mean(paths), *bootstrap_mean(paths), len(paths)) if paths else None,
            "time_ratio": (mean(times), *bootstrap_mean(times), len(times)) if times else None,
            "frozen": rate(near, n) if known else None,
            "elsewhere": rate(len(timeouts) - near, n) if known else None,
        }
    return out


def frozen_within(task: str) -> float:
    """The distance [m] from the goal's centre within which a timeout of `task` froze near the
    goal: its goal tolerance (the task class's) + FREEZE_MARGIN."""
    return task_class(task).goal_tolerance + FREEZE_MARGIN


def scene_order(scenes) -> list[str]:
    """`scenes` with the test scenes first in SCENE_ORDER, others by name, ALL_SCENES last."""
    order = {s: i for i, s in enumerate(SCENE_ORDER)}
    return sorted(set(scenes), key=lambda s: (s == ALL_SCENES, order.get(s, len(order)), s))


def finished_by_row(rows: list[dict]) -> dict[tuple[str, str], list[dict]]:
    """The finished episodes (status ok) of `rows` by (noise, row label), in their order."""
    groups = defaultdict(list)
    for r in rows:
        if r["status"] == "ok":
            groups[(r["noise"], r["label"])].append(r)
    return groups


def rate(k: int, n: int) -> tuple[float, float, float]:
    """k of n in % with its Wilson interval: (pct, lo, hi)."""
    return (100 * k / n, *(100 * x for x in wilson(k, n)))


def per_step(rows: list[dict], column: str) -> float | None:
    """Mean over all steps of a per-episode mean `column` (weighted by steps); None when no
    episode recorded it."""
    have = [r for r in rows if r[column] is not None and r["steps"]]
    steps = sum(r["steps"] for r in have)
    return sum(r[column] * r["steps"] for r in have) / steps if steps else None


def paired(rows: list[dict], noise: str, a: str, b: str) -> dict | None:
    """McNemar on collisions between rows a and b over the environments both finished."""
    by = {(r["label"], r["env_index"]): r for r in rows if r["noise"] == noise}
    envs = [
        i
        for (c, i), r in by.items()
        if c == a and r["status"] == "ok" and by.get((b, i), {}).get("status") == "ok"
    ]
    if not envs:
        return None
    only_a = sum(by[(a, i)]["collision"] and not by[(b, i)]["collision"] for i in envs)
    only_b = sum(by[(b, i)]["collision"] and not by[(a, i)]["collision"] for i in envs)
    return {
        "pairs": len(envs),
        "only_a": only_a,
        "only_b": only_b,
        "p": mcnemar_exact(only_a, only_b),
    }


def paired_scores(rows: list[dict], noise: str, a: str, b: str) -> dict | None:
    """Mean navigation score of row a minus row b over the environments both scored, with its
    95 % percentile-bootstrap interval over environments; None when they share none."""
    by = {(r["label"], r["env_index"]): r["nav_score"] for r in rows if r["noise"] == noise}
    envs = sorted(
        i
        for (c, i), score in by.items()
        if c == a and score is not None and by.get((b, i)) is not None
    )
    if not envs:
        return None
    diffs = [by[(a, i)] - by[(b, i)] for i in envs]
    return {"pairs": len(envs), "diff": mean(diffs), "ci": bootstrap_mean(diffs)}


def mean(xs):
    """Mean of the values that are not None (nan when none are)."""
    xs = [x for x in xs if x is not None]
    return sum(xs) / len(xs) if xs else math.nan


def fmt(x) -> str:
    """A paper figure, or '-' when the paper gives none."""
    return "-" if x is None else f"{x:g}"


def noise_order(noise: str) -> int:
    """Sort key: the noise profiles in the paper's order, others after."""
    return NOISE_PROFILES.index(noise) if noise in NOISE_PROFILES else len(NOISE_PROFILES)


def row_order(labels, defined) -> list[str]:
    """`labels` in the order of the experiment's rows `defined`, others after by name."""
    defined = list(defined)
    return sorted(
        set(labels), key=lambda c: (defined.index(c) if c in defined else len(defined), c)
    )
