"""`dcmppi replay`: rerun one recorded episode; exit 1 unless it reproduces its record."""

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


def run(args) -> int:
    from dcmppi.bench.runs.replay import replay

    if args.video:
        from dcmppi.render.video import check_path

        check_path(args.video)
    with episode_errors():
        found = replay(args.db, args.label, args.env, noise=args.noise, video=args.video)
    print(found.message)
    return 0 if found.reproduced else 1
