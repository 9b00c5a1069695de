"""`dcmppi report`: tables, CSV, plots and an HTML page of one or several results databases."""

import sys

from dcmppi.cli.common import command


def add_parser(subparsers, names: dict) -> None:
    p = command(
        subparsers,
        "report",
        "tables, CSV and plots of a results database, and report.html, a page of them all",
        run,
    )
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
        help="replay the first N failures of each row and one success into GIFs and episode "
        "viewers (HTML) linked from the report",
    )


def run(args) -> int:
    from dcmppi.bench.reports.report import write_report

    if args.gallery < 0:
        raise ValueError(f"--gallery must be >= 0, got {args.gallery}")
    dbs = args.db or ["results/static.db"]
    print(write_report(dbs, args.out, plots=not args.no_plots, gallery=args.gallery))
    out = args.out
    print(f"\nwrote {out}/report.md, {out}/report.html and {out}/episodes.csv", file=sys.stderr)
    return 0
