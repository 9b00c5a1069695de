"""`dcmppi replay`: rerun one recorded episode; exit 1 unless it reproduces its record."""

import sys

from dcmppi.cli.common import command, episode_errors


def add_parser(subparsers, names: dict) -> None:
    p = command(
        subparsers,
        "replay",
        "rerun one recorded episode and say whether it reproduces its record (exit 1 if not)",
        run,
    )
    p.add_argument(
        "--db", action="append", required=True, help="SQLite results file (repeatable: shards)"
    )
    p.add_argument("--label", required=True, help="the experiment's row")
    p.add_argument("--env", type=int, required=True, help="the environment index")
    p.add_argument("--noise", help="noise profile (default: the only one the row has there)")
    p.add_argument("--video", metavar="PATH", help="also render the rerun to PATH (.mp4, .gif)")
    p.add_argument(
        "--html",
        metavar="PATH",
        help="also write the rerun's episode viewer to PATH (.html): a page that plays it in "
        "2-D with its plans, rollouts and predicted futures",
    )


def run(args) -> int:
    from dcmppi.bench.runs.replay import replay
    from dcmppi.render.files import writable

    if args.video:
        writable(args.video, (".mp4", ".gif"), "video")
    if args.html:
        writable(args.html, (".html",), "page")
    with episode_errors():
        found = replay(
            args.db, args.label, args.env, noise=args.noise, video=args.video, page=args.html
        )
    print(found.message)
    if found.page is not None:
        print(f"wrote {found.page}", file=sys.stderr)
    return 0 if found.reproduced else 1
