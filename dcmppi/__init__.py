"""dcmppi: MPPI, Clustered MPPI, DC-MPPI and Tube-MPPI around static and moving obstacles.

    import dcmppi
    ctrl = dcmppi.make_controller("dc", K=500, seed=0)
    omega = ctrl.act(state, goal, static, moving, obstacle_model)

Subpackages: dcmppi.control (the algorithms, no MuJoCo), dcmppi.tasks (the dm_control task
suite), dcmppi.bench (episodes, experiments, results, reports), dcmppi.render (videos and
figures). `import dcmppi` loads only dcmppi.control.
"""

from pathlib import Path

# Installed, tasks/ and models/ are subpackages of dcmppi (pyproject maps them in). In a
# source checkout they sit beside dcmppi/, so let the package also search the checkout's
# root: `dcmppi.tasks` then imports from a checkout too (scripts, Ray workers, `python -m`
# run from the repository root, where this dcmppi/ shadows the installed one).
if not (Path(__file__).parent / "tasks").is_dir():
    __path__.append(str(Path(__file__).parent.parent))  # noqa: F821 (the package's __path__)

from .control import Controller, Diagnostics, controller_names, make_controller  # noqa: E402

__version__ = "0.1.0"

__all__ = ["Controller", "Diagnostics", "controller_names", "make_controller", "__version__"]
