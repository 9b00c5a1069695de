"""The layout's rules: what each subpackage may import, and no import cycles."""

import ast
import pathlib
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PACKAGES = {"dcmppi": ROOT / "dcmppi", "dcmppi.tasks": ROOT / "tasks"}


def _loaded_after(statement):
    """Modules in sys.modules after running `statement` in a fresh interpreter."""
    code = f"import sys; {statement}; print('\\n'.join(sorted(sys.modules)))"
    out = subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True, text=True, cwd=ROOT
    )
    return set(out.stdout.split())


def test_control_imports_no_mujoco_tasks_bench_or_render():
    loaded = _loaded_after("import dcmppi.control")
    forbidden = {"mujoco", "dm_control", "dcmppi.tasks", "dcmppi.bench", "dcmppi.render"}
    bad = {
        m for m in loaded if m.split(".")[0] in forbidden or ".".join(m.split(".")[:2]) in forbidden
    }
    assert not bad, f"dcmppi.control loaded {sorted(bad)}"
    assert "dcmppi.control.mppi" in loaded  # the test saw the package itself


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


def _imports(path, name):
    """dcmppi modules that `path` (module `name`) imports anywhere, functions included."""
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
            out.add(base)
            out |= {f"{base}.{a.name}" for a in node.names}
    return {m for m in out if m.startswith("dcmppi")}


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
    assert "dcmppi.bench.report" in graph and "dcmppi.bench.plots" in graph
