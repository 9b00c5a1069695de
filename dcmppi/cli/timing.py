"""`dcmppi timing`: its options and their checks; what each mode runs and prints is
dcmppi.bench.timing.cli's. Its errors are one line, "dcmppi timing: error: ... (see --help)"."""

import argparse

STEPS = 100  # control steps per case of the table, the profile, the fingerprint and --against
ENVIRONMENTS, WORKERS = 10, 2  # --profile EXPERIMENT: environments run, workers projected


def add_parser(subparsers, names: dict) -> None:
    from dcmppi.bench.timing.loop import BLOCK
    from dcmppi.bench.timing.scaling import STEPS as SCALING_STEPS
    from dcmppi.control import defaults

    p = subparsers.add_parser(
        "timing",
        help="controller ms per step on fixed problems (--json, --steps, --against pytorch_mppi, "
        "--scaling, --profile, --fingerprint)",
        description="median controller time per control step on fixed problems",
        formatter_class=argparse.HelpFormatter,
        one_line=True,
        check=check,
    )
    p.set_defaults(func=run)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument(
        "--steps",
        type=int,
        help=f"control steps per case (default {STEPS}; --scaling: {SCALING_STEPS} per point)",
    )
    p.add_argument(
        "--block", type=int, default=BLOCK, help="consecutive steps of a case (1: cold caches)"
    )
    _against_options(p, defaults.K, defaults.N)
    p.add_argument(
        "--scaling",
        action="store_true",
        help="ms per step of each controller as K, N, cylinders, moving obstacles and P grow",
    )
    p.add_argument("--out", help="--scaling: write scaling.json and scaling.png here")
    _profile_options(p)
    p.add_argument(
        "--fingerprint",
        action="store_true",
        help="hash every closed loop's actions (identical before and after a speed change)",
    )


def _against_options(p, k: int, n: int) -> None:
    p.add_argument(
        "--against",
        choices=["pytorch_mppi"],
        help="time pytorch_mppi beside our mppi on the same problem (needs the extra `peer`)",
    )
    p.add_argument("--K", type=int, help=f"--against: samples per step (default {k})")
    p.add_argument("--N", type=int, help=f"--against: horizon steps (default {n})")
    p.add_argument(
        "--threads",
        type=int,
        default=1,
        help="--against: also time our mppi with this many threads, interleaved (default 1: not)",
    )


def _profile_options(p) -> None:
    p.add_argument(
        "--profile",
        nargs="?",
        const="",
        metavar="EXPERIMENT",
        help="where one step's time goes, in microseconds; with an experiment (a name or a TOML "
        "file, as `dcmppi bench --experiment`), where its bench episodes' time goes, end to end",
    )
    p.add_argument(
        "--environments",
        type=int,
        help=f"--profile EXPERIMENT: environments of each row to run (default {ENVIRONMENTS})",
    )
    p.add_argument(
        "--workers",
        type=int,
        help=f"--profile EXPERIMENT: workers of the projected full run (default {WORKERS})",
    )


def check(args) -> None:
    """Refuse options that do not go together (ValueError, one line) and fill in the defaults
    that depend on the others: steps, K, N, environments, workers."""
    from dcmppi.bench.timing.scaling import STEPS as SCALING_STEPS

    if args.profile and args.steps is not None:
        raise ValueError(
            "--profile EXPERIMENT runs whole episodes: choose --environments, not --steps"
        )
    if args.profile and (args.against or args.scaling or args.fingerprint):
        raise ValueError(
            "--profile EXPERIMENT runs on its own: drop --against, --scaling, --fingerprint"
        )
    if args.steps is None:
        args.steps = SCALING_STEPS if args.scaling else STEPS
    if args.steps < 5:
        raise ValueError("--steps must be >= 5")
    if args.block < 1:
        raise ValueError("--block must be >= 1")
    _check_against(args)
    for name, default in (("environments", ENVIRONMENTS), ("workers", WORKERS)):
        value = getattr(args, name)
        if value is None:
            setattr(args, name, default)
        elif not args.profile:
            raise ValueError(
                f"--{name} is for --profile EXPERIMENT: add --profile static (or another)"
            )
        elif value < 1:
            raise ValueError(f"--{name} must be >= 1; got {value}")
    if args.out and not args.scaling:
        raise ValueError("--out is where --scaling writes its JSON and plot; add --scaling")


def _check_against(args) -> None:
    """--K, --N and --threads: --against's problem size and second row of ours."""
    from dcmppi.control import defaults

    for name in ("K", "N"):
        value = getattr(args, name)
        if value is None:
            setattr(args, name, getattr(defaults, name))
        elif not args.against:
            raise ValueError(
                f"--{name} sets the size of --against's problem: add --against pytorch_mppi"
            )
        elif not 1 <= value <= 100_000:
            raise ValueError(f"--{name} must be a whole number in 1 .. 100000; got {value}")
    if args.threads != 1 and not args.against:
        raise ValueError("--threads is --against's second row of ours: add --against pytorch_mppi")
    if not 1 <= args.threads <= 64:
        raise ValueError(f"--threads must be a whole number in 1 .. 64; got {args.threads}")


def run(args) -> int:
    """The mode the options chose: --against, --scaling, --profile EXPERIMENT, --profile,
    --fingerprint, else the table."""
    from dcmppi.bench.timing.cli import (
        against,
        fingerprints,
        profile_experiment,
        profile_steps,
        scale,
        timings,
    )

    if args.against:
        return against(args)
    if args.scaling:
        return scale(args)
    if args.profile:
        return profile_experiment(args)
    if args.profile is not None:
        return profile_steps(args)
    if args.fingerprint:
        return fingerprints(args)
    return timings(args)
