"""Reports of a results database: paper-style tables, diagnostics, CSV, plots, and all of them
on one HTML page (dcmppi.bench.reports.html), its tables made from the same `Table`s.

Statistics: failure rates with 95 % Wilson score intervals; the crowd-navigation field's
metrics (success, collisions with pedestrians or static obstacles, timeouts, time to goal, path
length, SPL, jerk, gap to pedestrians, personal space, time-to-collision, pedestrians' speed
loss) with 95 % intervals, '-' where a metric does not apply; paired comparisons of each row
against the experiment's reference row on the same environments with McNemar's exact test on
collisions; the paper's figures beside ours where the experiment gives them. Episodes with a
navigation score (BARN worlds) get a table of their own: success rate (Wilson) and mean score
with a 95 % percentile-bootstrap interval, and the paired score difference to the reference.
Smoothness (jerk, the applied control's rate, indecision; the task blocked's commitment to a
side) gets a table where episodes record it, and replays of recorded people (the task replay)
a table per scene against the people the robot replaced.
A database that is still being written, or holds fewer episodes for some rows than for others
or than the experiment asked for, gets a notice with the counts per row.
"""

from __future__ import annotations

import csv
import dataclasses
import datetime
import os
import tempfile
from pathlib import Path

from dcmppi.bench.episodes import columns
from dcmppi.bench.episodes.metrics import SIDE_DEADBAND
from dcmppi.bench.experiments import Experiment, Row
from dcmppi.bench.reports import html
from dcmppi.bench.results.database import TABLE_COLUMNS, ResultsDB, _canonical, writer_alive
from dcmppi.bench.results.provenance import differences, short
from dcmppi.bench.results.stats import (
    ALL_SCENES,
    COMMIT_WITHIN,
    FREEZE_MARGIN,
    diagnostics,
    field_metrics,
    fmt,
    frozen_within,
    noise_order,
    paired,
    paired_scores,
    per_step,
    rate,
    replay_scenes,
    row_order,
    scene_order,
    smoothness,
    summarize,
)
from dcmppi.render.html import Table

METRICS_NOTE = (
    "Per row over its finished episodes. Rates in % with 95 % Wilson intervals: success (the "
    "goal), collisions whose first contact was a pedestrian (moving obstacle) or a static "
    "obstacle or wall, timeouts (the time limit). Means, and a median, with 95 % "
    "percentile-bootstrap intervals (10,000 resamples):"
)
NOT_APPLICABLE = "'-': not applicable (no pedestrians, or not recorded by an older database)."

# A table's columns: (heading, key of its statistics, digits).
RATE_COLUMNS = (  # the metrics table's rates, of the outcome and collision kind
    ("Success %", "success", 1),
    ("Pedestrian collisions %", "pedestrian", 1),
    ("Static collisions %", "static", 1),
    ("Timeouts %", "timeout", 1),
)


def _declared(*names: str) -> tuple:
    """The (heading, name, digits) of declared columns."""
    return tuple((c.heading, c.name, c.digits) for c in map(columns.BY_NAME.get, names))


def _shown(table: str) -> tuple:
    """The (heading, name, digits) of the columns the report's `table` shows."""
    return _declared(*(c.name for c in columns.shown(table)))


METRICS_COLUMNS = RATE_COLUMNS + _shown("metrics")
SMOOTHNESS_COLUMNS = _shown("smoothness")
COMMIT_COLUMNS = (  # the task blocked's
    *_declared("commit_time"),
    (f"Committed within {COMMIT_WITHIN:g} s %", "committed", 1),
    (f"Settled within {COMMIT_WITHIN:g} s of leaving the line %", "settled", 1),
    ("Never switched %", "never_switched", 1),
)
PLAN_COMMIT_COLUMNS = (  # the side of the task blocked's obstacle that the plans take
    *_declared("plan_commit_time"),
    (f"Plan: committed within {COMMIT_WITHIN:g} s %", "plan_committed", 1),
    (f"Plan: settled within {COMMIT_WITHIN:g} s of the first side %", "plan_settled", 1),
    ("Plan: never switched %", "plan_never_switched", 1),
)

SMOOTHNESS_NOTE = "Means over episodes with 95 % percentile-bootstrap intervals:"
DIAGNOSTICS_COLUMNS = _shown("diagnostics")
DIAGNOSTICS_NOTE = "Per row, the mean over its finished episodes unless marked ('-': not recorded):"
COMMIT_NOTE = (
    "Blocked (one obstacle between start and goal): the robot's side is the sign of (goal - "
    f"start) x (robot - obstacle centre), none within {SIDE_DEADBAND:g} m of the line, counted "
    "until the robot draws level with the centre. Commit time: from the start until the side "
    "it keeps (mean over the episodes that took a side); committed: commit time <= "
    f"{COMMIT_WITHIN:g} s; settled: the side kept within {COMMIT_WITHIN:g} s of first "
    "taking one; never switched: took a side and kept it. Rates in % of the episodes with "
    "95 % Wilson intervals; an episode that never took a side counts as none."
)
PLAN_COMMIT_NOTE = (
    "Plan: the same of the side the controller's plan takes, which control noise cannot fake "
    "(the robot's wobble crosses the line's deadband): at each step until the robot draws "
    "level with the centre, the step's plan is rolled out from the state it was planned from "
    "and its side is the robot's side (as above) at the first planned point level with the "
    "centre; no side where the plan does not reach level within its horizon or reaches it "
    "within the obstacle's radius plus the robot's (it runs into the obstacle). Commit time: from "
    "the start until the planned side it keeps (it cannot come before the horizon reaches the "
    "obstacle); settled: kept within "
    f"{COMMIT_WITHIN:g} s of the first planned side. Rates over the episodes of controllers "
    "that plan ('-': the classical ones)."
)
REPLAY_NOTE = (
    "Per scene of the recorded people the robot replaced (the task replay), and over all "
    "scenes. Rates in % with 95 % Wilson intervals. Path / human: the robot's path over the "
    "replaced person's, both sampled at the recording's frame period; time / human: its time "
    "to the goal over theirs; each the mean of the per-episode ratios over the successful "
    "episodes, 95 % bootstrap interval. Frozen: timeouts that ended within "
    f"{FREEZE_MARGIN:g} m of the goal region (the final position within "
    f"{frozen_within('replay'):g} m of the goal); elsewhere: the other timeouts; in % "
    "of the episodes ('-': not recorded by an older database). Replaced person, own track: "
    "the people the robot replaced, each replayed along their own recorded track under the "
    "task's collision rule; Collisions %: how often that rule counts their own walk as a "
    "collision ('-': the recordings were not found where the task parameter path, else "
    "DCMPPI_CROWDS, says)."
)

SCORE_NOTE = (
    "Success: the goal reached without collision within the time limit; 95 % Wilson interval, "
    "the published success rate in parentheses. Navigation score (BARN): success x "
    "optimal_time / clip(time, 2 optimal_time, 8 optimal_time), optimal_time = shortest "
    "collision-free path length / 2 m/s (dcmppi.tasks.worlds.barn); mean over episodes with a 95 % "
    "percentile-bootstrap interval (10,000 resamples). Score - reference: mean paired "
    "difference over the environments both rows scored, bootstrap interval over environments."
)


def groups(rows: list[dict], exp: Experiment) -> list[tuple[str, str]]:
    """(noise, label) of the rows, in the paper's noise order and the experiment's row order."""
    noises = sorted({r["noise"] for r in rows}, key=noise_order)
    labels = row_order({r["label"] for r in rows}, [row.label for row in exp.rows])
    present = {(r["noise"], r["label"]) for r in rows}
    return [(n, c) for n in noises for c in labels if (n, c) in present]


def table(rows: list[dict], exp: Experiment, links: dict | None = None) -> Table:
    """The table in the layout of the paper's Table I, with goal, left-map and time-limit counts
    and McNemar against the reference row; '-' for a row of errors only. `links`
    {(noise, label): cell} adds a column of replays (the gallery's)."""
    stats = summarize(rows)
    ref = exp.reference
    head = [
        "Noise", "Row", "Episodes", "Goal %", "Collisions (paper)", "Failure % [95 % CI] (paper)",
        "Left map", "Time limit", "Controller ms/step (paper)",
    ]  # fmt: skip
    align = "llrrrlrrr"
    if ref:
        head.append(f"Collisions vs {ref}: McNemar")
        align += "l"
    if links is not None:
        head.append("Replays")
        align += "l"
    lines = []
    for noise, label in groups(rows, exp):
        s = stats[(noise, label)]
        paper = exp.paper(noise, label)
        errors = f" (+{s['errors']} errors)" if s["errors"] else ""
        ms = "-" if s["ctrl_ms"] is None else f"{s['ctrl_ms']:.2f}"
        if s["episodes"]:
            lo, hi = s["failure_ci_pct"]
            goal, failure = f"{s['goal_pct']:.1f}", f"{s['failure_pct']:.1f} [{lo:.1f}, {hi:.1f}]"
        else:  # errors only
            goal = failure = "-"
        line = [
            noise, label, f"{s['episodes']}{errors}", goal,
            f"{s['collisions']} ({fmt(paper.collisions)})",
            f"{failure} ({fmt(paper.failure_pct)})",
            str(s["left_map"]), str(s["time_limit"]), f"{ms} ({fmt(paper.ms_per_step)})",
        ]  # fmt: skip
        if ref:
            m = paired(rows, noise, label, ref) if label != ref else None
            line.append(
                f"{m['only_a']} vs {m['only_b']} discordant of {m['pairs']}, p = {m['p']:.3g}"
                if m
                else ""
            )
        if links is not None:
            line.append(links.get((noise, label), ""))
        lines.append(line)
    return Table(head, align, lines, "outcomes")


def score_table(rows: list[dict], exp: Experiment) -> Table | str:
    """BARN's metrics per (noise, row): success % with its Wilson interval and the published
    success rate (100 - the paper's failure %), the mean navigation score with its bootstrap
    interval, and the paired score difference to the reference row. '' without scores."""
    stats = summarize(rows)
    scored = [g for g in groups(rows, exp) if stats[g]["scored"]]
    if not scored:
        return ""
    ref = exp.reference
    head = [
        "Noise", "Row", "Episodes", "Success % [95 % CI] (published)", "Navigation score [95 % CI]",
    ]  # fmt: skip
    if ref:
        head.append(f"Score - {ref} [95 % CI]")
    lines = []
    for noise, label in scored:
        s = stats[(noise, label)]
        paper = exp.paper(noise, label).failure_pct
        published = "-" if paper is None else f"{100 - paper:g}"
        lo, hi = s["success_ci_pct"]
        slo, shi = s["nav_score_ci"]
        episodes = str(s["scored"])
        if s["scored"] < s["episodes"]:
            episodes += f" of {s['episodes']}"
        line = [
            noise, label, episodes, f"{s['goal_pct']:.1f} [{lo:.1f}, {hi:.1f}] ({published})",
            f"{s['nav_score']:.3f} [{slo:.3f}, {shi:.3f}]",
        ]  # fmt: skip
        if ref:
            d = paired_scores(rows, noise, label, ref) if label != ref else None
            line.append(f"{d['diff']:+.3f} [{d['ci'][0]:+.3f}, {d['ci'][1]:+.3f}]" if d else "")
        lines.append(line)
    return Table(head, "llr" + "l" * (len(head) - 3), lines, "scores")


def metrics_table(rows: list[dict], exp: Experiment) -> Table:
    """The field's metrics per (noise, row) with 95 % intervals (see `field_metrics`); '-' for
    the metrics that do not apply."""
    return _interval_table(field_metrics(rows), rows, exp, METRICS_COLUMNS, "metrics")


def smoothness_table(rows: list[dict], exp: Experiment) -> Table | str:
    """Smoothness per (noise, row) with 95 % intervals (see `smoothness`): the table's declared
    columns and the task blocked's commitment
    columns, the path's and the plans', where episodes record them; '' where no episode records
    a column of it that the metrics table does not show (an older database)."""
    stats = smoothness(rows)
    recorded = {key for s in stats.values() for key, x in s.items() if x is not None}
    own = {c.name for c in columns.shown("smoothness") if "metrics" not in c.tables}
    if not own & recorded:
        return ""
    shown = SMOOTHNESS_COLUMNS
    if any(s["blocked"] for s in stats.values()):
        shown += COMMIT_COLUMNS
    if any(s["planned"] for s in stats.values()):
        shown += PLAN_COMMIT_COLUMNS
    return _interval_table(stats, rows, exp, shown, "smoothness")


def _interval_table(stats: dict, rows: list[dict], exp: Experiment, columns, name: str) -> Table:
    """One line per (noise, row) of `stats` ({(noise, label): {"episodes", key: interval}}):
    its episodes and each of `columns` (header, key, digits) as 'value [lo, hi]'."""
    lines = []
    for noise, label in groups(rows, exp):
        s = stats.get((noise, label))
        if s is None:  # errors only
            continue
        cells = [_interval(s[key], digits) for _, key, digits in columns]
        lines.append([noise, label, str(s["episodes"]), *cells])
    head = ["Noise", "Row", "Episodes", *(h for h, _, _ in columns)]
    return Table(head, "llr" + "l" * len(columns), lines, name)


def replay_table(rows: list[dict], exp: Experiment) -> Table | str:
    """Replays per (noise, row, scene) (see `replay_scenes`): outcomes, path and time against
    the replaced person's, frozen timeouts; '' without replays."""
    stats = replay_scenes(rows)
    if not stats:
        return ""
    head = [
        "Noise", "Row", "Scene", "Episodes", "Success %", "Collisions %", "Timeouts %",
        "Path / human", "Time / human", "Frozen near goal %", "Timeouts elsewhere %",
    ]  # fmt: skip
    lines = []
    for noise, label in groups(rows, exp):
        scenes = scene_order(sc for n, c, sc in stats if (n, c) == (noise, label))
        if len(scenes) == 2:  # one scene: its "all" repeats it
            scenes = scenes[:1]
        for scene in scenes:
            s = stats[(noise, label, scene)]
            cells = [_interval(s[k], 1) for k in ("success", "collision", "timeout")]
            cells += [_interval(s[k], 2) for k in ("path_ratio", "time_ratio")]
            cells += [_interval(s[k], 1) for k in ("frozen", "elsewhere")]
            name = f"**{scene}**" if scene == ALL_SCENES else scene
            lines.append([noise, label, name, str(s["episodes"]), *cells])
    for scene, (n, hits) in own_tracks(rows, exp).items():
        cells = ["-", _interval(hits, 1) if hits else "-", *["-"] * 5]
        lines.append(["", OWN_TRACK, scene, str(n), *cells])
    return Table(head, "lllr" + "l" * 7, lines, "replay")


OWN_TRACK = "replaced person, own track"


def own_tracks(rows: list[dict], exp: Experiment) -> dict:
    """{scene: (people, collision rate (pct, lo, hi) or None)}: the replaced people of the
    replay episodes in `rows`, each replayed along their own track under the task's collision
    rule (tasks.replay.self_collisions), the check of that rule; rate None where the
    recordings are not found (the task parameter path, else $DCMPPI_CROWDS)."""
    from dcmppi.tasks import replay

    people = {}
    for r in rows:
        if r["status"] == "ok" and r.get("recording") is not None:
            people.setdefault(r["scene"], set()).add((r["recording"], int(r["person"])))
    path = exp.task_params.get("path")
    reading = {k: v for k, v in exp.task_params.items() if k in replay.READING}
    out = {}
    for scene in scene_order(people):
        if scene == ALL_SCENES:
            continue
        found = sorted(people[scene])
        given = replay.given_scene(scene, exp.task_params.get("scene"))
        try:
            ks = [replay.episode_index(given, r, person, path, **reading) for r, person in found]
            hits = replay.self_collisions(given, path, episodes=ks, **reading)
            out[scene] = (len(found), rate(int(hits.sum()), len(found)))
        except (ValueError, OSError):  # recordings not at hand: the count only
            out[scene] = (len(found), None)
    return out


def _interval(x, digits: int) -> str:
    """'value [lo, hi]' of a (value, lo, hi, ...) tuple, '-' for None."""
    if x is None:
        return "-"
    value, lo, hi = x[:3]
    return f"{value:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


def diagnostics_table(rows: list[dict], exp: Experiment) -> Table:
    """The diagnostics table's declared columns per (noise, row) (see `diagnostics`): '-' where
    not recorded (controllers that record none, an older database)."""
    stats = diagnostics(rows)
    lines = []
    for noise, label in groups(rows, exp):
        s = stats.get((noise, label), {})
        lines.append([noise, label, *(_num(s.get(key), d) for _, key, d in DIAGNOSTICS_COLUMNS)])
    head = ["Noise", "Row", *(h for h, _, _ in DIAGNOSTICS_COLUMNS)]
    return Table(head, "ll" + "r" * len(DIAGNOSTICS_COLUMNS), lines, "diagnostics")


def _notes(text: str, table: str) -> str:
    """The sentences (column.explained) of the declared columns of the report's `table` that
    the table `text` shows."""
    head = text.split("\n", 1)[0]
    return " ".join(c.explained for c in columns.shown(table) if f"| {c.heading} |" in head)


def _num(x, digits: int) -> str:
    return "-" if x is None else f"{x:.{digits}f}"


def speed_table(rows: list[dict], exp: Experiment) -> Table:
    """Where an episode's wall time goes, per row: ms per control step in the controller, in
    env.step (MuJoCo physics and the task) and elsewhere (environment construction,
    observation handling, diagnostics, bookkeeping), and seconds per episode."""
    head = [
        "Row", "Episodes", "Steps/episode", "Controller ms/step", "env.step ms/step",
        "Other ms/step", "Wall s/episode",
    ]  # fmt: skip
    lines = []
    for label in row_order({r["label"] for r in rows}, [row.label for row in exp.rows]):
        ok = [r for r in rows if r["label"] == label and r["status"] == "ok"]
        steps = sum(r["steps"] for r in ok)
        if not steps:
            continue
        ctrl, env = per_step(ok, "ctrl_ms_mean"), per_step(ok, "env_ms_mean")
        wall = sum(r["wall_s"] for r in ok)
        other = 1e3 * wall / steps - ctrl - env
        lines.append([
            label, str(len(ok)), f"{steps / len(ok):.0f}", f"{ctrl:.3f}", f"{env:.3f}",
            f"{other:.3f}", f"{wall / len(ok):.2f}",
        ])  # fmt: skip
    return Table(head, "l" + "r" * 6, lines, "time")


def notice(rows: list[dict], exp: Experiment, writers: list[tuple[str, dict]]) -> str:
    """'' for a complete database; otherwise what is missing, with the counts per row.
    `writers`: [(database name, writer mark)] of the databases that hold one."""
    lines = []
    for name, writer in writers:
        started = datetime.datetime.fromtimestamp(writer["started"]).strftime("%Y-%m-%d %H:%M")
        who = f"`dcmppi bench` (pid {writer['pid']} on {writer['host']}, started {started})"
        of = f" ({name})" if name else ""
        if writer_alive(writer):
            lines.append(f"**Still being written**{of} by {who}: the figures below are partial.")
        else:
            lines.append(
                f"**Interrupted**{of}: {who} stopped before finishing; rerun it to complete."
            )
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


# Columns that differ between two runs of one episode without its results differing.
TIMING = ("ctrl_ms_mean", "ctrl_ms_p95", "env_ms_mean", "wall_s", "run_id", "error", "traceback")


@dataclasses.dataclass
class Loaded:
    """The rows of one or several databases of one configuration (shards), merged: each row
    gains "source" (the index of its database in `paths`)."""

    paths: list[Path]
    rows: list[dict]
    exp: Experiment
    writers: list[tuple[str | None, dict]]  # (database name where several, writer mark)
    config: dict
    runs: list[dict]  # ResultsDB.runs() of each database, each with "source"
    conflicts: list[str]  # episodes two databases hold with different results


def load(db_paths) -> Loaded:
    """The rows of the databases `db_paths` (a path or a list), their latest experiment
    definition, writer marks, merged configuration and runs. Databases of different
    configurations are refused (ValueError, one line); an episode in several is reported
    once (a finished row over an error row; differing results are listed as conflicts)."""
    paths = [Path(db_paths)] if isinstance(db_paths, (str, os.PathLike)) else list(db_paths)
    if not paths:
        raise ValueError("no results database given; pass --db PATH (repeat it for shards)")
    paths = [Path(p) for p in paths]
    several = len(paths) > 1
    merged, writers, runs, conflicts = {}, [], [], []
    config = definition = None
    for i, path in enumerate(paths):
        db = ResultsDB(path)
        try:
            rows, writer, runs_i = db.rows(), db.writer, db.runs()
            config = db.config if config is None else _combine(paths[0], config, path, db.config)
            definition = definition or db.experiment
        finally:
            db.close()
        if writer:
            writers.append((path.name if several else None, writer))
        runs += [{**run, "source": i} for run in runs_i]
        for row in rows:
            row["source"] = i
            key = (row["noise"], row["label"], row["env_index"])
            old = merged.setdefault(key, row)
            if old is row or row["status"] != "ok":
                continue
            if old["status"] != "ok":
                merged[key] = row
                continue
            differ = [
                c
                for c in TABLE_COLUMNS
                if c not in TIMING and None not in (old[c], row[c]) and old[c] != row[c]
            ]
            if differ:
                c = differ[0]
                conflicts.append(
                    f"{'/'.join(map(str, key))} ({c} {old[c]} in {paths[old['source']].name}, "
                    f"{row[c]} in {path.name})"
                )
    rows = [merged[k] for k in sorted(merged)]
    if not rows or definition is None:
        raise ValueError(
            f"{', '.join(map(str, paths))}: no episodes recorded yet; run `dcmppi bench` first"
        )
    exp = Experiment.from_dict(definition, f"{paths[0]} (stored experiment)", resolve=False)
    older = tuple(  # rows of earlier runs that the latest one did not define
        Row(label, row["controller"], row["params"])
        for label, row in config["rows"].items()
        if label not in {r.label for r in exp.rows}
    )
    exp = dataclasses.replace(exp, rows=exp.rows + older)
    return Loaded(paths, rows, exp, writers, config, runs, conflicts)


def _combine(first: Path, config: dict, path: Path, other: dict) -> dict:
    """Two shards' configurations as one (rows of other labels are added); a ValueError names
    what differs."""
    differ = [k for k in sorted(config.keys() | other.keys()) if k != "rows"]
    differ = [k for k in differ if config.get(k) != other.get(k)]
    a, b = config.get("rows", {}), other.get("rows", {})
    differ += [f"row {label!r}" for label in sorted(a.keys() & b.keys()) if a[label] != b[label]]
    if differ:
        raise ValueError(
            f"{first} and {path} hold results of different configurations ({', '.join(differ)} "
            "differ); report them separately"
        )
    return {**config, "rows": {**b, **a}}


def provenance(data: Loaded) -> tuple[str, list[str], list]:
    """(the terminal's provenance line, report.md's Provenance section, the notice that the
    rows were recorded under several conditions and its table of versions ([] when not))."""
    recorded = [run for run in data.runs if run["provenance"] is not None]
    if not recorded:
        line = "Provenance: not recorded (rows written before dcmppi recorded it, or without it)"
        return line, ["## Provenance", "", line[len("Provenance: ") :].capitalize() + "."], []
    name = _run_names(data)
    latest = recorded[-1]["provenance"]
    libs = ", ".join(f"{k} {v}" for k, v in latest["libraries"].items() if v)
    line = f"Provenance: {short(latest)}; {libs}; {_machine(latest)}"
    md = ["## Provenance", "", *(_run_line(run, name) for run in data.runs)]
    md += [
        "",
        "Resolved parameters of the latest run (defaults included; the seed varies per "
        f"environment): task {latest['task']['name']} `{_canonical(latest['task']['params'])}`",
    ]
    md += [f"- `{label}` ({row['controller']}): `{_canonical(row['params'])}`"
           for label, row in latest["rows"].items()]  # fmt: skip
    return line, md, _mixed(data, recorded, name)


def _run_names(data: Loaded) -> dict:
    """{(source, run_id): "run N", or "DATABASE run N" where several databases are merged}."""
    several = len(data.paths) > 1
    return {
        (run["source"], run["run_id"]): (
            f"{data.paths[run['source']].name} run {run['run_id']}" if several
            else f"run {run['run_id']}"
        )
        for run in data.runs
    }  # fmt: skip


def _run_line(run: dict, name: dict) -> str:
    """A run's line of the Provenance section: when, episodes, code, libraries, machine, files."""
    prov = run["provenance"]
    started = _when(run["started"])
    ended = _when(run["ended"]) if run["ended"] else "not ended (running or killed)"
    text = f"- {name[(run['source'], run['run_id'])]}: {started} to {ended}, "
    text += f"{run['episodes']} episodes; "
    if prov is None:
        return text + "provenance not recorded"
    files = "; ".join(
        f"{what} {entry['path']} sha256 {entry['sha256'][:12]}"
        for what, entry in prov["files"].items()
    )
    libs = ", ".join(f"{k} {v}" for k, v in prov["libraries"].items() if v)
    return (
        text
        + f"{short(prov)}; {libs}; {_machine(prov)} on {prov['host']}"
        + (f"; files: {files}" if files else "")
    )


def _mixed(data: Loaded, recorded: list[dict], name: dict) -> list:
    """The notice and its table of the versions per row that the rows were recorded under
    several conditions (distinct provenances, or none recorded for some); [] when not."""
    conditions = []  # distinct provenances of the runs that own rows, in the order of the runs
    state = {}  # (source, run_id) -> index into conditions
    owning = {(r["source"], r["run_id"]) for r in data.rows}
    for run in (run for run in recorded if (run["source"], run["run_id"]) in owning):
        prov = run["provenance"]
        found = next((j for j, c in enumerate(conditions) if not differences(c, prov)), None)
        if found is None:
            conditions.append(prov)
            found = len(conditions) - 1
        state[(run["source"], run["run_id"])] = found
    unknown = [r for r in data.rows if (r["source"], r["run_id"]) not in state]
    if len(conditions) + bool(unknown) <= 1:
        return []
    what = differences(conditions[0], conditions[-1]) if len(conditions) > 1 else []
    mixed = (
        f"**Mixed**: these rows were recorded under {len(conditions) + bool(unknown)} different "
        "conditions (a run extended the database with --allow-mixed"
        + (f"; rows before provenance was recorded: {len(unknown)}" if unknown else "")
        + ")"
        + (f": {'; '.join(what[:3])}" if what else "")
        + ". The versions per row:"
    )
    return [mixed, _versions_per_row(data, name)]


def _versions_per_row(data: Loaded, name: dict) -> Table:
    """The table of the runs (code, episodes) that recorded each row's episodes."""
    per_row = {}
    for r in data.rows:
        key = (r["noise"], r["label"])
        run = (r["source"], r["run_id"])
        per_row.setdefault(key, {}).setdefault(run, 0)
        per_row[key][run] += 1
    by_run = {(run["source"], run["run_id"]): run["provenance"] for run in data.runs}
    lines = []
    for noise, label in groups(data.rows, data.exp):
        cells = [
            f"{name.get(run, 'no run')}: {short(by_run.get(run))} ({count})"
            for run, count in sorted(per_row[(noise, label)].items(), key=str)
        ]
        lines.append([noise, label, "; ".join(cells)])
    return Table(["Noise", "Row", "Runs: code (episodes)"], "lll", lines, "versions")


def _machine(prov: dict) -> str:
    """The CPU, its cores and, where recorded (since provenance recorded it), its kernels."""
    kernels = f"; {prov['kernels']}" if prov.get("kernels") else ""
    return f"{prov['cpu']} ({prov['cores']} cores{kernels})"


def _when(t: float) -> str:
    return datetime.datetime.fromtimestamp(t).strftime("%Y-%m-%d %H:%M")


def errors_section(rows: list[dict]) -> list[str]:
    """report.md's list of the error rows, grouped by error and traceback; [] without."""
    errors = [r for r in rows if r["status"] == "error"]
    if not errors:
        return []
    by = {}
    for r in errors:
        by.setdefault((r["error"], r["traceback"]), []).append(r)
    md = ["## Errors", "", f"{len(errors)} episodes ended in an error (rerun to run them again):"]
    for (error, trace), group in by.items():
        keys = ", ".join(f"{r['noise']}/{r['label']}/{r['env_index']}" for r in group[:20])
        keys += f" and {len(group) - 20} more" if len(group) > 20 else ""
        md += ["", f"- {len(group)} x `{error}` in {keys}"]
        if trace:
            md += ["", "```", trace.rstrip("\n"), "```"]
    return md


def write_report(db_paths, out_dir: str | Path, plots: bool = True, gallery: int = 0) -> str:
    """Write report.md, report.html, episodes.csv and the PNG plots into out_dir; return the
    text shown on the terminal (notices, tables, provenance).

    db_paths: a database, or a list of databases of one configuration (shards), merged.
    gallery: with N > 0, the first N failures of each row and one success are replayed into
      GIFs and episode viewers (dcmppi.bench.runs.replay.gallery) linked from the report beside
      the row's numbers.
    """
    data = load(db_paths)
    out = Path(out_dir)
    _writable(out)
    with open(out / "episodes.csv", "w", newline="") as f:
        writer_csv = csv.DictWriter(f, fieldnames=TABLE_COLUMNS, extrasaction="ignore")
        writer_csv.writeheader()
        writer_csv.writerows(data.rows)
    prov_line, prov_md, mixed = provenance(data)
    notices = (notice(data.rows, data.exp, data.writers), _conflicts(data.conflicts), *mixed)
    warning = [p for p in notices if p]
    tables = {
        "scores": score_table(data.rows, data.exp),
        "metrics": metrics_table(data.rows, data.exp),
        "smoothness": smoothness_table(data.rows, data.exp),
        "replay": replay_table(data.rows, data.exp),
        "diagnostics": diagnostics_table(data.rows, data.exp),
    }
    text = _terminal(data, tables, warning, prov_line)
    clips = _gallery(data.paths, out, gallery) if gallery > 0 else None
    tail = [*prov_md, "", f"Configuration: `{data.config}`"]
    finished = [r for r in data.rows if r["status"] == "ok"]
    if plots and finished:  # rows of errors only get no plot
        from dcmppi.bench.reports import plots as plotting

        for name in plotting.report_plots(finished, data.exp, out):
            tail += ["", f"![{name}]({name})"]
    links = None if clips is None else _links(clips)
    (out / "report.md").write_text("\n".join(_markdown(data, tables, warning, links) + tail) + "\n")
    failures = html.failures_table(data.rows, groups(data.rows, data.exp), clips)
    note = html.FAILURES_NOTE.format(db=data.paths[0])
    links = None if clips is None else html.replay_cells(clips)
    page = _markdown(data, tables, warning, links, ["## Failures", "", failures, "", note, ""])
    html.write(out / "report.html", page + tail, f"dcmppi report: {data.exp.name}")
    return text


def _writable(out: Path) -> None:
    """Make the folder `out`, or a ValueError naming why it cannot take the report."""
    try:
        out.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=out).close()
    except OSError as e:
        raise ValueError(
            f"cannot write the report into {out}: {e.strerror}; choose another --out"
        ) from None


def _conflicts(conflicts: list[str]) -> str:
    """The notice of episodes that two databases hold with different results ('' without)."""
    if not conflicts:
        return ""
    shown = ", ".join(conflicts[:5])
    more = f" and {len(conflicts) - 5} more" if len(conflicts) > 5 else ""
    return (
        f"**Conflicting databases**: {len(conflicts)} episodes are recorded with "
        f"different results in two of them (the first database's row is used): {shown}{more}"
    )


def _terminal(data: Loaded, tables: dict, warning: list, prov_line: str) -> str:
    """The text shown on the terminal: notices, the tables, the errors' count, provenance."""
    n_errors = sum(r["status"] == "error" for r in data.rows)
    errors_line = (
        f"{n_errors} episodes ended in errors: their messages and tracebacks are listed in "
        "report.md (Errors)"
        if n_errors
        else ""
    )
    parts = (
        *warning,
        table(data.rows, data.exp),
        tables["metrics"],
        tables["scores"],
        tables["diagnostics"],
        tables["smoothness"],
        tables["replay"],
        errors_line,
        prov_line,
    )
    return "\n\n".join(part for part in parts if part)


def _gallery(paths: list[Path], out: Path, n: int) -> dict:
    """The gallery's GIFs and episode viewers of the first `n` failures of each row and one
    success (dcmppi.bench.runs.replay.gallery)."""
    from dcmppi.bench.runs.replay import gallery

    return gallery(paths, out, n)


def _links(clips: dict) -> dict:
    """{(noise, label): report.md's links to the gallery's GIFs of the row}."""
    return {
        key: " ".join(f"[{index} {outcome}]({gif})" for index, outcome, gif, _ in entries)
        for key, entries in clips.items()
    }


def _markdown(
    data: Loaded, tables: dict, warning: list, links: dict | None, after: list = ()
) -> list:
    """report.md's lines up to the provenance: title, notices, the tables and their notes.
    links: the main table's Replays column (`table`); after: lines after its note."""
    rows, exp = data.rows, data.exp
    sources = ", ".join(f"`{p}`" for p in data.paths)
    several = len(data.paths) > 1
    scores, smooth, replays = tables["scores"], tables["smoothness"], tables["replay"]
    smooth_note = f"{SMOOTHNESS_NOTE} {_notes(smooth, 'smoothness')}"
    commit = [COMMIT_NOTE, ""] if COMMIT_COLUMNS[0][0] in smooth else []
    commit += [PLAN_COMMIT_NOTE, ""] if PLAN_COMMIT_COLUMNS[0][0] in smooth else []
    return [
        f"# dcmppi report: {exp.name} ({exp.task})",
        "",
        *([exp.description, ""] if exp.description else []),
        *([f"Merged from {len(data.paths)} databases: {sources}.", ""] if several else []),
        *(x for part in warning for x in (part, "")),
        table(rows, exp, links),
        "",
        _table_note(exp, links is not None),
        "",
        *after,
        "## Navigation metrics",
        "",
        tables["metrics"],
        "",
        f"{METRICS_NOTE} {_notes(tables['metrics'], 'metrics')} {NOT_APPLICABLE}",
        "",
        *(["## Smoothness", "", smooth, "", smooth_note, "", *commit] if smooth else []),
        *(["## Recorded people, per scene", "", replays, "", REPLAY_NOTE, ""] if replays else []),
        *(["## Navigation score", "", scores, "", SCORE_NOTE, ""] if scores else []),
        "## Controller diagnostics",
        "",
        tables["diagnostics"],
        "",
        f"{DIAGNOSTICS_NOTE} {_notes(tables['diagnostics'], 'diagnostics')}",
        "",
        "## Time per episode (wall clock of each worker)",
        "",
        speed_table(rows, exp),
        "",
        *([*errors_section(rows), ""] if any(r["status"] == "error" for r in rows) else []),
    ]


def _table_note(exp: Experiment, replays: bool) -> str:
    """The note below the main table: failure, intervals, McNemar, the paper's figures."""
    ref = f"the reference row `{exp.reference}`" if exp.reference else "no reference row"
    return (
        "Failure = any outcome but the goal (collision, left map, time limit). Intervals: 95 % "
        f"Wilson score. McNemar: exact two-sided test on collisions against {ref}, over the "
        "environments both rows finished; 'a vs b discordant' counts environments where only "
        f"this row / only the reference collided. Paper figures in parentheses. {exp.paper_note}"
        + (
            " Replays: GIFs of the first failures of each row and one success (environment, "
            "outcome), each beside its episode viewer (the .html of its name)."
            if replays
            else ""
        )
    )
