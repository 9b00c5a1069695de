"""The `dcmppi` command line: tasks, run, bench, report, timing."""

from __future__ import annotations

import argparse
import json
import os
import sys

from dcmppi.control.defaults import NOISE_PROFILES
from dcmppi.render import CAMERAS

# names that other flags set for every episode (a parameter would silently override them)
_RESERVED = {
    "--param": {"seed": "--seed"},
    "--task-param": {"random": "--seed", "noise": "--noise"},
}


def _key_values(pairs: list[str], flag: str) -> dict:
    """Parse NAME=VALUE pairs; VALUE is read as JSON when it parses, else as a string."""
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
    return out


def _csv(text: str | None) -> tuple[str, ...] | None:
    return None if text is None else tuple(s.strip() for s in text.split(",") if s.strip())


def cmd_tasks(args) -> int:
    from dcmppi import tasks

    for name, description in tasks.TASKS.items():
        print(f"{name:10s} {description}")
    return 0


def cmd_run(args) -> int:
    from dcmppi.bench.runner import EpisodeSpec, run_episode

    spec = EpisodeSpec(
        task=args.task,
        controller=args.controller,
        noise=args.noise,
        seed=args.seed,
        task_params=_key_values(args.task_param, "--task-param"),
        controller_params=_key_values(args.param, "--param"),
    )
    _check_names(spec.task, spec.controller)
    if args.video:
        from dcmppi.bench.runner import Episode
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
                    **result,
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


def cmd_compare(args) -> int:
    from dcmppi.bench.runner import Episode, EpisodeSpec
    from dcmppi.render.recording import compare
    from dcmppi.render.video import check_path

    check_path(args.video)
    controllers = _csv(args.controllers)
    specs = []
    for controller in controllers:
        _check_names(args.task, controller)
        specs.append(
            EpisodeSpec(
                task=args.task,
                controller=controller,
                noise=args.noise,
                seed=args.seed,
                task_params=_key_values(args.task_param, "--task-param"),
                controller_params=_key_values(args.param, "--param"),
            )
        )
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
    from dcmppi.bench.runner import EpisodeSpec
    from dcmppi.bench.snapshot import first_step
    from dcmppi.render.figures import write_figures

    controllers = _csv(args.controllers)
    if not controllers:
        raise ValueError("--controllers needs at least one controller name")
    for controller in controllers:
        _check_names(args.task, controller)
    spec = EpisodeSpec(
        task=args.task,
        controller=controllers[0],
        noise="none",
        seed=args.seed,
        task_params=_key_values(args.task_param, "--task-param"),
        controller_params=_key_values(args.param, "--param"),
    )
    observation, runs, _ = first_step(spec, controllers)
    result = write_figures(observation, runs, args.out, f"{spec.task}, seed {spec.seed}")
    for name, action in result["actions"].items():
        print(f"{name:10s} applies omega = {action:+.4f} rad/s")
    print("wrote " + ", ".join(result["files"]), file=sys.stderr)
    return 0


def cmd_bench(args) -> int:
    import dataclasses
    from pathlib import Path

    from dcmppi.bench.execution import run_all
    from dcmppi.bench.experiments import get_experiment
    from dcmppi.bench.report import table
    from dcmppi.bench.results import ResultsDB

    exp = get_experiment(args.experiment, args.episodes, _csv(args.controllers), _csv(args.noise))
    exp = dataclasses.replace(
        exp,
        task_params={**exp.task_params, **_key_values(args.task_param, "--task-param")},
        controller_params={**exp.controller_params, **_key_values(args.param, "--param")},
    )
    if args.workers < 1:
        raise ValueError(f"--workers must be >= 1, got {args.workers}")
    specs = exp.specs()
    _check_specs(specs)
    db_path = Path(args.db or f"results/{exp.name}.db")
    db_path.parent.mkdir(parents=True, exist_ok=True)
    db = ResultsDB(db_path, exp.config())
    done = db.done()
    todo = [(key, spec) for key, spec in specs if key not in done]
    print(
        f"{exp.name}: {len(specs)} episodes ({exp.episodes} environments x "
        f"{len(exp.noises)} noise x {len(exp.controllers)} controllers), "
        f"{len(specs) - len(todo)} already in {db_path}, {len(todo)} to run "
        f"on {args.workers} {args.executor} worker(s)",
        file=sys.stderr,
    )
    try:
        run_all(
            todo,
            db,
            args.workers,
            args.executor,
            args.ray_address,
            exp.name,
            progress=not args.no_progress,
        )
    except KeyboardInterrupt:
        print(
            f"\ninterrupted: finished episodes are saved in {db_path}; rerun to resume",
            file=sys.stderr,
        )
        return 130
    finally:
        rows = db.rows()
        db.close()
    wanted = {key for key, _ in specs}
    rows = [r for r in rows if (r["noise"], r["controller"], r["env_index"]) in wanted]
    print(table(rows, exp.name))
    errors = [r for r in rows if r["status"] == "error"]
    if errors:
        first = errors[0]
        print(
            f"{len(errors)} episode(s) raised errors, e.g. {first['controller']} "
            f"{first['noise']} environment {first['env_index']}: {first['error']}\n"
            f"they are recorded as errors in {db_path}; fix the cause and rerun to run them again",
            file=sys.stderr,
        )
        return 1
    return 0


def _check_specs(specs) -> None:
    """Build the environment and every controller of the first episodes before recording
    anything, so a bad parameter or a missing dependency fails here with its message instead
    of as one error row per episode."""
    from dcmppi.bench.runner import make_controller, make_env

    first = {}
    for _, spec in specs:
        first.setdefault(spec.controller, spec)
    for i, spec in enumerate(first.values()):
        make_controller(spec)
        if i == 0:
            make_env(spec).close()


def cmd_report(args) -> int:
    from dcmppi.bench.report import write_report

    print(write_report(args.db, args.out, plots=not args.no_plots))
    print(f"\nwrote {args.out}/report.md and {args.out}/episodes.csv", file=sys.stderr)
    return 0


def _check_names(task: str, controller: str) -> None:
    from dcmppi import controller_names
    from dcmppi.tasks import TASKS

    if task not in TASKS:
        raise ValueError(f"unknown task {task!r}; valid: {', '.join(TASKS)}")
    if controller not in controller_names():
        raise ValueError(
            f"unknown controller {controller!r}; valid: {', '.join(controller_names())}"
        )


_CAMERA_HELP = (
    "scene: straight down at the start, the goal and the obstacles between (default); "
    "top: the whole map; chase: behind the robot"
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="dcmppi", description="MPPI / Clustered / DC / Tube-MPPI benchmark on MuJoCo tasks."
    )
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("tasks", help="list the tasks")
    p.set_defaults(func=cmd_tasks)

    p = sub.add_parser("run", help="run one episode and print its outcome")
    p.add_argument("--task", required=True)
    p.add_argument("--controller", required=True)
    p.add_argument("--noise", default="none", choices=NOISE_PROFILES)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--param",
        action="append",
        metavar="NAME=VALUE",
        help="controller parameter, e.g. --param K=1000 (repeatable)",
    )
    p.add_argument(
        "--task-param",
        action="append",
        metavar="NAME=VALUE",
        help="task parameter, e.g. --task-param world=12 (repeatable)",
    )
    p.add_argument(
        "--video",
        metavar="PATH",
        help="also render the episode to PATH (.mp4: every frame, 1280x720; .gif: at most 120 "
        "frames, 480x270)",
    )
    p.add_argument("--camera", default="scene", choices=CAMERAS, help=_CAMERA_HELP)
    p.add_argument("--no-legend", action="store_true", help="no colour legend in the video")
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("compare", help="one episode under several controllers, side by side")
    p.add_argument("--task", required=True)
    p.add_argument("--controllers", default="mppi,clustered,dc")
    p.add_argument("--noise", default="none", choices=NOISE_PROFILES)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--param", action="append", metavar="NAME=VALUE")
    p.add_argument("--task-param", action="append", metavar="NAME=VALUE")
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
    p.set_defaults(func=cmd_compare)

    p = sub.add_parser("figure", help="value and rollout figures of one step (paper Fig. 2, 4)")
    p.add_argument("--task", default="crossing")
    p.add_argument("--controllers", default="mppi,clustered,dc")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--param", action="append", metavar="NAME=VALUE")
    p.add_argument("--task-param", action="append", metavar="NAME=VALUE")
    p.add_argument("--out", default="figures")
    p.set_defaults(func=cmd_figure)

    p = sub.add_parser("bench", help="run an experiment into a results database (resumable)")
    p.add_argument("--experiment", default="static", help="static | dynamic")
    p.add_argument("--episodes", type=int, help="environments (default: the paper's count)")
    p.add_argument("--controllers", help="comma-separated subset, e.g. mppi,clustered")
    p.add_argument("--noise", help="comma-separated noise profiles: none,control,process")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--executor", default="local", choices=("local", "ray"))
    p.add_argument("--ray-address", help="address of an existing Ray cluster")
    p.add_argument(
        "--param",
        action="append",
        metavar="NAME=VALUE",
        help="controller parameter for every controller (part of the configuration)",
    )
    p.add_argument(
        "--task-param",
        action="append",
        metavar="NAME=VALUE",
        help="task parameter (part of the configuration)",
    )
    p.add_argument("--db", help="SQLite results file (default results/EXPERIMENT.db)")
    p.add_argument("--no-progress", action="store_true")
    p.set_defaults(func=cmd_bench)

    p = sub.add_parser("report", help="tables, CSV and plots of a results database")
    p.add_argument("--db", default="results/static.db")
    p.add_argument("--out", default="report")
    p.add_argument("--no-plots", action="store_true")
    p.set_defaults(func=cmd_report)

    # `timing` parses its own options (dcmppi.bench.timing.main); listed here for --help.
    sub.add_parser("timing", help="controller ms per step on fixed problems (--json, --steps)")
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
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
    except (ValueError, RuntimeError, OSError) as e:
        print(f"dcmppi {args.command}: error: {e}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
