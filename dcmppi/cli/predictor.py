"""`dcmppi predictor train` (a learned predictor's model from recordings) and `dcmppi predictor
eval` (the standard ETH/UCY forecast protocol)."""

import json

from dcmppi.bench.crowds import evaluation, training
from dcmppi.cli.common import READING_FLAGS, command, flag_names, reading
from dcmppi.control.predictors import learned
from dcmppi.tasks.replay import recordings

PERIOD_HELP = (
    f"seconds between annotated frames, every file alike (default {recordings.PERIOD}, as "
    "forecasting papers read ETH/UCY)"
)
FLAGS = {**READING_FLAGS, "max_windows": "--max-windows", "limit": "--limit"}


def add_parser(subparsers, names: dict) -> None:
    p = command(
        subparsers,
        "predictor",
        "train the learned predictor on recorded crowds; evaluate forecasts on ETH/UCY "
        "(observe 8 frames, predict 12, leave one scene out)",
        run,
    )
    sub = p.add_subparsers(dest="action", required=True)
    folder = (
        f"folder of the ETH/UCY files (default: ${recordings.CROWDS_ENV}); "
        "not needed for --data paths"
    )

    _train_parser(sub, folder)
    _eval_parser(sub, folder)


def _train_parser(sub, folder: str) -> None:
    t = sub.add_parser("train", help="train a learned model; print its sha256")
    data = t.add_mutually_exclusive_group(required=True)
    data.add_argument(
        "--data",
        nargs="+",
        metavar="FILE",
        help="four-column files (frame id x y): paths, or names of " + ", ".join(recordings.FILES),
    )
    data.add_argument(
        "--leave-out",
        choices=list(recordings.SCENES),
        metavar="SCENE",
        help="every ETH/UCY file but this test scene's (the standard split): "
        + ", ".join(recordings.SCENES),
    )
    t.add_argument("--out", required=True, help="the model file to write (.npz)")
    t.add_argument("--seed", type=int, default=0, help="seed of the training (default 0)")
    reading(t, PERIOD_HELP, recordings.PERIOD)
    t.add_argument("--max-windows", type=int, help="train on this many windows, drawn by --seed")
    t.add_argument("--folder", help=folder)


def _eval_parser(sub, folder: str) -> None:
    e = sub.add_parser("eval", help="ADE/FDE, KDE NLL and coverage on the five ETH/UCY scenes")
    e.add_argument(
        "--predictors",
        default=",".join(evaluation.ROWS),
        help="comma-separated rows: cv (one sample), cv-noise (25 deg heading noise), "
        "cv-sampled (the cv predictor), cv-still and cv-crowds (it with the crowds preset's "
        "spread for people standing, and with both its spreads), "
        "learned-tracks (the learned model on the annotated "
        "tracks) or any registered predictor (default: " + ",".join(evaluation.ROWS) + ")",
    )
    e.add_argument(
        "--scenes", default=",".join(recordings.SCENES), help="comma-separated test scenes"
    )
    e.add_argument(
        "--model",
        action="append",
        metavar="SCENE=PATH",
        help="the learned model tested on SCENE (repeatable; default: one trained per scene "
        "on the others' files with --seed)",
    )
    e.add_argument("--seed", type=int, default=0, help="seed of samples and training")
    e.add_argument("--limit", type=int, help="at most this many windows per scene")
    reading(e, PERIOD_HELP, recordings.PERIOD, checks=False)
    e.add_argument("--folder", help=folder)
    e.add_argument("--json", action="store_true", help="print one JSON object")


def run(args) -> int:
    """Runs `dcmppi predictor train|eval`; returns the exit status."""
    with flag_names(FLAGS):
        return {"train": train, "eval": evaluate}[args.action](args)


def train(args) -> int:
    names = recordings.train_files(args.leave_out) if args.leave_out else args.data
    how = {"frame_step": args.frame_step, "max_speed": args.max_speed, "max_gap": args.max_gap}
    data = training.read(names, args.folder, args.period, **how)
    model = training.train(data, args.out, args.seed, args.max_windows)
    print(
        f"{args.out}: {len(model.features)} windows of {len(names)} files, shrink "
        f"{model.shrink:.2f}, sha256 {learned.sha256(args.out)}"
    )
    return 0


def evaluate(args) -> int:
    models = {}
    for item in args.model or ():
        scene, sep, path = item.partition("=")
        if not sep or scene not in recordings.SCENES:
            raise ValueError(
                f"--model {item!r}: expected SCENE=PATH, SCENE one of "
                + ", ".join(recordings.SCENES)
            )
        models[scene] = path
    result = evaluation.evaluate(
        _split(args.predictors),
        _split(args.scenes),
        args.folder,
        models or None,
        args.seed,
        args.limit,
        args.period,
        args.frame_step,
    )
    print(json.dumps(result, indent=1) if args.json else evaluation.table(result))
    return 0


def _split(text):
    return [part.strip() for part in text.split(",") if part.strip()]
