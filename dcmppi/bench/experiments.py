"""The paper's experiments (SPEC section 4) as lists of paired episodes.

Environment i of an experiment has one seed, shared by every controller and noise
profile: the same world, the same start and goal, the same noise sequence and the same
controller sampling stream. That makes every comparison paired.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from dcmppi.bench.runner import EpisodeSpec
from dcmppi.control.defaults import NOISE_PROFILES


@dataclasses.dataclass(frozen=True)
class Experiment:
    """An experiment: task, controllers, noise profiles, environment count, parameters.

    `task_params` and `controller_params` are the fixed configuration a results database
    is bound to; `controllers`, `noises` and `episodes` only choose which of its episodes
    to run, so a database can be extended with more of them.
    """

    name: str
    task: str
    controllers: tuple[str, ...]
    noises: tuple[str, ...]
    episodes: int
    base_seed: int = 2024
    task_params: dict = dataclasses.field(default_factory=dict)
    controller_params: dict = dataclasses.field(default_factory=dict)

    def seed(self, index: int) -> int:
        """World/noise/controller seed of environment `index` (independent streams)."""
        return int(np.random.SeedSequence([self.base_seed, index]).generate_state(1)[0])

    def config(self) -> dict:
        """What a results database is bound to: rows made under another config differ."""
        return {
            "experiment": self.name,
            "task": self.task,
            "base_seed": self.base_seed,
            "task_params": self.task_params,
            "controller_params": self.controller_params,
        }

    def specs(self) -> list[tuple[tuple[str, str, int], EpisodeSpec]]:
        """(key, spec) for every episode, key = (noise, controller, env_index).

        Ordered by environment first, so a partial run holds complete pairs.
        """
        out = []
        for index in range(self.episodes):
            for noise in self.noises:
                for controller in self.controllers:
                    spec = EpisodeSpec(
                        task=self.task,
                        controller=controller,
                        noise=noise,
                        seed=self.seed(index),
                        task_params=dict(self.task_params),
                        controller_params=dict(self.controller_params),
                    )
                    out.append(((noise, controller, index), spec))
        return out


EXPERIMENTS = {
    "static": Experiment(
        name="static",
        task="forest",
        controllers=("mppi", "tube", "clustered"),
        noises=NOISE_PROFILES,
        episodes=1000,
    ),
    "dynamic": Experiment(
        name="dynamic",
        task="crowd",
        controllers=("mppi", "clustered", "dc", "tube"),
        noises=("none",),
        episodes=100,
    ),
}

# The paper's figures (Table I and Sec. IV-B), shown beside ours in reports.
PAPER = {
    "static": {
        ("none", "mppi"): (11, 1.2, 190),
        ("none", "tube"): (9, 1.2, 364),
        ("none", "clustered"): (6, 0.9, 193),
        ("control", "mppi"): (59, 6.0, 195),
        ("control", "tube"): (44, 4.5, 376),
        ("control", "clustered"): (26, 2.9, 199),
        ("process", "mppi"): (48, 4.9, 355),
        ("process", "tube"): (49, 5.0, 376),
        ("process", "clustered"): (37, 3.9, 360),
    },
    "dynamic": {
        ("none", "mppi"): (3, None, 283),
        ("none", "clustered"): (2, None, 288),
        ("none", "dc"): (0, None, 454),
    },
}


def get_experiment(
    name: str,
    episodes: int | None = None,
    controllers: tuple[str, ...] | None = None,
    noises: tuple[str, ...] | None = None,
) -> Experiment:
    """The named experiment, optionally restricted or extended; bad input raises ValueError."""
    if name not in EXPERIMENTS:
        raise ValueError(f"unknown experiment {name!r}; valid: {', '.join(EXPERIMENTS)}")
    exp = EXPERIMENTS[name]
    if episodes is not None:
        if episodes < 1:
            raise ValueError(f"--episodes must be >= 1, got {episodes}")
        exp = dataclasses.replace(exp, episodes=episodes)
    if controllers is not None:
        from dcmppi import controller_names

        bad = [c for c in controllers if c not in controller_names()]
        if bad or not controllers:
            raise ValueError(
                f"unknown controller(s) {', '.join(bad) or '(none given)'}; "
                f"valid: {', '.join(controller_names())}"
            )
        exp = dataclasses.replace(exp, controllers=tuple(controllers))
    if noises is not None:
        bad = [n for n in noises if n not in NOISE_PROFILES]
        if bad or not noises:
            raise ValueError(
                f"unknown noise profile(s) {', '.join(bad) or '(none given)'}; "
                f"valid: {', '.join(NOISE_PROFILES)}"
            )
        exp = dataclasses.replace(exp, noises=tuple(noises))
    return exp
