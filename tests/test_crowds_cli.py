"""Recorded crowds at the command line: `dcmppi crowds check`, the refusals of `predictor` and
`bench` in one line naming their own options, a results database untouched by a refused run,
and the report's check of the rule for a scene given as a file."""

import hashlib
import json

import numpy as np
import pytest

from dcmppi import cli
from dcmppi.bench.experiments import load_experiment
from dcmppi.bench.reports.report import own_tracks
from dcmppi.bench.results.database import ResultsDB
from dcmppi.tasks.replay import recordings

WALK = [(12 * k, 1, 0.48 * k, 0.0) for k in range(30)]  # TrajNet's drone scenes: 12 frames
CROSS = [(12 * k, 2, 4.0, 3.0 - 0.48 * (k - 5)) for k in range(5, 30)]  # a step, 1.2 m/s


def write(path, rows, header=""):
    np.savetxt(path, np.array(rows, float), delimiter="\t", fmt="%.10g", header=header,
               comments="")  # fmt: skip
    return str(path)


@pytest.fixture
def files(tmp_path, monkeypatch):
    """good.txt (frame step 12) and bad.txt (person 1 at x = -30 at frame 0), no ETH/UCY."""
    monkeypatch.delenv(recordings.CROWDS_ENV, raising=False)
    bad = [(0, 1, -30.0, 0.0), *WALK[1:], *CROSS]
    return write(tmp_path / "good.txt", WALK + CROSS), write(tmp_path / "bad.txt", bad)


def error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    return err[0]


def test_crowds_check_says_what_each_file_is_and_exits_2_for_a_refused_one(files, capsys):
    good, bad = files
    assert cli.main(["crowds", "check", good]) == 0
    line = capsys.readouterr().out.strip()
    assert line.startswith(f"{good}: ok: frame step 12 (0.4 s), 55 positions, 2 people, walking ")
    assert "1.20 m/s median" in line and line.endswith("2 replay episodes")
    assert cli.main(["crowds", "check", good, bad, "--json"]) == 2
    first, second = (json.loads(line) for line in capsys.readouterr().out.splitlines())
    assert first["frame_step"] == 12 and first["speed_median"] == pytest.approx(1.2)
    assert first["episodes"] == 2 and not first["refused"] and first["people"] == 2
    assert second["refused"] and second["people"] is None
    (problem,) = second["problems"]
    assert problem.startswith(f"{bad}: person 1 moves at 76.2 m/s from frame 0 to frame 12")
    assert "pass --max-speed M_PER_S if people run" in problem  # the command's own option
    assert cli.main(["crowds", "check", bad, "--max-speed", "100"]) == 0
    assert cli.main(["crowds", "check", good, "--max-speed", "-1"]) == 2
    assert error_line(capsys).endswith("error: --max-speed must be > 0; got -1.0")


def test_predictor_refusals_name_the_file_and_the_commands_options(files, tmp_path, capsys):
    good, bad = files
    train = ["predictor", "train", "--out", str(tmp_path / "m.npz"), "--data"]
    assert cli.main([*train, bad]) == 2
    assert "error: " + bad + ": person 1 moves at" in error_line(capsys)
    stated = write(tmp_path / "stated.txt", WALK + CROSS, header="# period 0.8\n")
    assert cli.main([*train, stated]) == 2
    assert error_line(capsys).endswith("read at --period 0.4: pass --period 0.8")
    assert cli.main([*train, good, "--max-windows", "-5"]) == 2
    assert error_line(capsys).endswith("error: --max-windows must be > 0; got -5")
    short = write(tmp_path / "short.txt", WALK[:12] + CROSS[:12])
    assert cli.main([*train, short]) == 2
    assert "0 windows of 20 consecutive annotated frames of one person (the longest run has 12)" \
        in error_line(capsys)  # fmt: skip
    assert not (tmp_path / "m.npz").exists()
    assert cli.main(["predictor", "eval", "--predictors", "cv", "--scenes", "eth"]) == 2
    assert error_line(capsys).endswith("or pass --folder DIR")
    assert cli.main(["predictor", "train", "--leave-out", "eth", "--out", "m.npz"]) == 2
    assert error_line(capsys).endswith("or pass --folder DIR")


def test_a_refused_run_leaves_an_existing_results_database_untouched(files, tmp_path, capsys):
    good, bad = files
    exp = load_experiment("eth-ucy")
    db = ResultsDB(tmp_path / "r.db", exp.config())
    spec = type("Spec", (), {"controller": "orca", "task": "replay", "seed": 0})()
    spec.task_params = spec.controller_params = spec.shared_params = {}
    db.record(("none", "orca", 0), spec, {"outcome": "goal", "collision": 0})
    db.close()
    before = hashlib.sha256((tmp_path / "r.db").read_bytes()).hexdigest()
    argv = ["bench", "--experiment", "eth-ucy", "--controllers", "orca", "--episodes", "1"]
    argv += ["--task-param", f"scene={bad}", "--db", str(tmp_path / "r.db"), "--no-progress"]
    assert cli.main(argv) == 2
    assert f"{bad}: person 1 moves at 76.2 m/s" in error_line(capsys)
    assert hashlib.sha256((tmp_path / "r.db").read_bytes()).hexdigest() == before


def test_the_report_finds_a_scene_given_as_a_file(files):
    good, _ = files
    exp = load_experiment("eth-ucy").with_params({"scene": good}, {})
    rows = [{"status": "ok", "scene": "good", "recording": "good", "person": p} for p in (1, 2)]
    n, hits = own_tracks(rows, exp)["good"]
    assert n == 2 and hits is not None and hits[0] == 0.0  # found: the rule checked, no contact
