"""Reports of a results database: paper-style tables, diagnostics, CSV, plots.

Statistics: failure rates with 95 % Wilson score intervals; the crowd-navigation field's
metrics (success, collisions with pedestrians or static obstacles, timeouts, time to goal, path
length, SPL, jerk, gap to pedestrians, personal space, time-to-collision, pedestrians' speed
loss) with 95 % intervals, '-' where a metric does not apply; paired comparisons of each row
against the experiment's reference row on the same environments with McNemar's exact test on
collisions; the paper's figures beside ours where the experiment gives them. Episodes with a
navigation score (BARN worlds) get a table of their own: success rate (Wilson) and mean score
with a 95 % percentile-bootstrap interval, and the paired score difference to the reference.
A database that is still being written, or holds fewer episodes for some rows than for others
or than the experiment asked for, gets a notice with the counts per row.
"""

from __future__ import annotations

import csv
import dataclasses
import datetime
import os
import socket
from pathlib import Path

from dcmppi.bench.experiments import Experiment, Row
from dcmppi.bench.results import COLUMN_NAMES, ResultsDB
from dcmppi.bench.stats import (
    field_metrics,
    fmt,
    noise_order,
    paired,
    paired_scores,
    per_step,
    row_order,
    summarize,
)

METRICS_NOTE = (
    "Per row over its finished episodes. Rates in % with 95 % Wilson intervals: success (the "
    "goal), collisions whose first contact was a pedestrian (moving obstacle) or a static "
    "obstacle or wall, timeouts (the time limit). Means with 95 % percentile-bootstrap intervals "
    "(10,000 resamples): time to goal and path length over the successful episodes; SPL "
    "(success x shortest / max(path, shortest), shortest = the straight line to within the goal "
    "tolerance); mean jerk of the robot's planar velocity at the control rate; minimum "
    "surface gap to a pedestrian; personal space, the share of the control instants with a "
    "pedestrian's surface within 0.5 m of the robot's; pedestrians' speed loss, 1 - speed / "
    "preferred speed of those within 2 m of the robot (reactive crowds only). Minimum "
    "time-to-collision at constant velocities: the median over episodes with its bootstrap "
    "interval (inf: never on a collision course). '-': not applicable (no pedestrians, or not "
    "recorded by an older database)."
)

# The field's metrics table: (heading, field_metrics key, digits).
METRICS_COLUMNS = (
    ("Success %", "success", 1),
    ("Pedestrian collisions %", "pedestrian", 1),
    ("Static collisions %", "static", 1),
    ("Timeouts %", "timeout", 1),
    ("Time to goal [s]", "time_to_goal", 2),
    ("Path [m]", "path_length", 2),
    ("SPL", "spl", 3),
    ("Jerk [m/s^3]", "jerk_mean", 1),
    ("Min gap [m]", "min_ped_gap", 3),
    ("Personal space %", "personal_space_share", 1),
    ("Min TTC [s] (median)", "min_ttc", 2),
    ("Speed loss %", "ped_speed_loss", 1),
)

SCORE_NOTE = (
    "Success: the goal reached without collision within the time limit; 95 % Wilson interval, "
    "the published success rate in parentheses. Navigation score (BARN): success x "
    "optimal_time / clip(time, 2 optimal_time, 8 optimal_time), optimal_time = shortest "
    "collision-free path length / 2 m/s (dcmppi.tasks.barn); mean over episodes with a 95 % "
    "percentile-bootstrap interval (10,000 resamples). Score - reference: mean paired "
    "difference over the environments both rows scored, bootstrap interval over environments."
)


def groups(rows: list[dict], exp: Experiment) -> list[tuple[str, str]]:
    """(noise, label) of the rows, in the paper's noise order and the experiment's row order."""
    noises = sorted({r["noise"] for r in rows}, key=noise_order)
    labels = row_order({r["label"] for r in rows}, [row.label for row in exp.rows])
    present = {(r["noise"], r["label"]) for r in rows}
    return [(n, c) for n in noises for c in labels if (n, c) in present]


def table(rows: list[dict], exp: Experiment) -> str:
    """The Markdown table in the layout of the paper's Table I, with goal, left-map and
    time-limit counts and McNemar against the reference row."""
    stats = summarize(rows)
    ref = exp.reference
    head = (
        "| Noise | Row | Episodes | Goal % | Collisions (paper) | Failure % [95 % CI] (paper) "
        "| Left map | Time limit | Controller ms/step (paper) |"
    )
    rule = "|---|---|---:|---:|---:|---|---:|---:|---:|"
    if ref:
        head += f" Collisions vs {ref}: McNemar |"
        rule += "---|"
    lines = [head, rule]
    for noise, label in groups(rows, exp):
        s = stats[(noise, label)]
        paper = exp.paper(noise, label)
        lo, hi = s["failure_ci_pct"]
        errors = f" (+{s['errors']} errors)" if s["errors"] else ""
        ms = "-" if s["ctrl_ms"] is None else f"{s['ctrl_ms']:.2f}"
        line = (
            f"| {noise} | {label} | {s['episodes']}{errors} | {s['goal_pct']:.1f} | "
            f"{s['collisions']} ({fmt(paper.collisions)}) | "
            f"{s['failure_pct']:.1f} [{lo:.1f}, {hi:.1f}] ({fmt(paper.failure_pct)}) | "
            f"{s['left_map']} | {s['time_limit']} | {ms} ({fmt(paper.ms_per_step)}) |"
        )
        if ref:
            m = paired(rows, noise, label, ref) if label != ref else None
            vs = (
                f"{m['only_a']} vs {m['only_b']} discordant of {m['pairs']}, p = {m['p']:.3g}"
                if m
                else ""
            )
            line += f" {vs} |"
        lines.append(line)
    return "\n".join(lines)


def score_table(rows: list[dict], exp: Experiment) -> str:
    """BARN's metrics per (noise, row): success % with its Wilson interval and the published
    success rate (100 - the paper's failure %), the mean navigation score with its bootstrap
    interval, and the paired score difference to the reference row. '' without scores."""
    stats = summarize(rows)
    scored = [g for g in groups(rows, exp) if stats[g]["scored"]]
    if not scored:
        return ""
    ref = exp.reference
    head = (
        "| Noise | Row | Episodes | Success % [95 % CI] (published) | Navigation score [95 % CI] |"
    )
    rule = "|---|---|---:|---|---|"
    if ref:
        head += f" Score - {ref} [95 % CI] |"
        rule += "---|"
    lines = [head, rule]
    for noise, label in scored:
        s = stats[(noise, label)]
        paper = exp.paper(noise, label).failure_pct
        published = "-" if paper is None else f"{100 - paper:g}"
        lo, hi = s["success_ci_pct"]
        slo, shi = s["nav_score_ci"]
        episodes = str(s["scored"])
        if s["scored"] < s["episodes"]:
            episodes += f" of {s['episodes']}"
        line = (
            f"| {noise} | {label} | {episodes} | {s['goal_pct']:.1f} [{lo:.1f}, {hi:.1f}] "
            f"({published}) | {s['nav_score']:.3f} [{slo:.3f}, {shi:.3f}] |"
        )
        if ref:
            d = paired_scores(rows, noise, label, ref) if label != ref else None
            line += f" {d['diff']:+.3f} [{d['ci'][0]:+.3f}, {d['ci'][1]:+.3f}] |" if d else " |"
        lines.append(line)
    return "\n".join(lines)


def metrics_table(rows: list[dict], exp: Experiment) -> str:
    """The field's metrics per (noise, row) with 95 % intervals (see `field_metrics`); '-' for
    the metrics that do not apply."""
    stats = field_metrics(rows)
    head = "| Noise | Row | Episodes | " + " | ".join(h for h, _, _ in METRICS_COLUMNS) + " |"
    lines = [head, "|---|---|---:|" + "---|" * len(METRICS_COLUMNS)]
    for noise, label in groups(rows, exp):
        s = stats.get((noise, label))
        if s is None:  # errors only
            continue
        cells = [_interval(s[key], digits) for _, key, digits in METRICS_COLUMNS]
        lines.append(f"| {noise} | {label} | {s['episodes']} | {' | '.join(cells)} |")
    return "\n".join(lines)


def _interval(x, digits: int) -> str:
    """'value [lo, hi]' of a (value, lo, hi, ...) tuple, '-' for None."""
    if x is None:
        return "-"
    value, lo, hi = x[:3]
    return f"{value:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def diagnostics_table(rows: list[dict], exp: Experiment) -> str:
    """Controller diagnostics per (noise, row): '-' where the controller records none."""
    stats = summarize(rows)
    lines = [
        "| Noise | Row | ESS per step | Clusters per step | Fallback to Alg. 1 % | "
        "Tube deviation p95 [m] |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for noise, label in groups(rows, exp):
        s = stats[(noise, label)]
        cells = [_num(s["ess"], 1), _num(s["clusters"], 2), _num(s["fallback_pct"], 1)]
        cells.append(_num(s["tube_deviation_p95"], 3))
        lines.append(f"| {noise} | {label} | {' | '.join(cells)} |")
    return "\n".join(lines)


def _num(x, digits: int) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def speed_table(rows: list[dict], exp: Experiment) -> str:
    """Where an episode's wall time goes, per row: ms per control step in the controller, in
    env.step (MuJoCo physics and the task) and elsewhere (environment construction,
    observation handling, diagnostics, bookkeeping), and seconds per episode."""
    lines = [
        "| Row | Episodes | Steps/episode | Controller ms/step | env.step ms/step | "
        "Other ms/step | Wall s/episode |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for label in row_order({r["label"] for r in rows}, [row.label for row in exp.rows]):
        ok = [r for r in rows if r["label"] == label and r["status"] == "ok"]
        steps = sum(r["steps"] for r in ok)
        if not steps:
            continue
        ctrl, env = per_step(ok, "ctrl_ms_mean"), per_step(ok, "env_ms_mean")
        wall = sum(r["wall_s"] for r in ok)
        other = 1e3 * wall / steps - ctrl - env
        lines.append(
            f"| {label} | {len(ok)} | {steps / len(ok):.0f} | {ctrl:.3f} | {env:.3f} | "
            f"{other:.3f} | {wall / len(ok):.2f} |"
        )
    return "\n".join(lines)


def notice(rows: list[dict], exp: Experiment, writer: dict | None) -> str:
    """'' for a complete database; otherwise what is missing, with the counts per row."""
    lines = []
    if writer:
        started = datetime.datetime.fromtimestamp(writer["started"]).strftime("%Y-%m-%d %H:%M")
        who = f"`dcmppi bench` (pid {writer['pid']} on {writer['host']}, started {started})"
        if writer["host"] == socket.gethostname() and _alive(writer["pid"]):
            lines.append(f"**Still being written** by {who}: the figures below are partial.")
        else:
            lines.append(f"**Interrupted**: {who} stopped before finishing; rerun it to complete.")
    wanted = {(n, c) for n in exp.noises for c in exp.labels}
    counts = {g: [0, 0] for g in wanted}
    for r in rows:
        counts.setdefault((r["noise"], r["label"]), [0, 0])[r["status"] != "ok"] += 1
    expected = max([exp.episodes, *(ok for ok, _ in counts.values())])
    if any(ok < expected for ok, _ in counts.values()):
        order = groups([{"noise": n, "label": c} for n, c in counts], exp)
        shown = ", ".join(
            f"{n}/{c} {counts[(n, c)][0]}"
            + (f" (+{counts[(n, c)][1]} errors)" if counts[(n, c)][1] else "")
            for n, c in order
        )
        lines.append(
            f"**Partial**: {expected} finished episodes per row expected, rows hold "
            f"(noise/row finished): {shown}. Paired statistics use the environments both rows "
            "finished."
        )
    return "\n\n".join(lines)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def load(db_path: str | Path) -> tuple[list[dict], Experiment, dict | None, dict]:
    """Rows, the experiment the latest bench run asked for, the writer mark and the
    configuration the database is bound to."""
    db = ResultsDB(db_path)
    rows, definition, writer, config = db.rows(), db.experiment, db.writer, db.config
    db.close()
    if not rows or definition is None:
        raise ValueError(f"{db_path}: no episodes recorded yet; run `dcmppi bench` first")
    exp = Experiment.from_dict(definition, f"{db_path} (stored experiment)", resolve=False)
    older = tuple(  # rows of earlier runs that the latest one did not define
        Row(label, row["controller"], row["params"])
        for label, row in config["rows"].items()
        if label not in {r.label for r in exp.rows}
    )
    return rows, dataclasses.replace(exp, rows=exp.rows + older), writer, config


def write_report(db_path: str | Path, out_dir: str | Path, plots: bool = True) -> str:
    """Write report.md, episodes.csv and the PNG plots into out_dir; return the text shown
    on the terminal (notice, table, diagnostics)."""
    rows, exp, writer, config = load(db_path)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    with open(out / "episodes.csv", "w", newline="") as f:
        writer_csv = csv.DictWriter(f, fieldnames=COLUMN_NAMES)
        writer_csv.writeheader()
        writer_csv.writerows(rows)
    warning = notice(rows, exp, writer)
    scores = score_table(rows, exp)
    metrics = metrics_table(rows, exp)
    text = "\n\n".join(
        part
        for part in (warning, table(rows, exp), metrics, scores, diagnostics_table(rows, exp))
        if part
    )
    ref = f"the reference row `{exp.reference}`" if exp.reference else "no reference row"
    md = [
        f"# dcmppi report: {exp.name} ({exp.task})",
        "",
        *([exp.description, ""] if exp.description else []),
        *([warning, ""] if warning else []),
        table(rows, exp),
        "",
        "Failure = any outcome but the goal (collision, left map, time limit). Intervals: 95 % "
        f"Wilson score. McNemar: exact two-sided test on collisions against {ref}, over the "
        "environments both rows finished; 'a vs b discordant' counts environments where only "
        f"this row / only the reference collided. Paper figures in parentheses. {exp.paper_note}",
        "",
        "## Navigation metrics",
        "",
        metrics,
        "",
        METRICS_NOTE,
        "",
        *(["## Navigation score", "", scores, "", SCORE_NOTE, ""] if scores else []),
        "## Controller diagnostics",
        "",
        diagnostics_table(rows, exp),
        "",
        "ESS: effective sample size 1 / sum(w^2) of the weights that made the plan, mean over "
        "steps. Clusters: DBSCAN clusters per step; fallback: share of steps with no cluster, "
        "where Alg. 1 ran over all samples (clustered and dc only). Tube deviation: the 95th "
        "percentile over an episode's steps of |real - nominal| position, mean over episodes.",
        "",
        "## Time per episode (wall clock of each worker)",
        "",
        speed_table(rows, exp),
        "",
        f"Configuration: `{config}`",
    ]
    if plots:
        from dcmppi.bench import plots as plotting

        for name in plotting.report_plots(rows, exp, out):
            md += ["", f"![{name}]({name})"]
    (out / "report.md").write_text("\n".join(md) + "\n")
    return text
