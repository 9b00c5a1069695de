"""The experiment file format (TOML) and its checks: every error names the file, key and reason.

name = "mine"                 # optional, default: the file's stem
description = "..."           # optional
task = "forest"               # a dcmppi task (`dcmppi tasks`)
noises = ["none", "control"]  # optional, default ["none"]
episodes = 100                # environments, >= 1
base_seed = 2024              # optional, default 0; environment i's seed: (base_seed, i)
env_param = "world"           # optional: task parameter set to i in environment i (e.g. the
                              # BARN world); the seed then drives only noise and sampling
env_offset = 0                # optional, with env_param: it is set to env_offset + i instead
tuning = "seeds"              # optional, with env_param: the tuning environments (--tuning):
                              # "seeds" (the task draws each from its seed) or "beyond" (the
                              # cases after the test's: env_param = env_offset + episodes + i);
                              # without it, none (every environment with env_param has one)
reference = "mppi"            # optional: the row every other row is compared with (McNemar)
paper_note = "..."            # optional: where the paper's figures come from
[task_params]                 # optional: task keyword arguments (agent, time_limit, ...)
[controller_params]           # optional: shared by every row (each takes those it accepts)
[[rows]]                      # one or more
label = "mppi"                # optional, default: controller; unique, no comma
controller = "mppi"           # built-in, entry point or package.module:ClassName
params = { K = 1000 }         # optional: this row's own parameters
paper.none = { collisions = 11, failure_pct = 1.2, ms_per_step = 190 }  # optional, per noise
"""

from __future__ import annotations

import json
import numbers

from dcmppi.bench.crowds import recipes
from dcmppi.tasks import NOISE_PROFILES

TOP_KEYS = {
    "name": str,
    "description": str,
    "task": str,
    "noises": list,
    "episodes": int,
    "base_seed": int,
    "env_param": str,
    "env_offset": int,
    "tuning": str,
    "reference": str,
    "paper_note": str,
    "task_params": dict,
    "controller_params": dict,
    "rows": list,
}
ROW_KEYS = {"label": str, "controller": str, "params": dict, "paper": dict}
TUNING = ("seeds", "beyond")
PAPER_KEYS = {"collisions": int, "failure_pct": float, "ms_per_step": float}
REQUIRED = ("task", "episodes", "rows")
RESERVED = {
    "task_params": {"random": "environment i's seed comes from base_seed", "noise": "use noises"},
    "controller_params": {"seed": "each episode's controller seed comes from base_seed"},
    "params": {"seed": "each episode's controller seed comes from base_seed"},
}


class ExperimentError(ValueError):
    """A malformed experiment: `source: key: reason`."""

    def __init__(self, source: str, key: str, reason: str):
        super().__init__(f"{source}: {key}: {reason}")


def _type_name(kind) -> str:
    return {str: "a string", int: "an integer", float: "a number", list: "an array"}.get(
        kind, "a table"
    )


def _typed(source, key, value, kind):
    if kind is float:
        ok = isinstance(value, numbers.Real) and not isinstance(value, bool)
    else:
        ok = isinstance(value, kind) and not (kind is int and isinstance(value, bool))
    if not ok:
        raise ExperimentError(
            source, key, f"must be {_type_name(kind)}, got {type(value).__name__} {value!r}"
        )
    return value


def _table(source, key, data, keys, required=()) -> dict:
    """Check `data` (a table at `key`) against {name: type}; return it."""
    _typed(source, key or "(top level)", data, dict)
    unknown = sorted(set(data) - set(keys))
    if unknown:
        where = f"{key}." if key else ""
        raise ExperimentError(
            source, f"{where}{unknown[0]}", f"unknown key; valid keys: {', '.join(keys)}"
        )
    for name in required:
        if name not in data:
            raise ExperimentError(source, f"{key}.{name}" if key else name, "missing")
    for name, value in data.items():
        _typed(source, f"{key}.{name}" if key else name, value, keys[name])
    return data


def _check_values(source, key, data, reserved) -> dict:
    """`data` (parameters at `key`) checked: no name in `reserved`, values JSON without NaN or
    infinities; a copy."""
    for name, value in data.items():
        if name in reserved:
            raise ExperimentError(source, f"{key}.{name}", f"set per episode ({reserved[name]})")
        try:
            json.dumps(value, allow_nan=False)
        except (TypeError, ValueError):
            raise ExperimentError(
                source, f"{key}.{name}", f"{value!r} is not a number, string, array or table"
            ) from None
    return dict(data)


def parse(data: dict, source: str, resolve: bool = True) -> dict:
    """Check an experiment read from TOML (or stored as JSON) and return the arguments of
    `Experiment`. resolve=False skips the checks that import tasks and controllers (reading a
    stored definition back)."""
    _table(source, "", data, TOP_KEYS, REQUIRED)
    name, task, episodes, base_seed = _scalars(source, data, resolve)
    noises = _noises(source, data.get("noises", ["none"]))
    env_param = _env_param(source, data)
    env_offset, tuning = _environments(source, data, env_param)
    rows = _rows(source, data["rows"], resolve)
    labels = [row["label"] for row in rows]
    reference = data.get("reference")
    if reference is not None and reference not in labels:
        raise ExperimentError(
            source, "reference", f"{reference!r} is no row label; labels: {', '.join(labels)}"
        )
    return {
        "name": name,
        "description": data.get("description", ""),
        "task": task,
        "rows": rows,
        "noises": noises,
        "episodes": episodes,
        "base_seed": base_seed,
        "env_param": env_param,
        "env_offset": env_offset,
        "tuning": tuning,
        **{
            key: check_params(source, key, data.get(key, {}), RESERVED[key])
            for key in ("task_params", "controller_params")
        },
        "reference": reference,
        "paper_note": data.get("paper_note", ""),
    }


def _scalars(source, data, resolve) -> tuple[str, str, int, int]:
    """(name, task, episodes, base_seed), checked."""
    task = data["task"]
    name = data.get("name", "")
    if name and (not name.strip() or "/" in name or "\\" in name):
        raise ExperimentError(source, "name", f"{name!r}: a name is a word, not a path")
    if resolve:
        from dcmppi.tasks import TASKS

        if task not in TASKS:
            raise ExperimentError(
                source, "task", f"unknown task {task!r}; valid: {', '.join(TASKS)}"
            )
    episodes = data["episodes"]
    if episodes < 1:
        raise ExperimentError(source, "episodes", f"must be >= 1, got {episodes}")
    base_seed = data.get("base_seed", 0)
    if base_seed < 0:
        raise ExperimentError(source, "base_seed", f"must be >= 0, got {base_seed}")
    return name, task, episodes, base_seed


def _environments(source, data, env_param) -> tuple[int, str | None]:
    """(env_offset, tuning), checked: both only with env_param."""
    for key in ("env_offset", "tuning"):
        if key in data and env_param is None:
            raise ExperimentError(
                source, key, "only with env_param (without it environment i is its seed's)"
            )
    env_offset, tuning = data.get("env_offset", 0), data.get("tuning")
    if env_offset < 0:
        raise ExperimentError(source, "env_offset", f"must be >= 0, got {env_offset}")
    if tuning is not None and tuning not in TUNING:
        raise ExperimentError(
            source, "tuning", f"{tuning!r}; valid: {', '.join(map(repr, TUNING))}"
        )
    return env_offset, tuning


def _noises(source, noises: list) -> tuple[str, ...]:
    """The noise profiles: at least one, each known, none twice."""
    noises = tuple(noises)
    if not noises:
        raise ExperimentError(source, "noises", "empty; give at least one noise profile")
    for i, noise in enumerate(noises):
        if noise not in NOISE_PROFILES:
            raise ExperimentError(
                source,
                f"noises[{i}]",
                f"unknown noise profile {noise!r}; valid: {', '.join(NOISE_PROFILES)}",
            )
    if len(set(noises)) < len(noises):
        raise ExperimentError(source, "noises", f"repeats a profile: {list(noises)}")
    return noises


def _env_param(source, data) -> str | None:
    """The task parameter set to the environment index: a name no task_params entry sets."""
    env_param = data.get("env_param")
    if env_param is None:
        return None
    if env_param in RESERVED["task_params"] or not env_param.isidentifier():
        raise ExperimentError(
            source, "env_param", f"{env_param!r}: name a task parameter (e.g. world)"
        )
    if env_param in data.get("task_params", {}):
        raise ExperimentError(
            source,
            f"task_params.{env_param}",
            f"set per environment (env_param = {env_param!r}); remove it",
        )
    return env_param


def _rows(source, rows: list, resolve) -> tuple[dict, ...]:
    """The rows checked (`_row`), at least one, no label twice."""
    if not rows:
        raise ExperimentError(source, "rows", "empty; give at least one [[rows]] table")
    rows = tuple(_row(source, i, row, resolve) for i, row in enumerate(rows))
    labels = [row["label"] for row in rows]
    for i, label in enumerate(labels):
        if label in labels[:i]:
            raise ExperimentError(source, f"rows[{i}].label", f"{label!r} is used twice")
    return rows


def _row(source, i, data, resolve) -> dict:
    key = f"rows[{i}]"
    _table(source, key, data, ROW_KEYS, ("controller",))
    controller = data["controller"]
    if resolve:
        from dcmppi.bench.episodes.plugins import resolve_controller

        try:
            resolve_controller(controller)
        except ValueError as e:
            raise ExperimentError(source, f"{key}.controller", str(e)) from None
    label = data.get("label", controller)
    if not label.strip() or "," in label:
        raise ExperimentError(
            source, f"{key}.label", f"{label!r}: labels are non-empty and have no comma"
        )
    paper = {}
    for noise, figures in data.get("paper", {}).items():
        where = f"{key}.paper.{noise}"
        if noise not in NOISE_PROFILES:
            raise ExperimentError(
                source,
                where,
                f"unknown noise profile {noise!r}; valid: {', '.join(NOISE_PROFILES)}",
            )
        _table(source, where, figures, PAPER_KEYS)
        for name, value in figures.items():
            if value < 0 or (name == "failure_pct" and value > 100):
                raise ExperimentError(source, f"{where}.{name}", f"out of range: {value}")
        paper[noise] = dict(figures)
    return {
        "label": label,
        "controller": controller,
        "params": check_params(source, f"{key}.params", data.get("params", {}), RESERVED["params"]),
        "paper": paper,
    }


def check_params(source, key, data, reserved) -> dict:
    """`data` (parameters at `key`) checked: no name in `reserved`, values JSON without NaN or
    infinities, a model recipe's keys and types (`recipes.check`); a copy."""
    out = _check_values(source, key, data, reserved)
    for name, value in out.items():
        if recipes.is_recipe(name, value):
            try:
                recipes.check(f"{key}.{name}", value)
            except recipes.RecipeError as e:
                where = f"{key}.{name}"
                raise ExperimentError(source, where, f"model recipe: {e.reason}") from None
    return out
