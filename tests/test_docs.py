"""The documentation's examples run as written: every code block of the README (the first, the
install and test commands, is what CI runs), "Benchmark your own controller" with its files
written and its commands run, and docs/extending.md's agent and predictor; the links between
README.md, CHANGELOG.md and docs/*.md reach existing files and headings."""

import json
import os
import pathlib
import re
import shlex
import sqlite3
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXTENDING = "docs/extending.md"


def section(heading, page="README.md"):
    """The text of `page` under `heading` (a '## ' or '### ' line) up to the next heading of
    that level or above."""
    text = (ROOT / page).read_text()
    level = heading.split(" ")[0]
    start = text.index(f"\n{heading}\n")
    pattern = "\n#{2," + str(len(level)) + "} "
    ends = [m.start() for m in re.finditer(pattern, text[start + 1 :])]
    return text[start : start + 1 + ends[0]] if ends else text[start:]


def blocks(text):
    """(language, code) of each fenced block of Markdown text."""
    return re.findall(r"^```(\w+)\n(.*?)^```$", text, re.S | re.M)


@pytest.mark.slow
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

    ((lang, code),) = blocks(section("## Your own agent", EXTENDING))
    assert lang == "python" and code.count("\n") <= 45
    namespace = {}
    try:
        exec(compile(code, EXTENDING, "exec"), namespace)
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
        base.AGENTS.unregister("point")


def test_your_own_predictor_section_runs():
    """The registered predictor changes the plan, and with it a robot passes an obstacle that
    crosses its way, where the same planner with obstacles seen frozen drives into it."""
    from dcmppi.control import predictors

    ((lang, code),) = blocks(section("## Your own predictor", EXTENDING))
    assert lang == "python" and code.count("\n") <= 40
    namespace = {}
    try:
        exec(compile(code, EXTENDING, "exec"), namespace)
        np, dcmppi = namespace["np"], namespace["dcmppi"]
        u, moving = namespace["u"], namespace["moving"]
        assert u.shape == (3,) and np.hypot(u[0], u[1]) <= 1.5 + 1e-9
        frozen = dcmppi.make_controller("mppi", agent="holonomic", prediction="frozen", seed=0)
        assert not np.allclose(frozen.act(np.zeros(3), np.array([8.0, 0.0]), None, moving, None), u)

        def drive(**params):
            """12 s toward the goal while an obstacle crosses the way at 1.2 m/s, timed to meet
            the robot on the straight line: (smallest centre distance [m], final distance to
            the goal [m])."""
            ctrl = dcmppi.make_controller("mppi", agent="holonomic", seed=0, **params)
            state, obstacle = np.zeros(3), np.array([4.0, 3.2, -np.pi / 2, 0.5])
            closest = np.inf
            for _ in range(120):
                u = ctrl.act(state, np.array([8.0, 0.0]), None, obstacle[None], None)
                state = ctrl.agent.step(state, u, 0.1)
                obstacle[1] -= 1.2 * 0.1
                closest = min(closest, np.hypot(*(state[:2] - obstacle[:2])))
            return closest, np.hypot(state[0] - 8.0, state[1])

        touching = 0.5 + 0.5  # robot radius + obstacle radius
        closest, to_goal = drive(prediction="straight", speed=1.2)
        assert closest > touching and to_goal < 1.0
        assert drive(prediction="frozen")[0] < touching
    finally:
        predictors.base.PREDICTORS.unregister("straight")


@pytest.mark.slow
def test_your_own_predictor_plans_in_run_and_bench(tmp_path):
    """The README's predictor saved as my_predictor.py, named module:Class as the README says:
    `dcmppi run` plans with it and `dcmppi bench` records it beside frozen obstacles."""
    ((_, code),) = blocks(section("## Your own predictor", EXTENDING))
    (tmp_path / "my_predictor.py").write_text(code.split("\n\nctrl = ")[0] + "\n")
    (tmp_path / "exp.toml").write_text(
        'task = "crossing"\nnoises = ["none"]\nepisodes = 2\nbase_seed = 1\n'
        'reference = "frozen"\ntask_params = { agent = "holonomic" }\n'
        "controller_params = { K = 64 }\n"
        '[[rows]]\nlabel = "frozen"\ncontroller = "mppi"\n'
        '[[rows]]\nlabel = "straight"\ncontroller = "mppi"\n'
        'params = { prediction = "my_predictor:Straight", speed = 1.2 }\n'
    )
    env = {**os.environ, "PATH": f"{pathlib.Path(sys.executable).parent}{os.pathsep}"
           f"{os.environ['PATH']}"}  # fmt: skip
    paths = {}
    for prediction in ("my_predictor:Straight", "frozen"):
        run = subprocess.run(
            ["dcmppi", "run", "--task", "crossing", "--controller", "mppi", "--task-param",
             "agent=holonomic", "--param", f"prediction={prediction}", "--param", "K=64",
             "--json", *(["--param", "speed=1.2"] if ":" in prediction else [])],
            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
        )  # fmt: skip
        assert run.returncode == 0, run.stderr
        paths[prediction] = json.loads(run.stdout)["path_length"]
    assert paths["my_predictor:Straight"] != paths["frozen"]  # it planned with the predictor
    bench = subprocess.run(
        ["dcmppi", "bench", "--experiment", "exp.toml", "--db", "r.db", "--workers", "2"],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert bench.returncode == 0, bench.stderr
    rows = (
        sqlite3.connect(tmp_path / "r.db")
        .execute("SELECT label, status, params FROM episodes ORDER BY label, env_index")
        .fetchall()
    )
    assert [(label, status) for label, status, _ in rows] == [
        ("frozen", "ok"), ("frozen", "ok"), ("straight", "ok"), ("straight", "ok")
    ]  # fmt: skip
    straight = [params for label, _, params in rows if label == "straight"]
    assert all('"my_predictor:Straight"' in params for params in straight)


def ci_test_command():
    """The command .ci/run runs as its tests: its line `test_cmd="..."`."""
    lines = (ROOT / ".ci" / "run").read_text().splitlines()
    found = [line for line in lines if line.startswith("test_cmd=")]
    assert len(found) == 1, f".ci/run must set test_cmd once; found {found}"
    (command,) = shlex.split(found[0].partition("=")[2], comments=True)
    return command


def test_ci_runs_the_readme_test_command():
    """The second line of the README's first code block is the test command CI runs."""
    text = (ROOT / "README.md").read_text()
    first_block = re.search(r"^```\w*\n(.*?)^```$", text, re.S | re.M).group(1)
    lines = [line for line in first_block.splitlines() if line.strip()]
    assert len(lines) == 2 and lines[1] == ci_test_command() == "pytest -q"


def github_anchor(heading):
    """The fragment GitHub gives a Markdown heading: lower case, punctuation but - and _
    dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def headings(path):
    """Anchors of the headings of a Markdown file, outside fenced code."""
    prose = re.sub(r"^```.*?^```$", "", path.read_text(), flags=re.S | re.M)
    return {github_anchor(m) for m in re.findall(r"^#+ (.+)$", prose, re.M)}


def test_doc_links_reach_files_and_headings():
    pages = [ROOT / "README.md", ROOT / "CHANGELOG.md", *sorted((ROOT / "docs").glob("*.md"))]
    checked, broken = 0, []
    for page in pages:
        prose = re.sub(r"^```.*?^```$", "", page.read_text(), flags=re.S | re.M)
        for target in re.findall(r"\]\(([^)\s]+)\)", prose):
            if re.match(r"[a-z]+:", target):
                continue  # an external address
            path, _, anchor = target.partition("#")
            linked = (page.parent / path).resolve() if path else page
            checked += 1
            if not linked.exists() or (anchor and anchor not in headings(linked)):
                broken.append(f"{page.relative_to(ROOT)}: {target}")
    assert checked >= 10 and not broken, broken


def readme_blocks():
    """(index, language, code) of every fenced block of the README."""
    return [
        (i, lang, code) for i, (lang, code) in enumerate(blocks((ROOT / "README.md").read_text()))
    ]


def test_every_readme_block_is_run_by_a_test():
    """The first block is CI's (install, then the tests); python blocks run below (a block whose
    first line names its file is written for the commands of its section); toml and sh blocks
    are those of "Benchmark your own controller"."""
    own = blocks(section("## Benchmark your own controller"))
    for i, lang, code in readme_blocks():
        named = re.match(r"# \S+\.(py|toml)\n", code)
        assert i == 0 or (lang == "python" and not named) or (lang, code) in own, (i, code)


@pytest.mark.parametrize(
    "index",
    [i for i, lang, code in readme_blocks() if lang == "python" and not code.startswith("# ")],
)
def test_readme_python_block_runs(index, tmp_path, monkeypatch):
    """Each python block of the README runs as written, in a fresh namespace, in an empty
    folder (what it writes stays there)."""
    lang, code = blocks((ROOT / "README.md").read_text())[index]
    if "gymnasium" in code:
        pytest.importorskip("gymnasium", reason="the Gymnasium block needs dcmppi[gym]")
    if "dcmppi.bench.load" in code:
        pytest.importorskip("pandas", reason="dcmppi.bench.load needs dcmppi[pandas]")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, f"README.md block {index}", "exec"), {"__name__": "__readme__"})


# History belongs in git and CHANGELOG.md: no "eighth round", "issue 24", "#26" or commit hash
# in the README, docs/ or the code's docstrings and comments. A provenance line's content hash
# ("code 8eadbbb8") is a measurement's label, not history, and stays.
HISTORY = re.compile(
    r"\b(first|second|third|fourth|fifth|sixth|seventh|eighth|ninth|tenth|eleventh|twelfth)"
    r" round\b|\bround \d+\b|\bissues? #?\d+\b|(?<![\w/])#\d{2,}\b|\bcommits? [0-9a-f]{7,40}\b"
    r"|(?<!code )(?<![\w./:-])(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b",
    re.I,
)


def _history(text):
    return sorted({m.group(0) for m in HISTORY.finditer(text)})


def test_history_stays_out_of_docs_and_docstrings():
    pages = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
    code = [p for folder in ("dcmppi", "tasks", "models") for p in (ROOT / folder).rglob("*")]
    code = [p for p in code if p.suffix in (".py", ".toml", ".xml")]
    found = {}
    for path in pages + code:
        hits = _history(path.read_text())
        if hits:
            found[str(path.relative_to(ROOT))] = hits
    assert not found, f"history in docs or code (it belongs in CHANGELOG.md or git): {found}"


def test_the_history_pattern_finds_what_it_should():
    assert _history("the eighth round, issue 24, #26 and commit 341b7c4; e755496 too") == [
        "#26",
        "commit 341b7c4",
        "e755496",
        "eighth round",
        "issue 24",
    ]
    assert not _history("round(x), rounds to float32, code 8eadbbb8, 0x7fffffff, 1e-7, 2048")


def test_your_own_planner_step_section_runs():
    """The subclass's evaluate() seam steers the plan: the robot stays left of the line it
    charges, where plain mppi's path crosses it; two threads plan as one."""
    from dcmppi.control import make_controller

    ((lang, code),) = blocks(section("## Your own planner step", EXTENDING))
    assert lang == "python" and code.count("\n") <= 25
    namespace = {}
    exec(compile(code, EXTENDING, "exec"), namespace)
    np, keep_left = namespace["np"], namespace["KeepLeft"]
    assert namespace["state"][0] > 4.0  # it drove toward the goal

    def lowest_y(ctrl):
        state, lowest = np.zeros(3), np.inf
        for _ in range(50):
            state = ctrl.agent.step(state, ctrl.act(state, np.array([10.0, 0.0]), None), 0.1)
            lowest = min(lowest, state[1])
        return lowest

    assert lowest_y(keep_left(agent="holonomic", seed=0, threads=1)) > 0.0
    assert lowest_y(make_controller("mppi", agent="holonomic", seed=0)) < 0.0
    args = (np.zeros(3), np.array([10.0, 0.0]), None)
    one = keep_left(agent="holonomic", seed=0, threads=1).act(*args)
    np.testing.assert_array_equal(one, keep_left(agent="holonomic", seed=0, threads=2).act(*args))
