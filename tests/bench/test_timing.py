"""`dcmppi timing`: the command's tables, profile and fingerprint (structure, not speed: timing
is never an assertion here)."""

import json
import subprocess
import sys
import time

import numpy as np
import pytest

from dcmppi.bench import timing
from dcmppi.bench.timing import cases, loop, profile
from dcmppi.control import make_controller
from dcmppi.control.timer import NO_TIMER


def test_every_case_reports_a_ratio_to_its_reference_and_a_target(capsys, monkeypatch):
    labels = ("mppi", "clustered", "mppi holonomic")
    selected = tuple(c for c in cases.CASES if c.label in labels and c.problem == "forest")
    monkeypatch.setattr(cases, "CASES", selected)
    assert timing.main(["--steps", "6", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)["results"]
    assert [r["case"] for r in rows] == ["mppi", "clustered", "mppi holonomic"]
    assert rows[0]["ratio"] == 1.0 and rows[0]["target"] == "<= 0.2 ms"
    assert rows[2]["reference"] == "mppi" and rows[2]["target"] == "<= 1.5 x mppi"
    assert all(r["median_ms"] > 0 and r["p95_ms"] >= r["median_ms"] for r in rows)


def test_an_unknown_problem_names_the_valid_ones():
    with pytest.raises(ValueError, match="unknown timing problem 'desert'; valid: forest, "):
        loop.ClosedLoop("mppi", "desert", 5)


def test_the_pedestrian_problems_have_their_rows_and_targets(capsys, monkeypatch):
    rows = {(c.label, c.problem): c for c in cases.CASES}
    corridor = [rows[label, "corridor"] for label in ("mppi", "dc", "dc-cv", "dc-social")]
    assert [c.params.get("prediction") for c in corridor] == [None, None, "cv", "social"]
    assert all(c.params["agent"] == "holonomic" and c.params["beta"] == 100.0 for c in corridor)
    assert rows["dc-social", "corridor"].target_ms == 5.0
    selected = (rows["mppi", "crowd-sf"], rows["dc-social", "crowd-sf"])
    monkeypatch.setattr(cases, "CASES", selected)
    assert timing.main(["--steps", "6", "--json"]) == 0
    mppi, social = json.loads(capsys.readouterr().out)["results"]
    assert social["reference"] == "mppi" and social["target"] == "<= 20.0 ms"
    assert social["ratio"] == social["median_ms"] / mppi["median_ms"]  # crowd-sf's own mppi


def test_the_corridor_loop_walks_its_pedestrians_and_passes_their_velocities(monkeypatch):
    calls = []

    def recording(name, **params):  # the real controller, its act's arguments recorded
        ctrl = make_controller(name, **params)
        act = ctrl.act

        def record(*args, **kwargs):
            calls.append((args, kwargs))
            return act(*args, **kwargs)

        ctrl.act = record
        return ctrl

    monkeypatch.setattr(loop, "make_controller", recording)
    closed = loop.ClosedLoop("mppi", "corridor", 6, **cases.WALK)
    assert closed.ctrl.robot_radius == 0.3  # the corridor task's robot
    for _ in range(6):
        closed.step()
    moving = np.array([args[3] for args, _ in calls])  # (steps, 12, 4)
    velocity = np.array([kwargs["moving_velocity"] for _, kwargs in calls])  # (steps, 12, 2)
    assert moving.shape == (6, 12, 4) and velocity.shape == (6, 12, 2)
    assert all(args[5] is closed.bounds for args, _ in calls)
    assert (moving[:, :, 3] == 0.3).all()
    speed = np.hypot(velocity[..., 0], velocity[..., 1])
    assert (speed > 0.3).all()  # everyone walks ...
    heading = np.arctan2(velocity[..., 1], velocity[..., 0])
    assert np.allclose(np.exp(1j * moving[..., 2]), np.exp(1j * heading))  # ... as observed
    # each step moves them by dt x the velocity observed after it (semi-implicit Euler)
    step = np.diff(moving[..., :2], axis=0)
    assert np.allclose(step, closed.ctrl.dt * velocity[1:])


class _Parts:
    """A controller stand-in that times its parts through the hook, as the controllers do:
    warm-up parts in the first steps, then sample, evaluate (two rollouts) and a part of its
    own."""

    def __init__(self):
        self.timer = NO_TIMER
        self.steps = 0

    def act(self):
        self.steps += 1
        if self.steps <= loop.SKIP:
            with self.timer("warm-up"):
                return
        with self.timer("sample"):
            pass
        with self.timer("evaluate"):
            for _ in range(2):
                with self.timer("rollout"):
                    time.sleep(2e-4)
        with self.timer("my part"):
            pass


class _Loop:
    def __init__(self):
        self.ctrl, self.times = _Parts(), []

    def step(self):
        t0 = time.perf_counter()
        self.ctrl.act()
        self.times.append(time.perf_counter() - t0)


def test_profile_sums_each_label_per_step_through_the_timer_hook(capsys):
    result = profile.profile_loop(_Loop(), 8)
    parts = result["parts"]
    assert list(parts) == ["sample", "evaluate", "rollout", "my part"]  # no warm-up steps
    assert [p["calls"] for p in parts.values()] == [1, 1, 2, 1]
    us = {label: p["median_us_per_step"] for label, p in parts.items()}
    assert 400 <= us["rollout"] <= us["evaluate"] <= result["step_us"]  # 2 x 200 us, nested
    profile.print_profile({"fake": {"problem": "forest", **result}}, 8)
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].startswith("fake (forest): step ")
    assert [line.split(" us")[0].rsplit(" ", 1)[0].rstrip() for line in lines[2:]] == [
        "  sample",
        "  evaluate",
        "    rollout",  # within evaluate
        "  my part",
    ]
    assert lines[4].endswith("(2 calls)") and lines[5].endswith("(1 call)")


def test_profile_times_the_parts_each_controller_calls(capsys):
    if getattr(make_controller("mppi"), "timer", None) is not NO_TIMER:
        pytest.skip("the controllers do not have the timer hook (dcmppi.control.timer) yet")
    assert timing.main(["--profile", "--steps", "8", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert list(out) == [c.label for c in cases.PROFILE_CASES]
    mppi, clustered, dc = out["mppi"]["parts"], out["clustered"]["parts"], out["dc"]["parts"]
    assert {"sample", "controls", "rollout", "objective", "importance", "update"} <= set(mppi)
    assert "DBSCAN" not in mppi and "features" not in mppi
    assert clustered["rollout"]["calls"] == 2 and clustered["DBSCAN"]["calls"] == 1
    assert "prediction" in dc
    for agent in ("mppi unicycle", "mppi holonomic"):  # each agent's own rollout is timed
        assert out[agent]["parts"]["rollout"]["calls"] == 1
    for case in ("mppi", "clustered", "dc"):
        parts = out[case]["parts"]
        outer = [k for k in parts if profile.NESTED.get(k) not in parts]
        assert 0 < sum(parts[k]["median_us_per_step"] for k in outer) <= 1.5 * out[case]["step_us"]


def test_fingerprint_repeats_and_tells_controllers_and_perturbations_apart(capsys, monkeypatch):
    labels = ("mppi", "mppi tv", "clustered", "clustered tv")
    selected = tuple(
        c for c in cases.FINGERPRINT_CASES if c.label in labels and c.problem == "forest"
    )
    monkeypatch.setattr(cases, "FINGERPRINT_CASES", selected)
    runs = []
    for _ in range(2):
        assert timing.main(["--fingerprint", "--steps", "6", "--json"]) == 0
        runs.append(json.loads(capsys.readouterr().out)["results"])
    assert runs[0] == runs[1]  # same seeds, same actions, same hashes
    hashes = [r["sha1"] for r in runs[0]]
    assert [r["case"] for r in runs[0]] == list(labels)
    assert len(set(hashes)) == len(hashes) and all(len(h) == 40 for h in hashes)


@pytest.mark.slow
def test_python_m_runs_the_profile():
    out = subprocess.run(
        [sys.executable, "-m", "dcmppi.bench.timing", "--profile", "--steps", "5", "--json"],
        check=True,
        capture_output=True,
        text=True,
    )
    assert list(json.loads(out.stdout)) == [c.label for c in cases.PROFILE_CASES]
