"""Reports of a results database: paper-style tables, CSV, plots.

Statistics: failure rates with 95 % Wilson score intervals; paired comparisons of each
controller against `mppi` on the same environments with McNemar's exact test on
collisions; the paper's figures beside ours (they count out of 1000 environments).
"""

from __future__ import annotations

import csv
from pathlib import Path

from dcmppi.bench.experiments import PAPER
from dcmppi.bench.results import COLUMN_NAMES, ResultsDB
from dcmppi.bench.stats import controller_order, fmt, noise_order, paired, summarize


def table(rows: list[dict], experiment: str) -> str:
    """The Markdown table in the layout of the paper's Table I."""
    stats = summarize(rows)
    paper = PAPER.get(experiment, {})
    noises = sorted({k[0] for k in stats}, key=noise_order)
    lines = [
        "| Noise | Controller | Episodes | Collisions (paper /1000) | Failure % [95 % CI] "
        "(paper) | Controller ms/step (paper, MATLAB) | Collisions vs mppi: McNemar |",
        "|---|---|---:|---:|---|---:|---|",
    ]
    for noise in noises:
        controllers = [c for (n, c) in stats if n == noise]
        for controller in sorted(controllers, key=controller_order):
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
                f"{s['collisions']} ({fmt(p_col)}) | "
                f"{s['failure_pct']:.1f} [{lo:.1f}, {hi:.1f}] ({fmt(p_fail)}) | "
                f"{s['ctrl_ms']:.2f} ({fmt(p_ms)}) | {vs} |"
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
    controllers = sorted({r["controller"] for r in rows}, key=controller_order)
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
        from dcmppi.bench import plots as plotting

        for name in plotting.report_plots(rows, config, out):
            md += ["", f"![{name}]({name})"]
    (out / "report.md").write_text("\n".join(md) + "\n")
    return text
