"""The command line around episodes: a controller's exception, and bench / report / replay over
a user's controller module (`mine.py`, written to the test's folder, the current directory)."""

import sys

import pytest

from dcmppi import cli
from dcmppi.bench.results.database import ResultsDB

MINE = """
import sys

import numpy as np


class Steady:
    def __init__(self, seed=None):
        pass

    def reset(self):
        pass

    def act(self, state, goal, static, moving, obstacle_model):
        return np.array([0.1])


class Raiser(Steady):
    def act(self, *args):
        return 1 / 0


class Exiter(Steady):
    def act(self, *args):
        sys.exit(3)
"""


@pytest.fixture
def mine(tmp_path, monkeypatch):
    """The test's folder, holding `mine.py`, as the current directory and on sys.path."""
    (tmp_path / "mine.py").write_text(MINE)
    monkeypatch.chdir(tmp_path)
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "mine", raising=False)  # another test's folder's
    return tmp_path


@pytest.mark.parametrize("name, error", [("Raiser", "ZeroDivisionError: division by zero"),
                                         ("Exiter", "SystemExit: 3")])  # fmt: skip
def test_a_controllers_exception_is_a_runtime_error_with_its_type(mine, capsys, name, error):
    """It used to be shown as bad input (exit 2, no type); SystemExit ended dcmppi itself."""
    argv = ["run", "--task", "blocked", "--controller", f"mine:{name}"]
    assert cli.main([*argv, "--task-param", "time_limit=1"]) == 1
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1] == f"dcmppi run: error: the episode raised {error}"
    assert "Traceback" in err and "mine.py" in err


def _bench(*options):
    return cli.main(["bench", "--experiment", "small.toml", "--no-progress", *options])


@pytest.mark.slow
def test_shards_report_replay_and_a_mixed_resume(mine, capsys):
    (mine / "small.toml").write_text(
        'task = "blocked"\nepisodes = 3\ntask_params = { time_limit = 1.0 }\n'
        '[[rows]]\ncontroller = "mine:Steady"\nlabel = "steady"\n'
    )
    assert _bench("--shard", "0/2", "--db", "a.db") == 0
    assert _bench("--shard", "1/2", "--db", "b.db") == 0
    assert [r["env_index"] for r in ResultsDB("a.db").rows()] == [0, 2]
    capsys.readouterr()

    report = ["report", "--db", "a.db", "--db", "b.db", "--out", "out", "--no-plots"]
    assert cli.main([*report, "--gallery", "1"]) == 0
    assert "| none | steady | 3 |" in capsys.readouterr().out  # the shards merged
    gifs = list((mine / "out").rglob("*.gif"))
    assert gifs and all(
        gif.relative_to(mine / "out").as_posix() in (mine / "out" / "report.md").read_text()
        for gif in gifs
    )
    page = (mine / "out" / "report.html").read_text()  # each GIF beside its episode viewer
    assert all(f'<a href="{gif.relative_to(mine / "out").with_suffix(".html").as_posix()}">' in page
               and gif.with_suffix(".html").is_file() for gif in gifs)  # fmt: skip

    replay = ["replay", "--db", "a.db", "--db", "b.db", "--label", "steady", "--env", "1"]
    assert cli.main(replay) == 0
    assert "time_limit" in capsys.readouterr().out
    assert cli.main(["replay", "--db", "b.db", "--label", "steady", "--env", "2"]) == 2
    assert "steady" in capsys.readouterr().err

    with open("mine.py", "a") as f:  # the controller's module changes: its sha256 differs
        f.write("# edited\n")
    assert _bench("--shard", "0/2", "--db", "a.db", "--episodes", "5") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert "--allow-mixed" in err[-1] and err[-1].startswith("dcmppi bench: error:")
    assert _bench("--shard", "0/2", "--db", "a.db", "--episodes", "5", "--allow-mixed") == 0
    assert [r["env_index"] for r in ResultsDB("a.db").rows()] == [0, 2, 4]

    assert _bench("--tuning", "--episodes", "2") == 0  # other environments, their own database
    tuned = {r["env_index"]: r["seed"] for r in ResultsDB("results/small-tuning.db").rows()}
    tested = {r["env_index"]: r["seed"] for r in ResultsDB("a.db").rows()}
    assert set(tuned) == {0, 1} and tuned[0] != tested[0]
    replay = ["replay", "--db", "results/small-tuning.db", "--label", "steady", "--env", "1"]
    assert cli.main(replay) == 0


def test_the_tuning_help_names_the_seed_offset(capsys):
    from dcmppi.bench.experiments import TUNING_SEED

    for command in ("bench", "reach"):
        with pytest.raises(SystemExit):
            cli.main([command, "--help"])
        assert f"base seed + {TUNING_SEED} " in " ".join(capsys.readouterr().out.split())


@pytest.mark.slow
def test_reach_counts_solvable_environments_and_splits_a_databases_collisions(tmp_path, capsys):
    from dcmppi.bench.experiments import load_experiment

    db = ResultsDB(tmp_path / "sq.db", load_experiment("square-orca").config())
    spec = type("Spec", (), {"controller": "mppi", "task": "square", "seed": 0})()
    spec.task_params = spec.controller_params = spec.shared_params = {}
    db.record(("none", "mine", 0), spec, {"outcome": "collision", "collision": 1})
    db.record(("none", "mine", 1), spec, {"outcome": "goal", "collision": 0})
    db.close()
    argv = ["reach", "--experiment", "square-orca", "--episodes", "2", "--no-progress"]
    assert cli.main([*argv, "--db", str(tmp_path / "sq.db")]) == 0
    out = capsys.readouterr().out
    assert "square-orca: 2 environments: 2 solvable by the ideal robot" in out
    assert "mine: 1 of 2 episodes collided, 0 of them where every controller collides" in out
    other = ["reach", "--experiment", "corridor", "--episodes", "1", "--no-progress"]
    assert cli.main([*other, "--db", str(tmp_path / "sq.db")]) == 2  # another experiment's rows
    assert "holds another experiment's environments (task, base_seed" in capsys.readouterr().err


def test_reach_refuses_pedestrians_that_react(capsys):
    argv = ["reach", "--experiment", "corridor-visible", "--episodes", "1", "--no-progress"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "reachability needs obstacles whose paths do not depend" in err[0]


@pytest.mark.parametrize(
    ("param", "message"),
    [
        ("scenario=ring", "scenario must be one of circle_crossing, square_crossing; got 'ring'"),
        ("n_humans=-1", "n_humans must be >= 0"),
        ("circle_radius=0.3", "closer than the start spacing 0.8 m (2 robot_radius + 0.2): raise "
                              "circle_radius to >= 0.4"),
        ("obstacles=[[0, -4, 0.5]]", "touches the robot at its start (0, -4): move or shrink it"),
        ("circle_radius=0.6", "only 2 of 5 humans fit in circle_crossing"),
    ],
)  # fmt: skip
def test_crowdnavs_bad_input_ends_in_one_line_naming_the_fix(param, message, capsys):
    argv = ["run", "--task", "crowdnav", "--controller", "orca", "--task-param", param]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and message in err[0], err


def test_each_command_is_a_module_with_its_parser_and_handler():
    subparsers = next(a for a in cli.build_parser()._actions if a.dest == "command").choices
    names = [module.__name__.rsplit(".", 1)[1] for module in cli.COMMANDS]
    assert list(subparsers) == names  # the order `dcmppi --help` lists them in
    for name, module in zip(names, cli.COMMANDS, strict=True):
        assert subparsers[name].get_default("func") is module.run, name
