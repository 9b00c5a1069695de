"""The algorithms: analytic agents, the objective and its obstacle predictors, DBSCAN, and the
MPPI / Clustered / DC / Tube planners.

    registry.py      make_controller, controller_names, register (built-ins load on first use)
    controller.py    Controller: parameters, one step's frame, sampling, projection, rollouts
    mppi.py, clustered.py, dc.py, tube.py   the planners (paper Alg. 1-3, Tube-MPPI)
    objective.py     Objective: goal distance + static cost map + moving-obstacle term
    predictors/      frozen, prior, ekf: the moving obstacles' tracks (register_predictor)
    diagnostics.py   one record per planner kind of what a step computed
    agents/          dubins, unicycle, holonomic and the projection kernels
    costs.py, dbscan.py, dynamics.py, normal.py   compiled kernels
    defaults.py, validation.py, timer.py          planner defaults, checks, the profile's hook

Pure numpy, numba, scipy and scikit-learn. May import nothing of MuJoCo, dm_control,
dcmppi.tasks, dcmppi.bench or dcmppi.render (tests/test_architecture.py checks this).
`import dcmppi.control` loads no planner (and so neither scipy nor scikit-learn) until the
registry is used or a planner module is imported.
"""

from .controller import Controller
from .diagnostics import ClusteredDiagnostics, Diagnostics, TubeDiagnostics
from .objective import Objective
from .predictors import (
    Prediction,
    Predictor,
    make_predictor,
    predictor_names,
    register_predictor,
)
from .registry import controller_class, controller_names, make_controller, register

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
