"""Model recipes: a controller parameter `model` given as a table, resolved per environment into
the file of a `learned` predictor's model, trained on first use and cached.

    params = { prediction = "learned", model = { leave_out = "{scene}" } }           # ETH/UCY
    params = { prediction = "learned", model = { record = { episodes = 100, base_seed = 1 } } }

A recipe names its data by one of:
- `leave_out = SCENE`: the ETH/UCY files of the standard split that leaves SCENE out
  (`recordings.train_files`), found in `folder`, else the folder the environment's task
  parameter `path` names, else $DCMPPI_CROWDS (as the replay task finds them);
- `data = [FILES]`: four-column files, paths or names of recordings.FILES (found alike);
- `record = { episodes, base_seed, task, task_params, seconds }`: the crowds of `episodes`
  episodes of `task` (default: the experiment's, with its task parameters, the environment
  index's left out) under the seeds of `base_seed`, which must differ from the experiment's (so
  none is a test environment's), recorded as `dcmppi record` records them
  (`dcmppi.bench.crowds.recording`);
and may set the training as `dcmppi predictor train` takes it: `seed` (default 0), `period`
(the frame period every file is read at, default recordings.PERIOD), `frame_step` (the video
frames between annotated frames, default: each file's own), `max_windows`.

A string value may name the environment's task parameters in braces: "{scene}" is the task
parameter `scene` of that environment (the environment index where it is the experiment's
`env_param`); a list-valued parameter that an experiment with `env_param` cycles through (the
replay task's scene list: environment i plays scene i % S) gives its element i % S.

`Experiment.spec` puts the path of the trained file in the controller parameter `model`:
MODELS_ENV's folder (default MODELS_DIR, relative to the current directory, like the default
results database), named by the data and a hash of everything the model's bytes depend on (the
resolved recipe, the data files' sha256, the sources of the training and, for recorded crowds,
of the tasks). A missing file is trained there at once, by the code of `dcmppi predictor train`
(deterministic: the same inputs give the same bytes), written atomically, with a JSON beside it
(the recipe, the inputs' and the model's sha256). The results database's configuration holds
the recipe; provenance holds the resolved path (and its sha256). Data that is missing fails
with one line naming the fix.
"""

from __future__ import annotations

import functools
import hashlib
import importlib.util
import json
import os
import pathlib
import string
import sys

from dcmppi.bench.crowds import recording, training
from dcmppi.control.predictors import learned
from dcmppi.tasks.replay import recordings

MODELS_ENV = "DCMPPI_MODELS"  # environment variable naming the cache folder of trained models
MODELS_DIR = "results/models"
PARAM = "model"  # the controller parameter a recipe stands for
SOURCES = ("leave_out", "data", "record")
KEYS = {
    "leave_out": str,
    "data": list,
    "record": dict,
    "seed": int,
    "period": float,
    "frame_step": int,
    "max_windows": int,
    "folder": str,
}
RECORD_KEYS = {
    "episodes": int,
    "base_seed": int,
    "task": str,
    "task_params": dict,
    "seconds": float,
}
# the modules whose code makes a model's bytes (module names, read as files, not imported)
TRAINING_CODE = (
    "dcmppi.control.predictors.learned.model",
    "dcmppi.control.predictors.learned.training",
    "dcmppi.tasks.replay.recordings",
    "dcmppi.tasks.replay.checks",
    "dcmppi.bench.crowds.training",
    "dcmppi.bench.crowds.recipes",
)
RECORDING_CODE = (
    "dcmppi.bench.crowds.recording",
    "dcmppi.bench.episodes.futures",
    "dcmppi.bench.episodes.seeds",
)


class RecipeError(ValueError):
    """A malformed or unresolvable recipe: `where: model recipe: reason`."""

    def __init__(self, where: str, reason: str):
        super().__init__(f"{where}: model recipe: {reason}")
        self.reason = reason


def is_recipe(name: str, value) -> bool:
    """Whether parameter `name` = `value` is a model recipe (a table given for `model`)."""
    return name == PARAM and isinstance(value, dict)


def check(where: str, recipe: dict) -> dict:
    """The recipe checked for its keys and types (placeholders not resolved); a RecipeError
    naming `where` and the key otherwise."""
    _keys(where, recipe, KEYS)
    given = [k for k in SOURCES if k in recipe]
    if len(given) != 1:
        raise RecipeError(where, f"name the data by exactly one of {', '.join(SOURCES)}")
    if "data" in recipe and (
        not recipe["data"] or not all(isinstance(f, str) for f in recipe["data"])
    ):
        raise RecipeError(where, "data: a non-empty array of file names or paths")
    if "record" in recipe:
        record = recipe["record"]
        _keys(f"{where}.record", record, RECORD_KEYS)
        for name in ("episodes", "base_seed"):
            if name not in record:
                raise RecipeError(where, f"record.{name}: missing")
        if record["episodes"] < 1 or record["base_seed"] < 0:
            raise RecipeError(where, "record: episodes >= 1 and base_seed >= 0")
    for name in ("period", "frame_step", "max_windows"):
        if name in recipe and not recipe[name] > 0:
            raise RecipeError(where, f"{name}: must be > 0, got {recipe[name]}")
    return recipe


def _keys(where, table, keys):
    for name, value in table.items():
        if name not in keys:
            raise RecipeError(where, f"{name}: unknown key; valid keys: {', '.join(keys)}")
        kind = keys[name]
        ok = isinstance(value, (int, float) if kind is float else kind)
        if not ok or isinstance(value, bool):
            raise RecipeError(where, f"{name}: must be {kind.__name__}, got {value!r}")


def resolve(where: str, recipe: dict, exp, task_params: dict, index: int) -> dict:
    """The concrete recipe of environment `index` of experiment `exp` whose task parameters are
    `task_params` (env_param set): placeholders filled, the data named (file names for
    leave_out), the record's task and parameters filled in, the training's defaults set."""
    check(where, recipe)
    out = {k: _fill(where, v, exp, task_params, index) for k, v in recipe.items()}
    out.setdefault("seed", 0)
    out["period"] = float(out.get("period", recordings.PERIOD))
    if "leave_out" in out:
        try:
            out["data"] = list(recordings.train_files(out["leave_out"]))
        except ValueError as e:
            raise RecipeError(where, f"leave_out: {e}") from None
    if "record" in out:
        record = dict(out["record"])
        if record["base_seed"] == exp.base_seed and record.get("task", exp.task) == exp.task:
            raise RecipeError(
                where,
                f"record.base_seed {record['base_seed']} is the experiment's own: the test "
                "environments' seeds; choose another",
            )
        if "task" not in record:
            record["task"] = exp.task
            record.setdefault(
                "task_params",
                {k: v for k, v in exp.task_params.items() if k != exp.env_param},
            )
        record.setdefault("task_params", {})
        if "seconds" in record:
            record["seconds"] = float(record["seconds"])
        out["record"] = record
    if "folder" not in out and "record" not in out:
        folder = task_params.get("path")
        if isinstance(folder, str) and pathlib.Path(folder).is_dir():
            out["folder"] = folder
    return out


def _fill(where, value, exp, task_params, index):
    """`value` with "{name}" placeholders replaced by the environment's task parameters."""
    if isinstance(value, dict):
        return {k: _fill(where, v, exp, task_params, index) for k, v in value.items()}
    if isinstance(value, list):
        return [_fill(where, v, exp, task_params, index) for v in value]
    if not isinstance(value, str) or "{" not in value:
        return value
    fields = {}
    try:
        names = [name for _, name, _, _ in string.Formatter().parse(value) if name is not None]
    except ValueError as e:
        raise RecipeError(where, f"{value!r}: {e}") from None
    for name in names:
        if name not in task_params:
            known = ", ".join(sorted(task_params)) or "none"
            raise RecipeError(
                where, f"{value!r}: {{{name}}} names no task parameter; task parameters: {known}"
            )
        given = task_params[name]
        if isinstance(given, list):
            if not exp.env_param or not given:
                raise RecipeError(
                    where, f"{value!r}: task parameter {name} is a list and no env_param picks "
                    "one element per environment"
                )  # fmt: skip
            given = given[index % len(given)]
        fields[name] = given
    return value.format_map(fields)


def path_of(where: str, resolved: dict) -> pathlib.Path:
    """The cache file of a resolved recipe (module docstring)."""
    inputs = _inputs(where, resolved)
    key = hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()[:16]
    if "record" in resolved:
        r = resolved["record"]
        slug = f"{r['task']}-{r['episodes']}x-seed{r['base_seed']}"
    elif "leave_out" in resolved:
        slug = f"without-{resolved['leave_out']}"
    else:
        slug = f"data-{len(resolved['data'])}"
    folder = os.environ.get(MODELS_ENV) or MODELS_DIR
    return pathlib.Path(folder) / f"learned-{slug}-{key}.npz"


def _inputs(where, resolved) -> dict:
    """What the model's bytes depend on: the recipe (no folder), data and code sha256."""
    recipe = {k: v for k, v in resolved.items() if k not in ("folder", "leave_out")}
    code = list(TRAINING_CODE)
    data = {}
    if "record" in resolved:
        code += RECORDING_CODE
        code += sorted(_task_modules())
    else:
        for name in resolved["data"]:
            file = _data_file(where, name, resolved.get("folder"))
            data[name] = _file_sha256(str(file), *_stamp(file))
    return {
        "recipe": recipe,
        "data": data,
        "code": {m: _module_sha256(m) for m in code},
    }


def _data_file(where, name, folder) -> pathlib.Path:
    """The file of data `name` (a path, or a name of recordings.FILES in the folder)."""
    path = pathlib.Path(name)
    if path.suffix or os.sep in name:
        if not path.is_file():
            raise RecipeError(where, f"data {name}: no such file")
        return path
    try:
        file = recordings.crowds_folder(folder) / f"{name}.txt"
    except ValueError as e:
        raise RecipeError(where, str(e)) from None
    if not file.is_file():
        raise RecipeError(
            where, f"{file}: no such recording; the folder needs {', '.join(recordings.FILES)}"
        )
    return file


def _stamp(path) -> tuple:
    stat = pathlib.Path(path).stat()
    return stat.st_mtime_ns, stat.st_size


@functools.lru_cache(maxsize=64)
def _file_sha256(path, mtime_ns, size) -> str:
    return hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()


def _module_sha256(module: str) -> str:
    origin = importlib.util.find_spec(module).origin
    return _file_sha256(origin, *_stamp(origin))


def _task_modules() -> list:
    """The modules of dcmppi.tasks and its subpackages (the simulated crowds' code)."""
    folder = pathlib.Path(importlib.util.find_spec("dcmppi.tasks").origin).parent
    return [
        ".".join(["dcmppi.tasks", *p.relative_to(folder).with_suffix("").parts])
        for p in folder.rglob("*.py")
        if p.stem != "__init__"
    ]


def ensure(where: str, resolved: dict) -> pathlib.Path:
    """The cache file of `resolved`, trained first where it is missing (module docstring)."""
    path = path_of(where, resolved)
    if path.is_file():
        return path
    print(f"dcmppi: training the learned model {path} (first use; cached)", file=sys.stderr)
    try:
        build(resolved, path)
    except ValueError as e:
        raise RecipeError(where, str(e)) from None
    return path


def build(resolved: dict, path) -> None:
    """Trains the model of `resolved` into `path` (atomically) and writes its JSON beside it."""
    if "record" in resolved:
        r = resolved["record"]
        data = [
            recording.record(
                r["task"], r["task_params"], r["episodes"], r["base_seed"], resolved["period"],
                r.get("seconds"),
            )
        ]  # fmt: skip
    else:
        data = training.read(
            resolved["data"],
            resolved.get("folder"),
            resolved["period"],
            frame_step=resolved.get("frame_step"),
        )
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    part = path.with_name(f".{path.name}.{os.getpid()}.part")
    try:
        model = training.train(data, part, resolved["seed"], resolved.get("max_windows"))
        info = {
            "recipe": resolved,
            "inputs": _inputs(str(path), resolved),
            "windows": len(model.features),
            "shrink": model.shrink,
            "sha256": learned.sha256(part),
        }
        path.with_suffix(".json").write_text(json.dumps(info, indent=1, sort_keys=True) + "\n")
        os.replace(part, path)
    finally:
        part.unlink(missing_ok=True)
