"""Provenance: what a run ran is recorded per run, and a resume under other conditions is
refused (dcmppi.bench.results.provenance, ResultsDB.begin_run)."""

import sqlite3
import sys

import pytest

from dcmppi.bench.episodes.runner import EpisodeSpec
from dcmppi.bench.experiments import load_experiment
from dcmppi.bench.results import provenance
from dcmppi.bench.results.database import ADDED, SCHEMA_VERSION, ProvenanceMismatch, ResultsDB

CONFIG = {
    "task": "forest",
    "base_seed": 1,
    "task_params": {},
    "controller_params": {},
    "rows": {"mppi": {"controller": "mppi", "params": {}}},
}
PROV = {
    "dcmppi": "0.1.0",
    "code_sha256": "a" * 64,
    "commit": "c" * 40,
    "dirty": False,
    "task": {"name": "forest", "params": {"n_clusters": 65}},
    "rows": {"mppi": {"controller": "mppi", "params": {"K": 500}}},
    "files": {},
    "libraries": {"python": "3.11.7", "numpy": "2.0"},
    "cpu": "CPU",
    "cores": 2,
    "host": "h",
}
SPEC = EpisodeSpec("forest", "mppi")
RESULT = {
    "outcome": "goal",
    "failure": False,
    "collision": False,
    "steps": 10,
    "ctrl_ms_mean": 1.0,
    "env_ms_mean": 0.1,
    "wall_s": 1.0,
}


def _run(path, prov, keys=((0, RESULT),), allow_mixed=False, exp=None):
    """One bench run of `keys` = [(env_index, result)] under provenance `prov`."""
    config = CONFIG if exp is None else exp.config()
    db = ResultsDB(path, config, provenance=prov, allow_mixed=allow_mixed)
    try:
        db.begin_run({"name": "t"} if exp is None else exp.to_dict())
        for index, result in keys:
            db.record(("none", "mppi", index), SPEC, result)
        db.end_run()
        return db.run_id
    finally:
        db.close()


def _with(**changes):
    return {**PROV, **changes}


@pytest.mark.parametrize(
    "changed, named",
    [
        (_with(dcmppi="0.2.0"), "dcmppi 0.1.0 -> 0.2.0"),
        (
            _with(code_sha256="b" * 64),
            "dcmppi's code (sha256 aaaaaaaa -> bbbbbbbb; commit ccccccc -> commit ccccccc)",
        ),
        (
            _with(rows={"mppi": {"controller": "mppi", "params": {"K": 64}}}),
            "row 'mppi' parameter K: 500 -> 64",
        ),
        (
            _with(task={"name": "forest", "params": {"n_clusters": 10}}),
            "task parameter n_clusters: 65 -> 10",
        ),
    ],
)
def test_a_resume_under_other_provenance_is_refused_in_one_line(tmp_path, changed, named):
    path = tmp_path / "r.db"
    _run(path, PROV)
    _run(path, PROV, [(1, RESULT)])  # the same provenance resumes
    with pytest.raises(ProvenanceMismatch) as e:
        _run(path, changed, [(2, RESULT)])
    message = str(e.value)
    assert named in message and "\n" not in message
    assert "--allow-mixed" in message and "new --db" in message
    db = ResultsDB(path)
    assert [r["env_index"] for r in db.rows()] == [0, 1]  # the refused run recorded nothing
    assert [r["run_id"] for r in db.runs()] == [1, 2]
    db.close()


def test_library_versions_and_machine_are_recorded_not_compared(tmp_path):
    path = tmp_path / "r.db"
    _run(path, PROV)
    other = _with(
        libraries={"python": "3.12.0"},
        cpu="other",
        kernels="numpy AVX2, openblas Haswell",
        cores=64,
        host="node7",
    )
    _run(path, other, [(1, RESULT)])  # another node of a cluster: fine
    db = ResultsDB(path)
    runs = db.runs()
    assert [r["provenance"]["host"] for r in runs] == ["h", "node7"]
    assert all(r["ended"] >= r["started"] for r in runs)
    assert [r["run_id"] for r in db.rows()] == [1, 2]
    db.close()


def test_allow_mixed_extends_and_the_report_shows_the_versions_per_row(tmp_path):
    from dcmppi.bench.reports.report import write_report

    path = tmp_path / "r.db"
    exp = load_experiment("static").select(2, ("mppi",), ("none",))
    _run(path, PROV, exp=exp)
    changed = _with(code_sha256="b" * 64)
    with pytest.raises(ProvenanceMismatch):
        _run(path, changed, [(1, RESULT)], exp=exp)
    _run(path, changed, [(1, RESULT)], allow_mixed=True, exp=exp)
    text = write_report(path, tmp_path / "out", plots=False)
    assert "**Mixed**" in text
    md = (tmp_path / "out" / "report.md").read_text()
    assert "## Provenance" in md and "**Mixed**" in md
    line = next(x for x in md.splitlines() if x.startswith("| none | mppi | run 1"))
    assert "code aaaaaaaa" in line and "code bbbbbbbb" in line
    assert "CPU (2 cores) on h" in md  # recorded before the kernels were


def test_the_kernels_name_numpys_level_and_each_blas(monkeypatch):
    import threadpoolctl

    blas = {"user_api": "blas", "internal_api": "openblas", "architecture": "SkylakeX"}
    openmp = {"user_api": "openmp", "internal_api": "openmp"}
    monkeypatch.setattr(threadpoolctl, "threadpool_info", lambda: [openmp, blas, blas])
    numpy_part, blas_part = provenance.kernels().split(", ")
    assert blas_part == "openblas SkylakeX"
    monkeypatch.setattr(threadpoolctl, "threadpool_info", lambda: [])
    assert provenance.kernels() == numpy_part


def test_numpys_level_is_its_widest_target_that_runs():
    from types import SimpleNamespace

    umath = SimpleNamespace(
        __cpu_baseline__=["SSE", "SSE2", "X86_V2"],
        __cpu_dispatch__=["X86_V3", "X86_V4", "AVX512_ICL"],
        __cpu_features__={"SSE": True, "SSE2": True, "X86_V2": True, "X86_V3": True},
    )
    assert provenance.numpy_level(umath) == "X86_V3"
    umath.__cpu_features__["X86_V3"] = False  # disabled (NPY_DISABLE_CPU_FEATURES) or absent
    assert provenance.numpy_level(umath) == "X86_V2"
    umath.__cpu_features__ = {}
    assert provenance.numpy_level(umath) == "baseline"


def test_rows_that_only_errored_do_not_bind_the_fixed_rerun(tmp_path):
    """The bench says "fix the cause and rerun": a run whose rows are all errors (replaced by the
    rerun's) does not refuse the fixed code, and the report is not called mixed."""
    from dcmppi.bench.reports.report import write_report

    path = tmp_path / "r.db"
    exp = load_experiment("static").select(1, ("mppi",), ("none",))
    _run(path, PROV, [(0, {"error": "ZeroDivisionError: division by zero"})], exp=exp)
    fixed = _with(code_sha256="b" * 64)
    _run(path, fixed, [(0, RESULT)], exp=exp)  # no ProvenanceMismatch
    text = write_report(path, tmp_path / "out", plots=False)
    assert "Mixed" not in text
    with pytest.raises(ProvenanceMismatch):  # while its ok rows remain, other code is refused
        _run(path, PROV, [(1, RESULT)], exp=load_experiment("static").select(2, ("mppi",)))


def test_a_shard_running_beside_under_other_code_is_refused_before_either_records(tmp_path):
    path = tmp_path / "r.db"
    first = ResultsDB(path, CONFIG, provenance=PROV)
    first.begin_run({"name": "t"})  # started, nothing recorded yet, this process alive
    second = ResultsDB(path, CONFIG, provenance=_with(code_sha256="b" * 64))
    with pytest.raises(ProvenanceMismatch, match="dcmppi's code"):
        second.begin_run({"name": "t"})
    first.end_run()  # it recorded nothing: its run is dropped, and binds no one
    second.begin_run({"name": "t"})
    second.end_run()
    first.close()
    second.close()


def test_a_run_that_recorded_nothing_leaves_no_run(tmp_path):
    path = tmp_path / "r.db"
    _run(path, PROV)
    _run(path, _with(code_sha256="b" * 64), [], allow_mixed=True)  # a no-op resume
    db = ResultsDB(path)
    assert [r["run_id"] for r in db.runs()] == [1]
    db.close()
    _run(path, PROV, [(1, RESULT)])  # so the database is not mixed


def test_a_schema_4_database_opens_and_upgrades(tmp_path):
    path = tmp_path / "old.db"
    db = ResultsDB(path, CONFIG)
    db.record(("none", "mppi", 0), SPEC, RESULT)
    db.close()
    with sqlite3.connect(path) as c:  # make it a schema 4 database as dcmppi wrote it
        c.execute("DROP TABLE runs")
        for name in ADDED[5]:
            c.execute(f"ALTER TABLE episodes DROP COLUMN {name}")
        c.execute("UPDATE meta SET value = '4' WHERE key = 'schema'")
    old = ResultsDB(path)  # read-only: nothing converted
    assert old.runs() == [] and old.rows()[0]["run_id"] is None
    assert old.row("none", "mppi", 0)["trace"] is None
    old.close()
    pose = {"final_x": 1.0, "final_y": 2.0, "final_theta": 0.5}
    _run(path, PROV, [(1, {**RESULT, **pose, "trace": b"x"})])
    db = ResultsDB(path)
    assert [(r["env_index"], r["run_id"]) for r in db.rows()] == [(0, None), (1, 1)]
    assert db.row("none", "mppi", 1)["final_y"] == 2.0
    assert db._db.execute("SELECT value FROM meta WHERE key='schema'").fetchone() == (
        str(SCHEMA_VERSION),
    )
    db.close()


def _module(tmp_path, name, K):
    folder = tmp_path / f"v{K}"
    folder.mkdir()
    (folder / f"{name}.py").write_text(
        "class Mine:\n"
        f"    def __init__(self, K={K}, seed=None):\n"
        "        self.K = K\n"
        "    def reset(self):\n"
        "        pass\n"
        "    def act(self, state, goal, static, moving, obstacle_model):\n"
        "        return [0.0]\n"
    )
    return folder


def test_collect_resolves_defaults_and_hashes_user_modules_and_files(tmp_path, monkeypatch):
    """A user's controller whose default K changed (a copied package) is caught twice: the
    resolved parameter and the module's sha256; the layout file's sha256 too."""
    name = "h1_user_controller"
    layout = tmp_path / "world.csv"
    layout.write_text("world,x,y,radius\n0,1,1,0.1\n")
    provs = []
    for K in (500, 64):
        monkeypatch.syspath_prepend(str(_module(tmp_path, name, K)))
        sys.modules.pop(name, None)
        exp = load_experiment("barn").select(1, (f"{name}:Mine",), ("none",))
        exp = exp.with_params({"path": str(layout)}, {})
        provs.append(provenance.collect(exp, exp.specs()))
        monkeypatch.undo()
        layout.write_text("world,x,y,radius\n0,1,1,0.2\n")
    sys.modules.pop(name, None)
    first, second = provs
    assert first["rows"][f"{name}:Mine"]["params"] == {"K": 500}
    assert first["task"]["params"]["obstacle_measurement_std"] == 0.0  # Navigation's default
    assert "world" not in first["task"]["params"]  # the environment index
    assert first["libraries"]["numpy"] and first["cores"] >= 1 and first["code_sha256"]
    assert first["kernels"] == provenance.kernels()
    assert set(first["files"]) == {f"controller {name}:Mine", "task parameter path"}
    diffs = provenance.differences(first, second)
    assert f"row '{name}:Mine' parameter K: 500 -> 64" in diffs
    assert any(d.startswith(f"controller {name}:Mine (") for d in diffs)
    assert any(d.startswith("task parameter path (") for d in diffs)
    assert provenance.differences(first, first) == []


def test_the_barn_file_of_the_environment_is_hashed(tmp_path, monkeypatch):
    barn = tmp_path / "barn.csv"
    barn.write_text("world,x,y,radius\n0,1,1,0.1\n")
    monkeypatch.setenv("DCMPPI_BARN", str(barn))
    spec = EpisodeSpec("layout", "mppi", task_params={"world": 0})
    entry = provenance.task_files(spec)["$DCMPPI_BARN"]
    assert entry["path"] == str(barn) and len(entry["sha256"]) == 64
    assert provenance.task_files(EpisodeSpec("forest", "mppi")) == {}


def test_code_version_names_this_checkout():
    code, commit, dirty = provenance.code_version()
    assert len(code) == 64
    assert commit is None or (len(commit) == 40 and isinstance(dirty, bool))


def test_a_learned_predictors_model_file_is_hashed_and_a_missing_one_named(tmp_path):
    import types

    import numpy as np

    from dcmppi.control.predictors import learned

    t = 0.4 * np.arange(20)
    walks = np.stack([np.column_stack([v * t, np.full(20, y)]) for v, y in [(1, 0), (1.5, 2)]])
    windows = types.SimpleNamespace(
        observed=walks[:, :8],
        future=walks[:, 8:],
        neighbours=(np.zeros((0, 8, 2)),) * 2,
        source=np.arange(2),
        period=0.4,
    )
    model = tmp_path / "model.npz"
    learned.fit(windows, seed=0).save(model)
    exp = load_experiment("dynamic").select(1, ("dc",), ("none",))
    params = {"prediction": "learned", "model": str(model), "K": 64}
    spec = EpisodeSpec("crowd", "dc", "none", 0, {}, params)
    prov = provenance.collect(exp, [(("none", "dc", 0), spec)])
    entry = prov["files"]["row dc model"]
    assert entry == {"path": str(model.resolve()), "sha256": learned.sha256(model)}
    learned.fit(windows, seed=0, neighbours=2).save(model)  # another model, same path
    again = provenance.collect(exp, [(("none", "dc", 0), spec)])
    assert any(d.startswith("row dc model (") for d in provenance.differences(prov, again))
    missing = EpisodeSpec("crowd", "dc", "none", 0, {}, {**params, "model": "nowhere.npz"})
    with pytest.raises(ValueError, match=r"row 'dc': prediction 'learned' model=nowhere.npz: no"):
        provenance.collect(exp, [(("none", "dc", 0), missing)])
    assert provenance.model_files("dc", EpisodeSpec("crowd", "dc")) == {}
    other = tmp_path / "other.npz"
    learned.fit(windows, seed=1).save(other)
    two = [
        (("none", "dc", i), EpisodeSpec("crowd", "dc", "none", i, {}, {**params, "model": str(m)}))
        for i, m in enumerate([model, other, model])
    ]
    prov = provenance.collect(exp, two)  # a recipe's model per environment: every file
    assert {k for k in prov["files"] if "model" in k} == {
        "row dc model model.npz",
        "row dc model other.npz",
    }
    assert prov["files"]["row dc model other.npz"]["sha256"] == learned.sha256(other)
    assert prov["rows"]["dc"]["params"]["model"].startswith("per environment")
