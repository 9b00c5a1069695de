"""The benchmark from Python: `dcmppi.bench.run` writes what `dcmppi bench` writes, `load` gives
the episodes as a DataFrame. Episodes are short (the `blocked` task, K=32, N=20, 1 s)."""

import importlib.util
import subprocess
import sys

import pytest

import dcmppi.bench
from dcmppi import cli
from dcmppi.bench.results.database import TABLE_COLUMNS, ResultsDB

TINY = """
task = "blocked"
episodes = 2
task_params = { time_limit = 1.0 }
controller_params = { K = 32, N = 20 }
[[rows]]
controller = "mppi"
[[rows]]
controller = "clustered"
"""
# columns that differ between two runs of one episode without its results differing
CLOCK = {"ctrl_ms_mean", "ctrl_ms_p95", "env_ms_mean", "wall_s", "run_id"}


@pytest.fixture
def tiny(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


def _rows(path):
    db = ResultsDB(path)
    try:
        return [{k: v for k, v in r.items() if k not in CLOCK} for r in db.rows()]
    finally:
        db.close()


@pytest.mark.slow
def test_run_writes_the_rows_the_cli_writes_and_resumes(tiny, tmp_path, capsys):
    done = dcmppi.bench.run(str(tiny), db=tmp_path / "api.db", progress=False, verbose=False)
    argv = ["bench", "--experiment", str(tiny), "--db", str(tmp_path / "cli.db"), "--no-progress"]
    assert cli.main(argv) == 0
    assert capsys.readouterr().err.startswith("tiny: 4 episodes (2 environments x 1 noise x 2")
    assert _rows(tmp_path / "api.db") == _rows(tmp_path / "cli.db")
    assert (done.experiment, done.db, done.total, done.finished) == (
        "tiny",
        tmp_path / "api.db",
        4,
        4,
    )
    assert (done.ran, done.errored, done.errors) == (4, 0, [])
    again = dcmppi.bench.run(
        tiny, db=done.db, episodes=3, rows="mppi", progress=False, verbose=False
    )
    assert (again.total, again.finished, again.ran) == (3, 3, 1)  # environment 2 only
    assert [r["env_index"] for r in _rows(done.db) if r["label"] == "mppi"] == [0, 1, 2]
    if importlib.util.find_spec("pandas"):
        assert len(dcmppi.bench.load(again)) == 5  # its database's episodes, not only its own


@pytest.mark.parametrize(
    "options, message",
    [
        ({"episodes": 0}, "episodes must be >= 1, got 0"),
        ({"workers": 0}, "workers must be >= 1, got 0"),
        ({"rows": ("mppi", "fancy")}, "'fancy' is no row of tiny"),
        ({"noises": ("loud",)}, "unknown noise profile(s) loud"),
        ({"controller_params": {"seed": 3}}, "controller_params.seed: set per episode"),
        ({"task_params": {"time_limit": float("nan")}}, "task_params.time_limit: nan is not"),
        ({"controller_params": {"K": -1}}, "experiment tiny: "),
        ({"shard": (2, 2)}, "shard (i, n) needs 0 <= i < n, got (2, 2)"),
        ({"ray_address": "auto"}, "ray_address is for the ray executor, not 'local'"),
        ({"executor": "slurm"}, "unknown executor 'slurm'; valid: local, ray"),
        ({"episode_timeout": 0}, "episode_timeout must be > 0 seconds, got 0"),
        ({"rows": ()}, "rows needs at least one row label or controller"),
    ],
)
def test_bad_input_raises_before_a_database_is_made(tiny, tmp_path, options, message):
    db = tmp_path / "x.db"
    with pytest.raises(ValueError) as error:
        dcmppi.bench.run(tiny, db=db, verbose=False, **options)
    assert message in str(error.value)
    assert not db.exists()


def test_an_environment_index_past_the_tasks_cases_fails_before_a_database_is_made(tmp_path):
    """env_param = n_humans: environment 199 has 199 humans, more than CrowdNav's circle holds;
    environment 0 builds, so only the last environment's check stops the run."""
    path = tmp_path / "many.toml"
    path.write_text('task = "crowdnav"\nepisodes = 200\nenv_param = "n_humans"\n'
                    '[[rows]]\ncontroller = "orca"\n')  # fmt: skip
    db = tmp_path / "x.db"
    with pytest.raises(ValueError, match="environment 199: only 21 of 199 humans fit") as error:
        dcmppi.bench.run(path, db=db, verbose=False)
    assert str(error.value).endswith("(lower --episodes)") and not db.exists()
    dcmppi.bench.run(path, db=db, verbose=False, episodes=3, progress=False)  # 0-2 humans: fit
    assert db.exists()


def _record(path, keys):
    """A database of the tiny experiment holding made-up rows `keys` = [(noise, label, i)]."""
    from dcmppi.bench.experiments import load_experiment

    exp = load_experiment(str(path.parent / "tiny.toml"))
    db = ResultsDB(path, exp.config())
    db.begin_run(exp.to_dict())
    for key in keys:
        spec = exp.spec(*key)
        db.record(key, spec, {"outcome": "goal", "collision": 0, "failure": 0, "steps": 7})
    db.end_run()
    db.close()


def test_load_gives_one_row_per_episode_with_the_csv_columns(tiny, tmp_path):
    pd = pytest.importorskip("pandas", reason="dcmppi.bench.load needs the extra `pandas`")
    keys = [("none", label, i) for i in range(2) for label in ("mppi", "clustered")]
    _record(tmp_path / "a.db", keys[:3])
    _record(tmp_path / "b.db", keys[2:])  # a shard holding one of a.db's episodes too
    frame = dcmppi.bench.load([tmp_path / "a.db", tmp_path / "b.db"])
    assert isinstance(frame, pd.DataFrame) and list(frame.columns) == list(TABLE_COLUMNS)
    found = frame[["noise", "label", "env_index"]].itertuples(index=False, name=None)
    assert sorted(found) == sorted(keys)
    assert (frame["outcome"] == "goal").all() and (frame["steps"] == 7).all()
    assert len(dcmppi.bench.load(tmp_path / "a.db")) == 3


def test_load_without_pandas_names_the_extra(tiny, tmp_path, monkeypatch):
    _record(tmp_path / "a.db", [("none", "mppi", 0)])
    monkeypatch.setitem(sys.modules, "pandas", None)  # `import pandas` raises ImportError
    with pytest.raises(ImportError, match=r'pip install "dcmppi\[pandas\]"'):
        dcmppi.bench.load(tmp_path / "a.db")


def test_importing_the_package_loads_no_runner():
    code = "import sys, dcmppi.bench; print(sorted(m for m in sys.modules if 'dcmppi.' in m))"
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    assert out.stdout.strip() == "['dcmppi.bench']"  # not dcmppi.bench.api or what it runs
    assert callable(dcmppi.bench.run) and dcmppi.bench.run is dcmppi.bench.api.run
    with pytest.raises(AttributeError, match="no attribute 'rnu'"):
        dcmppi.bench.rnu  # noqa: B018
