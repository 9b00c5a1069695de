"""Results database and report statistics, on synthetic rows (no simulation)."""

import math
import os
import re
import subprocess

import numpy as np
import pytest
from scipy import stats

from dcmppi.bench.episodes.runner import EpisodeSpec
from dcmppi.bench.experiments import load_experiment
from dcmppi.bench.reports.report import table
from dcmppi.bench.results.database import SCHEMA_VERSION, ConfigMismatch, ResultsDB
from dcmppi.bench.results.stats import mcnemar_exact, paired, replay_scenes, summarize, wilson

CONFIG = {
    "task": "forest",
    "base_seed": 1,
    "task_params": {},
    "controller_params": {},
    "rows": {"mppi": {"controller": "mppi", "params": {}}},
}


def _result(outcome, steps=100, ms=1.0):
    return {
        "outcome": outcome,
        "collision": outcome == "collision",
        "failure": outcome != "goal",
        "steps": steps,
        "time_to_goal": 10.0 if outcome == "goal" else None,
        "nav_score": None,
        "path_length": 10.0,
        "min_clearance": 0.3,
        "ctrl_ms_mean": ms,
        "ctrl_ms_p95": ms,
        "env_ms_mean": 0.1,
        "wall_s": 1.0,
        "ess_mean": 10.0,
        "clusters_mean": None,
        "fallback_share": None,
        "tube_deviation_p95": None,
    }


def _spec(controller="mppi", noise="none", seed=0):
    return EpisodeSpec("forest", controller, noise, seed)


def test_database_records_resumes_and_never_duplicates(tmp_path):
    path = tmp_path / "r.db"
    db = ResultsDB(path, CONFIG)
    db.record(("none", "mppi", 0), _spec(), _result("goal"))
    db.record(("none", "mppi", 1), _spec(), {"error": "PhysicsError: boom"})
    db.close()
    db = ResultsDB(path, CONFIG)  # reopen: rows survive, the same key is not written twice
    assert db.done() == {("none", "mppi", 0)}  # the errored episode runs again
    db.record(("none", "mppi", 0), _spec(), _result("collision"))
    rows = db.rows()
    assert len(rows) == 2
    assert rows[0]["outcome"] == "goal"
    assert rows[1]["status"] == "error" and "boom" in rows[1]["error"]
    db.record(("none", "mppi", 1), _spec(), _result("goal"))  # a rerun replaces the error row
    rows = db.rows()
    assert len(rows) == 2 and rows[1]["status"] == "ok" and rows[1]["outcome"] == "goal"
    assert db.done() == {("none", "mppi", 0), ("none", "mppi", 1)}


def test_reading_never_writes_to_another_sqlite_file(tmp_path):
    import sqlite3

    path = tmp_path / "other.db"
    with sqlite3.connect(path) as c:
        c.execute("CREATE TABLE users (name TEXT)")
    before = path.read_bytes()
    for config in (None, CONFIG):
        with pytest.raises(ValueError, match="not a dcmppi results database"):
            ResultsDB(path, config)
    assert path.read_bytes() == before
    empty = tmp_path / "empty.db"
    empty.touch()
    with pytest.raises(ValueError, match="empty database"):
        ResultsDB(empty)
    assert empty.stat().st_size == 0


def test_database_refuses_another_configuration(tmp_path):
    path = tmp_path / "r.db"
    ResultsDB(path, CONFIG).close()
    other = {**CONFIG, "controller_params": {"K": 1000}}
    with pytest.raises(ConfigMismatch, match="another configuration"):
        ResultsDB(path, other)


def test_unreadable_database_gets_a_clear_error(tmp_path):
    path = tmp_path / "junk.db"
    path.write_bytes(b"this is not sqlite" * 100)
    with pytest.raises(ValueError, match="not a readable dcmppi results database"):
        ResultsDB(path, CONFIG)
    with pytest.raises(FileNotFoundError, match="dcmppi bench"):
        ResultsDB(tmp_path / "missing.db")


def test_wilson_interval_contains_the_estimate_and_matches_the_formula():
    for k, n in [(0, 10), (3, 10), (10, 10), (12, 1000)]:
        lo, hi = wilson(k, n)
        assert 0 <= lo <= k / n <= hi <= 1
    # the known interval for 0 of 10: upper bound z^2 / (n + z^2)
    z2 = 1.959963984540054**2
    assert wilson(0, 10)[1] == pytest.approx(z2 / (10 + z2))
    assert all(math.isnan(x) for x in wilson(0, 0))


def test_mcnemar_matches_the_exact_binomial_test():
    for b, c in [(0, 0), (1, 0), (5, 1), (12, 30), (7, 7)]:
        expected = 1.0 if b + c == 0 else stats.binomtest(b, b + c, 0.5).pvalue
        assert mcnemar_exact(b, c) == pytest.approx(expected)


@pytest.mark.parametrize(("task", "frozen"), [("replay", 2), ("crowdnav", 1)])
def test_a_timeout_froze_near_the_goal_by_its_tasks_goal_tolerance(task, frozen):
    """Timeouts 1.2 and 1.9 m from the goal: within 1 m of the replay's 1 m goal region both,
    of crowdnav's 0.3 m region only the first."""
    rows = [
        {"status": "ok", "noise": "none", "label": "a", "scene": "eth", "task": task,
         "outcome": "time_limit", "collision": 0, "goal_distance": d}
        for d in (1.2, 1.9)
    ]  # fmt: skip
    s = replay_scenes(rows)[("none", "a", "eth")]
    assert s["frozen"][0] == 50 * frozen and s["elsewhere"][0] == 100 - 50 * frozen


def test_summary_and_table_match_the_rows():
    rng = np.random.default_rng(0)
    rows = []
    for i in range(200):
        for c, p in [("mppi", 0.10), ("clustered", 0.03)]:
            r = rng.random()
            outcome = "collision" if r < p else ("time_limit" if r < p + 0.01 else "goal")
            res = _result(outcome, steps=int(rng.integers(50, 150)), ms=float(rng.random()))
            rows.append({**res, "noise": "none", "label": c, "env_index": i, "status": "ok"})
    rows.append(
        {
            **{k: None for k in _result("goal")},
            "noise": "none",
            "label": "mppi",
            "env_index": 999,
            "status": "error",
        }
    )
    s = summarize(rows)
    for c in ("mppi", "clustered"):
        ok = [r for r in rows if r["label"] == c and r["status"] == "ok"]
        assert s[("none", c)]["episodes"] == len(ok) == 200
        assert s[("none", c)]["collisions"] == sum(r["collision"] for r in ok)
        assert s[("none", c)]["failures"] == sum(r["failure"] for r in ok)
        w = sum(r["ctrl_ms_mean"] * r["steps"] for r in ok) / sum(r["steps"] for r in ok)
        assert s[("none", c)]["ctrl_ms"] == pytest.approx(w)
    assert s[("none", "mppi")]["errors"] == 1
    m = paired(rows, "none", "clustered", "mppi")
    both = {i: {} for i in range(200)}
    for r in rows:
        if r["status"] == "ok":
            both[r["env_index"]][r["label"]] = r["collision"]
    assert m["pairs"] == 200
    assert m["only_a"] == sum(v["clustered"] and not v["mppi"] for v in both.values())
    assert m["only_b"] == sum(v["mppi"] and not v["clustered"] for v in both.values())
    text = table(rows, load_experiment("static"))
    line = next(row for row in text.splitlines() if "| clustered |" in row)
    assert f"| {s[('none', 'clustered')]['collisions']} (6) |" in line  # ours, then the paper's
    assert f"p = {m['p']:.3g}" in line


def test_a_database_of_another_schema_is_refused(tmp_path):
    import sqlite3

    path = tmp_path / "old.db"
    with sqlite3.connect(path) as c:
        c.execute("CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)")
        c.execute("INSERT INTO meta VALUES ('schema', '1'), ('config', '{}')")
    for config in (None, CONFIG):
        message = f"results schema '1', this dcmppi writes {SCHEMA_VERSION}; use a new"
        with pytest.raises(ValueError, match=message):
            ResultsDB(path, config)


def test_new_rows_extend_a_database_changed_rows_are_refused(tmp_path):
    path = tmp_path / "r.db"
    ResultsDB(path, CONFIG).close()
    more = {**CONFIG, "rows": {"tube": {"controller": "tube", "params": {}}}}
    db = ResultsDB(path, more)  # a new label: added
    assert set(db.config["rows"]) == {"mppi", "tube"}
    db.close()
    assert set(ResultsDB(path).config["rows"]) == {"mppi", "tube"}
    changed = {**CONFIG, "rows": {"mppi": {"controller": "mppi", "params": {"K": 64}}}}
    with pytest.raises(ConfigMismatch, match="row 'mppi' differ"):
        ResultsDB(path, changed)
    renamed = {**CONFIG, "rows": {"mppi": {"controller": "clustered", "params": {}}}}
    with pytest.raises(ConfigMismatch, match="row 'mppi' differ"):
        ResultsDB(path, renamed)


def _partial_db(path, writer_pid=None):
    exp = load_experiment("static").select(3, ("mppi", "clustered"), ("none",))
    db = ResultsDB(path, exp.config())
    db.begin_run(exp.to_dict())
    for label, n in [("mppi", 3), ("clustered", 1)]:
        for i in range(n):
            db.record(("none", label, i), _spec(label), _result("goal"))
    db.record(("none", "clustered", 1), _spec("clustered"), {"error": "PhysicsError: boom"})
    if writer_pid is None:
        db.end_run()
    else:
        db._set("writer", {**db.writer, "pid": writer_pid})
    db.close()


def test_report_says_when_a_database_is_partial_or_being_written(tmp_path):
    from dcmppi.bench.reports.report import write_report

    _partial_db(tmp_path / "p.db")
    text = write_report(tmp_path / "p.db", tmp_path / "out", plots=False)
    assert "**Partial**: 3 finished episodes per row expected" in text
    assert "none/mppi 3, none/clustered 1 (+1 errors)" in text
    assert "Still being written" not in text and "Interrupted" not in text
    assert "**Partial**" in (tmp_path / "out" / "report.md").read_text()

    _partial_db(tmp_path / "w.db", writer_pid=os.getpid())  # this process: alive
    text = write_report(tmp_path / "w.db", tmp_path / "out", plots=False)
    assert "**Still being written** by `dcmppi bench` (pid" in text and "**Partial**" in text

    _partial_db(tmp_path / "k.db", writer_pid=_dead_pid())
    text = write_report(tmp_path / "k.db", tmp_path / "out", plots=False)
    assert "**Interrupted**" in text and "rerun it to complete" in text


def _dead_pid():
    proc = subprocess.Popen(["true"])
    proc.wait()
    return proc.pid


def test_a_complete_database_gets_no_notice(tmp_path):
    from dcmppi.bench.reports.report import write_report

    exp = load_experiment("static").select(2, ("mppi", "clustered"), ("none",))
    db = ResultsDB(tmp_path / "c.db", exp.config())
    db.begin_run(exp.to_dict())
    for label in ("mppi", "clustered"):
        for i in range(2):
            db.record(("none", label, i), _spec(label), _result("collision" if i else "goal"))
    db.end_run()
    db.close()
    text = write_report(tmp_path / "c.db", tmp_path / "out", plots=False)
    assert not text.startswith("**")
    line = next(x for x in text.splitlines() if "| clustered |" in x)
    assert "| 2 | 50.0 | 1 (6) | 50.0 [" in line and "0 vs 0 discordant of 2, p = 1 |" in line


def _complete_db(path, labels=("mppi", "clustered"), envs=range(2), result=None, collide=()):
    """A database of `result` (default: the goal) in every environment, a collision in the
    (label, environment) pairs of `collide`."""
    exp = load_experiment("static").select(2, labels, ("none",))
    db = ResultsDB(path, exp.config())
    db.begin_run(exp.to_dict())
    for label in labels:
        for i in envs:
            this = _result("collision") if (label, i) in collide else result or _result("goal")
            db.record(("none", label, i), _spec(label), this)
    db.end_run()
    db.close()


def _read_only(monkeypatch):
    """Open every database for writing as SQLite opens a file without write permission (the
    tests run as any user, root included)."""
    import sqlite3

    connect = sqlite3.connect

    def read_only(target, *args, **kwargs):
        if not kwargs.get("uri"):
            target, kwargs["uri"] = f"{os.path.abspath(target)}?mode=ro", True
            target = "file:" + target
        return connect(target, *args, **kwargs)

    monkeypatch.setattr(sqlite3, "connect", read_only)


def test_a_read_only_database_ends_in_one_line_even_for_a_no_op_resume(tmp_path, monkeypatch):
    from dcmppi.bench.results.database import StorageError

    path = tmp_path / "r.db"
    _complete_db(path)
    _read_only(monkeypatch)
    exp = load_experiment("static").select(2, ("mppi", "clustered"), ("none",))
    with pytest.raises(StorageError) as e:
        db = ResultsDB(path, exp.config())
        db.begin_run(exp.to_dict())  # nothing to run, but the run is recorded
    message = str(e.value)
    assert "\n" not in message and "read-only" in message and "new --db" in message


def test_a_full_disk_ends_in_one_line_and_keeps_the_rows(tmp_path):
    from dcmppi.bench.results.database import StorageError

    path = tmp_path / "r.db"
    db = ResultsDB(path, CONFIG)
    db.record(("none", "mppi", 0), _spec(), _result("goal"))
    pages = db._db.execute("PRAGMA page_count").fetchone()[0]
    db._db.execute(f"PRAGMA max_page_count = {pages}")  # SQLite's own "disk is full"
    big = {**_result("goal"), "trace": os.urandom(100_000)}
    with pytest.raises(StorageError) as e:
        db.record(("none", "mppi", 1), _spec(), big)
    message = str(e.value)
    assert "\n" not in message and "disk is full" in message and "rerun to resume" in message
    db.close()
    assert [r["env_index"] for r in ResultsDB(path).rows()] == [0]


def test_a_directory_sqlite_cannot_write_in_ends_in_one_line(tmp_path, monkeypatch):
    import sqlite3

    from dcmppi.bench.results.database import StorageError

    def cannot_open(*args, **kwargs):
        raise sqlite3.OperationalError("unable to open database file")

    monkeypatch.setattr(sqlite3, "connect", cannot_open)
    with pytest.raises(StorageError) as e:
        ResultsDB(tmp_path / "r.db", CONFIG)
    assert "\n" not in str(e.value) and "writable" in str(e.value)


@pytest.mark.parametrize("wal", [True, False])
def test_reports_read_where_sqlite_cannot_open_its_side_files(tmp_path, monkeypatch, wal):
    """A read-only directory or an archived WAL database: mode=ro cannot open -shm/-wal. The
    report reads a copy (with the -wal file's rows) or the file as immutable."""
    import shutil
    import sqlite3

    from dcmppi.bench.reports.report import write_report

    live = tmp_path / "live"
    live.mkdir()
    _complete_db(live / "r.db")
    if wal:  # rows only in the -wal file, as when a running database is archived
        db = sqlite3.connect(live / "r.db")
        db.execute("PRAGMA wal_autocheckpoint = 0")
        db.execute("UPDATE episodes SET outcome = 'collision', collision = 1, failure = 1")
        db.commit()
        archive = tmp_path / "archive"
        archive.mkdir()
        shutil.copy(live / "r.db", archive / "r.db")
        shutil.copy(live / "r.db-wal", archive / "r.db-wal")
        db.close()
    else:
        archive = live
    connect = sqlite3.connect

    def no_side_files(target, *args, **kwargs):
        if str(archive) in str(target) and "mode=ro" in str(target):
            raise sqlite3.OperationalError("unable to open database file")
        return connect(target, *args, **kwargs)

    monkeypatch.setattr(sqlite3, "connect", no_side_files)
    write_report(archive / "r.db", tmp_path / "out", plots=False)
    rows = (tmp_path / "out" / "episodes.csv").read_text().splitlines()
    assert len(rows) == 5
    assert all(("collision" if wal else "goal") in row for row in rows[1:])
    assert sorted(p.name for p in archive.iterdir()) == ["r.db"] + (["r.db-wal"] if wal else [])


def test_a_report_of_error_rows_has_no_nan_and_lists_the_tracebacks(tmp_path):
    from dcmppi.bench.reports.report import write_report

    error = {"error": "ZeroDivisionError: boom", "traceback": "Traceback\n  line 3\nZeroDiv"}
    _complete_db(tmp_path / "e.db", result=error)
    text = write_report(tmp_path / "e.db", tmp_path / "out", plots=True)
    md = (tmp_path / "out" / "report.md").read_text()
    assert not re.search(r"\bnan\b", text) and not re.search(r"\bnan\b", md)
    assert "| none | mppi | 0 (+2 errors) | - |" in md
    keys = "none/clustered/0, none/clustered/1, none/mppi/0, none/mppi/1"
    assert "## Errors" in md and f"- 4 x `ZeroDivisionError: boom` in {keys}" in md
    assert "```\nTraceback\n  line 3\nZeroDiv\n```" in md
    assert not list((tmp_path / "out").glob("*.png"))  # no empty plots


def test_a_row_keeps_the_final_pose_and_the_trace(tmp_path):
    import zlib

    trace = zlib.compress(np.arange(9, dtype="<f4").tobytes())
    db = ResultsDB(tmp_path / "r.db", CONFIG)
    db.record(
        ("none", "mppi", 3),
        _spec(),
        {**_result("goal"), "final_x": 1.0, "final_y": 2.0, "final_theta": -0.5, "trace": trace},
    )
    db.close()
    db = ResultsDB(tmp_path / "r.db")
    row = db.row("none", "mppi", 3)
    assert (row["final_x"], row["final_y"], row["final_theta"]) == (1.0, 2.0, -0.5)
    assert np.frombuffer(zlib.decompress(row["trace"]), "<f4").tolist() == list(range(9))
    assert db.row("none", "mppi", 4) is None
    assert "trace" not in db.rows()[0]  # the table's rows leave the traces out


def test_shards_merge_into_one_report(tmp_path):
    from dcmppi.bench.reports.report import write_report

    _complete_db(tmp_path / "a.db", envs=[0])
    _complete_db(tmp_path / "b.db", envs=[1])
    text = write_report([tmp_path / "a.db", tmp_path / "b.db"], tmp_path / "out", plots=False)
    assert not text.startswith("**")  # complete: 2 environments per row
    line = next(x for x in text.splitlines() if "| clustered |" in x)
    assert "| none | clustered | 2 | 100.0 |" in line
    md = (tmp_path / "out" / "report.md").read_text()
    assert "Merged from 2 databases" in md


def test_shards_with_different_results_or_configurations_are_named(tmp_path):
    from dcmppi.bench.reports.report import write_report

    _complete_db(tmp_path / "a.db", envs=[0, 1])
    _complete_db(tmp_path / "b.db", envs=[1], result=_result("collision"))
    text = write_report([tmp_path / "a.db", tmp_path / "b.db"], tmp_path / "out", plots=False)
    assert "**Conflicting databases**: 2 episodes are recorded with different results" in text
    assert "none/clustered/1 (outcome goal in a.db, collision in b.db)" in text
    other = tmp_path / "c.db"
    exp = load_experiment("static").select(1, ("mppi",), ("none",)).with_params({}, {"K": 64})
    db = ResultsDB(other, exp.config())
    db.begin_run(exp.to_dict())
    db.record(("none", "mppi", 0), _spec(), _result("goal"))
    db.close()
    with pytest.raises(ValueError) as e:
        write_report([tmp_path / "a.db", other], tmp_path / "out", plots=False)
    assert "\n" not in str(e.value) and "different configurations (controller_params" in str(
        e.value
    )


def test_the_gallery_is_linked_beside_the_rows(tmp_path, monkeypatch):
    import sys
    import types

    from dcmppi.bench.reports.report import write_report

    _complete_db(tmp_path / "g.db", collide=[("mppi", 1)])
    calls = []

    def gallery(db_paths, out_dir, n):
        calls.append((list(db_paths), n))
        return {("none", "mppi"): [(1, "collision", "gallery/mppi-1.gif", "gallery/mppi-1.html")]}

    replay = types.SimpleNamespace(gallery=gallery)
    monkeypatch.setitem(sys.modules, "dcmppi.bench.runs.replay", replay)
    write_report(tmp_path / "g.db", tmp_path / "out", plots=False, gallery=2)
    assert calls == [([tmp_path / "g.db"], 2)]
    md = (tmp_path / "out" / "report.md").read_text()
    line = next(x for x in md.splitlines() if x.startswith("| none | mppi |"))
    assert line.endswith("| [1 collision](gallery/mppi-1.gif) |")
    tables = _html_tables(tmp_path / "out" / "report.html")
    row = next(r for r in tables["outcomes"] if r[:2] == ["none", "mppi"])
    gif = '<img src="gallery/mppi-1.gif" alt="env 1: collision" title="env 1: collision">'
    assert row[-1] == f'<a href="gallery/mppi-1.html">{gif}</a>'  # the GIF opens its viewer
    assert tables["failures"] == [
        ["none", "mppi", "1", '<a href="gallery/mppi-1.html">1 (collision)</a>'],
        ["none", "clustered", "0", ""],
    ]


def _html_tables(path) -> dict:
    """{data-table: rows of cells (their inner HTML)} of the tables of an HTML page."""
    text = path.read_text()
    tables = {}
    for name, body in re.findall(r'data-table="(\w+)".*?<tbody>(.*?)</tbody>', text, re.S):
        rows = re.findall(r"<tr>(.*?)</tr>", body, re.S)
        tables[name] = [re.findall(r"<td[^>]*>(.*?)</td>", row, re.S) for row in rows]
    return tables


def test_the_html_report_holds_every_table_of_the_markdown_one(tmp_path):
    from dcmppi.bench.reports.report import write_report

    _complete_db(tmp_path / "h.db", labels=("mppi", "clustered", "tube"), envs=range(3))
    write_report(tmp_path / "h.db", tmp_path / "out", plots=False)
    md = (tmp_path / "out" / "report.md").read_text()
    tables = _html_tables(tmp_path / "out" / "report.html")
    names = ["outcomes", "failures", "metrics", "diagnostics", "time"]  # no smoothness recorded
    assert list(tables) == names
    md_tables = re.findall(r"((?:^\|.*\n)+)", md, re.M)
    assert len(md_tables) == len(names) - 1  # the failures are the page's own
    for name, text in zip([n for n in names if n != "failures"], md_tables, strict=True):
        lines = text.splitlines()[2:]
        assert len(tables[name]) == len(lines) == 3, name
        cells = [re.sub(r"<[^>]+>", "", c) for c in tables[name][0]]  # the intervals' spans
        assert lines[0] == "| " + " | ".join(cells) + " |", name
    assert "Configuration: <code>" in (tmp_path / "out" / "report.html").read_text()
    with pytest.raises(ValueError, match=r"^cannot write the report into .*/h.db/out: Not a dir"):
        write_report(tmp_path / "h.db", tmp_path / "h.db" / "out", plots=False)


def test_the_paths_plot_reruns_only_episodes_that_finished():
    """An episode that raised or timed out in environment 0 is not re-run for paths.png (it
    would raise or hang again in the report's process): the plot takes the environment where
    most rows finished, then the first noise profile and the lowest index."""
    from dcmppi.bench.reports.plots import paths_environment

    def ok(noise, label, index):
        return {"noise": noise, "label": label, "env_index": index, "status": "ok"}

    labels = ["mppi", "tube", "clustered"]
    rows = [ok("none", "mppi", 0), ok("none", "clustered", 0)]  # tube's episode 0 errored
    rows += [ok("none", c, 1) for c in labels] + [ok("control", c, 0) for c in labels]
    assert paths_environment(rows, labels) == ("none", 1, labels)
    assert paths_environment(rows[:2], labels) == ("none", 0, ["mppi", "clustered"])
    assert paths_environment([ok("process", "tube", 3), ok("control", "tube", 5)], labels) == (
        "control",
        5,
        ["tube"],
    )
