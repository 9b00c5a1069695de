"""`dcmppi record`: the pedestrians of a task's episodes written as an ETH/UCY recording (four
columns: frame id x y, its period stated in a first line `# period P`), for `dcmppi predictor
train --data FILE --period P` and the replay task."""

from dcmppi.cli.common import command, key_values
from dcmppi.tasks.replay import recordings


def add_parser(subparsers, names: dict) -> None:
    p = command(
        subparsers,
        "record",
        "record the moving pedestrians of a task's episodes (the robot absent: parked away) "
        "in the ETH/UCY four-column format, for `dcmppi predictor train --data`",
        run,
    )
    p.add_argument("--task", required=True, help="a task with pedestrians: square, corridor, crowd")
    p.add_argument("--task-param", action="append", metavar="NAME=VALUE", help=names["task_param"])
    p.add_argument("--episodes", type=int, default=1, help="episodes to record")
    p.add_argument(
        "--base-seed",
        type=int,
        default=0,
        help="episode e's seed: SeedSequence([S, e]), as an experiment of base_seed S seeds "
        "environment e (use another than the test experiment's)",
    )
    p.add_argument(
        "--period",
        type=float,
        default=recordings.PERIOD,
        help="seconds between frames, a whole number of control steps (as ETH/UCY: 0.4)",
    )
    p.add_argument(
        "--frame-step",
        type=int,
        default=recordings.FRAME_STEP,
        help="video frames between the annotated frames written (as ETH/UCY: 10)",
    )
    p.add_argument("--seconds", type=float, help="length of each episode (default: time limit)")
    p.add_argument("--out", required=True, help="the file to write (.txt)")


def run(args) -> int:
    """Runs `dcmppi record`; returns the exit status."""
    from dcmppi.bench.crowds.recording import record

    for pair in args.task_param or ():
        if pair.partition("=")[0] in ("random", "noise"):
            raise ValueError(f"--task-param {pair}: set per episode; choose them by --base-seed")
    params = key_values(args.task_param, "--task-param")
    if args.frame_step < 1:
        raise ValueError(f"--frame-step must be >= 1; got {args.frame_step}")
    recording = record(args.task, params, args.episodes, args.base_seed, args.period, args.seconds)
    recordings.save(recording, args.out, args.frame_step)
    frames = sum(len(t.frames) for t in recording.tracks)
    print(
        f"{args.out}: {len(recording.tracks)} people, {frames} positions of {args.episodes} "
        f"episodes of {args.task}, a frame every {args.period:g} s (stated in the file); train: "
        f"dcmppi predictor train --data {args.out} --period {args.period:g} --out MODEL.npz"
    )
    return 0
