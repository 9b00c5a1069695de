"""The benchmark runner end to end: paired episodes, executors, resume, errors, report.

Episodes here use small controllers (K=32, N=20) on the `blocked` task so the tests stay
fast; the logic under test does not depend on the sizes.
"""

import dataclasses
import os
import signal
import sqlite3
import subprocess
import sys
import time
from multiprocessing.connection import Connection

import numpy as np
import pytest

from dcmppi import cli
from dcmppi.bench.episodes.runner import Episode, EpisodeSpec, run_episode
from dcmppi.bench.experiments import load_experiment
from dcmppi.bench.reports.report import write_report
from dcmppi.bench.results.database import ResultsDB
from dcmppi.bench.results.stats import summarize
from dcmppi.bench.runs.execution import run_all, run_experiment
from dcmppi.control import ClusteredDiagnostics, TubeDiagnostics

SMALL = {"K": 32, "N": 20}
DETERMINISTIC = (
    "noise",
    "label",
    "controller",
    "env_index",
    "seed",
    "status",
    "outcome",
    "collision",
    "failure",
    "steps",
    "time_to_goal",
    "path_length",
    "min_clearance",
    "ess_mean",
    "clusters_mean",
    "fallback_share",
    "tube_deviation_p95",
    "params",
)


def tiny(episodes=2, rows=("mppi", "clustered"), noises=("none", "control")):
    """The static experiment's rows on the small `blocked` task."""
    exp = dataclasses.replace(load_experiment("static"), task="blocked", controller_params=SMALL)
    return exp.select(episodes, rows, noises)


def deterministic(rows):
    return [{k: r[k] for k in DETERMINISTIC} for r in rows]


def run_into(path, exp, **kwargs):
    db = ResultsDB(path, exp.config())
    run_experiment(exp, db, progress=False, **kwargs)
    rows = db.rows()
    db.close()
    return rows


def test_episode_is_reproducible_and_paired():
    spec = EpisodeSpec("blocked", "clustered", "control", seed=7, controller_params=SMALL)
    a, b = run_episode(spec, keep_path=True), run_episode(spec, keep_path=True)
    assert a["outcome"] in ("goal", "collision", "time_limit")
    assert (a["path"] == b["path"]).all() and a["min_clearance"] == b["min_clearance"]
    # the same environment seed gives the same world for another controller
    other = run_episode(dataclasses.replace(spec, controller="mppi"), keep_path=True)
    assert (other["path"][0] == a["path"][0]).all()


# a user's controller (tests/user_controllers.py): workers import it by name
USER_ROWS = ("mppi", "clustered", "user_controllers:Straight")


@pytest.mark.slow
def test_one_and_two_workers_give_identical_rows(tmp_path):
    exp = tiny(rows=USER_ROWS)
    one = run_into(tmp_path / "one.db", exp, workers=1)
    two = run_into(tmp_path / "two.db", exp, workers=2)
    assert len(one) == exp.count() == 12
    assert all(r["status"] == "ok" for r in one)
    assert deterministic(one) == deterministic(two)


@pytest.mark.slow
def test_ray_executor_matches_local(tmp_path):
    pytest.importorskip("ray")
    exp = tiny(episodes=1, rows=USER_ROWS, noises=("control",))
    local = run_into(tmp_path / "local.db", exp, workers=1)
    remote = run_into(tmp_path / "ray.db", exp, workers=2, executor="ray")
    assert all(r["status"] == "ok" for r in remote)
    assert deterministic(local) == deterministic(remote)


@pytest.mark.slow
def test_erroring_episode_is_recorded_and_the_run_goes_on(tmp_path):
    exp = tiny(episodes=1, rows=("mppi",), noises=("none",))
    ((key, good),) = exp.specs()
    bad = dataclasses.replace(good, controller_params={**SMALL, "lambda_": -1.0})
    db = ResultsDB(tmp_path / "e.db", exp.config())
    run_all([(("none", "mppi", 5), bad), (key, good)], db, progress=False)
    rows = {r["env_index"]: r for r in db.rows()}
    assert rows[5]["status"] == "error" and "lambda" in rows[5]["error"]
    assert rows[0]["status"] == "ok" and rows[0]["outcome"] is not None


def _bench_cmd(db, episodes):
    return [
        sys.executable,
        "-m",
        "dcmppi.cli",
        "bench",
        "--experiment",
        "static",
        "--episodes",
        str(episodes),
        "--controllers",
        "mppi",
        "--noise",
        "none",
        "--param",
        "K=32",
        "--param",
        "N=20",
        "--db",
        str(db),
        "--no-progress",
    ]


def _count(db):
    try:
        with sqlite3.connect(db) as c:
            return c.execute("SELECT COUNT(*) FROM episodes").fetchone()[0]
    except sqlite3.Error:
        return 0


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGINT])
def test_bench_resumes_after_kill_or_ctrl_c_without_loss_or_duplicates(tmp_path, sig):
    db = tmp_path / "r.db"
    n = 6
    # cwd outside the checkout: `python -m` puts the cwd first on sys.path, and the source
    # tree's dcmppi/ (without tasks/, mapped in only by the install) must not shadow it.
    proc = subprocess.Popen(
        _bench_cmd(db, n), cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    deadline = time.monotonic() + 120
    while _count(db) < 2 and time.monotonic() < deadline and proc.poll() is None:
        time.sleep(0.05)
    proc.send_signal(sig)
    proc.wait(timeout=60)
    partial = _count(db)
    assert 2 <= partial <= n
    if sig == signal.SIGINT and partial < n:
        assert proc.returncode == 130
    subprocess.run(_bench_cmd(db, n), cwd=tmp_path, check=True, capture_output=True, timeout=300)
    rows = ResultsDB(db).rows()
    assert sorted(r["env_index"] for r in rows) == list(range(n))  # none lost, none twice
    assert all(r["status"] == "ok" for r in rows)


@pytest.mark.slow
def test_report_numbers_match_the_rows(tmp_path):
    exp = tiny(episodes=2, rows=("mppi", "clustered"), noises=("none",))
    rows = run_into(tmp_path / "r.db", exp, workers=1)
    text = write_report(tmp_path / "r.db", tmp_path / "out", plots=True)
    s = summarize(rows)
    for c in ("mppi", "clustered"):
        line = next(x for x in text.splitlines() if f"| {c} |" in x)
        assert f"| {s[('none', c)]['episodes']} |" in line
        assert f"{s[('none', c)]['failure_pct']:.1f} [" in line
    report = (tmp_path / "out" / "report.md").read_text()
    for c in ("mppi", "clustered"):
        ok = [r for r in rows if r["label"] == c]
        steps = sum(r["steps"] for r in ok) / len(ok)
        assert f"| {c} | {len(ok)} | {steps:.0f} |" in report  # the time-per-episode table
    csv_rows = (tmp_path / "out" / "episodes.csv").read_text().strip().splitlines()
    assert len(csv_rows) == 1 + len(rows)
    for png in ("failure_rates.png", "controller_time.png", "paths.png"):
        assert (tmp_path / "out" / png).stat().st_size > 1000


@pytest.mark.parametrize(
    "argv, message",
    [
        (["bench", "--experiment", "nope"], "unknown experiment"),
        (["bench", "--controllers", "mppi,fancy"], "unknown controller"),
        (["bench", "--noise", "loud"], "unknown noise"),
        (["bench", "--episodes", "0"], "--episodes must be >= 1"),
        (["bench", "--episodes", "1", "--workers", "0"], "--workers must be >= 1"),
        (["bench", "--ray-address", "auto"], "--ray-address is for the ray executor, not 'local'"),
        (["bench", "--episodes", "1", "--episode-timeout", "0"], "--episode-timeout must be > 0"),
        (["run", "--task", "nope", "--controller", "mppi"], "unknown task"),
        (["run", "--task", "blocked", "--controller", "fancy"], "unknown controller"),
        (["bench", "--param", "K"], "NAME=VALUE"),
        (["bench", "--episodes", "1", "--param", "gain=NaN"], "gain=NaN: give finite numbers"),
        (["bench", "--task-param", "time_limit=1e999"], "time_limit=1e999: give finite numbers"),
        (["bench", "--episodes", "1", "--param", "K=-1"], "K must be > 0"),
        (["bench", "--episodes", "1", "--param", "seed=3"], "use --seed"),
        (["bench", "--episodes", "1", "--task-param", "noise=process"], "use --noise"),
        (["run", "--task", "blocked", "--controller", "mppi", "--param", "seed=3"], "use --seed"),
        (["figure", "--task", "blocked", "--controllers", ","], "at least one controller"),
        (["figure", "--controllers", "user_controllers:Straight,mppi"], "Straight records none"),
    ],
)
def test_bad_input_gets_a_clear_error(argv, message, capsys, tmp_path):
    """Refused before anything is recorded: no database is created (a bad parameter used to
    exit 0 with one error row per episode, and tie a new database to the bad configuration)."""
    db = tmp_path / "x.db"
    assert cli.main([*argv, *(["--db", str(db)] if argv[0] == "bench" else [])]) == 2
    assert message in capsys.readouterr().err
    assert not db.exists()


def test_a_directory_for_a_database_is_refused_by_the_cli(tmp_path, capsys):
    assert cli.main(["report", "--db", str(tmp_path), "--out", str(tmp_path / "o")]) == 2
    assert f"{tmp_path}: a directory; --db takes a database file's path" in capsys.readouterr().err


def test_unreadable_database_is_refused_by_the_cli(tmp_path, capsys):
    junk = tmp_path / "junk.db"
    junk.write_bytes(os.urandom(4096))
    assert cli.main(["report", "--db", str(junk), "--out", str(tmp_path / "o")]) == 2
    assert "not a readable dcmppi results database" in capsys.readouterr().err


@pytest.mark.parametrize("controller", ["mppi", "clustered", "tube"])
def test_episode_diagnostics_match_the_controllers_records(controller):
    spec = EpisodeSpec(
        "blocked",
        controller,
        "control",
        seed=4,
        task_params={"time_limit": 12.0},
        controller_params=SMALL,
    )
    episode = Episode(spec)
    ess, clusters, fallback, deviation = [], [], [], []
    while not episode.done:
        state = episode.time_step.observation["robot_pose"].copy()
        nominal = getattr(episode.controller, "nominal", None)  # tube: propagated last step
        episode.step()
        d = episode.controller.diagnostics
        ess.append(1.0 / np.sum(d.weights**2))
        if isinstance(d, ClusteredDiagnostics):
            clusters.append(int(d.labels.max()) + 1)
            fallback.append(d.chosen == -1)
        if isinstance(d, TubeDiagnostics):  # the tracking error before the reset decision
            deviation.append(0.0 if nominal is None else np.linalg.norm(state[:2] - nominal[:2]))
    result = episode.result()
    assert result["ess_mean"] == pytest.approx(np.mean(ess))
    if controller == "clustered":
        assert result["clusters_mean"] == pytest.approx(np.mean(clusters))
        assert result["fallback_share"] == pytest.approx(np.mean(fallback))
    else:
        assert result["clusters_mean"] is None and result["fallback_share"] is None
    if controller == "tube":
        assert result["tube_deviation_p95"] == pytest.approx(np.percentile(deviation, 95))
        assert max(deviation) > 0  # the noise pushes the robot off its nominal state
    else:
        assert result["tube_deviation_p95"] is None


@pytest.mark.parametrize("shield", [True, None])
def test_episode_records_how_often_the_shield_changed_the_command(shield):
    spec = EpisodeSpec(
        "square",
        "orca",
        seed=3,
        task_params={"time_limit": 4.0, "behavior": "orca", "robot_visible": False},
        controller_params={"shield": {"time_horizon": 2.0}} if shield else {},
    )
    episode = Episode(spec)
    changed = []
    while not episode.done:
        episode.step()
        changed.append(episode.controller.diagnostics.shielded)
    share = episode.result()["shield_share"]
    if shield:
        assert 0 < share < 1 and share == pytest.approx(np.mean(changed))
    else:
        assert share is None and set(changed) == {None}


@pytest.mark.slow
def test_bench_prints_a_summary_and_report_the_tables(tmp_path, capsys):
    db, out = tmp_path / "s.db", tmp_path / "report"
    argv = ["bench", "--experiment", "static", "--episodes", "1", "--noise", "none",
            "--controllers", "mppi,tube", "--param", "K=32", "--param", "N=20",
            "--db", str(db), "--no-progress"]  # fmt: skip
    assert cli.main(argv) == 0
    printed = capsys.readouterr()
    assert "|---" not in printed.out + printed.err
    assert f"2 of 2 episodes in {db}" in printed.out and "dcmppi report --db" in printed.out
    assert cli.main(["report", "--db", str(db), "--out", str(out), "--no-plots"]) == 0
    text = capsys.readouterr().out
    assert "Partial" not in text and "Still being written" not in text
    main, metrics, diagnostics = text.split("\n\n")[:3]  # then the provenance
    assert "| none | tube | 1 |" in main and "Collisions vs mppi: McNemar" in main
    assert "Success %" in metrics.splitlines()[0] and "| none | tube | 1 |" in metrics
    tube = next(line for line in diagnostics.splitlines() if "| tube |" in line)
    assert tube.endswith("|") and "| - | - |" in tube  # tube: ESS and deviation, no clusters
    assert "Tube deviation p95" in (out / "report.md").read_text()


def test_every_subcommand_lists_its_choices_and_defaults():
    from dcmppi import tasks
    from dcmppi.bench.experiments import experiment_names
    from dcmppi.control.agents import agent_names

    parser = cli.build_parser()
    subparsers = next(a for a in parser._actions if a.dest == "command").choices
    wanted = {
        "run": [
            *tasks.TASKS,
            "mppi",
            "package.module:ClassName",
            *agent_names(),
            *tasks.NOISE_PROFILES,
        ],
        "compare": [*tasks.TASKS, "dc", *agent_names(), *tasks.NOISE_PROFILES],
        "figure": [*tasks.TASKS, "tube", *agent_names()],
        "bench": [*experiment_names(), "clustered", *agent_names(), *tasks.NOISE_PROFILES, ".toml"],
        "report": ["results/static.db"],
    }
    for name, words in wanted.items():
        text = " ".join(subparsers[name].format_help().split())
        assert "(default:" in text, name
        for word in words:
            assert word in text, (name, word)


def test_the_cli_and_the_bench_workers_tune_malloc_themselves(monkeypatch):
    """glibc's malloc settings belong to the process: the entry points set them (every
    `dcmppi` command, each pool and Ray worker), not the Controller in a user's program."""
    from dcmppi.bench.runs import execution

    calls = []
    monkeypatch.setattr(cli, "tune_malloc", lambda: calls.append("cli"))
    monkeypatch.setattr(execution, "tune_malloc", lambda: calls.append("worker"))
    monkeypatch.setattr(signal, "signal", lambda *args: None)  # keep pytest's Ctrl-C
    monkeypatch.setattr(execution, "_exit_with_parent", lambda parent: None)
    assert cli.main(["tasks"]) == 0
    inbox, to_worker = os.pipe()
    from_worker, outbox = os.pipe()
    with Connection(to_worker, readable=False) as specs:
        specs.send(EpisodeSpec("no-such-task", "mppi"))
        specs.send(None)
    execution._serve(inbox, outbox, os.getpid())  # a local worker's loop
    with Connection(from_worker, writable=False) as results:
        assert "no-such-task" in results.recv()["error"]
    result = execution._run_in_worker(EpisodeSpec("no-such-task", "mppi"))  # Ray's function
    assert "no-such-task" in result["error"]
    assert calls == ["cli", "worker", "worker"]
