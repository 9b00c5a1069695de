"""BARN: the shortest-path length, the navigation score, the `barn` experiment and its report."""

import math
import pathlib
import sqlite3

import numpy as np
import pytest

from dcmppi import tasks
from dcmppi.bench.episodes.runner import EpisodeSpec, check_specs, make_env
from dcmppi.bench.experiments import Experiment, ExperimentError, load_experiment
from dcmppi.bench.reports.report import score_table, write_report
from dcmppi.bench.results.database import SCHEMA_VERSION, ResultsDB
from dcmppi.bench.results.stats import bootstrap_mean, paired_scores, summarize
from dcmppi.bench.runs.execution import run_experiment
from dcmppi.tasks.worlds import barn, layout

BARN = pathlib.Path(__file__).parent / "data" / "barn_worlds_0_1.csv"
BOUNDS = (-2.0, -4.0, 12.0, 4.0)


# The shortest collision-free path -------------------------------------------------------------


def test_shortest_path_around_a_disc_is_the_tangent_arc_tangent_length():
    """Start and goal 5 m either side of a disc: two tangents and an arc of the inflated disc."""
    d, rho = 5.0, 1.0 + 0.5  # centre distance, cylinder radius + robot radius
    exact = 2 * math.sqrt(d * d - rho * rho) + rho * (math.pi - 2 * math.acos(rho / d))
    length = barn.shortest_path_length([[5.0, 0.0, 1.0]], 0.5, (0, 0), (10, 0), BOUNDS)
    assert exact <= length < exact * 1.005  # a real path, never shorter than the true one


def test_shortest_path_is_straight_without_obstacles_and_through_a_wide_gap():
    assert barn.shortest_path_length(np.zeros((0, 3)), 0.3, (0, 0), (10, 0), BOUNDS) == 10.0
    wall = [[5.0, y, 0.1] for y in np.arange(-3.9, 4.0, 0.2) if abs(y) > 0.6]  # gap |y| < 0.6
    # the gap between the surfaces is 2 * (0.7 - 0.1) = 1.2 m
    assert barn.shortest_path_length(wall, 0.55, (0, 0), (10, 0), BOUNDS) == 10.0
    assert barn.shortest_path_length(wall, 0.65, (0, 0), (10, 0), BOUNDS) == math.inf


def test_shortest_path_rejects_a_start_in_collision():
    with pytest.raises(ValueError, match="start .* within 0.5 m of a cylinder"):
        barn.shortest_path_length([[0.2, 0, 0.1]], 0.5, (0, 0), (10, 0), BOUNDS)


# The score ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "success, actual, score",
    [
        (True, 4.0, 0.5),  # faster than 2 x optimal: clipped up to 2 x optimal
        (True, 10.0, 0.5),  # exactly 2 x optimal
        (True, 20.0, 0.25),  # between the clip points: optimal / actual
        (True, 40.0, 0.125),  # exactly 8 x optimal
        (True, 100.0, 0.125),  # slower than 8 x optimal: clipped down
        (False, 10.0, 0.0),  # failure
    ],
)
def test_navigation_score_at_its_clip_points(success, actual, score):
    assert barn.navigation_score(success, actual, 5.0) == pytest.approx(score)


# The experiment -------------------------------------------------------------------------------


def test_barn_experiment_maps_environment_i_to_world_i():
    exp = load_experiment("barn")
    assert (exp.task, exp.episodes, exp.env_param, exp.reference) == (
        "layout",
        300,
        "world",
        "mppi",
    )
    assert exp.labels == (
        "mppi", "clustered", "tube", "dwa", "mppi+smooth", "clustered+smooth", "mppi-6000x100",
        "mppi-6000x100+smooth",
    )  # fmt: skip
    budget = exp.spec("none", "mppi-6000x100+smooth", 0).controller_params
    assert (budget["K"], budget["N"], budget["preset"]) == (6000, 100, "smooth")  # BiC-MPPI's
    assert exp.task_params["agent"] == "unicycle" and exp.task_params["robot_radius"] == 0.3
    assert 100 - exp.paper("none", "mppi").failure_pct == pytest.approx(80.5)
    assert 100 - exp.paper("none", "clustered").failure_pct == pytest.approx(80.2)
    for i in (0, 1, 299):
        spec = exp.spec("none", "tube", i)
        assert spec.task_params["world"] == i and spec.seed == exp.seed(i)
    assert exp.config()["env_param"] == "world"  # a database is bound to it
    # --episodes n picks the first n worlds
    worlds = [spec.task_params["world"] for _, spec in exp.select(episodes=2).specs()]
    assert worlds == [0] * len(exp.labels) + [1] * len(exp.labels)
    exp = exp.with_params({"path": str(BARN)}, {})
    cylinders = np.loadtxt(BARN, delimiter=",", skiprows=1)
    env = make_env(exp.spec("none", "mppi", 1))
    static = env.reset().observation["static_obstacles"]
    np.testing.assert_allclose(static, cylinders[cylinders[:, 0] == 1, 1:])
    np.testing.assert_allclose(env.reset().observation["robot_pose"], layout.BARN_START)
    check_specs([spec for _, spec in exp.select(episodes=1).specs()])  # every row builds


def test_a_missing_barn_file_names_both_ways_to_give_it(monkeypatch, tmp_path):
    exp = load_experiment("barn")
    monkeypatch.delenv(layout.BARN_ENV, raising=False)
    with pytest.raises(ValueError, match=r"--task-param path=FILE.*DCMPPI_BARN=FILE"):
        check_specs([exp.spec("none", "mppi", 0)])
    monkeypatch.setenv(layout.BARN_ENV, str(tmp_path / "nowhere.csv"))
    with pytest.raises(ValueError, match=r"DCMPPI_BARN=.*nowhere\.csv: no such file.*path=FILE"):
        make_env(exp.spec("none", "mppi", 0))
    monkeypatch.setenv(layout.BARN_ENV, str(BARN))
    assert make_env(exp.spec("none", "mppi", 1)).task.num_static == 237


def test_env_param_is_checked():
    base = {"task": "layout", "episodes": 2, "rows": [{"controller": "mppi"}]}
    with pytest.raises(ExperimentError, match=r"x\.toml: task_params\.world: set per environment"):
        Experiment.from_dict({**base, "env_param": "world", "task_params": {"world": 3}}, "x.toml")
    with pytest.raises(ExperimentError, match=r"x\.toml: env_param: 'random': name a task"):
        Experiment.from_dict({**base, "env_param": "random"}, "x.toml")
    with pytest.raises(ValueError, match="sets world to the environment index; .* --episodes"):
        load_experiment("barn").with_params({"world": 4}, {})


def test_optimal_time_is_the_shortest_path_over_the_jackals_top_speed(tmp_path):
    env = tasks.load("layout", {"path": str(BARN), "world": 0, "robot_radius": 0.3})
    obs = env.reset().observation
    length = barn.shortest_path_length(
        obs["static_obstacles"], 0.3, layout.BARN_START, layout.BARN_GOAL, obs["map_bounds"]
    )
    assert 10.0 <= length < 11.0  # 10 m start to goal, and world 0 is open
    assert env.task.optimal_time == pytest.approx(length / 2.0)
    wider = tasks.load("layout", {"path": str(BARN), "world": 0, "robot_radius": 0.4})
    assert wider.task.optimal_time > env.task.optimal_time  # a wider robot detours further
    too_wide = tasks.load("layout", {"path": str(BARN), "world": 0, "robot_radius": 0.5})
    assert too_wide.task.optimal_time is None  # no path: no score
    plain = tmp_path / "plain.csv"
    plain.write_text("5,0,1\n")
    other = tasks.load("layout", {"path": str(plain), "start": (0, 0, 0), "goal": (10, 0)})
    assert other.task.optimal_time is None  # the score is BARN's


# End to end: a run, its database and its report -----------------------------------------------


@pytest.mark.slow
def test_one_barn_episode_end_to_end(tmp_path):
    exp = (
        load_experiment("barn")
        .select(episodes=1, rows=("mppi",))
        .with_params({"path": str(BARN)}, {"K": 100})
    )
    db = ResultsDB(tmp_path / "barn.db", exp.config())
    run_experiment(exp, db, progress=False)
    (row,) = db.rows()
    db.close()
    assert row["status"] == "ok" and row["outcome"] == "goal", row
    optimal = make_env(exp.spec("none", "mppi", 0)).task.optimal_time
    assert row["nav_score"] == pytest.approx(optimal / max(row["time_to_goal"], 2 * optimal))
    assert 0.125 <= row["nav_score"] <= 0.5
    text = write_report(tmp_path / "barn.db", tmp_path / "report", plots=False)
    scores = score_table([row], exp)
    assert scores in text  # the report's score table (its other tables start their rows alike)
    (line,) = [r for r in scores.splitlines() if r.startswith("| none | mppi | 1 | 100.0 [20.7")]
    assert f"| {row['nav_score']:.3f} [{row['nav_score']:.3f}, {row['nav_score']:.3f}] |" in line
    assert "(80.5)" in line  # BiC-MPPI's published success rate beside ours
    assert "## Navigation score" in (tmp_path / "report" / "report.md").read_text()


# Statistics and the report's table ------------------------------------------------------------


def _rows(scores_by_label):
    return [
        {
            "noise": "none",
            "label": label,
            "env_index": i,
            "status": "ok",
            "outcome": "goal" if score else "collision",
            "collision": not score,
            "failure": not score,
            "steps": 100,
            "time_to_goal": None,
            "path_length": 10.0,
            "ctrl_ms_mean": 1.0,
            "ess_mean": None,
            "clusters_mean": None,
            "fallback_share": None,
            "tube_deviation_p95": None,
            "nav_score": score,
        }
        for label, scores in scores_by_label.items()
        for i, score in enumerate(scores)
    ]


def test_bootstrap_interval_of_a_mean():
    rng = np.random.default_rng(3)
    x = rng.uniform(0, 0.5, 400)
    lo, hi = bootstrap_mean(x)
    assert lo < x.mean() < hi and bootstrap_mean(x) == (lo, hi)  # the same values, the same CI
    half = 1.96 * x.std(ddof=1) / math.sqrt(len(x))  # the normal interval, for a large n
    assert abs((hi - lo) / 2 - half) < 0.1 * half
    wide = bootstrap_mean(x[:40])
    assert wide[1] - wide[0] > 2 * (hi - lo)
    assert bootstrap_mean([0.3, 0.3]) == (0.3, 0.3)


def test_score_table_rows_and_paired_differences():
    a = [0.5, 0.4, 0.0, 0.3] * 10
    b = [0.4, 0.4, 0.0, 0.0] * 10
    rows = _rows({"mppi": a, "clustered": b})
    exp = load_experiment("barn")
    s = summarize(rows)[("none", "clustered")]
    assert (s["scored"], s["goals"]) == (40, 20)
    assert s["nav_score"] == pytest.approx(0.2)
    d = paired_scores(rows, "none", "clustered", "mppi")
    assert d["pairs"] == 40 and d["diff"] == pytest.approx(-0.1)
    assert d["ci"][0] < -0.1 < d["ci"][1] < 0
    text = score_table(rows, exp)
    line = next(r for r in text.splitlines() if "| clustered |" in r)
    lo, hi = s["success_ci_pct"]
    assert f"| 50.0 [{lo:.1f}, {hi:.1f}] (80.2) | 0.200 [" in line
    assert f"| -0.100 [{d['ci'][0]:+.3f}, {d['ci'][1]:+.3f}] |" in line
    assert score_table(_rows({"mppi": [None] * 3}), exp) == ""  # no scores, no table


def test_a_database_without_the_score_column_is_read_and_extended(tmp_path):
    """A schema-2 database (before nav_score) keeps its rows: read with nav_score None, and
    opening it to write adds the column."""
    config = {"task": "forest", "base_seed": 0, "task_params": {}, "controller_params": {}}
    path = tmp_path / "old.db"
    ResultsDB(path, config).close()
    with sqlite3.connect(path) as c:
        c.execute("ALTER TABLE episodes DROP COLUMN nav_score")
        c.execute("UPDATE meta SET value = '2' WHERE key = 'schema'")
        c.execute(
            "INSERT INTO episodes (noise, label, env_index, controller, task, seed, status, "
            "params) VALUES ('none', 'mppi', 0, 'mppi', 'forest', 1, 'ok', '{}')"
        )
    (row,) = ResultsDB(path).rows()
    assert row["env_index"] == 0 and row["nav_score"] is None
    db = ResultsDB(path, config)
    db.record(("none", "mppi", 1), EpisodeSpec("forest", "mppi"), {"nav_score": 0.4})
    assert [r["nav_score"] for r in db.rows()] == [None, 0.4]
    db.close()
    with sqlite3.connect(path) as c:
        (schema,) = c.execute("SELECT value FROM meta WHERE key = 'schema'").fetchone()
    assert schema == str(SCHEMA_VERSION)  # upgraded to the current schema
