"""The algorithms: analytic agents, the objective and its obstacle predictors, and the
MPPI / Clustered / DC / Tube planners, in layers (each imports only those above it here):

    kernels/         compiled numerics: rollouts, costs, draws, projection, sums, DBSCAN
    agents/          dubins, unicycle, holonomic: bounds and rollouts (register_agent)
    predictors/      frozen, prior, ekf, cv, social, given, learned: the moving obstacles' futures
    objective.py     Objective: goal distance + static cost map + moving-obstacle term (+ Pace)
    planners/        Controller and mppi, clustered, dc, tube, their smoothing; the classical
                     orca, hrvo, hl, social_force, dwa; the controllers' registry
    defaults.py, validation.py, registry.py, timer.py   defaults, checks, named registries,
                     the profile's hook (usable by every layer)

numpy, numba, scipy and scikit-learn (navground, for the classical orca, hrvo and hl, when one is
built). May import nothing of MuJoCo, dm_control,
dcmppi.tasks, dcmppi.bench or dcmppi.render (tests/test_architecture.py checks this and the
layers). `import dcmppi.control` loads no planner (and so neither scipy nor scikit-learn)
until the registry is used or a planner module is imported.
"""

from dcmppi.control.objective import Objective
from dcmppi.control.planners.controller import Controller
from dcmppi.control.planners.diagnostics import ClusteredDiagnostics, Diagnostics, TubeDiagnostics
from dcmppi.control.planners.registry import (
    controller_class,
    controller_names,
    make_controller,
    register,
)
from dcmppi.control.predictors import (
    Prediction,
    Predictor,
    make_predictor,
    predictor_names,
    register_predictor,
)

__all__ = [
    "ClusteredDiagnostics",
    "Controller",
    "Diagnostics",
    "Objective",
    "Prediction",
    "Predictor",
    "TubeDiagnostics",
    "controller_class",
    "controller_names",
    "make_controller",
    "make_predictor",
    "predictor_names",
    "register",
    "register_predictor",
]
