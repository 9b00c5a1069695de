"""`dcmppi outcomes`: old and new code's outcomes on paired episodes, the same within chance?"""

import sys

from dcmppi.cli.common import command


def add_parser(subparsers, names: dict) -> None:
    p = command(
        subparsers,
        "outcomes",
        "the same outcomes within chance? old and new code on paired episodes, per row: "
        "McNemar p > 0.05 and each collision rate in the other's 95 %% interval (exit 1 if not)",
        run,
    )
    p.add_argument(
        "--old", action="append", required=True, help="the old code's database (repeatable)"
    )
    p.add_argument(
        "--new", action="append", required=True, help="the new code's database (repeatable)"
    )


def run(args) -> int:
    from dcmppi.bench.reports.outcomes import compare, joint, table

    comparisons = compare(args.old, args.new)
    print(table(comparisons))
    print(f"\n{joint(comparisons)}")
    failing = [f"{c.label} ({c.noise})" for c in comparisons if not c.holds]
    if failing:
        print(f"\nthe outcomes differ beyond chance: {', '.join(failing)}", file=sys.stderr)
    return 1 if failing else 0
