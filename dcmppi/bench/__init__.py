"""The benchmark: it runs episodes and computes every number the results and plots show.

    import dcmppi.bench
    done = dcmppi.bench.run("static", episodes=20, workers=2, db="results/static.db")
    episodes = dcmppi.bench.load(done)  # a pandas DataFrame, one row per episode

`run`, `load` and `BenchRun` (`api`, what `dcmppi bench` wraps) load on first use, so
`import dcmppi.bench` stays light. In layers, each importing only those before it
(tests/test_architecture.py):

    episodes/        one episode: runner, plugins (users' controllers), metrics, futures,
                     reachability, snapshot (one step of every controller), seeds
    crowds/          the learned predictor's crowds: recorded simulations, model training and
                     recipes, forecasts of recorded people (`dcmppi record`, `dcmppi predictor`)
    experiments/     the TOML definitions of experiments and their checks
    results/         the SQLite database, provenance, statistics
    runs/            many episodes into a database (processes or Ray), replay, the gallery
    reports/         tables, CSV, plots, `dcmppi outcomes`
    timing/          `dcmppi timing`: speed, profiles, fingerprints, the pytorch_mppi peer
    api              `run` and `load`: the benchmark from Python

May import dcmppi.control, dcmppi.tasks and dcmppi.render. Nothing in dcmppi.control,
dcmppi.tasks or dcmppi.render imports it.
"""

import importlib
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from dcmppi.bench.api import BenchRun, load, run

__all__ = ["BenchRun", "load", "run"]


def __getattr__(name):
    if name in __all__:
        value = getattr(importlib.import_module(".api", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), *__all__})
