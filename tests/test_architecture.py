"""The layout's rules: where each subpackage lives, what it may import, no import cycles."""

import ast
import importlib
import pathlib
import re
import subprocess
import sys

import pytest

import dcmppi

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGES = {
    "dcmppi": ROOT / "dcmppi",
    **{name: ROOT / folder for name, folder in dcmppi.TOP_LEVEL_FOLDERS.items()},
}
# What each package may import of the rest of dcmppi, anywhere (functions included).
# A subpackage's rule applies on top of its package's: the layers inside control and bench.
CONTROL_BASE = ("dcmppi.control.defaults", "dcmppi.control.registry", "dcmppi.control.validation")
MAY_IMPORT = {
    "dcmppi.control": (),
    # compiled numerics: below everything else of control
    "dcmppi.control.kernels": CONTROL_BASE,
    "dcmppi.control.agents": (*CONTROL_BASE, "dcmppi.control.kernels"),
    "dcmppi.control.predictors": (*CONTROL_BASE, "dcmppi.control.kernels"),
    "dcmppi.control.objective": (
        *CONTROL_BASE,
        "dcmppi.control.kernels",
        "dcmppi.control.predictors",
    ),
    # the robots' models (dynamics: the motion they are built on), numbers and checks, compiled
    # math (libm), and the pedestrians' social force (a pure numba model the `social` predictor
    # shares); no planner
    "dcmppi.tasks": (
        *CONTROL_BASE,
        "dcmppi.control.agents",
        "dcmppi.control.kernels.dynamics",
        "dcmppi.control.kernels.libm",
        "dcmppi.control.kernels.projection",
        "dcmppi.control.kernels.social",
    ),
    "dcmppi.render": ("dcmppi.control", "dcmppi.tasks"),
    # bench's layers: one episode, experiments, the database, many episodes, reports; timing
    # may use them all
    "dcmppi.bench.episodes": ("dcmppi.control", "dcmppi.tasks"),
    # model recipes train the learned predictor (its fit) on recorded or simulated crowds
    "dcmppi.bench.experiments": (
        "dcmppi.bench.episodes",
        "dcmppi.control.predictors.learned",
        "dcmppi.tasks",
    ),
    "dcmppi.bench.results": (
        "dcmppi.TOP_LEVEL_FOLDERS",
        "dcmppi.__version__",
        "dcmppi.bench.episodes",
        "dcmppi.control",
        "dcmppi.tasks",
    ),
    "dcmppi.bench.runs": (
        "dcmppi.bench.episodes",
        "dcmppi.bench.experiments",
        "dcmppi.bench.results",
        "dcmppi.control",
        "dcmppi.render",
        "dcmppi.tasks",
    ),
    # forecasts of recorded crowds: the predictors against the recordings, no episodes
    "dcmppi.bench.forecasts": ("dcmppi.control", "dcmppi.tasks"),
    "dcmppi.bench.reports": (
        "dcmppi.bench.episodes",
        "dcmppi.bench.experiments",
        "dcmppi.bench.results",
        "dcmppi.bench.runs",
        "dcmppi.render",
        "dcmppi.tasks",
    ),
}


def _loaded_after(statement):
    """Modules in sys.modules after running `statement` in a fresh interpreter."""
    code = f"import sys; {statement}; print('\\n'.join(sorted(sys.modules)))"
    out = subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd=ROOT
    )
    return set(out.stdout.split())


@pytest.mark.slow
def test_control_imports_no_mujoco_tasks_bench_or_render():
    modules = sorted(_module_name(p) for p in (ROOT / "dcmppi" / "control").rglob("*.py"))
    loaded = _loaded_after("; ".join(f"import {m}" for m in modules))
    assert set(modules) <= loaded  # the test saw every module of the package
    forbidden = {"mujoco", "dm_control", "dcmppi.tasks", "dcmppi.bench", "dcmppi.render"}
    bad = {
        m for m in loaded if m.split(".")[0] in forbidden or ".".join(m.split(".")[:2]) in forbidden
    }
    assert not bad, f"dcmppi.control loaded {sorted(bad)}"


@pytest.mark.slow
def test_tasks_import_no_planner_scikit_learn_or_scipy():
    loaded = _loaded_after("import dcmppi.tasks")
    assert "dcmppi.tasks.navigation" in loaded  # the test saw the package itself
    planners = {f"dcmppi.control.planners.{m}" for m in ("mppi", "clustered", "dc", "tube")}
    assert not loaded & planners
    assert not {m for m in loaded if m.split(".")[0] == "sklearn"}
    # numba imports scipy's top-level package (its version check); nothing more of scipy
    scipy = {m for m in loaded - _loaded_after("import numba") if m.split(".")[0] == "scipy"}
    assert not scipy, f"dcmppi.tasks loaded {sorted(scipy)}"


def test_the_package_loads_the_controller_api_on_first_use():
    loaded = _loaded_after("import dcmppi")
    assert not {m for m in loaded if m.startswith("dcmppi.")}
    from dcmppi import control

    api = [n for n in dcmppi.__all__ if n != "__version__"]
    assert all(getattr(dcmppi, n) is getattr(control, n) for n in api)
    assert {"control", *dcmppi.__all__} <= set(dir(dcmppi))
    with pytest.raises(AttributeError, match="no attribute 'make_controler'"):
        dcmppi.make_controler  # noqa: B018


def test_render_imports_no_bench():
    modules = [p.stem for p in (ROOT / "dcmppi" / "render").glob("*.py") if p.stem != "__init__"]
    loaded = _loaded_after("; ".join(f"import dcmppi.render.{m}" for m in modules))
    assert {f"dcmppi.render.{m}" for m in modules} <= loaded
    assert not {m for m in loaded if m.startswith("dcmppi.bench")}


def _module_name(path):
    for package, root in PACKAGES.items():
        if path.is_relative_to(root):
            parts = list(path.relative_to(root).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            return ".".join([package, *parts])
    raise AssertionError(path)


def _imports(path, name, bases=True):
    """dcmppi names that `path` (module `name`) imports anywhere, functions included: what each
    statement names (`import a.b`: a.b; `from a import b`: a.b) and, with bases=True, the
    module of every `from` import (a), which runs too."""
    is_package = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = name.split(".")[: len(name.split(".")) - node.level + is_package]
                base = ".".join(parent + ([base] if base else []))
            if bases:
                out.add(base)
            out |= {f"{base}.{a.name}" for a in node.names}
    return {m for m in out if m.split(".")[0] == "dcmppi"}


def _within(module, packages):
    return any(module == p or module.startswith(p + ".") for p in packages)


@pytest.mark.parametrize("package", sorted(MAY_IMPORT))
def test_a_package_imports_only_what_its_rule_allows(package):
    root = PACKAGES.get(package, ROOT.joinpath(*package.split(".")))
    allowed = (package, *MAY_IMPORT[package])
    module = root.with_suffix(".py")
    files = [module] if module.is_file() else sorted(root.rglob("*.py"))
    assert files
    bad = {
        f"{path.relative_to(ROOT)}: {target}"
        for path in files
        for target in _imports(path, _module_name(path), bases=False)
        if not _within(target, allowed)
    }
    assert not bad, f"{package} may import only {allowed[1:]} of dcmppi; found {sorted(bad)}"


def test_nothing_below_the_command_line_imports_it():
    """dcmppi.cli sits on top: no other module imports it, not even inside a function."""
    cli = ROOT / "dcmppi" / "cli"
    files = [p for root in PACKAGES.values() for p in root.rglob("*.py") if cli not in p.parents]
    assert ROOT / "dcmppi" / "bench" / "timing" / "cli.py" in files  # a module named cli is not
    bad = {
        f"{path.relative_to(ROOT)}: {target}"
        for path in files
        for target in _imports(path, _module_name(path))
        if _within(target, ("dcmppi.cli",))
    }
    assert not bad, f"only dcmppi.cli's own modules may import it; found {sorted(bad)}"


def _packages():
    """(folder, docstring, children) of every package of dcmppi, its top-level folders' included:
    children are its modules' and subpackages' names (`__main__` and private ones too)."""
    for root in PACKAGES.values():
        for init in sorted(root.rglob("__init__.py")):
            folder = init.parent
            modules = [p.stem for p in folder.glob("*.py") if p.name != "__init__.py"]
            packages = [d.name for d in folder.iterdir() if (d / "__init__.py").is_file()]
            if folder == ROOT / "dcmppi":  # the top-level folders are its subpackages too
                packages += [name.split(".")[-1] for name in dcmppi.TOP_LEVEL_FOLDERS]
            yield folder, ast.get_docstring(ast.parse(init.read_text())) or "", modules + packages


def _defines(module: str, name: str) -> bool:
    """Whether dcmppi module `module` (a dotted name) has `name`: a submodule, or a name its
    source binds at the top (def, class, assignment, import, __all__)."""
    if _source(f"{module}.{name}"):
        return True
    path = _source(module)
    if path is None:
        return False
    tree = ast.parse(path.read_text())
    bound = set()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            bound.add(node.name)
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            bound |= {n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)}
            if any(isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                bound |= set(ast.literal_eval(node.value))
        elif isinstance(node, ast.Import | ast.ImportFrom):
            bound |= {(a.asname or a.name).split(".")[0] for a in node.names}
    return name in bound


def _source(module: str):
    """The file of dcmppi module `module` (a dotted name), or None."""
    for package, root in PACKAGES.items():
        if module == package or module.startswith(package + "."):
            path = root.joinpath(*module.split(".")[len(package.split(".")) :])
            for candidate in (path / "__init__.py", path.with_suffix(".py")):
                if candidate.is_file():
                    return candidate
    return None


def test_each_package_docstring_names_its_modules_and_only_what_exists():
    """A package's docstring names each module and subpackage it holds (as a word: `name`,
    name.py, name/); the files (x.py, x/) and the dotted dcmppi names it mentions exist, a
    file beside it or from the repository's root."""
    lacking, stale = [], []
    for folder, doc, children in _packages():
        where = folder.relative_to(ROOT)
        lacking += [f"{where}: {c}" for c in children if not re.search(rf"\b{c}\b", doc)]
        for path in re.findall(r"(?<![\w/.-])((?:\w+/)*\w+(?:\.py|/))(?![\w/])", doc):
            if not ((folder / path).exists() or (ROOT / path).exists()):
                stale.append(f"{where}: {path}")
        for name in re.findall(r"\bdcmppi(?:\.\w+)+", doc):
            module, _, attribute = name.rpartition(".")
            if not (_source(name) or _defines(module, attribute)):
                stale.append(f"{where}: {name}")
    assert not lacking, f"package docstrings that do not name a module of theirs: {lacking}"
    assert not stale, f"package docstrings that name what does not exist: {stale}"


def test_pyproject_installs_each_top_level_folder_as_the_package_maps_it():
    setuptools = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert setuptools["package-dir"] == {"dcmppi": "dcmppi", **dcmppi.TOP_LEVEL_FOLDERS}
    assert set(dcmppi.TOP_LEVEL_FOLDERS) <= set(setuptools["packages"])
    for name, folder in dcmppi.TOP_LEVEL_FOLDERS.items():
        # a source checkout finds the folder through the package's path: same last name
        assert name.split(".")[-1] == folder
        # the package imported (from the checkout, an editable or a built install) is that
        # folder's: the same __init__.py
        module = importlib.import_module(name)
        source = (ROOT / folder / "__init__.py").read_bytes()
        assert pathlib.Path(module.__file__).read_bytes() == source, module.__file__


def test_no_module_imports_another_in_a_circle():
    files = [p for root in PACKAGES.values() for p in root.rglob("*.py")]
    names = {_module_name(p): p for p in files}
    graph = {}
    for name, path in names.items():
        # `import a.b.c` runs a, a.b and a.b.c; a package's own __init__ is not a dependency
        # of its submodules here, since the package's submodules always load it first
        targets = {t for t in _imports(path, name) if t in names and t != name}
        graph[name] = {t for t in targets if not name.startswith(t + ".")}
    seen, stack = set(), []

    def visit(node):
        if node in stack:
            cycle = stack[stack.index(node) :] + [node]
            pytest.fail("import cycle: " + " -> ".join(cycle))
        if node in seen:
            return
        stack.append(node)
        for t in sorted(graph[node]):
            visit(t)
        stack.pop()
        seen.add(node)

    for node in sorted(graph):
        visit(node)
    assert "dcmppi.bench.reports.report" in graph and "dcmppi.bench.reports.plots" in graph
