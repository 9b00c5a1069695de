"""The `dcmppi` command line: tasks, controllers, run, compare, figure, bench, report, replay,
outcomes, reach, predictor, record, crowds, timing.

One module per command, each with `add_parser(subparsers, names)` (the command's options;
`names`: what --help lists, `common.choices()`) and `run(args)` (the command; returns the exit
status); `common` holds what they share. Errors of bad input or of the environment (ValueError,
RuntimeError, OSError) are one line, "dcmppi COMMAND: error: ..." (exit 2); an episode whose
controller raised is exit 1 (`common.EpisodeFailed`). `__main__` is `python -m dcmppi.cli`.

Controllers are named as `dcmppi controllers` lists them, or `package.module:ClassName`,
imported like `python -m` would: from the current directory first, then the installed packages.
"""

from __future__ import annotations

import argparse
import os
import sys

from dcmppi.cli import (
    bench,
    common,
    compare,
    controllers,
    crowds,
    figure,
    outcomes,
    predictor,
    reach,
    record,
    replay,
    report,
    run,
    tasks,
    timing,
)
from dcmppi.control.kernels._malloc import tune_malloc

COMMANDS = (
    tasks,
    controllers,
    run,
    compare,
    figure,
    bench,
    report,
    replay,
    outcomes,
    reach,
    predictor,
    record,
    crowds,
    timing,
)


def build_parser() -> argparse.ArgumentParser:
    """The `dcmppi` parser: one subcommand per module of COMMANDS."""
    parser = common.Parser(
        prog="dcmppi", description="MPPI / Clustered / DC / Tube-MPPI benchmark on MuJoCo tasks."
    )
    subparsers = parser.add_subparsers(dest="command", required=True)
    names = common.choices()
    for command in COMMANDS:
        command.add_parser(subparsers, names)
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
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except BrokenPipeError:
        raise
    except common.EpisodeFailed as e:
        print(f"dcmppi {args.command}: error: {e}", file=sys.stderr)
        return 1
    except (ValueError, RuntimeError, OSError) as e:
        print(f"dcmppi {args.command}: error: {e}", file=sys.stderr)
        return 2
