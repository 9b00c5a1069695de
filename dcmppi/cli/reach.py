"""`dcmppi reach`: the environments an ideal robot could solve; a database's collisions split
by them."""

import sys

from dcmppi.cli.common import TUNING, command, flag_names, key_values


def add_parser(subparsers, names: dict) -> None:
    p = command(
        subparsers,
        "reach",
        "which environments any controller could solve: an ideal robot's reachable set among "
        "obstacles that ignore the robot",
        run,
    )
    p.add_argument("--experiment", default="square-orca", help=f"one of {names['experiments']}")
    p.add_argument("--episodes", type=int, help="environments (default: the experiment's)")
    p.add_argument("--task-param", action="append", metavar="NAME=VALUE", help=names["task_param"])
    p.add_argument("--db", help="a results database: split each row's collisions by them")
    p.add_argument("--tuning", action="store_true", help=f"survey {TUNING}")
    p.add_argument("--no-progress", action="store_true", help="no progress line")


def run(args) -> int:
    from dcmppi.bench.episodes.reachability import summary, survey
    from dcmppi.bench.experiments import load_experiment

    with flag_names():
        exp = load_experiment(args.experiment)
    exp = exp.with_params(key_values(args.task_param, "--task-param"), {})
    exp = (exp.for_tuning() if args.tuning else exp).select(args.episodes, None, None)
    rows = _rows(args.db, exp) if args.db else []

    def progress(done, total):
        if not args.no_progress:
            end = "\n" if done == total else ""
            print(f"\r[reach] {done}/{total} environments", end=end, file=sys.stderr, flush=True)

    print(f"{exp.name}: " + summary(survey(exp, progress), rows))
    return 0


def _rows(path: str, exp) -> list[dict]:
    """The rows of the database at `path`, refused when it holds another experiment's
    environments."""
    from dcmppi.bench.results.database import ResultsDB

    db = ResultsDB(path)
    rows, config = db.rows(), db.config
    db.close()
    mine = exp.config()
    keys = ("task", "base_seed", "env_param", "env_offset", "task_params")
    differ = [k for k in keys if config.get(k) != mine.get(k)]
    if differ:
        raise ValueError(
            f"{path} holds another experiment's environments ({', '.join(differ)} differ "
            f"from {exp.name}'s); pass its --experiment, --task-param and --tuning values"
        )
    return rows
