"""Reports of a results database: paper-style tables, CSV, plots.

Statistics: failure rates with 95 % Wilson score intervals; paired comparisons of each
controller against `mppi` on the same environments with McNemar's exact test on
collisions; the paper's figures beside ours (they count out of 1000 environments).
"""

from __future__ import annotations

import csv
import math
from collections import defaultdict
from pathlib import Path

from dcmppi.experiments import NOISE_PROFILES, PAPER
from dcmppi.results import COLUMN_NAMES, ResultsDB

Z95 = 1.959963984540054


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


def mcnemar_exact(b: int, c: int) -> float:
    """Two-sided exact McNemar p-value for discordant pair counts b and c."""
    n = b + c
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(min(b, c) + 1)) / 2**n
    return min(1.0, 2 * tail)


def summarize(rows: list[dict]) -> dict[tuple[str, str], dict]:
    """Per (noise, controller): episodes, errors, collisions, failures, CI, ms/step."""
    groups = defaultdict(list)
    for r in rows:
        groups[(r["noise"], r["controller"])].append(r)
    out = {}
    for key, group in groups.items():
        ok = [r for r in group if r["status"] == "ok"]
        n = len(ok)
        failures = sum(r["failure"] for r in ok)
        steps = sum(r["steps"] for r in ok)
        out[key] = {
            "episodes": n,
            "errors": len(group) - n,
            "collisions": sum(r["collision"] for r in ok),
            "failures": failures,
            "failure_pct": 100 * failures / n if n else math.nan,
            "failure_ci_pct": tuple(100 * x for x in wilson(failures, n)),
            "ctrl_ms": (sum(r["ctrl_ms_mean"] * r["steps"] for r in ok) / steps)
            if steps
            else math.nan,
            "goal_time_s": _mean([r["time_to_goal"] for r in ok if r["outcome"] == "goal"]),
            "path_m": _mean([r["path_length"] for r in ok if r["outcome"] == "goal"]),
        }
    return out


def paired(rows: list[dict], noise: str, a: str, b: str) -> dict | None:
    """McNemar on collisions between controllers a and b over environments both finished."""
    by = {(r["controller"], r["env_index"]): r for r in rows if r["noise"] == noise}
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


def table(rows: list[dict], experiment: str) -> str:
    """The Markdown table in the layout of the paper's Table I."""
    stats = summarize(rows)
    paper = PAPER.get(experiment, {})
    noises = sorted({k[0] for k in stats}, key=_noise_order)
    lines = [
        "| Noise | Controller | Episodes | Collisions (paper /1000) | Failure % [95 % CI] "
        "(paper) | Controller ms/step (paper, MATLAB) | Collisions vs mppi: McNemar |",
        "|---|---|---:|---:|---|---:|---|",
    ]
    for noise in noises:
        controllers = [c for (n, c) in stats if n == noise]
        for controller in sorted(controllers, key=_controller_order):
            s = stats[(noise, controller)]
            p_col, p_fail, p_ms = paper.get((noise, controller), (None, None, None))
            lo, hi = s["failure_ci_pct"]
            vs = ""
            if controller != "mppi" and "mppi" in controllers:
                m = paired(rows, noise, controller, "mppi")
                if m:
                    vs = (
                        f"{m['only_a']} vs {m['only_b']} discordant of {m['pairs']}, "
                        f"p = {m['p']:.3g}"
                    )
            errors = f" (+{s['errors']} errors)" if s["errors"] else ""
            lines.append(
                f"| {noise} | {controller} | {s['episodes']}{errors} | "
                f"{s['collisions']} ({_fmt(p_col)}) | "
                f"{s['failure_pct']:.1f} [{lo:.1f}, {hi:.1f}] ({_fmt(p_fail)}) | "
                f"{s['ctrl_ms']:.2f} ({_fmt(p_ms)}) | {vs} |"
            )
    return "\n".join(lines)


def speed_table(rows: list[dict]) -> str:
    """Where an episode's wall time goes, per controller: ms per control step in the
    controller, in env.step (MuJoCo physics and the task) and elsewhere (environment
    construction, observation handling, bookkeeping), and seconds per episode."""
    lines = [
        "| Controller | Episodes | Steps/episode | Controller ms/step | env.step ms/step | "
        "Other ms/step | Wall s/episode |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    controllers = sorted({r["controller"] for r in rows}, key=_controller_order)
    for c in controllers:
        ok = [r for r in rows if r["controller"] == c and r["status"] == "ok"]
        steps = sum(r["steps"] for r in ok)
        if not steps:
            continue
        ctrl = sum(r["ctrl_ms_mean"] * r["steps"] for r in ok) / steps
        env = sum(r["env_ms_mean"] * r["steps"] for r in ok) / steps
        wall = sum(r["wall_s"] for r in ok)
        other = 1e3 * wall / steps - ctrl - env
        lines.append(
            f"| {c} | {len(ok)} | {steps / len(ok):.0f} | {ctrl:.3f} | {env:.3f} | "
            f"{other:.3f} | {wall / len(ok):.2f} |"
        )
    return "\n".join(lines)


def write_report(db_path: str | Path, out_dir: str | Path, plots: bool = True) -> str:
    """Write report.md, episodes.csv and the PNG plots into out_dir; return the table."""
    db = ResultsDB(db_path)
    rows, config = db.rows(), db.config
    db.close()
    if not rows:
        raise ValueError(f"{db_path}: no episodes recorded yet; run `dcmppi bench` first")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "episodes.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMN_NAMES)
        writer.writeheader()
        writer.writerows(rows)
    text = table(rows, config["experiment"])
    md = [
        f"# dcmppi report: {config['experiment']} experiment ({config['task']})",
        "",
        text,
        "",
        "Failure = collision or time limit. Intervals: 95 % Wilson score. McNemar: exact "
        "two-sided test on the environments both controllers finished; 'a vs b discordant' "
        "counts environments where only this controller / only mppi collided. The paper's "
        "figures count out of 1000 environments and were timed in MATLAB on an i7 laptop.",
        "",
        f"Configuration: `{config}`",
        "",
        "## Time per episode (wall clock of each worker)",
        "",
        speed_table(rows),
    ]
    if plots:
        from dcmppi import plots as plotting

        for name in plotting.report_plots(rows, config, out):
            md += ["", f"![{name}]({name})"]
    (out / "report.md").write_text("\n".join(md) + "\n")
    return text


def _mean(xs):
    xs = [x for x in xs if x is not None]
    return sum(xs) / len(xs) if xs else math.nan


def _fmt(x) -> str:
    return "-" if x is None else f"{x:g}"


def _noise_order(noise: str) -> int:
    return NOISE_PROFILES.index(noise) if noise in NOISE_PROFILES else len(NOISE_PROFILES)


def _controller_order(c: str) -> tuple:
    order = ("mppi", "tube", "clustered", "dc")
    return (order.index(c) if c in order else len(order), c)
