"""`dcmppi outcomes`: old against new code on paired episodes (synthetic rows)."""

import dataclasses

import pytest

from dcmppi.bench.episodes.runner import EpisodeSpec
from dcmppi.bench.experiments import load_experiment
from dcmppi.bench.reports.outcomes import Comparison, compare, joint, table
from dcmppi.bench.results.database import ResultsDB
from dcmppi.cli import main


def _db(path, collided, seed=0, experiment="static", failed=(), task_params=None, K=None):
    """A database of row mppi (noise none): environment i collided when i is in `collided`,
    timed out when in `failed`; with task_params or the row's K changed."""
    exp = load_experiment(experiment).select(len(collided) + 60, ("mppi",), ("none",))
    if task_params is not None:
        exp = dataclasses.replace(exp, task_params=task_params)
    if K is not None:
        rows = tuple(dataclasses.replace(r, params={**r.params, "K": K}) for r in exp.rows)
        exp = dataclasses.replace(exp, rows=rows)
    db = ResultsDB(path, exp.config())
    db.begin_run(exp.to_dict())
    for i in range(len(collided) + 60):
        hit = collided[i] if i < len(collided) else False
        outcome = "collision" if hit else "time_limit" if i in failed else "goal"
        result = {"outcome": outcome, "collision": hit, "failure": outcome != "goal", "steps": 9}
        db.record(("none", "mppi", i), EpisodeSpec(exp.task, "mppi", "none", seed + i), result)
    db.end_run()
    db.close()
    return path


def test_same_outcomes_within_chance_hold(tmp_path):
    old = _db(tmp_path / "old.db", [True] * 10 + [False] * 30)
    new = _db(tmp_path / "new.db", [True] * 8 + [False] * 30 + [True, True], failed=(50,))
    (c,) = compare(old, new)
    assert (c.pairs, c.old, c.new, c.only_old, c.only_new) == (100, 10, 10, 2, 2)
    assert c.p == 1.0 and c.inside and c.holds
    assert (c.old_failures, c.new_failures) == (10, 11)
    assert "| none | mppi | 100 | 10 | 10 | 2 / 2 | 1.00 | yes | 10 | 11 | holds |" in table([c])
    assert main(["outcomes", "--old", str(old), "--new", str(new)]) == 0


def test_more_collisions_fail_the_rule(tmp_path, capsys):
    old = _db(tmp_path / "old.db", [True] * 5 + [False] * 35)
    new = _db(tmp_path / "new.db", [True] * 20 + [False] * 20)
    (c,) = compare(old, new)
    assert (c.only_old, c.only_new) == (0, 15) and c.p < 0.001 and not c.inside and not c.holds
    assert main(["outcomes", "--old", str(old), "--new", str(new)]) == 1
    out = capsys.readouterr()
    assert "differ beyond chance: mppi (none)" in out.err
    assert "joint test over 1 rows (Holm, McNemar, 5% family-wise): differ: mppi (none" in out.out


def _row(label, p):
    return Comparison("none", label, 300, 10, 12, 4, 6, p, 10, 12)


def test_the_joint_test_steps_down_over_the_rows():
    """Holm: p_(i) <= 0.05 / (m - i + 1) in turn; the first that is not stops it."""
    # one row's own test fails (0.02 < 0.05), the six rows together do not (0.02 > 0.05 / 6)
    rows = [_row(name, p) for name, p in zip("abcdef", (0.3, 0.02, 0.5, 1, 1, 1), strict=True)]
    assert not rows[1].holds
    assert joint(rows).endswith("the same within chance (smallest p = 0.02, threshold 0.00833)")
    # 0.001 <= 0.05 / 3, 0.02 <= 0.05 / 2 and 0.04 <= 0.05 / 1: all three differ ...
    rows = [_row("a", 0.02), _row("b", 0.001), _row("c", 0.04)]
    assert joint(rows).endswith(
        "differ: b (none, p = 0.001), a (none, p = 0.02), c (none, p = 0.04)"
    )
    # ... but 0.03 > 0.05 / 2 stops the step-down: 0.04 is not rejected either
    rows = [_row("a", 0.03), _row("b", 0.001), _row("c", 0.04)]
    assert joint(rows).endswith("differ: b (none, p = 0.001)")


def test_other_seeds_or_experiments_are_refused(tmp_path):
    old = _db(tmp_path / "old.db", [False] * 3)
    with pytest.raises(ValueError, match="has seed 0 in the old databases and 7 in the new"):
        compare(old, _db(tmp_path / "seeds.db", [False] * 3, seed=7))
    with pytest.raises(ValueError, match="experiment 'static' and the new 'dynamic'"):
        compare(old, _db(tmp_path / "dyn.db", [False] * 3, experiment="dynamic"))


def test_other_configurations_are_refused(tmp_path):
    """The rule pairs two codes on the same episodes: databases run with other task or row
    parameters are not paired, even with the same seeds."""
    old = _db(tmp_path / "old.db", [False] * 3)
    other = _db(tmp_path / "task.db", [False] * 3, task_params={"time_limit": 3.0})
    with pytest.raises(ValueError, match="ran task_params .* and the new .*time_limit"):
        compare(old, other)
    with pytest.raises(ValueError, match="row 'mppi' ran .*'K': 64"):
        compare(old, _db(tmp_path / "row.db", [False] * 3, K=64))


def test_databases_without_a_shared_finished_episode_are_refused(tmp_path):
    old = _db(tmp_path / "old.db", [False] * 3)
    exp = load_experiment("static").select(3, ("mppi",), ("none",))
    db = ResultsDB(tmp_path / "errors.db", exp.config())
    db.begin_run(exp.to_dict())
    for i in range(3):  # every episode an error row
        db.record(("none", "mppi", i), EpisodeSpec(exp.task, "mppi", "none", i), {"error": "x"})
    db.end_run()
    db.close()
    with pytest.raises(ValueError, match="share no finished episode"):
        compare(old, tmp_path / "errors.db")
