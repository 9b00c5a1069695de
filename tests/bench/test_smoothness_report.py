"""The smoothness, commitment and per-scene tables of a report, and the columns schemas 6 to 8
added in an older database: read as NULL, added when it is opened to write, its rows kept."""

import math
import os
import pathlib
import re
import sqlite3

import pytest

from dcmppi.bench.episodes.runner import EpisodeSpec, run_episode
from dcmppi.bench.experiments import load_experiment
from dcmppi.bench.reports.report import own_tracks, replay_table, smoothness_table, write_report
from dcmppi.bench.results.database import ADDED, SCHEMA_VERSION, ResultsDB
from dcmppi.bench.results.stats import replay_scenes, smoothness
from dcmppi.bench.runs.execution import run_experiment
from dcmppi.control.defaults import DT
from dcmppi.tasks.replay import recordings

ROOT = pathlib.Path(__file__).resolve().parents[2]
SMALL = {"K": 64, "N": 20}


def crowds():
    """The ETH/UCY folder ($DCMPPI_CROWDS, else ../shared/crowds), or skip saying why."""
    folder = pathlib.Path(os.environ.get(recordings.CROWDS_ENV) or ROOT.parent / "shared/crowds")
    if not (folder / "biwi_eth.txt").is_file():
        pytest.skip(f"the ETH/UCY files are absent ({folder}; set {recordings.CROWDS_ENV})")
    return folder


SINCE_5 = (*ADDED[6], *ADDED[7], *ADDED[8])  # the columns schema 5 lacks


def _row(label, i, **values):
    base = dict.fromkeys(SINCE_5)
    return {
        "noise": "none",
        "label": label,
        "env_index": i,
        "status": "ok",
        "outcome": "goal",
        "collision": 0,
        "time_to_goal": 10.0,
        "jerk_mean": 100.0,
        **base,
        **values,
    }


def test_the_smoothness_table_shows_the_rates_and_blocked_commitment():
    exp = load_experiment("static").select(3, ("mppi",), ("none",))
    rows = [
        _row("mppi", i, control_rate_angular=a, indecision_per_m=0.5, indecision_per_s=0.4)
        for i, a in enumerate((1.0, 2.0, 3.0))
    ]
    text = smoothness_table(rows, exp)
    line = text.splitlines()[2]
    assert line.startswith("| none | mppi | 3 | 100.0 [100.0, 100.0] | - | 2.00 [")
    assert "Commit" not in text
    sided = [(0.5, 0.0, 0), (2.0, 1.5, 1), (None, None, 0)]  # prompt; hesitant; never sided
    for r, (t, d, k) in zip(rows, sided, strict=True):
        r.update(commit_time=t, commit_delay=d, side_switches=k)
    s = smoothness(rows)[("none", "mppi")]
    assert s["blocked"] == 3 and s["commit_time"][0] == pytest.approx(1.25)
    assert s["committed"][0] == pytest.approx(100 / 3)
    assert s["settled"][0] == pytest.approx(100 / 3)
    assert s["never_switched"][0] == pytest.approx(100 / 3)
    assert "| Commit time [s] |" in smoothness_table(rows, exp)
    assert "Plan:" not in smoothness_table(rows, exp)
    planned = [(4.0, 0.0, 0), (5.0, 0.5, 1), (6.0, 2.0, 2)]  # prompt, settled, hesitant
    for r, (t, d, k) in zip(rows, planned, strict=True):
        r.update(plan_commit_time=t, plan_commit_delay=d, plan_side_switches=k)
    s = smoothness(rows)[("none", "mppi")]
    assert s["planned"] == 3 and s["plan_commit_time"][0] == pytest.approx(5.0)
    assert s["plan_committed"][0] == 0.0  # none within 1 s of the start
    assert s["plan_settled"][0] == pytest.approx(200 / 3)
    assert s["plan_never_switched"][0] == pytest.approx(100 / 3)
    text = smoothness_table(rows, exp)
    head = [cell.strip() for cell in text.splitlines()[0].split("|")]
    assert head[-5:-1] == [
        "Plan: commit time [s]",
        "Plan: committed within 1 s %",
        "Plan: settled within 1 s of the first side %",
        "Plan: never switched %",
    ]
    cells = [cell.strip() for cell in text.splitlines()[2].split("|")]
    assert cells[-3].startswith("66.7 [") and cells[-2].startswith("33.3 [")
    assert s["committed"][0] == pytest.approx(100 / 3)  # the path's, unchanged
    classical = [{**r, "plan_side_switches": None} for r in rows]
    assert smoothness(classical)[("none", "mppi")]["plan_settled"] is None
    assert "Plan:" not in smoothness_table(classical, exp)
    old = [{**r, **dict.fromkeys(SINCE_5)} for r in rows]
    assert smoothness_table(old, exp) == ""  # an older database: no table


def test_replays_per_scene_ratios_and_freezing():
    rows = [
        _row("dc", 0, scene="eth", frame_path_length=12.0, human_path_length=10.0,
             time_to_goal=12.0, human_time=8.0),
        _row("dc", 1, scene="eth", frame_path_length=10.0, human_path_length=10.0,
             time_to_goal=8.0, human_time=8.0),
        _row("dc", 2, scene="univ", outcome="time_limit", time_to_goal=None, goal_distance=1.5),
        _row("dc", 3, scene="univ", outcome="time_limit", time_to_goal=None, goal_distance=5.0),
        _row("dc", 4, scene="univ", outcome="collision", collision=1, time_to_goal=None),
    ]  # fmt: skip
    rows = [{**r, "task": "replay"} for r in rows]  # frozen: within the replay's 1 m + 1 m
    stats = replay_scenes(rows)
    eth, univ, every = (stats[("none", "dc", s)] for s in ("eth", "univ", "all"))
    assert eth["path_ratio"][0] == pytest.approx(1.1)  # (1.2 + 1.0) / 2
    assert eth["time_ratio"][0] == pytest.approx(1.25)  # (1.5 + 1.0) / 2
    assert univ["path_ratio"] is None and univ["timeout"][0] == pytest.approx(200 / 3)
    assert univ["frozen"][0] == pytest.approx(100 / 3)
    assert univ["elsewhere"][0] == pytest.approx(100 / 3)
    assert every["episodes"] == 5 and every["collision"][0] == pytest.approx(20)
    exp = load_experiment("eth-ucy").select(5, ("dc",), ("none",))
    lines = replay_table(rows, exp).splitlines()
    assert [line.split(" | ")[2] for line in lines[2:]] == ["eth", "univ", "**all**"]
    assert replay_scenes([_row("dc", 0)]) == {} and replay_table([_row("dc", 0)], exp) == ""


def _old_database(tmp_path, schema=5):
    """A complete static database, then made as `schema` (5, 6 or 7) wrote it."""
    exp = load_experiment("static").select(2, ("mppi",), ("none",))
    path = tmp_path / "old.db"
    db = ResultsDB(path, exp.config())
    db.begin_run(exp.to_dict())
    for i in range(2):
        spec = EpisodeSpec("blocked", "mppi", "none", i, {}, SMALL)
        db.record(("none", "mppi", i), spec, run_episode(spec))
    db.end_run()
    db.close()
    with sqlite3.connect(path) as c:
        before = c.execute("SELECT env_index, outcome, path_length, jerk_mean FROM episodes")
        before = before.fetchall()
        for version in range(schema + 1, SCHEMA_VERSION + 1):
            for name in ADDED[version]:
                c.execute(f"ALTER TABLE episodes DROP COLUMN {name}")
        c.execute("UPDATE meta SET value = ? WHERE key = 'schema'", (str(schema),))
    return exp, path, before


@pytest.mark.slow
def test_a_schema_5_database_reports_and_upgrades_keeping_its_rows(tmp_path):
    exp, path, before = _old_database(tmp_path)
    text = write_report(path, tmp_path / "out", plots=False)  # read-only: nothing converted
    assert not re.search(r"\bnan\b", text) and "Turn sign changes" not in text
    with sqlite3.connect(path) as c:
        assert c.execute("SELECT value FROM meta WHERE key = 'schema'").fetchone() == ("5",)
    old = ResultsDB(path)
    assert all(r["commit_time"] is None and r["scene"] is None for r in old.rows())
    old.close()
    ResultsDB(path, exp.config()).close()  # opening to write adds the columns
    with sqlite3.connect(path) as c:
        assert c.execute("SELECT value FROM meta WHERE key = 'schema'").fetchone() == (
            str(SCHEMA_VERSION),
        )
        columns = {r[1] for r in c.execute("PRAGMA table_info(episodes)")}
        assert columns >= set(SINCE_5)
        kept = c.execute("SELECT env_index, outcome, path_length, jerk_mean FROM episodes")
        assert kept.fetchall() == before


@pytest.mark.slow
def test_a_schema_6_database_reports_its_path_sides_and_upgrades(tmp_path):
    exp, path, before = _old_database(tmp_path, schema=6)
    text = write_report(path, tmp_path / "out", plots=False)  # read-only: nothing converted
    assert "| Commit time [s] |" in text and "Plan:" not in text
    with sqlite3.connect(path) as c:
        assert c.execute("SELECT value FROM meta WHERE key = 'schema'").fetchone() == ("6",)
    old = ResultsDB(path)
    rows = old.rows()
    old.close()
    assert all(r["plan_side_switches"] is None for r in rows)
    assert all(r["side_switches"] is not None for r in rows)
    db = ResultsDB(path, exp.config())  # opening to write adds the columns, keeps the rows
    spec = EpisodeSpec("blocked", "mppi", "none", 2, {}, SMALL)
    db.record(("none", "mppi", 2), spec, run_episode(spec))
    rows = db.rows()
    db.close()
    assert [r["plan_side_switches"] is None for r in rows] == [True, True, False]
    with sqlite3.connect(path) as c:
        assert c.execute("SELECT value FROM meta WHERE key = 'schema'").fetchone() == (
            str(SCHEMA_VERSION),
        )
        kept = c.execute("SELECT env_index, outcome, path_length, jerk_mean FROM episodes")
        assert kept.fetchall()[:2] == before


@pytest.mark.slow
def test_a_schema_7_database_reports_without_the_time_columns_and_upgrades(tmp_path):
    assert ADDED[8] == ("time_waiting", "time_slow", "detour")
    assert ADDED[9] == ("discomfort_frequency",)
    assert ADDED[10] == ("intrusion_ratio", "social_distance")
    assert SCHEMA_VERSION == 11 and ADDED[11] == ("shield_share",)
    exp, path, _ = _old_database(tmp_path, schema=7)
    with sqlite3.connect(path) as c:  # schema 7's filter-guard share, no longer declared
        c.execute("ALTER TABLE episodes ADD COLUMN guard_share REAL")
        c.execute("UPDATE episodes SET guard_share = 0.25")
        before = c.execute("SELECT * FROM episodes ORDER BY env_index").fetchall()
    text = write_report(path, tmp_path / "out", plots=False)  # read-only: nothing converted
    diagnostics = next(b for b in text.split("\n\n") if b.startswith("| Noise | Row | ESS"))
    head, _, line = diagnostics.splitlines()
    assert head.endswith("| Waiting [s] | Slow in free space [s] | Detour |")
    assert line.endswith("| - | - | - |") and not re.search(r"\bnan\b", text)
    with sqlite3.connect(path) as c:
        assert c.execute("SELECT value FROM meta WHERE key = 'schema'").fetchone() == ("7",)
    old = ResultsDB(path)
    assert all(r[name] is None for r in old.rows() for name in ADDED[8])
    old.close()
    db = ResultsDB(path, exp.config())  # opening to write adds the columns, keeps the rows
    spec = EpisodeSpec("blocked", "mppi", "none", 2, {}, SMALL)
    result = run_episode(spec)
    db.record(("none", "mppi", 2), spec, result)
    rows = db.rows()
    db.close()
    assert [r["detour"] is None for r in rows] == [True, True, False]
    assert rows[2]["detour"] == pytest.approx(result["path_length"] / 20.0)  # start to goal
    assert 0 <= rows[2]["time_waiting"] <= rows[2]["steps"] * DT
    assert 0 <= rows[2]["time_slow"] <= rows[2]["steps"] * DT
    with sqlite3.connect(path) as c:
        schema = c.execute("SELECT value FROM meta WHERE key = 'schema'").fetchone()
        assert schema == (str(SCHEMA_VERSION),)
        kept = c.execute("SELECT * FROM episodes ORDER BY env_index").fetchall()
    assert [row[: len(before[0])] for row in kept[:2]] == before  # every old value kept
    added = sum(len(ADDED[v]) for v in range(8, SCHEMA_VERSION + 1))
    assert kept[0][len(before[0]) :] == (None,) * added  # the columns added since 7, NULL
    assert "guard_share" not in rows[0] and kept[2][len(before[0]) - 1] is None  # kept, unread
    text = write_report(path, tmp_path / "out", plots=False)
    diagnostics = next(b for b in text.split("\n\n") if b.startswith("| Noise | Row | ESS"))
    cells = diagnostics.splitlines()[2].split(" | ")
    assert cells[-3] == f"{rows[2]['time_waiting']:.1f}"  # the one episode that records it


@pytest.mark.slow
def test_a_tiny_replay_run_reports_its_scenes(tmp_path):
    folder = crowds()
    exp = load_experiment("eth-ucy").select(3, ("dc-cv",), ("none",))
    exp = exp.with_params({"path": str(folder)}, SMALL)
    db = ResultsDB(tmp_path / "r.db", exp.config())
    run_experiment(exp, db, progress=False)
    rows = db.rows()
    db.close()
    text = write_report(tmp_path / "r.db", tmp_path / "out", plots=False)
    md = (tmp_path / "out" / "report.md").read_text()
    assert [r["scene"] for r in rows] == ["eth", "hotel", "univ"]  # environment i: scene i % 5
    assert [r["recording"] for r in rows[:2]] == ["biwi_eth", "biwi_hotel"]
    assert rows[2]["recording"] in recordings.SCENES["univ"]
    for r in rows:
        assert r["human_time"] > 0 and r["human_path_length"] >= 5.0 and r["person"] >= 0
        assert 0 < r["frame_path_length"] <= r["path_length"] + 1e-9
    lines = [line.split(" | ") for line in replay_table(rows, exp).splitlines()[2:]]
    assert [cells[2] for cells in lines] == [
        "eth",
        "hotel",
        "univ",
        "**all**",
        *"eth hotel univ".split(),
    ]
    for cells in lines[4:]:  # each replaced person along their own track: the rule's check
        assert cells[1] == "replaced person, own track" and cells[3] == "1"
        assert cells[5] in ("0.0 [0.0, 79.3]", "100.0 [20.7, 100.0]")
    hits = own_tracks(rows, exp)
    assert set(hits) == {"eth", "hotel", "univ"} and all(n == 1 for n, _ in hits.values())
    missing = exp.with_params({"path": str(tmp_path)}, {})  # no recordings there: count only
    assert own_tracks(rows, missing)["eth"] == (1, None)
    assert "## Recorded people, per scene" in md and "| none | dc-cv | univ | 1 |" in text
    assert "## Smoothness" in md and not math.isnan(rows[0]["indecision_per_s"])
