"""The rows of `dcmppi timing`, and the cases of `--fingerprint` and `--profile`."""

import dataclasses


@dataclasses.dataclass(frozen=True)
class Case:
    """One timing row: a controller with parameters on a problem (loop.PROBLEMS), its reference
    row (ratios are to its median) and its target (ms, or a ratio to the reference)."""

    label: str
    controller: str
    problem: str
    params: dict = dataclasses.field(default_factory=dict)
    reference: str = "mppi"
    target_ms: float | None = None
    target_ratio: float | None = None


TV, MIXED = {"perturbation": "time_varying"}, {"perturbation": "mixed"}
# the pedestrian experiments' shared parameters (those of `dynamic`): the holonomic robot
WALK = {"agent": "holonomic", **MIXED, "Sigma": [1.0, 1.0, 0.1], "gamma": 1.0, "beta": 100.0}
CV, SOCIAL = {**WALK, "prediction": "cv"}, {**WALK, "prediction": "social"}
BIG = {**TV, "K": 2048, "N": 100}
# the learned predictor's model: square-orca's recipe (200 episodes of the square's ORCA crowd
# recorded under base seed 1), trained on first use into the model cache (`with_model`), the
# same file as that experiment's dc-learned row
LEARNED_MODEL = {
    "record": {
        "task": "square",
        "task_params": {"behavior": "orca", "robot_visible": False},
        "episodes": 200,
        "base_seed": 1,
    },
    "seed": 0,
    "period": 0.4,
}
LEARNED = {**WALK, "prediction": "learned", "model": LEARNED_MODEL}
BASE_CASES = (
    Case("mppi", "mppi", "forest", target_ms=0.2),
    Case("mppi tv", "mppi", "forest", TV, target_ms=0.3),
    Case("mppi mixed", "mppi", "forest", MIXED),
    Case("mppi auto", "mppi", "forest", {"lambda_": "auto"}),  # the chosen temperature
    Case("clustered", "clustered", "forest", target_ratio=1.2),
    Case("tube", "tube", "forest", target_ratio=2.5),
    Case("tube", "tube", "forest+push", target_ratio=2.5),
    # agents: the same problem and perturbation kind as their dubins reference row
    Case(
        "mppi unicycle",
        "mppi",
        "forest",
        {"agent": "unicycle", "perturbation": "constant"},
        target_ratio=1.5,
    ),
    Case(
        "mppi holonomic",
        "mppi",
        "forest",
        {"agent": "holonomic", "perturbation": "constant"},
        target_ratio=1.5,
    ),
    Case(
        "mppi unicycle tv",
        "mppi",
        "forest",
        {"agent": "unicycle", **TV},
        "mppi tv",
        target_ratio=1.5,
    ),
    Case(
        "mppi holonomic mixed",
        "mppi",
        "forest",
        {"agent": "holonomic", **MIXED},
        "mppi mixed",
        target_ratio=1.5,
    ),
    Case("mppi", "mppi", "crowd"),
    Case("clustered", "clustered", "crowd"),
    Case("dc", "dc", "crowd", target_ms=2.0),
    Case(
        "dc holonomic",
        "dc",
        "crowd",
        {"agent": "holonomic", **MIXED, "Sigma": [1.0, 1.0, 0.1]},
        target_ms=2.0,
    ),
    # pedestrians: 12 in the corridor, 100 walkers in the crowd
    Case("mppi", "mppi", "corridor", WALK),
    Case("dc", "dc", "corridor", WALK),
    Case("dc-cv", "dc", "corridor", CV),
    Case("dc-social", "dc", "corridor", SOCIAL, target_ms=5.0),
    Case("mppi", "mppi", "crowd-sf", WALK),
    Case("dc-social", "dc", "crowd-sf", SOCIAL, target_ms=20.0),
    # the size practitioners run, and its samples split over 2 threads (same plan:
    # the two rows' fingerprints are equal)
    Case("mppi tv 2048x100", "mppi", "forest", BIG),
    Case(
        "mppi tv 2048x100 threads=2",
        "mppi",
        "forest",
        {**BIG, "threads": 2},
        "mppi tv 2048x100",
        target_ratio=round(1 / 1.7, 2),
    ),
)
# the learned predictor among 20 and 100 walkers (its model trained first where not cached)
LEARNED_CASES = (
    Case("dc-cv", "dc", "crowd-sf-20", CV, "dc-cv"),
    Case("dc-learned", "dc", "crowd-sf-20", LEARNED, "dc-cv", target_ms=5.0),
    Case("dc-cv", "dc", "crowd-sf", CV),
    Case("dc-learned", "dc", "crowd-sf", LEARNED, "dc-cv", target_ms=20.0),
    # its k-d tree's exact search (the default is approximate: learned.APPROXIMATION)
    Case("dc-learned exact", "dc", "crowd-sf-20", {**LEARNED, "approximation": 0.0}, "dc-cv"),
    Case("dc-learned exact", "dc", "crowd-sf", {**LEARNED, "approximation": 0.0}, "dc-cv"),
)
# the smooth preset beside each paper mode on the same problem: its correlated draws, filter and
# chosen temperature may cost at most 15 % more
SMOOTH = {"preset": "smooth", "perturbation": "correlated"}  # as the experiments' smooth rows
SMOOTH_CASES = tuple(
    Case(f"{label}+smooth", controller, problem, {**params, **SMOOTH}, label, target_ratio=1.15)
    for label, controller, problem, params in (
        ("mppi", "mppi", "corridor", WALK),
        ("dc", "dc", "corridor", WALK),
        ("dc-cv", "dc", "corridor", CV),
        ("mppi", "mppi", "crowd-sf", WALK),
    )
)
# the safety shield after a planner and a classical planner among the corridor's 12 walkers:
# its linear programs may cost at most 15 % of dc-cv's step
SHIELD = {"shield": True}
SHIELD_CASES = (
    Case("dc-cv+shield", "dc", "corridor", {**CV, **SHIELD}, "dc-cv", target_ratio=1.15),
    Case("dc-cv+smooth+shield", "dc", "corridor", {**CV, **SMOOTH, **SHIELD}, "dc-cv+smooth"),
)
# the crowds preset as the rows dc-recommended run it: at most 2 x dc-cv's step
CROWDS = {"preset": "crowds", "perturbation": "correlated", "gamma": 0.1, "beta": 50.0}
CROWDS_CASES = (
    Case("dc-recommended", "dc", "corridor", {**CV, **CROWDS}, "dc-cv", target_ratio=2.0),
)
CASES = BASE_CASES + SMOOTH_CASES + SHIELD_CASES + CROWDS_CASES + LEARNED_CASES

# `--fingerprint`: every row of the table and the variants that take other code paths
# (the learned rows aside: their plans depend on a trained model's bytes)
VARIANTS = (
    Case("dc ekf", "dc", "crowd", {"prediction": "ekf"}),
    Case("dc tv", "dc", "crowd", TV),
    Case("dc unicycle", "dc", "crowd", {"agent": "unicycle"}),
    Case("clustered unicycle", "clustered", "forest", {"agent": "unicycle"}),
    Case("clustered holonomic", "clustered", "forest", {"agent": "holonomic"}),
    Case("clustered tv", "clustered", "forest", TV),
    Case("clustered mixed", "clustered", "forest", MIXED),
    Case("tube unicycle", "tube", "forest+push", {"agent": "unicycle"}),
    Case("tube holonomic", "tube", "forest+push", {"agent": "holonomic"}),
    Case("mppi unicycle mixed", "mppi", "forest", {"agent": "unicycle", **MIXED}),
    Case("mppi holonomic tv", "mppi", "forest", {"agent": "holonomic", **TV}),
)
# the smooth preset's paths (its rows, correlated draws in the clustered features), after the
# others so that a machine's older fingerprints stay comparable
CORRELATED = {"agent": "holonomic", "perturbation": "correlated"}
PRESET_VARIANTS = SMOOTH_CASES + (Case("clustered correlated", "clustered", "forest", CORRELATED),)
# the options for time to the goal (dcmppi.control.pace, planners.speeds), after those
PACE = {"cost_to_go": 10.0, "path_align": 1.0, "speed_weight": 1.0}
POLAR = {"speed_mean": "polar"}
PACE_VARIANTS = (
    Case("dc-cv+smooth pace", "dc", "corridor", {**CV, **SMOOTH, **PACE}),
    Case("dc-cv+smooth polar", "dc", "corridor", {**CV, **SMOOTH, **POLAR}),
    Case("mppi+smooth polar", "mppi", "corridor", {**WALK, **SMOOTH, **POLAR}),
    Case("tube holonomic polar", "tube", "forest+push", {"agent": "holonomic", **POLAR}),
)
# the shield's paths for the other agents (it turns the unicycle and slows it, turns the car)
# where it changes their commands
SHIELD_VARIANTS = SHIELD_CASES + tuple(
    Case(f"dc-cv {agent}+shield", "dc", "corridor", {"agent": agent, "prediction": "cv", **SHIELD})
    for agent in ("unicycle", "dubins")
)
FINGERPRINT_CASES = (
    BASE_CASES + VARIANTS + PRESET_VARIANTS + PACE_VARIANTS + SHIELD_VARIANTS + CROWDS_CASES
)

# `--profile`
PROFILE_CASES = (
    Case("mppi", "mppi", "forest"),
    Case("mppi tv", "mppi", "forest", TV),  # the peer's problem: nu x N x K normals per step
    Case("clustered", "clustered", "forest"),
    Case("dc", "dc", "crowd"),
    # the agents on mppi's problem and perturbation kind: their rollouts beside dubins'
    Case("mppi unicycle", "mppi", "forest", {"agent": "unicycle", "perturbation": "constant"}),
    Case("mppi holonomic", "mppi", "forest", {"agent": "holonomic", "perturbation": "constant"}),
    # the holonomic robot's default (mixed) beside the car's: 3 x the normals per step
    Case("mppi mixed", "mppi", "forest", MIXED),
    Case("mppi holonomic mixed", "mppi", "forest", {"agent": "holonomic", **MIXED}),
    Case("dc-social", "dc", "corridor", SOCIAL),  # the social predictor's share of a step
)


def with_model(params: dict) -> dict:
    """`params` with a model recipe (a table for `model`, resolved as
    dcmppi.bench.crowds.recipes resolves one) replaced by the path of its trained file."""
    from dcmppi.bench.crowds import recipes

    recipe = params.get(recipes.PARAM)
    if not recipes.is_recipe(recipes.PARAM, recipe):
        return params
    return {**params, recipes.PARAM: str(recipes.ensure("dcmppi timing", recipe))}
