"""dcmppi: MPPI, Clustered MPPI, DC-MPPI and Tube-MPPI around static and moving obstacles.

    import dcmppi
    ctrl = dcmppi.make_controller("dc", K=500, seed=0)
    omega = ctrl.act(state, goal, static, moving, obstacle_model)

Subpackages, each importing only those listed after it:
  dcmppi.bench   episodes, experiments, results, reports (any of the others);
  dcmppi.render  videos and figures (tasks, control; never bench);
  dcmppi.tasks   the dm_control tasks (of control: agents, dynamics, defaults, validation);
  dcmppi.models  the MJCF files of the arena and the robots (data);
  dcmppi.control the algorithms (nothing of the others, no MuJoCo).
dcmppi.cli (the `dcmppi` command) and dcmppi.gym (Gymnasium environments) sit on top.
tests/test_architecture.py checks these arrows.

This module itself imports nothing of them: `Controller`, `Diagnostics`, `controller_names`,
`make_controller` and `control` load dcmppi.control on first use, so `import dcmppi.tasks`
does not load the controllers (nor scikit-learn, scipy).

Top-level folders: the repository keeps tasks/ and models/ beside dcmppi/; TOP_LEVEL_FOLDERS
below maps each to its subpackage, as pyproject.toml's `package-dir` does for an installed copy.
"""

import importlib
from pathlib import Path
from typing import TYPE_CHECKING

__version__ = "0.1.0"

# -- Top-level folders that are subpackages --------------------------------------------------
# Installed, pyproject.toml's package-dir puts each folder inside the package. In a source
# checkout the folders sit beside dcmppi/, so the package also searches the checkout's root:
# `dcmppi.tasks` then imports from a checkout too (scripts, Ray workers, `python -m` run from
# the repository root, where this dcmppi/ shadows the installed one). Hence each folder is
# named like its subpackage's last part. tests/test_architecture.py checks that pyproject's map
# equals this one.
TOP_LEVEL_FOLDERS = {"dcmppi.tasks": "tasks", "dcmppi.models": "models"}

if not (Path(__file__).parent / "tasks").is_dir():
    __path__.append(str(Path(__file__).parent.parent))  # noqa: F821 (the package's __path__)

# -- The controller API, loaded on first use (PEP 562) ---------------------------------------
_CONTROL_NAMES = ("Controller", "Diagnostics", "controller_names", "make_controller")

if TYPE_CHECKING:
    from dcmppi.control import Controller, Diagnostics, controller_names, make_controller


def __getattr__(name):
    if name == "control" or name in _CONTROL_NAMES:
        control = importlib.import_module(".control", __name__)
        value = control if name == "control" else getattr(control, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted({*globals(), "control", *_CONTROL_NAMES})


__all__ = ["Controller", "Diagnostics", "controller_names", "make_controller", "__version__"]
