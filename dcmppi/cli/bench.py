"""`dcmppi bench`: an experiment into a results database (resumable), through
`dcmppi.bench.run`."""

import signal
import sys

from dcmppi.cli.common import SHARED, TUNING, comma_list, command, flag_names, key_values, params


def add_parser(subparsers, names: dict) -> None:
    p = command(subparsers, "bench", "run an experiment into a results database (resumable)", run)
    p.add_argument("--experiment", default="static", help=f"one of {names['experiments']}")
    p.add_argument("--episodes", type=int, help="environments (default: the experiment's)")
    p.add_argument(
        "--controllers",
        help="comma-separated row labels (default: every row of the experiment), or "
        f"controllers for rows of their own: {names['controllers']}",
    )
    p.add_argument(
        "--noise",
        help=f"comma-separated noise profiles (default: the experiment's): {names['noises']}",
    )
    p.add_argument(
        "--workers", type=int, default=1, help="episodes at a time, each in a worker process"
    )
    p.add_argument(
        "--executor", default="local", choices=("local", "ray"), help="worker processes or Ray"
    )
    p.add_argument("--ray-address", help="address of an existing Ray cluster")
    configuration = "; part of the configuration"
    params(p, SHARED + configuration, names["task_param"] + configuration)
    p.add_argument("--db", help="SQLite results file (default: results/EXPERIMENT.db)")
    p.add_argument(
        "--shard",
        metavar="I/N",
        help="run only the environments with index %% N == I (0 <= I < N): N jobs fill one "
        "database or N that `dcmppi report` merges, e.g. I = $SLURM_ARRAY_TASK_ID",
    )
    p.add_argument(
        "--episode-timeout",
        type=float,
        metavar="S",
        help="record an episode still running after S seconds as a timeout error and go on (the "
        "clock starts when a worker receives it: a fresh worker's start-up, about a second, "
        "counts)",
    )
    p.add_argument(
        "--allow-mixed",
        action="store_true",
        help="extend a database recorded under another dcmppi version, resolved parameter or "
        "input file (the report then shows the versions per row)",
    )
    p.add_argument(
        "--tuning",
        action="store_true",
        help=f"run {TUNING} (default --db results/EXPERIMENT-tuning.db)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress line")


def run(args) -> int:
    from dcmppi import bench

    options = dict(
        episodes=args.episodes,
        workers=args.workers,
        db=args.db,
        rows=comma_list(args.controllers),
        noises=comma_list(args.noise),
        task_params=key_values(args.task_param, "--task-param"),
        controller_params=key_values(args.param, "--param"),
        executor=args.executor,
        ray_address=args.ray_address,
        shard=shard(args.shard),
        episode_timeout=args.episode_timeout,
        allow_mixed=args.allow_mixed,
        tuning=args.tuning,
        progress=not args.no_progress,
    )
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        with flag_names():
            done = bench.run(args.experiment, **options)
    except KeyboardInterrupt as e:
        return 128 + signal.SIGTERM if isinstance(e, _Terminated) else 130
    finally:
        signal.signal(signal.SIGTERM, previous)
    return _summary(done)


def shard(text: str | None) -> tuple[int, int]:
    """--shard I/N as (I, N), 0 <= I < N; None: (0, 1), everything."""
    if text is None:
        return 0, 1
    i, sep, n = text.partition("/")
    try:
        shard = int(i), int(n)
    except ValueError:
        shard = (-1, 0)
    if not sep or not 0 <= shard[0] < shard[1]:
        raise ValueError(
            f"--shard expects I/N with 0 <= I < N (environments with index % N == I), got "
            f"{text!r}; e.g. --shard $SLURM_ARRAY_TASK_ID/4 in a SLURM array of 4 (0-3)"
        )
    return shard


def _summary(done) -> int:
    """Print what the run did (a `dcmppi.bench.BenchRun`); 1 if episodes ended in errors."""
    print(
        f"{done.experiment}: {done.finished} of {done.total} episodes in {done.db}; this run "
        f"{done.ran} episodes, {done.failed} failed, {done.errored} errors, "
        f"{done.seconds:.0f} s\n"
        f"the table: dcmppi report --db {done.db} --out report"
    )
    if not done.errors:
        return 0
    shown = 10
    lines = [
        f"  {r['label']} {r['noise']} environment {r['env_index']}: {r['error']}"
        for r in done.errors[:shown]
    ]
    if len(done.errors) > shown:
        lines.append(f"  ... and {len(done.errors) - shown} more (dcmppi report lists them)")
    print(
        f"{len(done.errors)} episode(s) ended in errors:\n" + "\n".join(lines) + "\n"
        f"they are recorded as errors in {done.db}; fix the cause and rerun to run them again",
        file=sys.stderr,
    )
    return 1


class _Terminated(KeyboardInterrupt):
    """SIGTERM: stops a bench like Ctrl-C."""


def _terminate(signum, frame):
    raise _Terminated()
