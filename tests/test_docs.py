"""The README's examples run as written: "Benchmark your own controller" (its files are written,
its commands run) and "Your own agent"."""

import os
import pathlib
import re
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]


def section(heading):
    """The README's text under `heading` (a '## ' or '### ' line) up to the next heading of
    that level or above."""
    text = (ROOT / "README.md").read_text()
    level = heading.split(" ")[0]
    start = text.index(f"\n{heading}\n")
    pattern = "\n#{2," + str(len(level)) + "} "
    ends = [m.start() for m in re.finditer(pattern, text[start + 1 :])]
    return text[start : start + 1 + ends[0]] if ends else text[start:]


def blocks(text):
    """(language, code) of each fenced block of Markdown text."""
    return re.findall(r"^```(\w+)\n(.*?)^```$", text, re.S | re.M)


def test_benchmark_your_own_controller_section_runs(tmp_path):
    found = blocks(section("## Benchmark your own controller"))
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


def test_your_own_agent_section_runs():
    """The registered agent plans with every controller: a few steps reach the goal's side of
    the cylinder without touching it."""
    from dcmppi.control.agents import base

    ((lang, code),) = blocks(section("### Your own agent"))
    assert lang == "python" and code.count("\n") <= 45
    namespace = {}
    try:
        exec(compile(code, "README.md", "exec"), namespace)
        np, dcmppi = namespace["np"], namespace["dcmppi"]
        assert namespace["u"].shape == (2,) and abs(namespace["u"]).max() <= 0.8
        for name in ("mppi", "clustered", "dc", "tube"):
            ctrl = dcmppi.make_controller(name, agent="point", v_max=0.8, seed=0, K=64, N=20)
            state = np.zeros(3)
            for _ in range(120):
                u = ctrl.act(state, np.array([5.0, 2.0]), np.array([[2.5, 0.4, 0.5]]))
                state = ctrl.agent.step(state, u, 0.1)
                assert np.hypot(state[0] - 2.5, state[1] - 0.4) > 1.0, name
            assert np.hypot(state[0] - 5.0, state[1] - 2.0) < 0.5, name
    finally:
        base._AGENTS.pop("point", None)
