"""The benchmark from Python: `run` an experiment into a results database, `load` its episodes.

    import dcmppi.bench
    done = dcmppi.bench.run("static", episodes=20, workers=2, db="results/static.db")
    episodes = dcmppi.bench.load(done)  # a pandas DataFrame, one row per episode

`dcmppi bench` is `run` behind its options. A rerun with the same database resumes: only the
episodes the database lacks (or holds as errors) run.
"""

from __future__ import annotations

import dataclasses
import itertools
import os
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path

from dcmppi.bench.episodes.runner import check_specs, check_world
from dcmppi.bench.experiments import Experiment, load_experiment
from dcmppi.bench.results.database import TABLE_COLUMNS, ResultsDB
from dcmppi.bench.results.provenance import collect
from dcmppi.bench.runs.execution import check_run, run_experiment

__all__ = ["BenchRun", "load", "run"]


@dataclasses.dataclass(frozen=True)
class BenchRun:
    """What `run` did.

    experiment: the experiment's name; db: the database's path.
    total: the episodes selected (in the shard); finished: those of them the database holds
      without an error now, earlier runs' included.
    ran, failed, errored: the episodes this call ran, those of them that failed (any outcome but
      the goal) and those that ended in an error; seconds: this call's wall-clock time.
    errors: the selection's error rows in the database (dicts with "noise", "label",
      "env_index", "error", "traceback", ...), earlier runs' included.
    """

    experiment: str
    db: Path
    total: int
    finished: int
    ran: int
    failed: int
    errored: int
    seconds: float
    errors: list[dict]


def run(
    experiment: str | os.PathLike | Experiment = "static",
    *,
    episodes: int | None = None,
    workers: int = 1,
    db: str | os.PathLike | None = None,
    rows: Sequence[str] | None = None,
    noises: Sequence[str] | None = None,
    task_params: Mapping | None = None,
    controller_params: Mapping | None = None,
    executor: str = "local",
    ray_address: str | None = None,
    shard: tuple[int, int] = (0, 1),
    episode_timeout: float | None = None,
    allow_mixed: bool = False,
    tuning: bool = False,
    progress: bool = True,
    verbose: bool = True,
) -> BenchRun:
    """Run an experiment's episodes that the database `db` lacks; return a `BenchRun`.

    experiment: a shipped experiment's name (`dcmppi.bench.experiments.experiment_names()`),
      the path of a TOML file, or an `Experiment`.
    episodes: environments (default: the experiment's); every row and noise runs in each.
    workers: episodes at a time, each in a worker process; executor: "local" (processes) or
      "ray" (`ray_address`: an existing Ray cluster's).
    db: the SQLite results file (default: results/NAME.db; its folder is made).
    rows: row labels of the experiment, or controller names for rows of their own (default:
      every row); noises: noise profiles (default: the experiment's).
    task_params, controller_params: task parameters and parameters for every controller that
      takes them, added to the experiment's (part of the configuration the database is bound to).
    shard: (i, n): only the environments whose index % n == i.
    episode_timeout: seconds after which a running episode is recorded as a timeout error.
    allow_mixed: extend a database recorded under another dcmppi version, resolved parameter
      or input file.
    tuning: run the experiment's tuning environments (`Experiment.for_tuning`: none a test
      environment) instead of its own; the default database is results/NAME-tuning.db.
    progress: the progress line on stderr; verbose: the plan line (episodes to run) on stderr,
      and where the finished episodes are when interrupted.

    Bad input raises ValueError before anything is recorded. KeyboardInterrupt stops the
    workers and is re-raised; the finished episodes stay in the database (rerun to resume).
    """
    exp = _experiment(experiment, episodes, rows, noises, task_params, controller_params, tuning)
    i, n = shard
    if not 0 <= i < n:
        raise ValueError(f"shard (i, n) needs 0 <= i < n, got {shard}")
    check_run(workers, executor, ray_address, episode_timeout)  # before the database is made
    database = _open(exp, shard, db, allow_mixed, tuple(controller_params or ()))
    how = dict(ray_address=ray_address, progress=progress, episode_timeout=episode_timeout)
    return _execute(exp, database, workers, executor, verbose, shard=shard, **how)


def load(db: str | os.PathLike | BenchRun | Sequence[str | os.PathLike]):
    """The episodes of a results database as a pandas DataFrame: one row per episode, the
    columns of the report's episodes.csv (`dcmppi.bench.results.database.TABLE_COLUMNS`:
    noise, label, controller, env_index, seed, status, outcome, the metrics, ...).

    db: a database, the `BenchRun` that `run` returned, or a list of databases of one
    configuration (shards), merged as `dcmppi report` merges them. Needs pandas (`pip install
    "dcmppi[pandas]"`)."""
    try:
        import pandas as pd
    except ImportError:
        raise ImportError('dcmppi.bench.load needs pandas: pip install "dcmppi[pandas]"') from None
    from dcmppi.bench.reports.report import load as load_rows

    rows = load_rows(db.db if isinstance(db, BenchRun) else db).rows
    return pd.DataFrame([{c: r[c] for c in TABLE_COLUMNS} for r in rows], columns=TABLE_COLUMNS)


def _experiment(
    experiment, episodes, rows, noises, task_params, controller_params, tuning
) -> Experiment:
    """The experiment to run: loaded (on its tuning environments with `tuning`), its episodes,
    rows and noises selected, parameters added."""
    if not isinstance(experiment, Experiment):
        experiment = load_experiment(os.fspath(experiment))
    exp = experiment.with_params(dict(task_params or {}), dict(controller_params or {}))
    if tuning:
        exp = exp.for_tuning()
    return exp.select(episodes, _names(rows), _names(noises))


def _open(exp: Experiment, shard, db, allow_mixed: bool, chosen=()) -> ResultsDB:
    """The database to run `exp` into, once its first environment's rows and noises build (a
    bad name, parameter or world raises ValueError before anything is recorded); `chosen`: the
    shared parameters the caller gave."""
    # one environment's episodes hold every row and noise; the others are made as they run
    first = list(itertools.islice(exp.specs(shard), len(exp.noises) * len(exp.labels)))
    try:
        others = [(r.controller, r.params) for r in exp.rows if r.label not in exp.labels]
        check_specs([spec for _, spec in first], others, chosen)
        _check_last(exp, shard, first[0][1])
    except ValueError as e:
        raise ValueError(f"experiment {exp.name}: {e}") from e
    path = Path(db or f"results/{exp.name}.db")
    path.parent.mkdir(parents=True, exist_ok=True)
    return ResultsDB(path, exp.config(), collect(exp, first), allow_mixed)


def _check_last(exp: Experiment, shard, spec) -> None:
    """With env_param, the task of the shard's last environment builds as well (`spec`: the
    first one's episode): an index past the cases a task has (a BARN world, a recorded episode)
    fails before anything is recorded."""
    indices = exp.indices(shard)
    if not exp.env_param or len(indices) < 2:
        return
    last = indices[-1]
    task_params = {**spec.task_params, exp.env_param: exp.env_offset + last}
    try:
        check_world(dataclasses.replace(spec, seed=exp.seed(last), task_params=task_params))
    except ValueError as e:
        raise ValueError(f"environment {last}: {e} (lower --episodes)") from e


def _execute(exp, database, workers, executor, verbose, shard, **how) -> BenchRun:
    """Run the episodes of `exp` in `shard` that `database` lacks (`how`: run_experiment's
    ray_address, progress, episode_timeout); close the database; say what was done."""
    total = exp.count(shard)
    before = sum(exp.wants(key, shard) for key in database.done())
    of = f", shard {shard[0]}/{shard[1]} of them" if shard[1] > 1 else ""
    _say(
        verbose,
        f"{exp.name}: {total} episodes ({exp.episodes} environments{of} x "
        f"{len(exp.noises)} noise x {len(exp.labels)} rows), {before} already in "
        f"{database.path}, {total - before} to run on {workers} {executor} worker(s)",
    )
    start = time.monotonic()
    try:
        bar = run_experiment(exp, database, workers, executor, shard=shard, **how)
    except KeyboardInterrupt:
        _say(
            verbose,
            f"\ninterrupted: finished episodes are saved in {database.path}; rerun to resume",
        )
        raise
    finally:
        rows = database.rows()
        selected = [r for r in rows if exp.wants((r["noise"], r["label"], r["env_index"]), shard)]
        database.close()
    errors = [r for r in selected if r["status"] == "error"]
    return BenchRun(
        exp.name, database.path, total, len(selected) - len(errors), bar.done, bar.failures,
        bar.errors, time.monotonic() - start, errors,
    )  # fmt: skip


def _names(names) -> tuple[str, ...] | None:
    """None, or names as a tuple (a single string is one name)."""
    if names is None:
        return None
    return (names,) if isinstance(names, str) else tuple(names)


def _say(verbose: bool, line: str) -> None:
    if verbose:
        print(line, file=sys.stderr)
