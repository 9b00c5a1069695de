"""Episode execution: crash isolation, timeouts, signals and orphans, shards, lazy episode lists.

The controllers that crash, exit, hang or raise live in a module written to the test's folder
(`crashing.py`), as a user's would: spawned workers inherit sys.path, and `dcmppi bench` run in
that folder imports it from there. Episodes are short (`blocked`, a 2 s time limit).
"""

import os
import signal
import subprocess
import sys
import time
import tracemalloc

import pytest

from dcmppi import cli
from dcmppi.bench.episodes.runner import EpisodeSpec
from dcmppi.bench.experiments import Experiment
from dcmppi.bench.results.database import ResultsDB
from dcmppi.bench.runs.execution import run_all

CRASHING = '''
import os, signal, sys, time
from pathlib import Path

import numpy as np


class Steady:
    """Drives straight on."""

    def __init__(self, seed=None):
        pass

    def reset(self):
        pass

    def act(self, state, goal, static, moving, obstacle_model):
        return np.zeros(1)


class Killer(Steady):
    def act(self, *args):
        os.kill(os.getpid(), signal.SIGKILL)


class Exiter(Steady):
    def act(self, *args):
        sys.exit(3)


class Raiser(Steady):
    def act(self, *args):
        return 1 / 0


class Sleeper(Steady):
    def act(self, *args):
        Path(__file__).with_name("started").touch()
        time.sleep(600)
'''
SHORT = {"time_limit": 2.0}


@pytest.fixture
def crashing(tmp_path, monkeypatch):
    """The folder of the module `crashing`, on sys.path."""
    (tmp_path / "crashing.py").write_text(CRASHING)
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


class Results:
    """A database stand-in: the results `run_all` records, by key."""

    def __init__(self):
        self.results = {}

    def record(self, key, spec, result):
        assert key not in self.results
        self.results[key] = result


def episodes(*classes, envs=(0,)):
    """[(key, spec)]: each `crashing` class in each environment, key = ("none", class, env)."""
    return [
        (("none", c, i), EpisodeSpec("blocked", f"crashing:{c}", "none", i, task_params=SHORT))
        for i in envs
        for c in classes
    ]


@pytest.mark.slow
def test_a_killed_worker_is_an_error_row_and_the_pool_goes_on(crashing):
    """The process pool used to end with BrokenProcessPool and record nothing more."""
    db = Results()
    run_all(episodes("Killer", "Steady", envs=(0, 1, 2)), db, workers=2, progress=False)
    assert len(db.results) == 6
    for (_, label, _), result in db.results.items():
        if label == "Killer":
            assert result == {"error": "worker died (signal 9)"}
        else:
            assert "error" not in result and result["outcome"] == "time_limit"


@pytest.mark.slow
def test_sys_exit_and_exceptions_are_error_rows_with_tracebacks(crashing):
    """One worker: SystemExit used to end the bench (status 3, no message)."""
    db = Results()
    run_all(episodes("Exiter", "Raiser", "Steady"), db, workers=1, progress=False)
    exited, raised, steady = (db.results[("none", c, 0)] for c in ("Exiter", "Raiser", "Steady"))
    assert exited["error"] == "SystemExit: 3" and "sys.exit(3)" in exited["traceback"]
    assert raised["error"] == "ZeroDivisionError: division by zero"
    assert "return 1 / 0" in raised["traceback"]
    assert steady["outcome"] == "time_limit"


@pytest.mark.slow
def test_a_stuck_episode_times_out_and_the_run_goes_on(crashing):
    db = Results()
    start = time.monotonic()
    # The clock includes a fresh worker's start-up: 15 s leaves room for a loaded machine
    # (parallel tests) and still tells the 600 s sleeper from the 2 s episode.
    run_all(episodes("Sleeper", "Steady"), db, workers=1, progress=False, episode_timeout=15.0)
    assert db.results[("none", "Sleeper", 0)] == {
        "error": "timeout: no result after 15 s (--episode-timeout)"
    }
    assert db.results[("none", "Steady", 0)]["outcome"] == "time_limit"
    assert time.monotonic() - start < 60


def experiment(episodes=3, rows=("Steady",), **params):
    rows = [{"label": r, "controller": f"crashing:{r}"} for r in rows]
    data = {"task": "blocked", "episodes": episodes, "task_params": SHORT, "rows": rows}
    return Experiment.from_dict({**data, **params}, "test")


def test_shards_split_the_environments(crashing):
    exp = experiment(episodes=7, rows=("Steady", "Killer"), noises=["none", "control"])
    keys = [key for key, _ in exp.specs()]
    shards = [[key for key, _ in exp.specs((i, 3))] for i in range(3)]
    assert sorted(sum(shards, [])) == sorted(keys) and len(keys) == exp.count() == 28
    assert [exp.count((i, 3)) for i in range(3)] == [len(s) for s in shards] == [12, 8, 8]
    assert {key[2] for key in shards[1]} == {1, 4}
    assert all(exp.wants(key, (1, 3)) == (key in shards[1]) for key in keys)
    assert not exp.wants(("process", "Steady", 1), (1, 3))


def test_the_episode_list_is_made_lazily(crashing):
    """1e5 environments used to build every spec (1.4 GB) before the first episode ran."""
    exp = experiment(episodes=100_000)
    tracemalloc.start()
    try:
        first = next(iter(exp.specs((3, 4))))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert first[0] == ("none", "Steady", 3) and exp.count((3, 4)) == 25_000
    assert peak < 1_000_000


@pytest.mark.parametrize("shard", ["2/2", "1", "a/2", "-1/2", "1/0"])
def test_bad_shards_get_one_line(shard, capsys, tmp_path):
    argv = ["bench", "--episodes", "1", f"--shard={shard}", "--db", str(tmp_path / "x.db")]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "--shard expects I/N with 0 <= I < N" in err and len(err.splitlines()) == 1


@pytest.mark.slow
def test_shards_fill_one_database(crashing, capsys):
    toml = crashing / "small.toml"
    toml.write_text(
        'task = "blocked"\nepisodes = 5\ntask_params = { time_limit = 1.0 }\n'
        '[[rows]]\ncontroller = "crashing:Steady"\n'
    )
    db = crashing / "s.db"
    for shard in ("1/2", "0/2"):
        argv = ["bench", "--experiment", str(toml), "--shard", shard, "--db", str(db)]
        assert cli.main([*argv, "--no-progress"]) == 0
    assert "3 of 3 episodes" in capsys.readouterr().out
    rows = ResultsDB(db).rows()
    assert sorted(r["env_index"] for r in rows) == list(range(5))


def bench(folder, rows, *options, episodes=2):
    """A `dcmppi bench` process in `folder` on rows of `crashing` classes."""
    (folder / "exp.toml").write_text(
        f'task = "blocked"\nepisodes = {episodes}\ntask_params = {{ time_limit = 2.0 }}\n'
        + "".join(f'[[rows]]\ncontroller = "crashing:{r}"\nlabel = "{r}"\n' for r in rows)
    )
    argv = ["bench", "--experiment", "exp.toml", "--db", "b.db", "--no-progress", *options]
    return subprocess.Popen(
        [sys.executable, "-m", "dcmppi.cli", *argv],
        cwd=folder,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


@pytest.mark.slow
def test_bench_records_a_killed_episode_and_names_it(crashing):
    """One worker: the controller's os.kill used to kill the bench itself, every rerun too."""
    proc = bench(crashing, ("Killer", "Steady"))
    out, err = proc.communicate(timeout=240)
    assert proc.returncode == 1, err
    assert "2 of 4 episodes" in out
    assert "Killer none environment 0: worker died (signal 9)" in err
    assert "Killer none environment 1: worker died (signal 9)" in err
    rows = ResultsDB(crashing / "b.db").rows()
    assert [(r["label"], r["status"]) for r in rows] == [("Killer", "error")] * 2 + [
        ("Steady", "ok")
    ] * 2


def _descendants(pid: int) -> set[int]:
    """Live (not zombie) processes under `pid`."""
    children = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if fields[0] != "Z":
                children.setdefault(int(fields[1]), []).append(int(entry))
    out, todo = set(), [pid]
    while todo:
        found = children.get(todo.pop(), [])
        out.update(found)
        todo.extend(found)
    return out


def _alive(pids) -> set[int]:
    alive = set()
    for pid in pids:
        try:
            with open(f"/proc/{pid}/stat") as f:
                if f.read().rsplit(")", 1)[1].split()[0] != "Z":
                    alive.add(pid)
        except OSError:
            pass
    return alive


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
@pytest.mark.parametrize(
    ("signals", "gap"), [("INT INT", 0.3), ("INT INT", 0.005), ("TERM", 0.3), ("KILL", 0.3)]
)
def test_signals_end_the_bench_and_its_workers_at_once(crashing, signals, gap):
    """Ctrl-C twice with two workers used to hang; SIGKILL left the workers and multiprocessing's
    resource tracker running; SIGTERM said nothing about resuming. A second Ctrl-C right after
    the first (gap 5 ms) used to cut the workers' stop short: a worker left running printed a
    BrokenPipeError traceback when it finished its episode."""
    proc = bench(crashing, ("Sleeper", "Steady"), "--workers", "2")
    try:
        deadline = time.monotonic() + 120
        while not (crashing / "started").exists():
            assert time.monotonic() < deadline and proc.poll() is None, proc.communicate()
            time.sleep(0.1)
        workers = _descendants(proc.pid)
        assert len(workers) == 2
        for name in signals.split():
            proc.send_signal(getattr(signal, f"SIG{name}"))
            time.sleep(gap)
        out, err = proc.communicate(timeout=20)
        deadline = time.monotonic() + 10
        while _alive(workers) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _alive(workers)
    finally:
        proc.kill()
        proc.wait()
    if signals == "TERM":
        assert proc.returncode == 143
    if signals == "INT INT":  # killed by the second one if it came while Python was exiting
        assert proc.returncode in (130, -signal.SIGINT)
    if signals != "KILL":
        assert "rerun to resume" in err
        assert "Traceback" not in err


@pytest.mark.slow
def test_ray_records_dead_workers_and_timeouts(crashing):
    pytest.importorskip("ray")
    db = Results()
    todo = episodes("Killer", "Sleeper", "Steady")
    run_all(todo, db, workers=2, executor="ray", progress=False, episode_timeout=20.0)
    assert db.results[("none", "Killer", 0)]["error"].startswith("worker died")
    assert db.results[("none", "Sleeper", 0)]["error"].startswith("timeout: no result after 20 s")
    assert db.results[("none", "Steady", 0)]["outcome"] == "time_limit"
