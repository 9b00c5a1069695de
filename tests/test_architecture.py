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
    # bench's layers: one episode, crowds, experiments, the database, many episodes, reports;
    # timing may use them all
    "dcmppi.bench.episodes": ("dcmppi.control", "dcmppi.tasks"),
    # the learned predictor's crowds: simulated ones recorded (episodes' obstacle motion and
    # seeds), its models trained and resolved from recipes, the predictors' forecasts of
    # recorded ones (under a preset's settings too)
    "dcmppi.bench.crowds": (
        "dcmppi.bench.episodes",
        "dcmppi.control.defaults",
        "dcmppi.control.predictors",
        "dcmppi.tasks",
    ),
    # model recipes (crowds) stand for the learned predictor's model files
    "dcmppi.bench.experiments": ("dcmppi.bench.crowds", "dcmppi.bench.episodes", "dcmppi.tasks"),
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
    "dcmppi.bench.reports": (
        "dcmppi.bench.episodes",
        "dcmppi.bench.experiments",
        "dcmppi.bench.results",
        "dcmppi.bench.runs",
        "dcmppi.render",
        "dcmppi.tasks",
    ),
}

# Imports inside a function that close a circle: (importer, imported): the reason. The circle
# check leaves them out; each must stay inside a function.
LAZY_CIRCLES: dict[tuple[str, str], str] = {}


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


def _statements(path, name):
    """(base, names, lazy) of each import statement of `path` (module `name`), functions
    included: `import a.b` is ("a.b", ()), `from a import b, c` is ("a", ("b", "c")), relative
    ones resolved; lazy: inside a function."""
    is_package = path.name == "__init__.py"
    tree = ast.parse(path.read_text())
    functions = (ast.FunctionDef, ast.AsyncFunctionDef)
    lazy = {
        id(node)
        for function in ast.walk(tree)
        if isinstance(function, functions)
        for node in ast.walk(function)
    }
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            yield from ((a.name, (), id(node) in lazy) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = name.split(".")[: len(name.split(".")) - node.level + is_package]
                base = ".".join(parent + ([base] if base else []))
            yield base, tuple(a.name for a in node.names), id(node) in lazy


def _imports(path, name):
    """dcmppi names that `path` (module `name`) imports anywhere, functions included: what each
    statement names (`import a.b`: a.b; `from a import b`: a.b)."""
    out = set()
    for base, names, _ in _statements(path, name):
        out |= {f"{base}.{n}" for n in names} if names else {base}
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
        for target in _imports(path, _module_name(path))
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


def _package_name(folder: pathlib.Path) -> str:
    """The dotted name of a package folder of dcmppi (top-level folders by their map)."""
    for name, root in PACKAGES.items():
        if folder == root or root in folder.parents:
            return ".".join([name, *folder.relative_to(root).parts])
    raise ValueError(folder)


def test_design_layout_names_every_package_and_its_modules():
    """docs/design.md's "Package layout" table has a row per package (the data of
    dcmppi.models and the root's own modules aside) naming each of its modules and
    subpackages, and no row for a package that does not exist."""
    text = (ROOT / "docs" / "design.md").read_text()
    section = text.split("\n## Package layout\n", 1)[1].split("\n## ", 1)[0]
    rows = {}
    for line in section.splitlines():
        match = re.match(r"\| `([\w.]+)` \|[^|]*\|(.*)\|$", line)
        if match:
            rows[match[1]] = set(re.findall(r"`(\w+)`", match[2]))
    lacking, packages = [], set()
    for folder, _, children in _packages():
        name = _package_name(folder)
        if name == "dcmppi" or name.startswith("dcmppi.models"):
            continue
        packages.add(name)
        named = rows.get(name, set())
        lacking += [f"{name}: {c}" for c in children if c != "__main__" and c not in named]
    assert not lacking, f"design.md's layout table does not name: {lacking}"
    assert set(rows) == packages, f"rows without a package: {set(rows) - packages}"


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


def _parents(module):
    parts = module.split(".")
    return {".".join(parts[:i]) for i in range(1, len(parts))}


def _import_graph(modules, allowed=()):
    """{module: the modules of `modules` ({name: path}) that it runs by an import, functions
    included}, and the (module, target) pairs of `allowed` that are imports inside a function.

    `import a.b` and `from a import b` run a, and a.b where it is a module. A module's own
    packages load before it: an import of one counts only where it reads a name that the
    package's __init__ defines (`from a import seed` in a.b), not where it reads a submodule
    (`from a import c` in a.b). A pair of `allowed` is left out of the graph where it is lazy.
    """
    graph, lazy = {}, set()
    for name, path in modules.items():
        own = _parents(name)
        graph[name] = set()
        for base, names, inside in _statements(path, name):
            submodules = {f"{base}.{n}" for n in names} & set(modules)
            reads = {base} if len(submodules) < len(names) else set()
            runs = _parents(base) | {base} | submodules
            for target in runs & set(modules) - {name}:
                if inside and (name, target) in allowed:
                    lazy.add((name, target))
                elif target not in own or target in reads:
                    graph[name].add(target)
    return graph, lazy


def _cycle(graph):
    """A cycle of `graph` ({node: successors}) as a list that ends where it starts; None if
    none."""
    done, stack = set(), []

    def visit(node):
        if node in stack:
            return stack[stack.index(node) :] + [node]
        if node in done:
            return None
        stack.append(node)
        found = next(filter(None, (visit(t) for t in sorted(graph[node]))), None)
        stack.pop()
        done.add(node)
        return found

    return next(filter(None, (visit(node) for node in sorted(graph))), None)


def test_no_module_imports_another_in_a_circle():
    """Imports inside functions count: a lazy import that closes a circle hides it, it does not
    break it (break one by moving the shared piece to a module below both). LAZY_CIRCLES are
    the exceptions, each an import inside a function."""
    files = [p for root in PACKAGES.values() for p in root.rglob("*.py")]
    graph, lazy = _import_graph({_module_name(p): p for p in files}, LAZY_CIRCLES)
    assert lazy == set(LAZY_CIRCLES), f"not imports inside a function: {set(LAZY_CIRCLES) - lazy}"
    cycle = _cycle(graph)
    assert cycle is None, "import cycle: " + " -> ".join(cycle)
    assert "dcmppi.bench.reports.plots" in graph["dcmppi.bench.reports.report"]
    assert "dcmppi.bench.crowds.recording" in graph["dcmppi.bench.crowds.recipes"]


def test_the_circle_check_sees_a_lazy_import_and_a_name_of_a_package(tmp_path):
    """The package exp defines seed and imports its models; models imports crowds inside a
    function; crowds reads seed from exp: a circle. crowds reading seed from a module below
    (dcmppi.seeds) instead, or reading only a module of exp (schema), is none."""
    sources = {
        "dcmppi/__init__.py": "",
        "dcmppi/seeds.py": "def seed(): pass\n",
        "dcmppi/exp/__init__.py": "from dcmppi.exp import models\n\n\ndef seed(): pass\n",
        "dcmppi/exp/models.py": "def build():\n    from dcmppi.exp import crowds\n",
        "dcmppi/exp/crowds.py": "from dcmppi.exp import seed\n",
        "dcmppi/exp/schema.py": "",
    }
    for file, text in sources.items():
        (tmp_path / file).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / file).write_text(text)
    crowds = tmp_path / "dcmppi/exp/crowds.py"
    modules = {
        ".".join(pathlib.Path(f).with_suffix("").parts).removesuffix(".__init__"): tmp_path / f
        for f in sources
    }
    assert _cycle(_import_graph(modules)[0]) == [
        "dcmppi.exp",
        "dcmppi.exp.models",
        "dcmppi.exp.crowds",
        "dcmppi.exp",
    ]
    for fixed in ("from dcmppi.seeds import seed\n", "from dcmppi.exp import schema\n"):
        crowds.write_text(fixed)
        assert _cycle(_import_graph(modules)[0]) is None


MAX_FUNCTION_LINES = 60  # def line to last line, decorators excluded
# numba's compiling decorators (numba.njit(...), @overload(f), @intrinsic, ...): the kernels
# they compile are exempt
NUMBA_DECORATORS = {
    "cfunc",
    "generated_jit",
    "guvectorize",
    "intrinsic",
    "jit",
    "njit",
    "overload",
    "overload_method",
    "stencil",
    "vectorize",
}


def _names(node):
    """The names and attribute names that `node` mentions."""
    return {getattr(n, "id", None) or getattr(n, "attr", None) for n in ast.walk(node)} - {None}


def _long_functions(tree, limit=MAX_FUNCTION_LINES):
    """(line, name, lines) of each function of module `tree` longer than `limit` lines, those
    that numba compiles left out: a decorator that names one of NUMBA_DECORATORS or a name the
    module binds to an expression that does (`kernel = numba.njit(cache=True)`)."""
    compiling = set(NUMBA_DECORATORS)
    for node in tree.body:
        if isinstance(node, ast.Assign) and _names(node.value) & compiling:
            compiling |= {n.id for n in node.targets if isinstance(n, ast.Name)}
    functions = (n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef | ast.AsyncFunctionDef))
    return [
        (f.lineno, f.name, f.end_lineno - f.lineno + 1)
        for f in functions
        if f.end_lineno - f.lineno + 1 > limit
        and not any(_names(d) & compiling for d in f.decorator_list)
    ]


def test_no_function_is_longer_than_the_limit_outside_the_numba_kernels():
    files = [p for root in PACKAGES.values() for p in root.rglob("*.py")]
    assert ROOT / "tasks" / "physics.py" in files  # the top-level folders are walked too
    long = [
        f"{path.relative_to(ROOT)}:{line} {name} ({lines} lines)"
        for path in sorted(files)
        for line, name, lines in _long_functions(ast.parse(path.read_text()))
    ]
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines (split them): {long}"


def test_the_length_check_exempts_only_what_numba_compiles():
    def source(decorator, lines):
        body = "".join(f"    x = {i}\n" for i in range(lines - 1))
        return f"{decorator}\ndef f():\n{body}"

    kernel = "kernel = numba.njit(cache=True)\n"
    assert _long_functions(ast.parse(source("", 61))) == [(2, "f", 61)]
    assert _long_functions(ast.parse(source("@functools.cache", 61))) == [(2, "f", 61)]
    assert _long_functions(ast.parse(source("", 60))) == []
    for decorator in ("@numba.njit(cache=True)", "@overload(g, inline='always')", "@kernel"):
        assert _long_functions(ast.parse(kernel + source(decorator, 61))) == []
