"""`dcmppi tasks`: the tasks and what each is."""

from dcmppi.cli.common import command


def add_parser(subparsers, names: dict) -> None:
    command(subparsers, "tasks", "list the tasks", run)


def run(args) -> int:
    from dcmppi import tasks

    for name, description in tasks.TASKS.items():
        print(f"{name:10s} {description}")
    return 0
