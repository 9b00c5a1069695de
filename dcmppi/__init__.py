"""dcmppi: MPPI, Clustered MPPI, DC-MPPI and Tube-MPPI around static and moving obstacles.

Controllers are pure numpy + scikit-learn; the MuJoCo task suite is `dcmppi.tasks`.

    import dcmppi
    ctrl = dcmppi.make_controller("dc", K=500, seed=0)
    omega = ctrl.act(state, goal, static, moving, obstacle_model)
"""

from . import clustered, dc, mppi, tube  # noqa: F401  (registers the controllers)
from .controllers import Controller, Diagnostics, controller_names, make_controller

__version__ = "0.1.0"

__all__ = ["Controller", "Diagnostics", "controller_names", "make_controller", "__version__"]
