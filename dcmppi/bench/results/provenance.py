"""What a benchmark run ran: code, resolved parameters, input files, libraries, machine.

`collect(exp, specs)` gathers it before a run; the results database stores it per run
(`ResultsDB(..., provenance=...)`, table `runs`) and refuses to extend a database recorded
under other conditions (`differences`): another dcmppi version or code (the sha256 of the
package's source, so a commit that touches only documentation is no difference), another
resolved task or controller parameter (the classes' defaults included), another sha256 of an
input file (layout CSV/JSON, the BARN file of $DCMPPI_BARN, the module of a user's
package.module:ClassName controller or predictor, a learned predictor's model file). Library
versions, CPU and host are recorded and shown, never compared (shards of one benchmark run on
different machines). So is the arithmetic the CPU gives numpy and the BLAS (`kernels`):
machines of one model name may differ in it, and with it in the last bits of every plan, so
in the episodes' numbers.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import inspect
import json
import os
import platform
import socket
import subprocess
from pathlib import Path

from dcmppi import TOP_LEVEL_FOLDERS, __version__

LIBRARIES = ("numpy", "numba", "mujoco", "dm_control", "scikit-learn")
SOURCE_SUFFIXES = (".py", ".xml", ".toml")  # code, MJCF models, shipped experiments
BARN_ENV = "DCMPPI_BARN"

PACKAGE = Path(__file__).resolve().parents[2]  # dcmppi/


def collect(exp, specs) -> dict:
    """The provenance of a run of `exp` (an Experiment) over `specs` = [(key, EpisodeSpec)]:
    {"dcmppi", "code_sha256", "commit", "dirty", "task": {"name", "params"}, "rows": {label:
    {"controller", "params"}}, "files": {what: {"path", "sha256"}}, "libraries": {name:
    version}, "cpu", "kernels", "cores", "host"}. Builds each row's controller once (as
    check_specs does)."""
    first, models = {}, {}
    for (_, label, _), spec in specs:
        first.setdefault(label, spec)
        models.setdefault(label, {}).setdefault(_model(spec), spec)
    code, commit, dirty = code_version()
    files = {}
    rows = {}
    for label, spec in first.items():
        per_environment = len(models[label]) > 1  # a recipe: one model per scene, say
        for each in models[label].values():  # before the controller: a missing file
            found = model_files(label, each)
            if per_environment:
                found = {f"{k} {Path(v['path']).name}": v for k, v in found.items()}
            files.update(found)
        rows[label] = {"controller": spec.controller, "params": controller_params(spec)}
        if per_environment:
            rows[label]["params"]["model"] = "per environment (files: row LABEL model NAME)"
        files.update(user_modules(spec))
    task = {"name": exp.task, "params": {}}
    if first:
        spec = next(iter(first.values()))
        task["params"] = task_params(spec, exp.env_param)
        files.update(task_files(spec))
    return {
        "dcmppi": __version__,
        "code_sha256": code,
        "commit": commit,
        "dirty": dirty,
        "task": task,
        "rows": rows,
        "files": files,
        "libraries": libraries(),
        "cpu": cpu_model(),
        "kernels": kernels(),
        "cores": os.cpu_count(),
        "host": socket.gethostname(),
    }


def differences(stored: dict, new: dict) -> list[str]:
    """What differs between two provenances in what a resume must keep: the dcmppi version and
    code, the task's and the rows (present in both)' resolved parameters and the input files'
    sha256. [] when nothing does."""
    out = []
    if stored.get("dcmppi") != new.get("dcmppi"):
        out.append(f"dcmppi {stored.get('dcmppi')} -> {new.get('dcmppi')}")
    if stored.get("code_sha256") != new.get("code_sha256"):
        a, b = (str(p.get("code_sha256"))[:8] for p in (stored, new))
        out.append(f"dcmppi's code (sha256 {a} -> {b}; {_where(stored)} -> {_where(new)})")
    task_old, task_new = stored.get("task", {}), new.get("task", {})
    out += _params("task parameter", task_old.get("params", {}), task_new.get("params", {}))
    rows_old, rows_new = stored.get("rows", {}), new.get("rows", {})
    for label in sorted(rows_old.keys() & rows_new.keys()):
        a, b = rows_old[label], rows_new[label]
        if a.get("controller") != b.get("controller"):
            out.append(f"row {label!r} controller {a.get('controller')} -> {b.get('controller')}")
        out += _params(f"row {label!r} parameter", a.get("params", {}), b.get("params", {}))
    files_old, files_new = stored.get("files", {}), new.get("files", {})
    for what in sorted(files_old.keys() & files_new.keys()):
        a, b = files_old[what], files_new[what]
        if a["sha256"] != b["sha256"]:
            out.append(
                f"{what} ({b['path']}) sha256 {a['sha256'][:8]} -> {b['sha256'][:8]}"
                + (f", was {a['path']}" if a["path"] != b["path"] else "")
            )
    return out


def _params(what: str, old: dict, new: dict) -> list[str]:
    return [
        f"{what} {k}: {json.dumps(old.get(k))} -> {json.dumps(new.get(k))}"
        for k in sorted(old.keys() | new.keys())
        if old.get(k) != new.get(k)
    ]


def short(prov: dict | None) -> str:
    """One line naming the code of a provenance: 'dcmppi VERSION code SHA256[:8] (commit
    SHA1[:7], dirty)'."""
    if not prov:
        return "unknown (recorded before provenance)"
    code = (prov.get("code_sha256") or "?")[:8]
    return f"dcmppi {prov.get('dcmppi')} code {code} ({_where(prov)})"


def _where(prov: dict) -> str:
    commit = prov.get("commit")
    where = "no git checkout" if commit is None else f"commit {commit[:7]}"
    return where + (", dirty" if prov.get("dirty") else "")


def code_version() -> tuple[str, str | None, bool | None]:
    """(sha256 of dcmppi's source files, git commit, whether the checkout's code differs from
    it); commit and dirty are None outside a git checkout of dcmppi."""
    roots = _source_roots()
    digest = hashlib.sha256()
    for root in roots:
        for path in sorted(p for p in root.rglob("*") if p.suffix in SOURCE_SUFFIXES):
            if "__pycache__" in path.parts:
                continue
            digest.update(f"{root.name}/{path.relative_to(root).as_posix()}\0".encode())
            digest.update(path.read_bytes())
    checkout = PACKAGE.parent
    commit = _git(checkout, "rev-parse", "HEAD")
    if commit is None or not (checkout / "pyproject.toml").is_file():
        return digest.hexdigest(), None, None
    names = [str(root.relative_to(checkout)) for root in roots if root.is_relative_to(checkout)]
    status = _git(checkout, "status", "--porcelain", "--", *names)
    return digest.hexdigest(), commit, bool(status)


def _source_roots() -> list[Path]:
    """The directories of dcmppi's code: the package and, in a source checkout, the top-level
    folders that are its subpackages (tasks/, models/)."""
    package = PACKAGE
    roots = [package]
    for folder in TOP_LEVEL_FOLDERS.values():
        outside = package.parent / folder
        if not (package / folder).is_dir() and outside.is_dir():
            roots.append(outside)
    return roots


def _git(cwd: Path, *args: str) -> str | None:
    try:
        done = subprocess.run(
            ["git", "-C", str(cwd), *args], capture_output=True, text=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def controller_params(spec) -> dict:
    """The parameters the controller of `spec` runs with, its class's defaults included (a
    dcmppi.Controller's `params`; another class's signature defaults, then what it is given);
    the per-episode seed left out."""
    from dcmppi.bench.episodes.plugins import accepted_params, resolve_controller
    from dcmppi.bench.episodes.runner import controller_for

    controller = controller_for(spec)
    params = getattr(controller, "params", None)
    if not isinstance(params, dict):  # not a dcmppi.Controller: what its signature takes
        cls = resolve_controller(spec.controller)
        accepted = accepted_params(cls, None)
        params = _defaults(cls)
        params.update(
            {k: v for k, v in spec.shared_params.items() if accepted is None or k in accepted}
        )
        params.update(spec.controller_params)
    params = {k: v for k, v in params.items() if k != "seed"}
    return json.loads(json.dumps(params, default=repr, sort_keys=True))


def task_params(spec, env_param: str | None = None) -> dict:
    """The task parameters of `spec`, the task class's (and Navigation's) defaults and the
    simulated robot included; the seed, the noise profile and `env_param` left out (they vary
    per episode)."""
    from dcmppi import tasks

    cls = tasks.task_class(spec.task)
    params = {**_defaults(tasks.Navigation), **_defaults(cls)}
    params.update(spec.task_params)
    params.update(tasks.robot(spec.task, spec.task_params))
    for name in ("random", "noise", env_param):
        params.pop(name, None)
    return json.loads(json.dumps(params, default=repr, sort_keys=True))


def _defaults(cls) -> dict:
    """Keyword defaults of `cls`'s constructor (None where it has no signature)."""
    try:
        parameters = inspect.signature(cls).parameters.values()
    except (TypeError, ValueError):
        return {}
    return {p.name: p.default for p in parameters if p.default is not p.empty}


def task_files(spec) -> dict:
    """{what: {"path", "sha256"}} of the files `spec`'s task reads: task parameters naming a file
    (the layout's `path`) and, for a BARN world without one, $DCMPPI_BARN's file."""
    out = {}
    for name, value in sorted(spec.task_params.items()):
        if isinstance(value, str) and Path(value).is_file():
            out[f"task parameter {name}"] = file_entry(value)
    barn = os.environ.get(BARN_ENV)
    if spec.task_params.get("world") is not None and "path" not in spec.task_params and barn:
        if Path(barn).is_file():
            out[f"${BARN_ENV}"] = file_entry(barn)
    return out


def _model(spec):
    """The `model` parameter `spec`'s controller gets (None if none)."""
    model = {**spec.shared_params, **spec.controller_params}.get("model")
    return None if model is None else str(model)


def model_files(label: str, spec) -> dict:
    """{"row LABEL model": {"path", "sha256"}} of the model file a row's learned predictor reads
    (prediction "learned", parameter `model`; the row's own parameters over the shared ones);
    {} for other rows. A ValueError names a model file that does not exist. `collect` keys a
    row whose environments use several files (a recipe per scene) "row LABEL model NAME"."""
    params = {**spec.shared_params, **spec.controller_params}
    model = params.get("model")
    if params.get("prediction") != "learned" or model is None:
        return {}
    path = Path(str(model))
    if not path.is_file():
        raise ValueError(
            f"row {label!r}: prediction 'learned' model={model}: no such file; train one with "
            "`dcmppi predictor train --out MODEL` or fix the path"
        )
    return {f"row {label} model": file_entry(path)}


def user_modules(spec) -> dict:
    """{what: {"path", "sha256"}} of the modules of `spec`'s controller and predictor classes
    that live outside dcmppi (a user's package.module:ClassName, an installed entry point)."""
    from dcmppi.bench.episodes.plugins import resolve_controller
    from dcmppi.control.predictors.base import predictor_class

    out = {}
    classes = {f"controller {spec.controller}": resolve_controller(spec.controller)}
    prediction = {**spec.shared_params, **spec.controller_params}.get("prediction")
    if isinstance(prediction, str):
        classes[f"prediction {prediction}"] = predictor_class(prediction)
    roots = _source_roots()
    for what, cls in classes.items():
        try:
            path = Path(inspect.getfile(cls)).resolve()
        except (TypeError, OSError):
            continue
        if not any(path.is_relative_to(root) for root in roots):
            out[what] = file_entry(path)
    return out


def file_entry(path) -> dict:
    """{"path": absolute path, "sha256": hex digest} of a file."""
    path = Path(path).resolve()
    return {"path": str(path), "sha256": hashlib.sha256(path.read_bytes()).hexdigest()}


def libraries() -> dict:
    """Versions of Python and the libraries that shape results (None: not installed)."""
    out = {"python": platform.python_version()}
    for name in LIBRARIES:
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = None
    return out


def cpu_model() -> str:
    """The CPU's model name (Linux: /proc/cpuinfo), else platform.processor()."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.partition(":")[2].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def kernels() -> str:
    """The instruction sets that numpy's loops and the BLAS dispatch to here: numpy's widest
    build target this processor runs and each BLAS's kernel family (e.g. "numpy X86_V3, openblas
    Haswell"). They change the last bits of transcendental functions and of sums."""
    try:
        from numpy._core import _multiarray_umath as umath
    except ImportError:  # numpy 1.x
        from numpy.core import _multiarray_umath as umath
    out = [f"numpy {numpy_level(umath)}"]
    from threadpoolctl import threadpool_info

    for lib in threadpool_info():  # numpy's BLAS, and scipy's where loaded (often the same)
        blas = f"{lib.get('internal_api')} {lib.get('architecture') or '?'}"
        if lib.get("user_api") == "blas" and blas not in out:
            out.append(blas)
    return ", ".join(out)


def numpy_level(umath) -> str:
    """The widest of numpy's build targets (its baseline, then what it dispatches to) that the
    processor has and numpy enabled: what its loops run (numpy 2.4's grouped levels X86_V2,
    X86_V3, X86_V4 included); "baseline" without one."""
    features = umath.__cpu_features__
    targets = [*getattr(umath, "__cpu_baseline__", ()), *getattr(umath, "__cpu_dispatch__", ())]
    return next((t for t in reversed(targets) if features.get(t)), "baseline")
