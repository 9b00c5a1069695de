"""`dcmppi crowds check FILE...`: recorded crowds (four-column files frame id x y) as the replay
task and the learned predictor read them: per file its frame step and period, people, positions,
walking speeds, the replay episodes it yields, and the problems that refuse it (exit 2).
`dcmppi crowds spread [FILE...]`: the error of constant-velocity extrapolation by observed speed
(dcmppi.bench.crowds.spread)."""

import json

import numpy as np

from dcmppi.bench.crowds import spread
from dcmppi.cli.common import READING_FLAGS, command, flag_names, flagged, reading
from dcmppi.tasks.replay import recordings, scenes


def add_parser(subparsers, names: dict) -> None:
    p = command(
        subparsers,
        "crowds",
        "check recorded crowds (four-column files frame id x y) as dcmppi reads them",
        run,
    )
    sub = p.add_subparsers(dest="action", required=True)
    c = sub.add_parser(
        "check",
        help="per file: frame step, period, people, positions, walking speeds, replay episodes "
        "and the problems that refuse it (exit 2 when a file would be refused)",
    )
    files(c, "+", "names of " + ", ".join(recordings.FILES), "the file's own")
    c.add_argument("--json", action="store_true", help="print one JSON object per file")
    e = sub.add_parser(
        "spread",
        help="the velocity error of constant-velocity extrapolation by observed speed, at "
        + ", ".join(f"{h:g}" for h in spread.HORIZONS)
        + " s (what the cv predictor's cv_std and cv_std_still stand for)",
    )
    files(
        e, "*", "names of the ETH/UCY files (default: all of them, each at its own period)",
        "each file's own",
    )  # fmt: skip
    e.add_argument("--json", action="store_true", help="print the rows as one JSON list")


def files(parser, nargs, names, own):
    """The recorded files' arguments of `parser`: FILE (`nargs`; paths or `names`), the reading
    flags (the period's default: `own`) and --folder."""
    parser.add_argument(
        "files", nargs=nargs, metavar="FILE", help=f"four-column files: paths, or {names}"
    )
    reading(
        parser,
        f"seconds between annotated frames (default: {own}: stated in a '# period' line, "
        f"known, else {recordings.PERIOD})",
    )
    parser.add_argument(
        "--folder", help=f"folder of the ETH/UCY files named (default: ${recordings.CROWDS_ENV})"
    )


def run(args) -> int:
    """Runs `dcmppi crowds check` or `spread`; check returns 2 when a file would be refused."""
    how = {"frame_step": args.frame_step, "max_speed": args.max_speed, "max_gap": args.max_gap}
    if args.action == "spread":
        with flag_names(READING_FLAGS):
            read = [
                recordings.load(f, args.folder, args.period, **how)
                for f in args.files or recordings.FILES
            ]
        rows = spread.by_speed(read)
        print(json.dumps(rows) if args.json else spread.table(rows))
        return 0
    with flag_names(READING_FLAGS):
        found = [summary(f, args.folder, args.period, **how) for f in args.files]
    for entry in found:
        entry["problems"] = [flagged(p, READING_FLAGS) for p in entry["problems"]]
        entry["notes"] = [flagged(n, READING_FLAGS) for n in entry["notes"]]
        print(json.dumps(entry) if args.json else text(entry))
    return 2 if any(entry["refused"] for entry in found) else 0


def summary(name, folder=None, period=None, **reading) -> dict:
    """What `dcmppi crowds check` says of one file (a name of recordings.FILES or a path):
    file, frame_step, period [s], people, positions, speed_median and speed_p99 [m/s], episodes
    (the replay task's), problems and notes (lines), refused."""
    try:
        seen = recordings.examine(name, folder, period, **reading)
    except ValueError as e:
        if str(e).split(" ", 1)[0] in READING_FLAGS:  # a bad option, not a bad file
            raise
        return {"file": str(name), "problems": [str(e)], "notes": [], "refused": True}
    rec, speeds = seen.recording, seen.speeds
    moving = speeds is not None and len(speeds) > 0
    return {
        "file": str(seen.path),
        "frame_step": seen.frame_step,
        "period": seen.period,
        "people": len(rec.tracks) if rec else None,
        "positions": seen.positions,
        "speed_median": float(np.median(speeds)) if moving else None,
        "speed_p99": float(np.percentile(speeds, 99)) if moving else None,
        "episodes": len(scenes.candidates(rec)) if rec else None,
        "problems": list(seen.problems),
        "notes": list(seen.notes),
        "refused": bool(seen.problems),
    }


def text(entry) -> str:
    """The lines of one file's summary."""
    get = entry.get
    parts = []
    if get("frame_step") is not None:
        period = f" ({get('period'):.4g} s)" if get("period") is not None else ""
        parts.append(f"frame step {get('frame_step'):g}{period}")
    if get("positions") is not None:
        parts.append(f"{get('positions')} positions")
    if get("people") is not None:
        parts.append(f"{get('people')} people")
    if get("speed_median") is not None:
        parts.append(
            f"walking {get('speed_median'):.2f} m/s median, {get('speed_p99'):.2f} m/s 99th "
            "percentile"
        )
    if get("episodes") is not None:
        parts.append(f"{get('episodes')} replay episodes")
    head = f"{entry['file']}: {'refused' if entry['refused'] else 'ok'}"
    lines = [head + (": " + ", ".join(parts) if parts else "")]
    lines += [f"  problem: {p}" for p in entry["problems"]]
    lines += [f"  note: {n}" for n in entry["notes"]]
    return "\n".join(lines)
