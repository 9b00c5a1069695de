"""The algorithms: analytic models, costs, DBSCAN, and the MPPI / Clustered / DC / Tube controllers.

Pure numpy, numba and scikit-learn. Imports nothing of MuJoCo, dm_control, dcmppi.tasks,
dcmppi.bench or dcmppi.render (tests/test_architecture.py checks this).
"""

from . import clustered, dc, mppi, tube  # noqa: F401  (registers the controllers)
from .controllers import Controller, Diagnostics, controller_names, make_controller, register

__all__ = ["Controller", "Diagnostics", "controller_names", "make_controller", "register"]
