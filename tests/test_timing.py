"""`dcmppi timing`: the command's tables and profile (structure, not speed: timing is never an
assertion here)."""

import json

from dcmppi.bench import timing


def test_every_case_reports_a_ratio_to_its_reference_and_a_target(capsys, monkeypatch):
    labels = ("mppi", "clustered", "mppi holonomic")
    cases = tuple(c for c in timing.CASES if c.label in labels and c.problem == "forest")
    monkeypatch.setattr(timing, "CASES", cases)
    assert timing.main(["--steps", "6", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["results"]
    assert [r["case"] for r in rows] == ["mppi", "clustered", "mppi holonomic"]
    assert rows[0]["ratio"] == 1.0 and rows[0]["target"] == "<= 0.2 ms"
    assert rows[2]["reference"] == "mppi" and rows[2]["target"] == "<= 1.5 x mppi"
    assert all(r["median_ms"] > 0 and r["p95_ms"] >= r["median_ms"] for r in rows)


def test_profile_times_the_parts_each_controller_calls(capsys):
    assert timing.main(["--profile", "--steps", "8", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    mppi, clustered, dc = out["mppi"]["parts"], out["clustered"]["parts"], out["dc"]["parts"]
    assert {"sample", "evaluate", "  rollout", "Alg. 1 update"} <= set(mppi)
    assert "DBSCAN" not in mppi and "  obstacle tracks" not in mppi
    assert clustered["evaluate"]["calls"] == 2 and clustered["DBSCAN"]["calls"] == 1
    assert "  obstacle tracks" in dc and "  cost-map count" not in dc  # the crowd has no map
    for agent in ("mppi unicycle", "mppi holonomic"):  # each agent's own rollout is timed
        assert out[agent]["parts"]["  rollout"]["calls"] == 1
    assert {"mppi mixed", "mppi holonomic mixed"} <= set(out)
    for parts, case in ((mppi, "mppi"), (clustered, "clustered")):
        inner = sum(parts[k]["median_us_per_step"] for k in parts if k.startswith("  "))
        assert 0 < inner <= 1.5 * parts["evaluate"]["median_us_per_step"]  # nested in evaluate
        assert parts["evaluate"]["median_us_per_step"] < 1.5 * out[case]["step_us"]


def test_fingerprint_repeats_and_tells_controllers_and_perturbations_apart(capsys, monkeypatch):
    labels = ("mppi", "mppi tv", "clustered", "clustered tv")
    cases = tuple(
        c for c in timing.FINGERPRINT_CASES if c.label in labels and c.problem == "forest"
    )
    monkeypatch.setattr(timing, "FINGERPRINT_CASES", cases)
    runs = []
    for _ in range(2):
        assert timing.main(["--fingerprint", "--steps", "6", "--json"]) == 0
        runs.append(json.loads(capsys.readouterr().out)["results"])
    assert runs[0] == runs[1]  # same seeds, same actions, same hashes
    hashes = [r["sha1"] for r in runs[0]]
    assert [r["case"] for r in runs[0]] == list(labels)
    assert len(set(hashes)) == len(hashes) and all(len(h) == 40 for h in hashes)
