"""Experiments: TOML files of named rows (a controller with parameters) run as paired episodes.

Environment i of an experiment has one seed, shared by every row and noise profile: the same
world, the same start and goal, the same noise sequence and the same controller sampling
stream. That makes every comparison paired. An experiment with `env_param` (e.g. "world", the
BARN world of the `layout` task) also sets that task parameter to i in environment i. The
shipped experiments (static, dynamic, dynamic-dubins, barn) are TOML files beside this module;
`load_experiment` takes their names or a path. The file format: `dcmppi.bench.experiments.schema`.

A controller parameter `model` given as a table is a model recipe (dcmppi.bench.crowds.recipes):
environment i's spec holds the path of a `learned` predictor's model trained for it (e.g. on the
ETH/UCY scenes other than environment i's), trained on first use and cached.

May import dcmppi.tasks (task names, noise profiles), dcmppi.bench.episodes (controller names,
the environments' seeds) and the model recipes of dcmppi.bench.crowds; runs no episode itself.
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

from dcmppi.bench.crowds import recipes
from dcmppi.bench.episodes.runner import EpisodeSpec
from dcmppi.bench.episodes.seeds import environment_seed
from dcmppi.bench.experiments.schema import RESERVED, ExperimentError, check_params, parse

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

TUNING_SEED = 7919  # added to an experiment's base seed for its tuning environments

__all__ = [
    "TUNING_SEED",
    "Experiment",
    "ExperimentError",
    "Paper",
    "Row",
    "experiment_names",
    "load_experiment",
]


class Paper(NamedTuple):
    """The paper's figures of one (noise, row); None where it gives none."""

    collisions: int | None = None
    failure_pct: float | None = None
    ms_per_step: float | None = None


@dataclasses.dataclass(frozen=True)
class Row:
    """A row of the table: `label`, the `controller` name, its own `params` and the paper's
    figures per noise profile, {noise: {"collisions", "failure_pct", "ms_per_step"}}."""

    label: str
    controller: str
    params: dict = dataclasses.field(default_factory=dict)
    paper: dict = dataclasses.field(default_factory=dict)


@dataclasses.dataclass(frozen=True)
class Experiment:
    """An experiment: task, rows, noise profiles, environment count, parameters.

    `task`, `task_params`, `controller_params` (shared by every row), `base_seed`, `env_param`
    and each row's controller and params are what a results database is bound to (`config`);
    `selected` rows, `noises` and `episodes` only choose which of its episodes to run, so a
    database can be extended with more of them.
    """

    name: str
    task: str
    rows: tuple[Row, ...]
    noises: tuple[str, ...]
    episodes: int
    base_seed: int = 0
    task_params: dict = dataclasses.field(default_factory=dict)
    controller_params: dict = dataclasses.field(default_factory=dict)
    env_param: str | None = None  # task parameter set to env_offset + the environment index
    env_offset: int = 0
    tuning: str | None = None  # with env_param: how `for_tuning` draws environments
    reference: str | None = None
    description: str = ""
    paper_note: str = ""
    selected: tuple[str, ...] = ()  # labels to run; () = every row

    @classmethod
    def from_dict(cls, data: dict, source: str, resolve: bool = True) -> Experiment:
        """An experiment from its TOML/JSON form (see `schema`); `source` names it in errors."""
        data = dict(data)
        selected = tuple(data.pop("selected", ()))
        args = parse(data, source, resolve)
        rows = tuple(Row(**row) for row in args.pop("rows"))
        labels = [row.label for row in rows]
        unknown = [label for label in selected if label not in labels]
        if unknown:  # a stored database's selection, or a hand-written one
            raise ExperimentError(
                source, "selected", f"{', '.join(map(repr, unknown))}: no row label; labels: "
                f"{', '.join(labels)}"
            )  # fmt: skip
        return cls(**args, rows=rows, selected=selected)

    def to_dict(self) -> dict:
        """The TOML/JSON form, with the selected labels (what a results database stores)."""
        return {
            "name": self.name,
            "description": self.description,
            "task": self.task,
            "noises": list(self.noises),
            "episodes": self.episodes,
            "base_seed": self.base_seed,
            **self._environments(),
            **({"tuning": self.tuning} if self.tuning else {}),
            **({"reference": self.reference} if self.reference else {}),
            "paper_note": self.paper_note,
            "task_params": self.task_params,
            "controller_params": self.controller_params,
            "rows": [dataclasses.asdict(row) for row in self.rows],
            "selected": list(self.labels),
        }

    @property
    def labels(self) -> tuple[str, ...]:
        """Labels of the rows to run."""
        return self.selected or tuple(row.label for row in self.rows)

    def row(self, label: str) -> Row:
        return next(row for row in self.rows if row.label == label)

    def paper(self, noise: str, label: str) -> Paper:
        """The paper's figures of (noise, row `label`)."""
        rows = [row for row in self.rows if row.label == label]
        return Paper(**rows[0].paper.get(noise, {})) if rows else Paper()

    def seed(self, index: int) -> int:
        """World/noise/controller seed of environment `index` (independent streams)."""
        return environment_seed(self.base_seed, index)

    def config(self) -> dict:
        """What a results database is bound to: rows made under another config differ."""
        return {
            "task": self.task,
            "base_seed": self.base_seed,
            **self._environments(),
            "task_params": self.task_params,
            "controller_params": self.controller_params,
            "rows": {r.label: {"controller": r.controller, "params": r.params} for r in self.rows},
        }

    def spec(self, noise: str, label: str, index: int) -> EpisodeSpec:
        """The episode of row `label` in environment `index` under `noise`."""
        row = self.row(label)
        task_params = dict(self.task_params)
        if self.env_param:
            task_params[self.env_param] = self.env_offset + index
        return EpisodeSpec(
            task=self.task,
            controller=row.controller,
            noise=noise,
            seed=self.seed(index),
            task_params=task_params,
            controller_params=self._models(f"row {label!r}", row.params, task_params, index),
            shared_params=self._models("controller_params", self.controller_params, task_params,
                                       index),
        )  # fmt: skip

    def _models(self, where: str, params: dict, task_params: dict, index: int) -> dict:
        """`params` with each model recipe replaced by the path of its trained file, trained
        first where it is missing (`recipes`)."""
        out = dict(params)
        for name, value in params.items():
            if recipes.is_recipe(name, value):
                resolved = recipes.resolve(where, value, self, task_params, index)
                out[name] = str(recipes.ensure(where, resolved))
        return out

    def specs(
        self, shard: tuple[int, int] = (0, 1)
    ) -> Iterator[tuple[tuple[str, str, int], EpisodeSpec]]:
        """(key, spec) for every selected episode of `shard` (i, n): the environments whose
        index % n == i; key = (noise, row label, env_index). Made one by one (an iterator).

        Ordered by environment first, so a partial run holds complete pairs.
        """
        for index in self.indices(shard):
            for noise in self.noises:
                for label in self.labels:
                    yield (noise, label, index), self.spec(noise, label, index)

    def indices(self, shard: tuple[int, int] = (0, 1)) -> range:
        """The environments of `shard` (i, n): index % n == i."""
        i, n = shard
        return range(i, self.episodes, n)

    def count(self, shard: tuple[int, int] = (0, 1)) -> int:
        """The number of episodes `specs(shard)` yields."""
        return len(self.indices(shard)) * len(self.noises) * len(self.labels)

    def wants(self, key: tuple[str, str, int], shard: tuple[int, int] = (0, 1)) -> bool:
        """Whether `specs(shard)` yields episode `key` = (noise, label, env_index)."""
        noise, label, index = key
        return noise in self.noises and label in self.labels and index in self.indices(shard)

    def for_tuning(self) -> Experiment:
        """This experiment on its tuning environments, to choose parameters on without the test
        environments: base seed + TUNING_SEED and, with env_param, as its `tuning` says ("seeds":
        env_param dropped, the task draws each environment from its seed; "beyond": the cases
        after the test's, env_offset + episodes + i). Its name is NAME-tuning; the paper's
        figures are left out. ValueError where env_param has no `tuning`."""
        if self.env_param and self.tuning is None:
            raise ValueError(
                f"experiment {self.name} has no tuning environments: environment i is its "
                f'{self.env_param} {self.env_offset} + i (declare tuning = "seeds" or '
                '"beyond" in its file where other environments exist)'
            )
        draw = {}
        if self.tuning == "seeds":
            draw = {"env_param": None, "env_offset": 0}
        elif self.tuning == "beyond":
            draw = {"env_offset": self.env_offset + self.episodes}
        return dataclasses.replace(
            self,
            name=f"{self.name}-tuning",
            base_seed=self.base_seed + TUNING_SEED,
            rows=tuple(dataclasses.replace(row, paper={}) for row in self.rows),
            paper_note="",
            tuning=None,
            **draw,
        )

    def _environments(self) -> dict:
        """env_param and a nonzero env_offset, as stored (`to_dict`, `config`)."""
        if not self.env_param:
            return {}
        offset = {"env_offset": self.env_offset} if self.env_offset else {}
        return {"env_param": self.env_param, **offset}

    def select(
        self,
        episodes: int | None = None,
        rows: tuple[str, ...] | None = None,
        noises: tuple[str, ...] | None = None,
    ) -> Experiment:
        """This experiment restricted or extended (command-line options); bad input raises
        ValueError. `rows` are labels or, for a row of its own, a controller name."""
        exp = self
        if episodes is not None:
            if episodes < 1:
                raise ValueError(f"episodes must be >= 1, got {episodes}")
            exp = dataclasses.replace(exp, episodes=episodes)
        if rows is not None:
            if not rows:
                raise ValueError("rows needs at least one row label or controller")
            rows = tuple(dict.fromkeys(rows))
            extra = tuple(_own_row(exp, item) for item in rows if item not in exp._all_labels())
            exp = dataclasses.replace(exp, rows=exp.rows + extra, selected=rows)
        if noises is not None:
            from dcmppi.tasks import NOISE_PROFILES

            bad = [n for n in noises if n not in NOISE_PROFILES]
            if bad or not noises:
                raise ValueError(
                    f"unknown noise profile(s) {', '.join(bad) or '(none given)'}; "
                    f"valid: {', '.join(NOISE_PROFILES)}"
                )
            exp = dataclasses.replace(exp, noises=tuple(dict.fromkeys(noises)))
        return exp

    def with_params(self, task_params: dict, controller_params: dict) -> Experiment:
        """Task and shared controller parameters added (the command line's, `dcmppi.bench.run`'s);
        a name set per episode or a value that is no finite JSON raises ValueError."""
        source = f"experiment {self.name}"
        task_params = check_params(source, "task_params", task_params, RESERVED["task_params"])
        controller_params = check_params(
            source, "controller_params", controller_params, RESERVED["controller_params"]
        )
        if self.env_param in task_params:
            raise ValueError(
                f"--task-param {self.env_param}=...: experiment {self.name} sets "
                f"{self.env_param} to the environment index; choose environments with --episodes"
            )
        return dataclasses.replace(
            self,
            task_params={**self.task_params, **task_params},
            controller_params={**self.controller_params, **controller_params},
        )

    def _all_labels(self) -> list[str]:
        return [row.label for row in self.rows]


def _own_row(exp: Experiment, item: str) -> Row:
    """A row of one controller named on the command line, labelled with its name."""
    from dcmppi.bench.episodes.plugins import resolve_controller

    try:
        resolve_controller(item)
    except ValueError as e:
        raise ValueError(
            f"--controllers: {item!r} is no row of {exp.name} ({', '.join(exp._all_labels())}) "
            f"and {e}"
        ) from None
    return Row(label=item, controller=item)


def experiment_names() -> list[str]:
    """The shipped experiments."""
    files = importlib.resources.files(__name__).iterdir()
    return sorted(f.name.removesuffix(".toml") for f in files if f.name.endswith(".toml"))


def load_experiment(name: str) -> Experiment:
    """A shipped experiment by name, or a TOML file by path; a malformed file raises an
    ExperimentError naming the file, the key and the reason."""
    if name in experiment_names():
        resource = importlib.resources.files(__name__) / f"{name}.toml"
        text, source, stem = resource.read_text(), f"{name}.toml (shipped)", name
    elif name.endswith(".toml") or Path(name).is_file():
        path = Path(name)
        try:
            text = path.read_text()
        except OSError as e:
            raise ValueError(f"{name}: cannot read the experiment file ({e.strerror})") from e
        source, stem = str(path), path.stem
    else:
        raise ValueError(
            f"unknown experiment {name!r}; valid: {', '.join(experiment_names())}, or the path "
            "of a .toml file"
        )
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ExperimentError(source, "TOML syntax", str(e)) from None
    exp = Experiment.from_dict(data, source)
    return exp if exp.name else dataclasses.replace(exp, name=stem)
