"""The episode columns' declarations drive the database's schema and migrations, episodes.csv,
`run_episode`'s result and the report's tables and notes."""

import csv
import sqlite3

import numpy as np
import pytest

from dcmppi.bench.episodes import columns
from dcmppi.bench.episodes.columns import EPISODE, Column, EpisodeResult
from dcmppi.bench.episodes.runner import EpisodeSpec, run_episode
from dcmppi.bench.experiments import load_experiment
from dcmppi.bench.reports.report import (
    diagnostics_table,
    metrics_table,
    smoothness_table,
    write_report,
)
from dcmppi.bench.results.database import ADDED, SCHEMA_VERSION, TABLE_COLUMNS, ResultsDB

# What each schema version added before the declarations (database.py's ADDED up to schema 7),
# less guard_share (schema 7's filter guard, removed): databases that hold it keep it, unread.
ADDED_BY_HAND = {
    3: {"nav_score"},
    4: {"success", "collision_kind", "timeout", "spl", "jerk_mean", "min_ped_gap",
        "personal_space_share", "min_ttc", "ped_speed_loss"},
    5: {"run_id", "traceback", "final_x", "final_y", "final_theta", "trace"},
    6: {"goal_distance", "control_rate_linear", "control_rate_angular", "turn_sign_changes",
        "indecision_per_m", "indecision_per_s", "commit_time", "commit_delay", "side_switches",
        "scene", "recording", "person", "human_time", "human_path_length", "frame_path_length"},
    7: {"plan_commit_time", "plan_commit_delay", "plan_side_switches"},
}  # fmt: skip
SAMPLE = {"TEXT": "x", "INTEGER": 1, "REAL": 0.5, "BLOB": b"\x00"}


def _sample() -> EpisodeResult:
    """A result of every episode column: 0.5 in each REAL one, a goal reached."""
    values = {c.name: SAMPLE[c.type] for c in EPISODE}
    return EpisodeResult({**values, "outcome": "goal", "collision": 0, "collision_kind": None})


def test_each_schema_version_adds_the_columns_declared_since_it():
    assert {v: set(names) for v, names in ADDED.items() if v <= 7} == ADDED_BY_HAND
    assert SCHEMA_VERSION == max(ADDED) and set(ADDED) == set(range(3, SCHEMA_VERSION + 1))
    assert all(ADDED[v] for v in ADDED)  # a version adds columns


def test_a_new_database_and_its_csv_have_every_declared_column(tmp_path):
    exp = load_experiment("static").select(2, ("mppi",), ("none",))
    db = ResultsDB(tmp_path / "r.db", exp.config())
    db.begin_run(exp.to_dict())
    db.record(("none", "mppi", 0), EpisodeSpec("forest", "mppi"), _sample())
    db.end_run()
    db.close()
    with sqlite3.connect(tmp_path / "r.db") as c:
        table = [(r[1], r[2], r[3]) for r in c.execute("PRAGMA table_info(episodes)")]
    assert table == [(col.name, col.type, int(col.required)) for col in columns.COLUMNS]
    write_report(tmp_path / "r.db", tmp_path / "out", plots=False)
    with open(tmp_path / "out" / "episodes.csv") as f:
        header, row = list(csv.reader(f))
    names = [col.name for col in columns.COLUMNS if col.type != "BLOB"]
    assert header == names == list(TABLE_COLUMNS)
    assert row[header.index("path_length")] == "0.5" and "trace" not in header


def test_the_report_shows_each_declared_column_with_its_unit_digits_and_note(tmp_path):
    exp = load_experiment("static").select(2, ("mppi",), ("none",))
    db = ResultsDB(tmp_path / "r.db", exp.config())
    db.begin_run(exp.to_dict())
    for i in range(2):
        db.record(("none", "mppi", i), EpisodeSpec("forest", "mppi"), _sample())
    db.end_run()
    rows = db.rows()
    db.close()
    write_report(tmp_path / "r.db", tmp_path / "out", plots=False)
    md = (tmp_path / "out" / "report.md").read_text()
    tables = {"metrics": metrics_table, "smoothness": smoothness_table}
    tables["diagnostics"] = diagnostics_table
    assert set(tables) == set(columns.TABLES)
    for name, make in tables.items():
        head, _, line = make(rows, exp).splitlines()[:3]
        head = [c.strip() for c in head.split("|")]
        cells = [c.strip() for c in line.split("|")]
        for column in columns.shown(name):  # 0.5 in every episode, in its unit
            shown = cells[head.index(column.heading)]
            assert shown.startswith(f"{0.5 * column.scale:.{column.digits}f}"), column.name
            assert column.explained in md and f"| {column.heading} |" in md
            unit = "%" if column.percent else column.unit.replace("1/", "per ")
            assert unit in column.heading
    assert "Path [m]" in md and "Speed loss %" in md and "Turn sign changes per m" in md


def test_an_episode_result_is_checked_against_the_declarations():
    good = dict(_sample())
    assert list(EpisodeResult(good)) == [c.name for c in EPISODE]
    with pytest.raises(TypeError, match=r"missing \['spl'\], undeclared \['speed'\]"):
        EpisodeResult({**{k: v for k, v in good.items() if k != "spl"}, "speed": 1.0})
    with pytest.raises(TypeError, match=r"undeclared \['seed'\]"):  # the database's column
        EpisodeResult({**good, "seed": 3})
    with pytest.raises(TypeError, match=r"steps=np.int64\(7\) \(int64, not INTEGER\)"):
        EpisodeResult({**good, "steps": np.int64(7)})
    assert EpisodeResult({**good, "steps": 7, "spl": None, "ess_mean": 1})["ess_mean"] == 1
    with pytest.raises(ValueError, match="column x: type='FLOAT', over='best'"):
        Column("x", "FLOAT", "a value", over="best")
    with pytest.raises(ValueError, match=r"column y: tables=\('metrics',\)"):
        Column("y", "REAL", "a value", tables=("metrics",))  # a shown column needs its title


def test_a_recorded_episode_keeps_every_value_of_its_result(tmp_path):
    spec = EpisodeSpec("blocked", "mppi", "control", 1, {"time_limit": 2.0}, {"K": 64, "N": 20})
    result = run_episode(spec)
    assert isinstance(result, EpisodeResult)
    assert result["commit_time"] is not None and result["scene"] is None  # blocked, no replay
    db = ResultsDB(tmp_path / "r.db", {"task": "blocked"})
    db.record(("control", "mppi", 1), spec, result)
    row = db.row("control", "mppi", 1)
    db.close()
    assert {name: row[name] for name in result} == result
