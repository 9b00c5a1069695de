"""Run many episodes into a results database: in-process, a local process pool, or Ray.

Episodes are independent and fully seeded, so the executor and the worker count change
only the order in which rows arrive, never their contents. Only the calling process
writes the database, one committed row per finished episode.

The pool's and Ray's worker processes tune glibc's malloc for the controllers' per-step
temporaries (`dcmppi.control._malloc.tune_malloc`) before their first episode; an in-process
run (one local worker) leaves the calling process's malloc as it is.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Iterable

from dcmppi.bench.results import ResultsDB
from dcmppi.bench.runner import EpisodeSpec, run_episode
from dcmppi.control._malloc import tune_malloc

EXECUTORS = ("local", "ray")
_SINGLE_THREAD = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def run_safely(spec: EpisodeSpec) -> dict:
    """`run_episode`, with any exception turned into {"error": "Type: message"}."""
    try:
        return run_episode(spec)
    except Exception as e:  # noqa: BLE001 - recorded, and the run goes on
        return {"error": f"{type(e).__name__}: {e}"}


class Progress:
    """One status line on stderr: done / total, failures, errors, rate and ETA."""

    def __init__(self, total: int, label: str, enabled: bool = True):
        self.total, self.label, self.enabled = total, label, enabled
        self.done = self.failures = self.errors = 0
        self.start = time.monotonic()
        self._last = 0.0

    def update(self, result: dict) -> None:
        self.done += 1
        self.errors += "error" in result
        self.failures += bool(result.get("failure"))
        now = time.monotonic()
        if self.enabled and (now - self._last > 0.5 or self.done == self.total):
            self._last = now
            rate = self.done / max(now - self.start, 1e-9)
            eta = (self.total - self.done) / rate if rate > 0 else float("inf")
            sys.stderr.write(
                f"\r[{self.label}] {self.done}/{self.total} episodes, "
                f"{self.failures} failed, {self.errors} errors, {rate:.2f} ep/s, "
                f"ETA {_hms(eta)}   "
            )
            if self.done == self.total:
                sys.stderr.write("\n")
            sys.stderr.flush()


def run_experiment(
    exp,
    db: ResultsDB,
    workers: int = 1,
    executor: str = "local",
    ray_address: str | None = None,
    progress: bool = True,
) -> Progress:
    """Run the episodes of `exp` (a `dcmppi.bench.experiments.Experiment`) that `db` does not
    hold yet. The database records the experiment's definition (for reports) and, while the
    run lasts, that it is being written."""
    done = db.done()
    todo = [(key, spec) for key, spec in exp.specs() if key not in done]
    db.begin_run(exp.to_dict())
    try:
        return run_all(todo, db, workers, executor, ray_address, exp.name, progress)
    finally:
        db.end_run()


def run_all(
    todo: list[tuple[tuple, EpisodeSpec]],
    db: ResultsDB,
    workers: int = 1,
    executor: str = "local",
    ray_address: str | None = None,
    label: str = "bench",
    progress: bool = True,
) -> Progress:
    """Run `todo` = [(key, spec)] and record each result in `db` as it finishes.

    On KeyboardInterrupt, the episodes already finished are committed, pending ones are
    cancelled and the interrupt is re-raised.
    """
    if executor not in EXECUTORS:
        raise ValueError(f"unknown executor {executor!r}; valid: {', '.join(EXECUTORS)}")
    if workers < 1:
        raise ValueError(f"--workers must be >= 1, got {workers}")
    bar = Progress(len(todo), label, enabled=progress)
    if executor == "ray":
        results = _ray(todo, workers, ray_address)
    elif workers == 1:
        results = ((key, spec, run_safely(spec)) for key, spec in todo)
    else:
        results = _pool(todo, workers)
    for key, spec, result in results:
        db.record(key, spec, result)
        bar.update(result)
    return bar


def _pool(todo, workers) -> Iterable:
    import concurrent.futures as cf
    import multiprocessing

    os.environ.update(_SINGLE_THREAD)  # inherited by the workers: no BLAS oversubscription
    ctx = multiprocessing.get_context("spawn")  # no inherited MuJoCo/GL state
    pool = cf.ProcessPoolExecutor(max_workers=workers, mp_context=ctx, initializer=_init_worker)
    try:
        futures = {pool.submit(run_safely, spec): (key, spec) for key, spec in todo}
        for future in cf.as_completed(futures):
            key, spec = futures[future]
            yield key, spec, future.result()
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _init_worker() -> None:
    """A pool worker's setup: malloc tuned (see the module docstring), and Ctrl-C left to the
    parent, which commits what finished and stops the workers."""
    import signal

    tune_malloc()
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _run_in_worker(spec: EpisodeSpec) -> dict:
    """`run_safely` in a Ray worker, its malloc tuned first (once per process)."""
    tune_malloc()
    return run_safely(spec)


def _ray(todo, workers, address) -> Iterable:
    try:
        import ray
    except ImportError as e:
        raise RuntimeError(
            "the ray executor needs Ray: pip install 'dcmppi[ray]' (or use --executor local)"
        ) from e
    from dcmppi.bench.plugins import import_roots

    started = not ray.is_initialized()
    if started:
        # Ray's workers do not share this process's sys.path: hand them the directories of
        # package.module:ClassName controllers and predictors (on a cluster, the nodes must
        # have them too)
        names = {spec.controller for _, spec in todo}
        for _, spec in todo:
            prediction = {**spec.shared_params, **spec.controller_params}.get("prediction")
            names |= {prediction} if isinstance(prediction, str) else set()
        roots = import_roots(names)
        paths = roots + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
        env = {**_SINGLE_THREAD, **({"PYTHONPATH": os.pathsep.join(paths)} if roots else {})}
        kwargs = {"address": address} if address else {"num_cpus": workers}
        ray.init(
            **kwargs,
            include_dashboard=False,
            log_to_driver=False,
            runtime_env={"env_vars": env},
        )
    remote = ray.remote(max_retries=3, num_cpus=1)(_run_in_worker)
    pending = {}
    try:
        pending = {remote.remote(spec): (key, spec) for key, spec in todo}
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                key, spec = pending.pop(ref)
                yield key, spec, ray.get(ref)
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
        if started:
            ray.shutdown()


def _hms(seconds: float) -> str:
    if seconds == float("inf"):
        return "?"
    seconds = int(seconds)
    return f"{seconds // 3600}h{seconds // 60 % 60:02d}m{seconds % 60:02d}s"
