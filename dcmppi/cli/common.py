"""What the commands share: the parser and help classes, the names --help lists, NAME=VALUE and
comma-separated options, and how an episode's exception is reported."""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import re
import textwrap
import traceback

# names that other flags set for every episode (a parameter would silently override them)
RESERVED = {
    "--param": {"seed": "--seed"},
    "--task-param": {"random": "--seed", "noise": "--noise"},
}
CAMERA_HELP = (
    "scene: straight down at the start, the goal and the obstacles between (default); "
    "top: the whole map; chase: behind the robot"
)
SHARED = "parameter for every controller that takes it (repeatable)"
TUNING = (  # 7919: dcmppi.bench.experiments.TUNING_SEED (tests/test_cli.py checks it)
    "the experiment's tuning environments instead of its test ones, to choose parameters on: "
    "base seed + 7919 and, where environment i is a benchmark's case i, the draws its file names"
)
PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep  # dcmppi/


class Parser(argparse.ArgumentParser):
    """An ArgumentParser; with one_line=True its errors are one line, "PROG: error: ... (see
    --help)" (exit 2), arguments it does not know included, and `check(args)` runs after
    parsing: it may fill in defaults and raise ValueError (such an error)."""

    def __init__(self, *args, one_line: bool = False, check=None, **kwargs):
        super().__init__(*args, **kwargs)
        self.one_line, self.check = one_line, check

    def parse_known_args(self, args=None, namespace=None):
        namespace, extras = super().parse_known_args(args, namespace)
        if self.one_line and extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        if self.check is not None:
            try:
                self.check(namespace)
            except ValueError as e:
                self.error(str(e))
        return namespace, extras

    def error(self, message):
        if not self.one_line:
            super().error(message)
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


class Help(argparse.ArgumentDefaultsHelpFormatter):
    """Shows an option's default unless it is None or False or the help gives it."""

    def _get_help_string(self, action):
        if action.default in (None, False) or "default" in (action.help or ""):
            return action.help
        return super()._get_help_string(action)

    def _split_lines(self, text, width):
        """Lines of at most `width`, never breaking a hyphenated name (corridor-visible)."""
        return textwrap.wrap(" ".join(text.split()), width, break_on_hyphens=False)


def choices() -> dict[str, str]:
    """The names --help lists: tasks, controllers (built-in and installed), agents, noise
    profiles, experiments; and the --task-param help that names the agents."""
    from dcmppi.bench.episodes.plugins import available_controllers
    from dcmppi.bench.experiments import experiment_names
    from dcmppi.control.agents import agent_names
    from dcmppi.tasks import NOISE_PROFILES, TASKS

    agents = ", ".join(agent_names())
    return {
        "tasks": ", ".join(TASKS),
        "controllers": ", ".join(available_controllers()) + ", or package.module:ClassName",
        "agents": agents,
        "noises": ", ".join(NOISE_PROFILES),
        "experiments": ", ".join(experiment_names()) + ", or the path of a .toml file",
        "task_param": (
            f"task parameter (repeatable), e.g. agent=NAME (agents: {agents}) or time_limit=60"
        ),
    }


def command(subparsers, name: str, text: str, run) -> argparse.ArgumentParser:
    """The parser of command `name` (help and description `text`) that runs `run(args)`."""
    p = subparsers.add_parser(name, help=text, description=text, formatter_class=Help)
    p.set_defaults(func=run)
    return p


def params(p: argparse.ArgumentParser, controller_help: str, task_help: str) -> None:
    """--param and --task-param NAME=VALUE (repeatable)."""
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help=controller_help)
    p.add_argument("--task-param", action="append", metavar="NAME=VALUE", help=task_help)


def key_values(pairs: list[str] | None, flag: str) -> dict:
    """Parse NAME=VALUE pairs; VALUE is read as JSON when it parses, else as a string; numbers
    must be finite."""
    out = {}
    for pair in pairs or []:
        name, sep, value = pair.partition("=")
        if not sep or not name:
            raise ValueError(f"{flag} expects NAME=VALUE, got {pair!r}")
        if name in RESERVED[flag]:
            raise ValueError(
                f"{flag} {name}=... is set per episode; use {RESERVED[flag][name]} "
                "(bench: the experiment seeds every environment)"
            )
        try:
            out[name] = json.loads(value)
        except json.JSONDecodeError:
            out[name] = value
        try:  # JSON's NaN, Infinity and 1e999 parse, but no record or experiment file holds them
            json.dumps(out[name], allow_nan=False)
        except ValueError:
            raise ValueError(f"{flag} {name}={value}: give finite numbers") from None
    return out


def comma_list(text: str | None) -> tuple[str, ...] | None:
    """A comma-separated list, its items stripped, empty ones dropped; None stays None."""
    return None if text is None else tuple(s.strip() for s in text.split(",") if s.strip())


# dcmppi.bench.run's arguments, by the flag that sets each
FLAGS = {
    "episodes": "--episodes",
    "rows": "--controllers",
    "workers": "--workers",
    "executor": "--executor",
    "ray_address": "--ray-address",
    "episode_timeout": "--episode-timeout",
}


# how recorded crowds are read (dcmppi.tasks.replay.recordings.load), by the flag that sets each
READING_FLAGS = {
    "folder": "--folder",
    "period": "--period",
    "frame_step": "--frame-step",
    "max_speed": "--max-speed",
    "max_gap": "--max-gap",
}


def reading(p: argparse.ArgumentParser, period: str, default=None, checks: bool = True) -> None:
    """The options of READING_FLAGS but --folder: --period (`period`: its help; `default`),
    --frame-step and, with checks, --max-speed and --max-gap."""
    from dcmppi.tasks.replay import recordings

    p.add_argument("--period", type=float, default=default, help=period)
    p.add_argument(
        "--frame-step",
        type=int,
        help="video frames between annotated frames (default: each file's most common step)",
    )
    if checks:
        p.add_argument(
            "--max-speed",
            type=float,
            default=recordings.MAX_SPEED,
            help="refuse a person moving faster [m/s] between consecutive annotations "
            f"(default {recordings.MAX_SPEED:g})",
        )
        p.add_argument(
            "--max-gap",
            type=float,
            default=recordings.MAX_GAP,
            help=f"read a person absent for longer [s] as two (default {recordings.MAX_GAP:g})",
        )


@contextlib.contextmanager
def flag_names(flags=FLAGS):
    """The Python API's ValueErrors about an argument of `flags` ({argument: flag}), which begin
    with its name ("workers must be >= 1, ...") or advise it ("... pass period=SECONDS"),
    re-raised with the flag that sets it ("--workers must be >= 1, ...", "--period SECONDS")."""
    try:
        yield
    except ValueError as e:
        text = flagged(str(e), flags)
        if text == str(e):
            raise
        raise ValueError(text) from e


def flagged(text: str, flags: dict) -> str:
    """`text` with the arguments of `flags` named by their flags (`flag_names`)."""
    name, space, rest = text.partition(" ")
    if name in flags:
        text = f"{flags[name]}{space}{rest}"
    for argument, flag in flags.items():
        text = re.sub(rf"(?<![\w.-]){argument}=(?=\S)", f"{flag} ", text)
    return text


class EpisodeFailed(Exception):
    """An episode raised: a runtime error of a controller (exit 1), not bad input."""


@contextlib.contextmanager
def episode_errors():
    """Episodes run in this block: an exception raised in code outside dcmppi (a user's
    controller, numpy, ...) or of a type other than dcmppi's one-line errors (ValueError,
    RuntimeError, OSError) prints its traceback and becomes EpisodeFailed ("Type: message")."""
    try:
        yield
    except (KeyboardInterrupt, BrokenPipeError):
        raise
    except BaseException as e:  # noqa: BLE001 - SystemExit of a controller included
        frames = traceback.extract_tb(e.__traceback__)[1:]
        ours = all(os.path.abspath(f.filename).startswith(PACKAGE) for f in frames)
        if ours and isinstance(e, (ValueError, RuntimeError, OSError)):
            raise
        traceback.print_exc()
        message = f"{type(e).__name__}: {e}" if str(e) else type(e).__name__
        raise EpisodeFailed(f"the episode raised {message}") from None
