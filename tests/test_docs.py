"""docs/own_controller.md runs as written: its files are written, its commands run."""

import os
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]


def blocks(path):
    """(language, code) of each fenced block of a Markdown file."""
    return re.findall(r"^```(\w+)\n(.*?)^```$", path.read_text(), re.S | re.M)


def test_benchmark_your_own_controller_section_runs(tmp_path):
    found = blocks(ROOT / "docs" / "own_controller.md")
    assert [lang for lang, _ in found] == ["python", "toml", "sh"]
    for _, code in found[:2]:
        name = re.match(r"# (\S+)\n", code).group(1)  # the block's first line names its file
        (tmp_path / name).write_text(code)
    env = {**os.environ, "PATH": f"{pathlib.Path(sys.executable).parent}{os.pathsep}"
           f"{os.environ['PATH']}"}  # fmt: skip
    run = subprocess.run(
        ["bash", "-euo", "pipefail", "-c", found[2][1]],
        cwd=tmp_path,  # as a user runs it: beside my_planner.py, outside this checkout
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    report = (tmp_path / "report-mine" / "report.md").read_text()
    for noise in ("none", "control"):
        assert f"| {noise} | mppi | 3 |" in report
        assert f"| {noise} | head-for-goal | 3 |" in report
    assert "| none | mppi | 3 | 100.0 |" in report  # mppi drives around the obstacle
    assert "Collisions vs mppi: McNemar" in report and "Partial" not in report
