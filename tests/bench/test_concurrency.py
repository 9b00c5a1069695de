"""Several runs writing one results database at once: the configuration merge and each insert
are single transactions, conflicts are errors, a live writer is named."""

import threading

import pytest

import dcmppi.bench.results.database as results
from dcmppi.bench.episodes.runner import EpisodeSpec
from dcmppi.bench.results.database import ConfigMismatch, ResultsDB

BASE = {
    "task": "forest",
    "base_seed": 1,
    "task_params": {},
    "controller_params": {},
    "rows": {"mppi": {"controller": "mppi", "params": {}}},
}
RESULT = {"outcome": "goal", "failure": False, "collision": False, "steps": 10}


def _with_row(K):
    return {**BASE, "rows": {**BASE["rows"], "new": {"controller": "mppi", "params": {"K": K}}}}


def test_two_runs_adding_one_label_with_other_params_cannot_both_pass(tmp_path, monkeypatch):
    """Run A reads the configuration; run B starts then and may read it before A writes its
    merge (A waits until B merged or 1 s passed). Without one transaction around read,
    merge and write, both pass and the label holds K = 100 and K = 300 rows."""
    path = tmp_path / "r.db"
    ResultsDB(path, BASE).close()
    merge = results._merge
    a_merging, b_merged = threading.Event(), threading.Event()

    def interleaved(where, stored, requested):
        if requested["rows"]["new"]["params"]["K"] == 100:  # run A: let B go first if it can
            a_merging.set()
            b_merged.wait(timeout=1.0)
        else:
            b_merged.set()
        return merge(where, stored, requested)

    monkeypatch.setattr(results, "_merge", interleaved)
    outcome = {}

    def run(name, K):
        try:
            ResultsDB(path, _with_row(K)).close()
            outcome[name] = "ok"
        except ConfigMismatch as e:
            outcome[name] = str(e)

    a = threading.Thread(target=run, args=("A", 100))
    a.start()
    assert a_merging.wait(timeout=30)  # A read the configuration, B starts now
    b = threading.Thread(target=run, args=("B", 300))
    b.start()
    a.join()
    b.join()
    assert sorted(outcome.values())[1] == "ok"  # exactly one passed ...
    refused = sorted(outcome.values())[0]
    assert "row 'new' differ" in refused  # ... the other was refused, naming the row
    stored = ResultsDB(path).config["rows"]["new"]["params"]["K"]
    assert stored == (100 if outcome["A"] == "ok" else 300)


def test_an_episode_recorded_with_other_params_is_an_error_not_dropped(tmp_path):
    path = tmp_path / "r.db"
    first, second = ResultsDB(path, BASE), ResultsDB(path, BASE)
    first.record(
        ("none", "mppi", 0), EpisodeSpec("forest", "mppi", controller_params={"K": 1}), RESULT
    )
    with pytest.raises(ConfigMismatch) as e:
        second.record(
            ("none", "mppi", 0), EpisodeSpec("forest", "mppi", controller_params={"K": 2}), RESULT
        )
    message = str(e.value)
    assert "none/mppi/0 is already recorded with other parameters" in message
    assert "controller_params.K: 1 -> 2" in message and "\n" not in message
    # the same episode with the same parameters (two runs of one configuration): kept once
    second.record(
        ("none", "mppi", 0), EpisodeSpec("forest", "mppi", controller_params={"K": 1}), RESULT
    )
    assert len(second.rows()) == 1
    # an error row retried with 1.0 for 1 (equal numbers, as the configuration check takes them)
    key, error = ("none", "mppi", 1), {"error": "x"}
    first.record(key, EpisodeSpec("forest", "mppi", controller_params={"gain": 1}), error)
    second.record(key, EpisodeSpec("forest", "mppi", controller_params={"gain": 1.0}), RESULT)
    assert [r["status"] for r in second.rows() if r["env_index"] == 1] == ["ok"]
    first.close()
    second.close()


def test_a_second_live_writer_is_warned_about(tmp_path, capsys):
    path = tmp_path / "r.db"
    first, second = ResultsDB(path, BASE), ResultsDB(path, BASE)
    first.begin_run({"name": "t"})
    first._set("writer", {**first.writer, "pid": 1})  # another live process (init) on this host
    second.begin_run({"name": "t"})
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert f"warning: {path} is also being written by pid 1 on" in err
    second.end_run()
    first.close()
    second.close()
    capsys.readouterr()
    ResultsDB(path, BASE).begin_run({"name": "t"})  # the mark was removed: no warning
    assert capsys.readouterr().err == ""
