"""The `dcmppi` command line: tasks, controllers, run, compare, figure, bench, report, replay,
outcomes, reach, timing.

Controllers are named as `dcmppi controllers` lists them, or `package.module:ClassName`,
imported like `python -m` would: from the current directory first, then the installed packages.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import textwrap
import traceback

from dcmppi.control.kernels._malloc import tune_malloc
from dcmppi.render import CAMERAS

# names that other flags set for every episode (a parameter would silently override them)
_RESERVED = {
    "--param": {"seed": "--seed"},
    "--task-param": {"random": "--seed", "noise": "--noise"},
}


def _key_values(pairs: list[str], flag: str) -> dict:
    """Parse NAME=VALUE pairs; VALUE is read as JSON when it parses, else as a string; numbers
    must be finite."""
    out = {}
    for pair in pairs or []:
        name, sep, value = pair.partition("=")
        if not sep or not name:
            raise ValueError(f"{flag} expects NAME=VALUE, got {pair!r}")
        if name in _RESERVED[flag]:
            raise ValueError(
                f"{flag} {name}=... is set per episode; use {_RESERVED[flag][name]} "
                "(bench: the experiment seeds every environment)"
            )
        try:
            out[name] = json.loads(value)
        except json.JSONDecodeError:
            out[name] = value
        try:  # JSON's NaN, Infinity and 1e999 parse, but no record or experiment file holds them
            json.dumps(out[name], allow_nan=False)
        except ValueError:
            raise ValueError(f"{flag} {name}={value}: give finite numbers") from None
    return out


def _csv(text: str | None) -> tuple[str, ...] | None:
    return None if text is None else tuple(s.strip() for s in text.split(",") if s.strip())


def cmd_tasks(args) -> int:
    from dcmppi import tasks

    for name, description in tasks.TASKS.items():
        print(f"{name:10s} {description}")
    return 0


def cmd_controllers(args) -> int:
    from dcmppi.bench.episodes.plugins import ENTRY_POINT_GROUP, entry_points
    from dcmppi.control import controller_class, controller_names
    from dcmppi.control.agents import agent_class, agent_names
    from dcmppi.control.predictors import predictor_class, predictor_names

    print("controllers (--controller NAME, or package.module:ClassName for your own class):")
    for name in controller_names():
        print(f"  {name:12s} built-in: {_summary(controller_class(name))}")
    for name, ep in sorted(entry_points().items()):
        if name not in controller_names():
            dist = f", from {ep.dist.name} {ep.dist.version}" if ep.dist else ""
            print(f"  {name:12s} entry point {ep.value} ({ENTRY_POINT_GROUP}{dist})")
    print("agents (--task-param agent=NAME):")
    for name in agent_names():
        print(f"  {name:12s} {_summary(agent_class(name))}")
    print("predictors (--param prediction=NAME, or package.module:ClassName for your own):")
    for name in predictor_names():
        print(f"  {name:12s} {_summary(predictor_class(name))}")
    return 0


def _summary(cls) -> str:
    return (cls.__doc__ or cls.__name__).strip().splitlines()[0]


def cmd_run(args) -> int:
    from dcmppi.bench.episodes.runner import EpisodeSpec, check_specs, run_episode

    spec = EpisodeSpec(
        task=args.task,
        controller=args.controller,
        noise=args.noise,
        seed=args.seed,
        task_params=_key_values(args.task_param, "--task-param"),
        controller_params=_key_values(args.param, "--param"),
    )
    check_specs([spec])
    with _episode_errors():
        if args.video:
            from dcmppi.bench.episodes.runner import Episode
            from dcmppi.render.recording import record_episode
            from dcmppi.render.video import check_path

            check_path(args.video)
            result = record_episode(
                Episode(spec), args.video, camera=args.camera, legend=not args.no_legend
            )
        else:
            result = run_episode(spec)
    if args.json:
        print(
            json.dumps(
                {
                    "task": spec.task,
                    "controller": spec.controller,
                    "noise": spec.noise,
                    "seed": spec.seed,
                    **{k: v for k, v in result.items() if k != "trace"},  # bytes: the database's
                }
            )
        )
    else:
        ttg = "-" if result["time_to_goal"] is None else f"{result['time_to_goal']:.1f} s"
        print(
            f"{spec.task} / {spec.controller} / noise {spec.noise} / seed {spec.seed}: "
            f"{result['outcome']}\n"
            f"  time to goal {ttg}, path {result['path_length']:.1f} m, "
            f"min clearance {result['min_clearance']:.2f} m, {result['steps']} steps\n"
            f"  controller {result['ctrl_ms_mean']:.2f} ms/step (p95 {result['ctrl_ms_p95']:.2f}), "
            f"env.step {result['env_ms_mean']:.2f} ms/step"
        )
    return 0


class EpisodeFailed(Exception):
    """An episode raised: a runtime error of a controller (exit 1), not bad input."""


@contextlib.contextmanager
def _episode_errors():
    """Episodes run in this block: an exception raised in code outside dcmppi (a user's
    controller, numpy, ...) or of a type other than dcmppi's one-line errors (ValueError,
    RuntimeError, OSError) prints its traceback and becomes EpisodeFailed ("Type: message")."""
    package = os.path.dirname(os.path.abspath(__file__)) + os.sep
    try:
        yield
    except (KeyboardInterrupt, BrokenPipeError):
        raise
    except BaseException as e:  # noqa: BLE001 - SystemExit of a controller included
        frames = traceback.extract_tb(e.__traceback__)[1:]
        ours = all(os.path.abspath(f.filename).startswith(package) for f in frames)
        if ours and isinstance(e, (ValueError, RuntimeError, OSError)):
            raise
        traceback.print_exc()
        message = f"{type(e).__name__}: {e}" if str(e) else type(e).__name__
        raise EpisodeFailed(f"the episode raised {message}") from None


def cmd_compare(args) -> int:
    from dcmppi.bench.episodes.runner import Episode, EpisodeSpec, check_specs
    from dcmppi.render.recording import compare
    from dcmppi.render.video import check_path

    check_path(args.video)
    controllers = _csv(args.controllers)
    if not controllers:
        raise ValueError("--controllers needs at least one controller name")
    specs = [
        EpisodeSpec(
            task=args.task,
            controller=controller,
            noise=args.noise,
            seed=args.seed,
            task_params=_key_values(args.task_param, "--task-param"),
            shared_params=_key_values(args.param, "--param"),
        )
        for controller in controllers
    ]
    check_specs(specs)
    with _episode_errors():
        results = compare(
            [Episode(spec) for spec in specs],
            args.video,
            camera=args.camera,
            width=args.width,
            height=args.height,
            legend=not args.no_legend,
        )
    for spec, result in zip(specs, results, strict=True):
        print(
            f"{spec.controller:10s} {result['outcome']:10s} {result['steps']:5d} steps, "
            f"min clearance {result['min_clearance']:.2f} m"
        )
    print(f"wrote {args.video}", file=sys.stderr)
    return 0


def cmd_figure(args) -> int:
    import dataclasses

    import numpy as np

    from dcmppi.bench.episodes.runner import EpisodeSpec, check_specs, controller_for
    from dcmppi.bench.episodes.snapshot import first_step
    from dcmppi.render.figures import require_diagnostics, write_figures

    controllers = _csv(args.controllers)
    if not controllers:
        raise ValueError("--controllers needs at least one controller name")
    spec = EpisodeSpec(
        task=args.task,
        controller=controllers[0],
        noise="none",
        seed=args.seed,
        task_params=_key_values(args.task_param, "--task-param"),
        shared_params=_key_values(args.param, "--param"),
    )
    specs = {c: dataclasses.replace(spec, controller=c) for c in controllers}
    check_specs(list(specs.values()))
    require_diagnostics({c: controller_for(s) for c, s in specs.items()})  # before the episode
    observation, runs, _ = first_step(spec, controllers)
    result = write_figures(observation, runs, args.out, f"{spec.task}, seed {spec.seed}")
    for name, action in result["actions"].items():
        controls = ", ".join(f"{u:+.4f}" for u in np.atleast_1d(action))
        print(f"{name:10s} applies u = ({controls})")
    print("wrote " + ", ".join(result["files"]), file=sys.stderr)
    return 0


def _shard(text: str | None) -> tuple[int, int]:
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


class _Terminated(KeyboardInterrupt):
    """SIGTERM: stops a bench like Ctrl-C."""


def _terminate(signum, frame):
    raise _Terminated()


def cmd_bench(args) -> int:
    import itertools
    import signal
    import time
    from pathlib import Path

    from dcmppi.bench.episodes.runner import check_specs
    from dcmppi.bench.experiments import load_experiment
    from dcmppi.bench.results.database import ResultsDB
    from dcmppi.bench.results.provenance import collect
    from dcmppi.bench.runs.execution import run_experiment

    exp = load_experiment(args.experiment).select(
        args.episodes, _csv(args.controllers), _csv(args.noise)
    )
    exp = exp.with_params(
        _key_values(args.task_param, "--task-param"), _key_values(args.param, "--param")
    )
    shard = _shard(args.shard)
    if args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    if args.ray_address and args.executor != "ray":
        raise ValueError("--ray-address is for Ray's workers: add --executor ray")
    if args.episode_timeout is not None and not args.episode_timeout > 0:
        raise ValueError(f"--episode-timeout must be > 0 seconds, got {args.episode_timeout}")
    # one environment's episodes hold every row and noise; the others are made as they run
    first = list(itertools.islice(exp.specs(shard), len(exp.noises) * len(exp.labels)))
    try:
        check_specs([spec for _, spec in first])
    except ValueError as e:
        raise ValueError(f"experiment {exp.name}: {e}") from e
    db_path = Path(args.db or f"results/{exp.name}.db")
    db_path.parent.mkdir(parents=True, exist_ok=True)
    db = ResultsDB(db_path, exp.config(), collect(exp, first), args.allow_mixed)
    total = exp.count(shard)
    before = sum(exp.wants(key, shard) for key in db.done())
    of = f", shard {shard[0]}/{shard[1]} of them" if shard[1] > 1 else ""
    print(
        f"{exp.name}: {total} episodes ({exp.episodes} environments{of} x "
        f"{len(exp.noises)} noise x {len(exp.labels)} rows), {before} already in {db_path}, "
        f"{total - before} to run on {args.workers} {args.executor} worker(s)",
        file=sys.stderr,
    )
    start = time.monotonic()
    previous = signal.signal(signal.SIGTERM, _terminate)
    try:
        bar = run_experiment(
            exp,
            db,
            args.workers,
            args.executor,
            args.ray_address,
            not args.no_progress,
            shard=shard,
            timeout=args.episode_timeout,
        )
    except KeyboardInterrupt as e:
        print(
            f"\ninterrupted: finished episodes are saved in {db_path}; rerun to resume",
            file=sys.stderr,
        )
        return 128 + signal.SIGTERM if isinstance(e, _Terminated) else 130
    finally:
        signal.signal(signal.SIGTERM, previous)
        rows = [r for r in db.rows() if exp.wants((r["noise"], r["label"], r["env_index"]), shard)]
        db.close()
    errors = [r for r in rows if r["status"] == "error"]
    print(
        f"{exp.name}: {len(rows) - len(errors)} of {total} episodes in {db_path}; this run "
        f"{bar.done} episodes, {bar.failures} failed, {bar.errors} errors, "
        f"{time.monotonic() - start:.0f} s\n"
        f"the table: dcmppi report --db {db_path} --out report"
    )
    if errors:
        shown = 10
        lines = [
            f"  {r['label']} {r['noise']} environment {r['env_index']}: {r['error']}"
            for r in errors[:shown]
        ]
        if len(errors) > shown:
            lines.append(f"  ... and {len(errors) - shown} more (dcmppi report lists them)")
        print(
            f"{len(errors)} episode(s) ended in errors:\n" + "\n".join(lines) + "\n"
            f"they are recorded as errors in {db_path}; fix the cause and rerun to run them again",
            file=sys.stderr,
        )
        return 1
    return 0


def cmd_report(args) -> int:
    from dcmppi.bench.reports.report import write_report

    if args.gallery < 0:
        raise ValueError(f"--gallery must be >= 0, got {args.gallery}")
    dbs = args.db or ["results/static.db"]
    print(write_report(dbs, args.out, plots=not args.no_plots, gallery=args.gallery))
    print(f"\nwrote {args.out}/report.md and {args.out}/episodes.csv", file=sys.stderr)
    return 0


def cmd_replay(args) -> int:
    from dcmppi.bench.runs.replay import replay

    if args.video:
        from dcmppi.render.video import check_path

        check_path(args.video)
    with _episode_errors():
        found = replay(args.db, args.label, args.env, noise=args.noise, video=args.video)
    print(found.message)
    return 0 if found.reproduced else 1


def cmd_outcomes(args) -> int:
    from dcmppi.bench.reports.outcomes import compare, joint, table

    comparisons = compare(args.old, args.new)
    print(table(comparisons))
    print(f"\n{joint(comparisons)}")
    failing = [f"{c.label} ({c.noise})" for c in comparisons if not c.holds]
    if failing:
        print(f"\nthe outcomes differ beyond chance: {', '.join(failing)}", file=sys.stderr)
    return 1 if failing else 0


def cmd_reach(args) -> int:
    from dcmppi.bench.episodes.reachability import summary, survey
    from dcmppi.bench.experiments import load_experiment
    from dcmppi.bench.results.database import ResultsDB

    exp = load_experiment(args.experiment).select(args.episodes, None, None)
    exp = exp.with_params(_key_values(args.task_param, "--task-param"), {})
    rows = []
    if args.db:
        db = ResultsDB(args.db)
        rows, config = db.rows(), db.config
        db.close()
        mine = exp.config()
        keys = ("task", "base_seed", "env_param", "task_params")
        differ = [k for k in keys if config.get(k) != mine.get(k)]
        if differ:
            raise ValueError(
                f"{args.db} holds another experiment's environments ({', '.join(differ)} differ "
                f"from {exp.name}'s); pass its --experiment and --task-param values"
            )

    def progress(done, total):
        if not args.no_progress:
            end = "\n" if done == total else ""
            print(f"\r[reach] {done}/{total} environments", end=end, file=sys.stderr, flush=True)

    print(f"{exp.name}: " + summary(survey(exp, progress), rows))
    return 0


class _Help(argparse.ArgumentDefaultsHelpFormatter):
    """Shows an option's default unless it is None or False or the help gives it."""

    def _get_help_string(self, action):
        if action.default in (None, False) or "default" in (action.help or ""):
            return action.help
        return super()._get_help_string(action)

    def _split_lines(self, text, width):
        """Lines of at most `width`, never breaking a hyphenated name (corridor-visible)."""
        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False)


def _choices() -> dict[str, str]:
    """The names --help lists: tasks, controllers (built-in and installed), agents, noise
    profiles, experiments."""
    from dcmppi.bench.episodes.plugins import available_controllers
    from dcmppi.bench.experiments import experiment_names
    from dcmppi.control.agents import agent_names
    from dcmppi.tasks import NOISE_PROFILES, TASKS

    return {
        "tasks": ", ".join(TASKS),
        "controllers": ", ".join(available_controllers()) + ", or package.module:ClassName",
        "agents": ", ".join(agent_names()),
        "noises": ", ".join(NOISE_PROFILES),
        "experiments": ", ".join(experiment_names()) + ", or the path of a .toml file",
    }


_CAMERA_HELP = (
    "scene: straight down at the start, the goal and the obstacles between (default); "
    "top: the whole map; chase: behind the robot"
)


def build_parser() -> argparse.ArgumentParser:
    c = _choices()
    parser = argparse.ArgumentParser(
        prog="dcmppi", description="MPPI / Clustered / DC / Tube-MPPI benchmark on MuJoCo tasks."
    )
    sub = parser.add_subparsers(dest="command", required=True)

    def command(name, text, func):
        p = sub.add_parser(
            name,
            help=text,
            description=text,
            formatter_class=_Help,
        )
        p.set_defaults(func=func)
        return p

    def params(p, controller_help, task_help):
        p.add_argument("--param", action="append", metavar="NAME=VALUE", help=controller_help)
        p.add_argument("--task-param", action="append", metavar="NAME=VALUE", help=task_help)

    task_param = (
        f"task parameter (repeatable), e.g. agent=NAME (agents: {c['agents']}) or time_limit=60"
    )
    shared = "parameter for every controller that takes it (repeatable)"

    command("tasks", "list the tasks", cmd_tasks)
    command("controllers", "list the controllers (built-in, installed) and agents", cmd_controllers)

    p = command("run", "run one episode and print its outcome", cmd_run)
    p.add_argument("--task", required=True, help=f"one of {c['tasks']}")
    p.add_argument("--controller", required=True, help=f"one of {c['controllers']}")
    p.add_argument("--noise", default="none", help=f"noise profile: {c['noises']}")
    p.add_argument("--seed", type=int, default=0, help="environment seed")
    params(p, "controller parameter, e.g. K=1000 (repeatable)", task_param)
    p.add_argument(
        "--video",
        metavar="PATH",
        help="also render the episode to PATH (.mp4: every frame, 1280x720; .gif: at most 120 "
        "frames, 480x270)",
    )
    p.add_argument("--camera", default="scene", choices=CAMERAS, help=_CAMERA_HELP)
    p.add_argument("--no-legend", action="store_true", help="no colour legend in the video")
    p.add_argument("--json", action="store_true", help="print one JSON object")

    p = command("compare", "one episode under several controllers, side by side", cmd_compare)
    p.add_argument("--task", required=True, help=f"one of {c['tasks']}")
    p.add_argument(
        "--controllers", default="mppi,clustered,dc", help=f"comma-separated: {c['controllers']}"
    )
    p.add_argument("--noise", default="none", help=f"noise profile: {c['noises']}")
    p.add_argument("--seed", type=int, default=0, help="environment seed")
    params(p, shared, task_param)
    p.add_argument(
        "--video",
        required=True,
        metavar="PATH",
        help=".mp4 (every frame) or .gif (at most 120 frames, smaller tiles)",
    )
    p.add_argument("--camera", default="scene", choices=CAMERAS, help=_CAMERA_HELP)
    p.add_argument("--width", type=int, help="tile width in pixels (default 640, GIF 320)")
    p.add_argument("--height", type=int, help="tile height in pixels (default 480, GIF 240)")
    p.add_argument("--no-legend", action="store_true", help="no colour legend in the video")

    p = command("figure", "value and rollout figures of one step (paper Fig. 2, 4)", cmd_figure)
    p.add_argument("--task", default="crossing", help=f"one of {c['tasks']}")
    p.add_argument(
        "--controllers", default="mppi,clustered,dc", help=f"comma-separated: {c['controllers']}"
    )
    p.add_argument("--seed", type=int, default=0, help="environment seed")
    params(p, shared, task_param)
    p.add_argument("--out", default="figures", help="output directory")

    p = command("bench", "run an experiment into a results database (resumable)", cmd_bench)
    p.add_argument("--experiment", default="static", help=f"one of {c['experiments']}")
    p.add_argument("--episodes", type=int, help="environments (default: the experiment's)")
    p.add_argument(
        "--controllers",
        help="comma-separated row labels (default: every row of the experiment), or "
        f"controllers for rows of their own: {c['controllers']}",
    )
    p.add_argument(
        "--noise", help=f"comma-separated noise profiles (default: the experiment's): {c['noises']}"
    )
    p.add_argument(
        "--workers", type=int, default=1, help="episodes at a time, each in a worker process"
    )
    p.add_argument(
        "--executor", default="local", choices=("local", "ray"), help="worker processes or Ray"
    )
    p.add_argument("--ray-address", help="address of an existing Ray cluster")
    params(p, f"{shared}; part of the configuration", f"{task_param}; part of the configuration")
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
    p.add_argument("--no-progress", action="store_true", help="no progress line")

    p = command("report", "tables, CSV and plots of a results database", cmd_report)
    p.add_argument(
        "--db",
        action="append",
        help="SQLite results file (default: results/static.db); repeat it to merge the "
        "databases of one configuration (--shard runs)",
    )
    p.add_argument("--out", default="report", help="output directory")
    p.add_argument("--no-plots", action="store_true", help="tables and CSV only")
    p.add_argument(
        "--gallery",
        type=int,
        default=0,
        metavar="N",
        help="replay the first N failures of each row and one success into GIFs linked from "
        "report.md",
    )

    p = command(
        "replay",
        "rerun one recorded episode and say whether it reproduces its record (exit 1 if not)",
        cmd_replay,
    )
    p.add_argument(
        "--db", action="append", required=True, help="SQLite results file (repeatable: shards)"
    )
    p.add_argument("--label", required=True, help="the experiment's row")
    p.add_argument("--env", type=int, required=True, help="the environment index")
    p.add_argument("--noise", help="noise profile (default: the only one the row has there)")
    p.add_argument("--video", metavar="PATH", help="also render the rerun to PATH (.mp4, .gif)")

    p = command(
        "outcomes",
        "the same outcomes within chance? old and new code on paired episodes, per row: "
        "McNemar p > 0.05 and each collision rate in the other's 95 %% interval (exit 1 if not)",
        cmd_outcomes,
    )
    p.add_argument(
        "--old", action="append", required=True, help="the old code's database (repeatable)"
    )
    p.add_argument(
        "--new", action="append", required=True, help="the new code's database (repeatable)"
    )

    p = command(
        "reach",
        "which environments any controller could solve: an ideal robot's reachable set among "
        "obstacles that ignore the robot",
        cmd_reach,
    )
    p.add_argument("--experiment", default="square-orca", help=f"one of {c['experiments']}")
    p.add_argument("--episodes", type=int, help="environments (default: the experiment's)")
    p.add_argument("--task-param", action="append", metavar="NAME=VALUE", help=task_param)
    p.add_argument("--db", help="a results database: split each row's collisions by them")
    p.add_argument("--no-progress", action="store_true", help="no progress line")

    # `timing` parses its own options (dcmppi.bench.timing.main); listed here for --help.
    sub.add_parser(
        "timing",
        help="controller ms per step on fixed problems (--json, --steps, --against pytorch_mppi, "
        "--scaling, --profile, --fingerprint)",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the `dcmppi` command `argv` (default: sys.argv[1:]); returns the exit status.

    Every command first tunes glibc's malloc for this process
    (`dcmppi.control.kernels._malloc.tune_malloc`): the controllers' per-step temporaries stay in
    the heap instead of being faulted in again each step."""
    argv = sys.argv[1:] if argv is None else list(argv)
    tune_malloc()
    if os.getcwd() not in sys.path:  # package.module:ClassName from here, as with python -m
        sys.path.insert(0, os.getcwd())
    try:
        try:
            return _main(argv)
        finally:
            sys.stdout.flush()  # a reader that has gone shows here, not at exit
    except BrokenPipeError:
        # The reader left (`dcmppi tasks | head -1`): stop quietly, like a command killed by
        # SIGPIPE, and point stdout at /dev/null so that the exit's flush has nowhere to fail.
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    except KeyboardInterrupt as e:
        command = f"dcmppi {argv[0]}" if argv else "dcmppi"
        print(f"{command}: interrupted" + (f"; {e}" if str(e) else ""), file=sys.stderr)
        return 130


def _main(argv: list[str]) -> int:
    if argv[:1] == ["timing"]:
        from dcmppi.bench import timing

        return timing.main(argv[1:])
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except BrokenPipeError:
        raise
    except EpisodeFailed as e:
        print(f"dcmppi {args.command}: error: {e}", file=sys.stderr)
        return 1
    except (ValueError, RuntimeError, OSError) as e:
        print(f"dcmppi {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
