"""Controllers by name: the built-in registry, installed entry points and module:Class strings.

A name is one of
- a built-in controller ("mppi", "clustered", "dc", "tube");
- the name of an entry point in the group `dcmppi.controllers` of an installed package
  (pyproject.toml: `[project.entry-points."dcmppi.controllers"] mine = "pkg.module:Class"`);
- `package.module:ClassName`, imported like `python -m` would (the current directory first).

A controller is any class with `reset()` and `act(state, goal, static, moving,
obstacle_model)`, or a subclass of dcmppi.Controller. Episode specs carry the name, never the
class: every process (pool or Ray worker) resolves it again, so the class only needs to be
importable there.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import inspect
from pathlib import Path

from dcmppi.control import Controller
from dcmppi.control import controller_class as builtin_class
from dcmppi.control import controller_names as builtin_names
from dcmppi.control.planners.registry import accepted_params as controller_params

ENTRY_POINT_GROUP = "dcmppi.controllers"
PROTOCOL = "act(state, goal, static, moving, obstacle_model) and reset()"


def entry_points() -> dict:
    """Installed controllers: {name: importlib.metadata.EntryPoint} of the group
    `dcmppi.controllers` (a built-in name shadows an entry point of the same name)."""
    found = importlib.metadata.entry_points(group=ENTRY_POINT_GROUP)
    return {ep.name: ep for ep in found}


def available_controllers() -> list[str]:
    """Built-in controllers, then the installed entry points' names."""
    builtin = builtin_names()
    return builtin + sorted(set(entry_points()) - set(builtin))


def resolve_controller(name: str) -> type:
    """The class a controller name (built-in, entry point or package.module:ClassName) stands
    for; a ValueError says what is wrong and the fix."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"a controller name must be a non-empty string; got {name!r}")
    if ":" in name:
        return _checked(name, _import(name))
    if name in builtin_names():
        return builtin_class(name)
    found = entry_points()
    if name in found:
        ep = found[name]
        try:
            cls = ep.load()
        except Exception as e:  # noqa: BLE001 - any import failure, reported in one line
            raise ValueError(
                f"controller {name!r} (entry point {ep.value!r} of group {ENTRY_POINT_GROUP}): "
                f"loading it raised {type(e).__name__}: {e}; reinstall or fix that package"
            ) from e
        return _checked(f"{name} ({ep.value})", cls)
    raise ValueError(
        f"unknown controller {name!r}; valid: {', '.join(available_controllers())}, or "
        "package.module:ClassName for your own class (`dcmppi controllers` lists them)"
    )


def _import(name: str):
    module_name, _, attr = name.partition(":")
    if not module_name or not attr:
        raise ValueError(f"controller {name!r}: expected package.module:ClassName")
    try:
        module = importlib.import_module(module_name)
    except ModuleNotFoundError as e:
        if e.name and module_name.startswith(e.name):
            raise ValueError(
                f"controller {name!r}: no module named {e.name!r}; run from the directory "
                "that holds it, add that directory to PYTHONPATH or install its package"
            ) from e
        raise ValueError(
            f"controller {name!r}: importing {module_name} failed: {e}; install what it needs"
        ) from e
    except Exception as e:  # noqa: BLE001 - a broken module, reported in one line
        raise ValueError(
            f"controller {name!r}: importing {module_name} raised {type(e).__name__}: {e}"
        ) from e
    obj = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            classes = sorted(n for n, v in vars(module).items() if inspect.isclass(v))
            raise ValueError(
                f"controller {name!r}: {module_name} ({getattr(module, '__file__', '?')}) has "
                f"no {attr!r}; its classes: {', '.join(classes) or 'none'}"
            )
        obj = getattr(obj, part)
    return obj


def _checked(name: str, cls) -> type:
    if not inspect.isclass(cls):
        raise ValueError(
            f"controller {name!r} is a {type(cls).__name__}, not a class; point to a class "
            f"with {PROTOCOL}"
        )
    missing = [m for m in ("reset", "act") if not callable(getattr(cls, m, None))]
    if missing:
        raise ValueError(
            f"controller {name!r}: class {cls.__name__} has no {' or '.join(missing)}(); a "
            f"controller needs {PROTOCOL} (or subclass dcmppi.Controller)"
        )
    return cls


def accepted_params(cls: type, agent, prediction=None) -> set[str] | None:
    """Keyword arguments `cls` takes (None: any). A dcmppi.Controller takes its own, its agent's
    and its predictor's (`prediction`, None: the class's default) parameters; another class those
    its `param_names()` lists where it has one (the classical planners), else what its __init__
    names."""
    if issubclass(cls, Controller):
        if not isinstance(agent, str):
            return set(cls.param_names())
        return set(controller_params(cls, agent, prediction))
    if callable(getattr(cls, "param_names", None)):
        return set(cls.param_names())
    try:
        parameters = inspect.signature(cls).parameters.values()
    except (TypeError, ValueError):  # no signature to read (a C extension type)
        return None
    if any(p.kind == p.VAR_KEYWORD for p in parameters):
        return None
    return {p.name for p in parameters if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}


def build(name: str, own: dict, shared: dict):
    """Construct controller `name` with its `own` parameters (each must be accepted) and those
    of the `shared` ones (seed, robot parameters, an experiment's common parameters) that its
    class accepts. `shared` must hold "agent"."""
    cls = resolve_controller(name)
    accepted = accepted_params(cls, shared["agent"], {**shared, **own}.get("prediction"))
    if accepted is not None:
        unknown = sorted(set(own) - accepted)
        if unknown:
            raise ValueError(
                f"unknown parameter(s) {', '.join(unknown)} for controller {name!r}; it takes "
                f"{', '.join(sorted(accepted)) or 'none'}"
            )
        shared = {k: v for k, v in shared.items() if k in accepted}
    try:
        return cls(**{**shared, **own})
    except TypeError as e:
        raise ValueError(f"constructing controller {name!r} failed: {e}") from e


def import_roots(names) -> list[str]:
    """The sys.path directories the package.module:ClassName names among `names` import from
    (what a worker that does not share this process's sys.path needs, e.g. Ray's)."""
    roots = []
    for name in names:
        if ":" not in name:
            continue
        _import(name)  # a clear error if it does not import here
        module_name = name.partition(":")[0]
        path = Path(importlib.import_module(module_name).__file__)
        depth = module_name.count(".") + (path.name == "__init__.py")
        root = str(path.parents[depth])
        if root not in roots:
            roots.append(root)
    return roots
