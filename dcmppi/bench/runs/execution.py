"""Run many episodes into a results database: local worker processes or Ray.

Episodes are independent and fully seeded, so the executor and the worker count change
only the order in which rows arrive, never their contents. Only the calling process
writes the database, one committed row per finished episode.

Every episode runs in a worker process (with one worker too), so nothing an episode does ends
the bench: an exception (SystemExit included) is an error row with its traceback; a worker that
dies (a segfault, the OOM killer, a controller's `os.kill`) is the error row "worker died
(signal N)" of the episode it held, and a fresh worker takes its place; an episode still
running after `episode_timeout` seconds is killed and recorded as a timeout. Local workers run
in a session of their own (a Ctrl-C reaches the parent only, which kills them at once) and exit
with their parent, even a SIGKILLed one (PR_SET_PDEATHSIG on Linux, a parent-pid watchdog
thread).

Workers tune glibc's malloc for the controllers' per-step temporaries
(`dcmppi.control.kernels._malloc.tune_malloc`) before their first episode.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import signal
import subprocess
import sys
import threading
import time
import traceback
from collections.abc import Iterable, Iterator
from multiprocessing.connection import Connection, wait

from dcmppi.bench.episodes.runner import EpisodeSpec, run_episode
from dcmppi.bench.results.database import ResultsDB
from dcmppi.control.kernels._malloc import tune_malloc

EXECUTORS = ("local", "ray")
_SINGLE_THREAD = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
_PR_SET_PDEATHSIG = 1


def run_safely(spec: EpisodeSpec) -> dict:
    """`run_episode`, with anything it raises but KeyboardInterrupt (SystemExit too) turned into
    {"error": "Type: message", "traceback": text}."""
    try:
        return run_episode(spec)
    except KeyboardInterrupt:
        raise
    except BaseException as e:  # noqa: BLE001 - recorded, and the run goes on
        return {"error": error_message(e), "traceback": traceback.format_exc()}


def error_message(e: BaseException) -> str:
    """An error row's message: "Type: message", or the type alone when the message is empty."""
    return f"{type(e).__name__}: {e}" if str(e) else type(e).__name__


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
    shard: tuple[int, int] = (0, 1),
    episode_timeout: float | None = None,
) -> Progress:
    """Run the episodes of `exp` (a `dcmppi.bench.experiments.Experiment`) in `shard` (i, n):
    environments with index % n == i, that `db` does not hold yet. The database records the
    experiment's definition (for reports) and, while the run lasts, that it is being written.
    The episodes are made one by one as workers take them (`Experiment.specs` is lazy)."""
    done = db.done()
    held = sum(exp.wants(key, shard) for key in done)
    todo = ((key, spec) for key, spec in exp.specs(shard) if key not in done)
    first_environment = itertools.islice(exp.specs(shard), len(exp.noises) * len(exp.labels))
    db.begin_run(exp.to_dict())
    try:
        return run_all(
            todo,
            db,
            workers,
            executor,
            ray_address,
            exp.name,
            progress,
            total=exp.count(shard) - held,
            episode_timeout=episode_timeout,
            plugins=plugin_names(spec for _, spec in first_environment),
        )
    finally:
        db.end_run()


def run_all(
    todo: Iterable[tuple[tuple, EpisodeSpec]],
    db: ResultsDB,
    workers: int = 1,
    executor: str = "local",
    ray_address: str | None = None,
    label: str = "bench",
    progress: bool = True,
    total: int | None = None,
    episode_timeout: float | None = None,
    plugins: set[str] | None = None,
) -> Progress:
    """Run `todo` = [(key, spec)] and record each result in `db` as it finishes.

    `total` is the number of episodes in `todo` (default: counted), for the progress line;
    `episode_timeout` the seconds after which a running episode is killed and recorded as a
    timeout; `plugins` the controller and predictor names of `todo` (`plugin_names`; Ray's
    workers get their directories), default: read from `todo`. Bad arguments raise ValueError
    (`check_run`).
    On KeyboardInterrupt the workers are killed at once (the finished episodes are already
    committed) and the interrupt is re-raised.
    """
    check_run(workers, executor, ray_address, episode_timeout)
    if total is None:
        todo = list(todo)  # an iterator has no len
        total = len(todo)
    bar = Progress(total, label, enabled=progress)
    if executor == "ray":
        if plugins is None:
            todo = list(todo)
            plugins = plugin_names(spec for _, spec in todo)
        results = _ray(todo, workers, ray_address, episode_timeout, plugins)
    else:
        results = _local(todo, workers, episode_timeout)
    try:
        for key, spec, result in results:
            db.record(key, spec, result)
            bar.update(result)
    finally:
        results.close()  # stops the workers now, also on KeyboardInterrupt
    return bar


def check_run(workers: int, executor: str, ray_address: str | None, episode_timeout) -> None:
    """A ValueError, one line naming the argument, unless `run_all` can run with these."""
    if executor not in EXECUTORS:
        raise ValueError(f"unknown executor {executor!r}; valid: {', '.join(EXECUTORS)}")
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    if ray_address and executor != "ray":
        raise ValueError(f"ray_address is for the ray executor, not {executor!r}")
    if episode_timeout is not None and not episode_timeout > 0:
        raise ValueError(f"episode_timeout must be > 0 seconds, got {episode_timeout}")


def plugin_names(specs: Iterable[EpisodeSpec]) -> set[str]:
    """The controller names and string `prediction` parameters of `specs`."""
    names = set()
    for spec in specs:
        prediction = {**spec.shared_params, **spec.controller_params}.get("prediction")
        names |= {spec.controller} | ({prediction} if isinstance(prediction, str) else set())
    return names


def timeout_error(timeout: float) -> dict:
    return {"error": f"timeout: no result after {timeout:g} s (--episode-timeout)"}


def death_error(exitcode: int | None) -> dict:
    """The error row of an episode whose worker process ended with `exitcode` (negative: the
    signal that killed it)."""
    cause = (
        f"signal {-exitcode}" if exitcode is not None and exitcode < 0 else f"exit code {exitcode}"
    )
    return {"error": f"worker died ({cause})"}


class _Worker:
    """A worker process, its pipes and the episode it holds: job = (key, spec, started).

    A fresh interpreter (no inherited MuJoCo/GL state, and unlike multiprocessing's spawn no
    re-import of the caller's __main__) with this process's sys.path, in a session of its own:
    a Ctrl-C at the terminal reaches only the parent, which stops it."""

    def __init__(self):
        inbox, to_worker = os.pipe()
        from_worker, outbox = os.pipe()
        code = (
            f"import sys; sys.path[:] = {sys.path!r}; "
            "from dcmppi.bench.runs.execution import _serve; "
            f"_serve({inbox}, {outbox}, {os.getpid()})"
        )
        try:
            self.proc = subprocess.Popen(
                [sys.executable, "-c", code],
                pass_fds=(inbox, outbox),
                start_new_session=True,
                env={**os.environ, **_SINGLE_THREAD},  # no BLAS oversubscription
            )
        finally:
            os.close(inbox)
            os.close(outbox)
        self.inbox = Connection(to_worker, readable=False)
        self.outbox = Connection(from_worker, writable=False)
        self.job = None

    def give(self, job) -> None:
        """Hand the worker an episode; its clock (--episode-timeout) starts now, a fresh
        worker's start-up included. A worker that died meanwhile closes its outbox: the loop
        records the episode as its death."""
        self.job = (*job, time.monotonic())
        try:
            self.inbox.send(job[1])
        except OSError:
            pass

    def stop(self) -> None:
        """Ends the process: at once if it holds an episode, else after it read the stop."""
        if self.job is None:
            try:
                self.inbox.send(None)
                self.proc.wait(5.0)
            except (OSError, subprocess.TimeoutExpired):
                pass
        self.proc.kill()
        self.proc.wait()
        self.inbox.close()
        self.outbox.close()


def _local(todo, workers: int, timeout: float | None) -> Iterator:
    """(key, spec, result) of each episode of `todo` as it finishes, on `workers` processes."""
    jobs = iter(todo)
    pool: list[_Worker] = []
    try:
        for job in jobs:
            pool.append(_Worker())
            pool[-1].give(job)
            if len(pool) == workers:
                break
        while busy := [w for w in pool if w.job is not None]:
            wait_s = None
            if timeout is not None:
                wait_s = max(0.0, min(w.job[2] for w in busy) + timeout - time.monotonic())
            ready = wait([w.outbox for w in busy], wait_s)
            for i, w in enumerate(pool):
                if w.job is None:
                    continue
                result, stuck = None, False
                if w.outbox in ready:
                    try:
                        result = w.outbox.recv()
                    except (EOFError, OSError):  # died while holding the episode
                        result = death_error(w.proc.wait())
                elif timeout is not None and time.monotonic() - w.job[2] >= timeout:
                    result, stuck = timeout_error(timeout), True
                if result is None:
                    continue
                key, spec, _ = w.job
                w.job = None
                if stuck:
                    w.proc.kill()
                    w.proc.wait()
                yield key, spec, result
                job = next(jobs, None)
                if job is not None:
                    if w.proc.poll() is not None:  # a fresh process takes a dead one's place
                        w.stop()
                        w = pool[i] = _Worker()
                    w.give(job)
    finally:
        with _interrupts_held():  # a second Ctrl-C waits until every worker is stopped
            for w in pool:
                w.stop()


@contextlib.contextmanager
def _interrupts_held():
    """SIGINT and SIGTERM held back in this block (delivered, and so raised, when it ends); on
    the main thread of a POSIX system, else nothing."""
    held = {signal.SIGINT, signal.SIGTERM}
    main = threading.current_thread() is threading.main_thread()
    if not (main and hasattr(signal, "pthread_sigmask")):
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


def _serve(inbox: int, outbox: int, parent: int) -> None:
    """A worker's loop: run each spec read from file descriptor `inbox`, write its result to
    `outbox`; None (or the parent closing the pipe) stops it."""
    _exit_with_parent(parent)
    tune_malloc()
    specs, results = Connection(inbox, writable=False), Connection(outbox, readable=False)
    while True:
        try:
            spec = specs.recv()
        except EOFError:
            return
        if spec is None:
            return
        result = run_safely(spec)
        try:
            results.send(result)
        except OSError:  # the parent stopped reading (interrupted): nobody to report to
            return


def _exit_with_parent(parent: int) -> None:
    """This process ends when process `parent` does: SIGKILL from the kernel on Linux, and a
    thread that watches the parent's pid (any platform, and a parent gone before the prctl)."""
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            ctypes.CDLL(None).prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        except (OSError, AttributeError):
            pass

    def watch():
        while os.getppid() == parent:
            time.sleep(1.0)
        os._exit(1)

    if os.getppid() != parent:
        os._exit(1)
    threading.Thread(target=watch, daemon=True).start()


def _run_in_worker(spec: EpisodeSpec) -> dict:
    """`run_safely` in a Ray worker, its malloc tuned first (once per process)."""
    tune_malloc()
    return run_safely(spec)


def _ray(todo, workers: int, address: str | None, timeout: float | None, plugins) -> Iterator:
    """(key, spec, result) of each episode of `todo` as it finishes on Ray: `workers` episodes
    in flight (on a cluster at least its CPU count). A task's time (`timeout`) counts from its
    submission; a task that fails or whose worker dies is an error row (no retries)."""
    try:
        import ray
    except ImportError as e:
        raise RuntimeError(
            "the ray executor needs Ray: pip install 'dcmppi[ray]' (or use --executor local)"
        ) from e
    jobs = iter(todo)
    first = next(jobs, None)
    if first is None:
        return
    started = _ray_start(ray, workers, address, plugins)
    window = max(workers, int(ray.cluster_resources().get("CPU", 0))) if address else workers
    remote = ray.remote(max_retries=0, num_cpus=1)(_run_in_worker)
    pending = {}  # ref -> (key, spec, submission time)

    def submit(job):
        pending[remote.remote(job[1])] = (*job, time.monotonic())

    try:
        submit(first)
        for job in jobs:
            submit(job)
            if len(pending) == window:
                break
        while pending:
            yield _ray_finished(ray, pending, timeout)
            job = next(jobs, None)
            if job is not None:
                submit(job)
    finally:
        for ref in pending:
            ray.cancel(ref, force=True)
        if started:
            ray.shutdown()


def _ray_start(ray, workers: int, address: str | None, plugins) -> bool:
    """Start Ray here (num_cpus=workers) or join the cluster at `address`, unless it runs
    already; whether this call started it."""
    if ray.is_initialized():
        return False
    # Ray's workers do not share this process's sys.path: hand them the directories of
    # package.module:ClassName controllers and predictors (on a cluster, the nodes must
    # have them too)
    from dcmppi.bench.episodes.plugins import import_roots

    roots = import_roots(plugins)
    paths = roots + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]
    env = {**_SINGLE_THREAD, **({"PYTHONPATH": os.pathsep.join(paths)} if roots else {})}
    kwargs = {"address": address} if address else {"num_cpus": workers}
    ray.init(**kwargs, include_dashboard=False, log_to_driver=False, runtime_env={"env_vars": env})
    return True


def _ray_finished(ray, pending: dict, timeout: float | None) -> tuple:
    """(key, spec, result) of the next task of `pending` to finish, taken out of it; the
    oldest one, cancelled, as a timeout error when none finishes within `timeout` of its
    submission."""
    wait_s = None
    if timeout is not None:
        oldest = min(t for _, _, t in pending.values())
        wait_s = max(0.0, oldest + timeout - time.monotonic())
    ready, _ = ray.wait(list(pending), num_returns=1, timeout=wait_s)
    if not ready:
        ref = min(pending, key=lambda r: pending[r][2])
        key, spec, _ = pending.pop(ref)
        ray.cancel(ref, force=True)
        return key, spec, timeout_error(timeout)
    ref = ready[0]
    key, spec, _ = pending.pop(ref)
    try:
        result = ray.get(ref)
    except ray.exceptions.WorkerCrashedError:
        result = {"error": "worker died (Ray WorkerCrashedError)"}
    except ray.exceptions.RayError as e:
        result = {"error": f"{type(e).__name__}: {e}".splitlines()[0]}
        result["traceback"] = str(e)
    return key, spec, result


def _hms(seconds: float) -> str:
    if seconds == float("inf"):
        return "?"
    seconds = int(seconds)
    return f"{seconds // 3600}h{seconds // 60 % 60:02d}m{seconds % 60:02d}s"
