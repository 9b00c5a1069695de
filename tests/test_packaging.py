"""Packaging: every package the code imports is declared, and the files a user relies on exist."""

import ast
import importlib.metadata
import pathlib
import re
import sys

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = pathlib.Path(__file__).resolve().parents[1]
PYPROJECT = tomllib.loads((ROOT / "pyproject.toml").read_text())


def _requirement_names(requirements):
    return {
        re.split(r"[\s<>=!~;\[]", r, maxsplit=1)[0].lower().replace("_", "-") for r in requirements
    }


def _imported_top_level_modules():
    names = set()
    for folder in ("dcmppi", "tasks", "models"):
        for path in (ROOT / folder).rglob("*.py"):
            for node in ast.walk(ast.parse(path.read_text())):
                if isinstance(node, ast.Import):
                    names |= {a.name.split(".")[0] for a in node.names}
                elif isinstance(node, ast.ImportFrom) and not node.level and node.module:
                    names.add(node.module.split(".")[0])
    return names - set(sys.stdlib_module_names) - {"dcmppi", "tasks", "models", "__future__"}


def test_every_imported_package_is_declared():
    project = PYPROJECT["project"]
    declared = _requirement_names(project["dependencies"])
    for extra in project["optional-dependencies"].values():
        declared |= _requirement_names(extra)
    distributions = importlib.metadata.packages_distributions()
    missing = {}
    for module in sorted(_imported_top_level_modules()):
        dists = {d.lower().replace("_", "-") for d in distributions.get(module, [])}
        if not dists:
            continue  # not installed here (an optional extra this test run lacks)
        if not dists & declared:
            missing[module] = sorted(dists)
    assert not missing, f"imported but not declared in pyproject.toml: {missing}"


def test_license_citation_and_changelog_exist():
    assert PYPROJECT["project"]["license"] == "MIT"
    assert "MIT License" in (ROOT / "LICENSE").read_text()
    citation = (ROOT / "CITATION.cff").read_text()
    assert "cff-version: 1.2.0" in citation
    assert "Path Integral Control with Rollout Clustering and Dynamic Obstacles" in citation
    changelog = (ROOT / "CHANGELOG.md").read_text()
    assert re.search(r"^## \[\d+\.\d+\.\d+\] - \d{4}-\d{2}-\d{2}$", changelog, re.M)
    assert PYPROJECT["project"]["version"] in changelog


def test_the_build_and_the_linter_are_pinned_as_ci_needs():
    # license = "MIT" (a PEP 639 expression) needs setuptools >= 77
    build = PYPROJECT["build-system"]["requires"]
    assert any(re.fullmatch(r"setuptools>=(\d+)", r) and int(r.split(">=")[1]) >= 77 for r in build)
    # CI runs `ruff format --check`: a new ruff release must not fail it with no change of code
    assert any(
        re.fullmatch(r"ruff==[\d.]+", r)
        for r in PYPROJECT["project"]["optional-dependencies"]["dev"]
    )


def test_every_package_folder_is_installed():
    """A wheel ships only the packages pyproject lists: each folder with an __init__.py of
    dcmppi/ and of the top-level folders it maps (tasks/, models/) must be among them."""
    setuptools = PYPROJECT["tool"]["setuptools"]
    packages = set(setuptools["packages"])
    found = set()
    for package, folder in setuptools["package-dir"].items():
        for init in (ROOT / folder).rglob("__init__.py"):
            found.add(".".join([package, *init.parent.relative_to(ROOT / folder).parts]))
    assert "dcmppi.tasks.replay" in found and "dcmppi.bench.crowds" in found
    assert found - packages == set(), f"add to [tool.setuptools] packages: {found - packages}"
