"""`dcmppi timing`: the command's tables, profile, fingerprint and scaling curves (structure and
fits, not speed: timing is never an assertion here)."""

import json
import subprocess
import sys
import time

import numpy as np
import pytest

from dcmppi import cli
from dcmppi.bench.results import provenance
from dcmppi.bench.timing import cases, cores, episodes, loop, profile, scaling
from dcmppi.bench.timing.worlds import dense_forest, world
from dcmppi.control import make_controller
from dcmppi.control.timer import NO_TIMER


def test_every_case_reports_a_ratio_to_its_reference_and_a_target(capsys, monkeypatch):
    labels = ("mppi", "clustered", "mppi holonomic")
    selected = tuple(c for c in cases.CASES if c.label in labels and c.problem == "forest")
    monkeypatch.setattr(cases, "CASES", selected)
    assert cli.main(["timing", "--steps", "6", "--json"]) == 0
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
    assert cli.main(["timing", "--steps", "6", "--json"]) == 0
    mppi, social = json.loads(capsys.readouterr().out)["results"]
    assert social["reference"] == "mppi" and social["target"] == "<= 20.0 ms"
    assert social["ratio"] == social["median_ms"] / mppi["median_ms"]  # crowd-sf's own mppi


def test_every_row_has_its_reference_row_on_its_problem():
    rows = {(c.label, c.problem.split("+")[0]) for c in cases.CASES}
    for c in cases.CASES:
        assert (c.reference, c.problem.split("+")[0]) in rows, (c.label, c.problem)


def test_each_smooth_row_is_timed_against_its_paper_mode_on_its_problem():
    rows = {(c.label, c.problem): c for c in cases.CASES}
    assert cases.SMOOTH_CASES
    for c in cases.SMOOTH_CASES:
        paper = rows[c.reference, c.problem]
        assert c.label == f"{paper.label}+smooth" and c.controller == paper.controller
        smooth = {"preset": "smooth", "perturbation": "correlated"}  # as the experiments' rows
        assert c.params == {**paper.params, **smooth} and c.target_ratio == 1.15


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
    assert cli.main(["timing", "--profile", "--steps", "8", "--json"]) == 0
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
        assert cli.main(["timing", "--fingerprint", "--steps", "6", "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        assert out["kernels"] == provenance.kernels()  # the hashes are this machine's
        runs.append(out["results"])
    assert runs[0] == runs[1]  # same seeds, same actions, same hashes
    hashes = [r["sha1"] for r in runs[0]]
    assert [r["case"] for r in runs[0]] == list(labels)
    assert len(set(hashes)) == len(hashes) and all(len(h) == 40 for h in hashes)


@pytest.mark.slow
def test_python_m_runs_the_profile():
    out = subprocess.run(
        [sys.executable, "-m", "dcmppi.cli", "timing", "--profile", "--steps", "5", "--json"],
        check=True,
        capture_output=True,
        text=True,
    )
    assert list(json.loads(out.stdout)) == [c.label for c in cases.PROFILE_CASES]


def _synthetic(ns, intercept_ms, noise, seed=0):
    """Scaling results of one controller on the K and N axes (BASE's K = 500, N = 50) whose
    medians grow by `ns` per state-step over `intercept_ms`, with relative noise."""
    rng = np.random.default_rng(seed)
    sizes = [(k, 50) for k in (250, 500, 1000, 2000, 4000, 8000)] + [
        (500, n) for n in (25, 50, 100, 200)
    ]
    points = [
        {"K": k, "N": n, "median_ms": (intercept_ms + ns * 1e-6 * k * n) * rng.normal(1, noise)}
        for k, n in sizes
    ]
    return {"K": {"mppi": {"points": points[:6]}}, "N": {"mppi": {"points": points[6:]}}}


def test_the_fit_recovers_a_known_ns_per_state_step_from_synthetic_timings():
    assert scaling.fit_line([1e4, 2e4, 4e4], [0.07, 0.12, 0.22]) == pytest.approx((0.02, 5.0))
    fitted = scaling.fits(_synthetic(ns=12.0, intercept_ms=0.05, noise=0.03))["mppi"]
    assert fitted["ns_per_state_step"]["ns"] == pytest.approx(12.0, rel=0.05)
    assert fitted["ns_per_state_step"]["intercept_ms"] == pytest.approx(0.05, abs=0.03)
    fitted = scaling.fits(_synthetic(ns=12.0, intercept_ms=0.2, noise=0.0))["mppi"]  # exact
    assert fitted["ns_per_state_step"]["intercept_ms"] == pytest.approx(0.2)
    assert fitted["ns_per_obstacle_state_step"] is None  # no moving axis: no fit
    with pytest.raises(ValueError, match="two different sizes"):
        scaling.fit_line([1e4, 1e4], [0.1, 0.2])


TINY_AXES = (
    scaling.Axis("K", "samples K", (16, 32), "K"),
    scaling.Axis("N", "horizon N (steps)", (5, 10), "N"),
    scaling.Axis("static", "static cylinders (forest)", (0, 4), "cylinders"),
    scaling.Axis("moving", "moving obstacles (crowd)", (0, 6), "obstacles"),
    scaling.Axis("P", "futures per obstacle P (crowd)", (2, 4), "P", ("dc",)),
)
TINY_BASE = {"K": 32, "N": 10, "static": 4, "moving": 6, "P": 4}


def test_scaling_times_a_tiny_grid_and_writes_its_json_and_plot(capsys, monkeypatch, tmp_path):
    pytest.importorskip("matplotlib")
    monkeypatch.setattr(scaling, "AXES", TINY_AXES)
    monkeypatch.setattr(scaling, "BASE", TINY_BASE)
    assert cli.main(["timing", "--scaling", "--steps", "5", "--json", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr()
    report = json.loads(out.out)
    assert report == json.loads((tmp_path / "scaling.json").read_text())
    assert (tmp_path / "scaling.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert out.err.startswith("wrote ") and "scaling.png" in out.err
    assert set(report) == {"settings", "axes", "results", "fits"}
    assert report["settings"]["base"] == TINY_BASE and report["settings"]["seconds"] > 0
    results = report["results"]
    assert list(results) == ["K", "N", "static", "moving", "P"]
    assert list(results["K"]) == ["mppi", "clustered", "dc", "tube"] and list(results["P"]) == [
        "dc"
    ]
    assert {c: r["problem"] for c, r in results["K"].items()} == scaling.HOME
    assert all(r["problem"] == "crowd" for r in results["moving"].values())
    k = results["K"]["mppi"]["points"]
    assert [(p["K"], p["N"], p["P"]) for p in k] == [(16, 10, 4), (32, 10, 4)]
    static = results["static"]["tube"]["points"]
    assert static[0]["cylinders"] == 0 < static[1]["cylinders"] and static[1]["obstacles"] == 0
    moving = results["moving"]["clustered"]["points"]
    assert [p["obstacles"] for p in moving] == [0, 6] and moving[0]["cylinders"] == 0
    assert [p["P"] for p in results["P"]["dc"]["points"]] == [2, 4]
    assert results["K"]["dc"]["points"][0]["obstacles"] == 6  # dc's home: the crowd at BASE
    for curve in (c for axis in results.values() for c in axis.values()):
        assert all(0 < p["median_ms"] <= p["p95_ms"] for p in curve["points"])
    fitted = report["fits"]
    assert set(fitted) == {"mppi", "clustered", "dc", "tube"}
    assert all(f["ns_per_state_step"] and f["ns_per_obstacle_state_step"] for f in fitted.values())
    assert (
        fitted["dc"]["ns_per_future_state_step"]
        and fitted["mppi"]["ns_per_future_state_step"] is None
    )
    panels = scaling.figure_data(report)
    assert panels["static cylinders (forest)"]["base"] == static[1]["cylinders"]
    assert panels["samples K"]["curves"]["dc"][0] == [16, 32]


def test_scaling_prints_a_table_per_axis_and_the_fits(capsys, monkeypatch):
    monkeypatch.setattr(scaling, "AXES", TINY_AXES[-1:])
    monkeypatch.setattr(scaling, "BASE", TINY_BASE)
    assert cli.main(["timing", "--scaling", "--steps", "5"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("dcmppi timing --scaling: median ms per step, one thread, 5 steps")
    assert lines[2].split() == ["futures", "per", "obstacle", "P", "(crowd)", "dc"]
    assert [line.split()[0] for line in lines[3:5]] == ["2", "4"]
    assert lines[-1].startswith("dc: ns per future-state-step ")


def test_dense_forest_is_the_forest_task_up_to_its_clusters_then_grows_the_map():
    task = world("forest")
    same = dense_forest(65)
    np.testing.assert_array_equal(same.static, task.static)
    np.testing.assert_array_equal(same.start, task.start)
    np.testing.assert_array_equal(dense_forest(16).map_bounds, task.map_bounds)
    assert dense_forest(260).map_bounds.tolist() == [0.0, 0.0, 150.0, 100.0]  # 4 x the clusters
    with pytest.raises(ValueError, match="builds its own world"):
        loop.ClosedLoop("mppi", "corridor", 5, world=task)


_SHORT = """
description = "two rows on short forest episodes"
task = "forest"
noises = ["none", "control"]
episodes = 50
task_params = { time_limit = 4.0 }
[[rows]]
label = "mppi"
controller = "mppi"
[[rows]]
label = "clustered"
controller = "clustered"
"""


def test_the_experiment_profile_splits_steps_and_episodes_and_projects_the_run(tmp_path, capsys):
    path = tmp_path / "short.toml"
    path.write_text(_SHORT)
    assert (
        cli.main(
            ["timing", "--profile", str(path), "--environments", "2", "--workers", "4", "--json"]
        )
        == 0
    )
    report = json.loads(capsys.readouterr().out)
    assert report["experiment"] == "short" and report["environments"] == 2
    rows = report["rows"]
    assert list(rows) == ["mppi", "clustered"]
    for label, row in rows.items():
        assert row["episodes"] == 4  # 2 environments x 2 noise profiles
        step = row["per_step_us"]
        assert 0 < step["controller parts"] < step["controller"]
        assert step["controller parts"] == pytest.approx(sum(row["parts_us"].values()))
        env_parts = {name: step[name] for name, _, _ in episodes.ENV_PARTS}
        assert env_parts.pop("obstacle motion") == 0  # the forest has no moving obstacles
        assert all(v > 0 for v in env_parts.values()) and sum(env_parts.values()) < step["env.step"]
        runner_parts = [step[name] for name, _, _ in episodes.RUNNER_PARTS]
        assert all(v > 0 for v in runner_parts) and sum(runner_parts) < step["runner"]
        assert ("DBSCAN" in row["parts_us"]) == (label == "clustered")
        whole = row["steps_per_episode"] * (step["controller"] + step["env.step"] + step["runner"])
        assert row["episode_s"] == pytest.approx(
            whole * 1e-6 + sum(row["per_episode_ms"].values()) * 1e-3
        )
    projection = report["projection"]
    assert projection["episodes"] == 200  # the whole experiment: 50 x 2 noise profiles x 2 rows
    each = 100 * sum(r["episode_s"] for r in rows.values())
    assert projection["minutes"] == pytest.approx(each / 4 / 60)
    assert 0 < projection["floor_minutes"] < projection["minutes"]
    assert cli.main(["timing", "--profile", str(path), "--environments", "1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[1].split() == ["mppi", "clustered"]
    assert "      DBSCAN" not in lines and any(line.startswith("    DBSCAN") for line in lines)
    assert lines[-1].startswith("the experiment's 200 episodes on 2 workers: ")


def test_the_experiment_profile_times_the_moving_obstacles_motion(tmp_path, capsys):
    path = tmp_path / "crowd.toml"
    path.write_text(
        'task = "crowd"\nepisodes = 3\ntask_params = { time_limit = 2.0 }\n'
        '[[rows]]\nlabel = "mppi"\ncontroller = "mppi"\n'
    )
    assert cli.main(["timing", "--profile", str(path), "--environments", "1", "--json"]) == 0
    step = json.loads(capsys.readouterr().out)["rows"]["mppi"]["per_step_us"]
    assert 0 < step["obstacle motion"] < step["env.step"]


def test_a_profiled_episode_is_the_bench_episode(tmp_path):
    from dcmppi.bench.episodes.runner import run_episode
    from dcmppi.bench.experiments import load_experiment
    from dcmppi.bench.results.database import ResultsDB

    path = tmp_path / "short.toml"
    path.write_text(_SHORT)
    exp = load_experiment(str(path)).select(episodes=1, noises=("control",))
    (key, spec), *_ = exp.specs()
    db = ResultsDB(tmp_path / "p.db", exp.config())
    one = episodes.profile_episode(spec, db, key)
    recorded = db.row(*key)
    db.close()
    plain = run_episode(spec)
    assert one["steps"] == plain["steps"]
    timing_fields = {"ctrl_ms_mean", "ctrl_ms_p95", "env_ms_mean", "wall_s"}
    same = [k for k in plain if k in recorded and k not in timing_fields]
    assert {"trace", "outcome", "ess_mean", "min_clearance", "jerk_mean"} <= set(same)
    assert {k: recorded[k] for k in same} == {k: plain[k] for k in same}


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--environments", "3"], "--environments is for --profile EXPERIMENT"),
        (["--profile", "static", "--workers", "0"], "--workers must be >= 1; got 0"),
        (["--profile", "static", "--steps", "5"], "choose --environments, not --steps"),
        (["--profile", "static", "--scaling"], "--profile EXPERIMENT runs on its own"),
    ],
)
def test_the_experiment_profile_refuses_bad_options_in_one_line(argv, message, capsys):
    with pytest.raises(SystemExit, match="2"):
        cli.main(["timing", *argv])
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


def test_an_unknown_experiment_to_profile_is_one_line(capsys):
    assert cli.main(["timing", "--profile", "desert"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown experiment 'desert'; valid: barn, " in err[0]


def test_a_row_the_bench_would_refuse_is_refused_before_any_episode(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text(
        _SHORT.replace('controller = "clustered"', 'controller = "clustered"\nparams = { K = 0 }')
    )
    assert cli.main(["timing", "--profile", str(path), "--environments", "1"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.strip().splitlines()) == 1 and "K must be" in err


def test_the_machines_gains_run_their_kernels_on_every_thread(monkeypatch):
    """cores: the kernels do the work they name (nothing a compiler could drop), and the gain
    counts every thread's call."""
    x = np.arange(5.0)
    y = np.empty(5)
    assert cores.stream(x, y, 3) == 1.0 and np.array_equal(y, 0.5 * x + 1.0)
    start = 1.0 + 1e-3 * np.arange(8)
    after = start
    for _ in range(3):
        after = after * 0.9999999 + 1e-7
    assert cores.compute(0) == start.sum() and cores.compute(3) == pytest.approx(after.sum())
    one = 1.0
    for _ in range(3):
        one = one * 0.9999999 + 1e-7
    assert cores.vector(0) == cores.VECTOR_SIZE
    assert cores.vector(3) == pytest.approx(cores.VECTOR_SIZE * one, rel=1e-12)
    calls = []
    monkeypatch.setattr(cores, "REPEATS", 2)
    gains = cores._gain(lambda *a: calls.append(a), [(1,), (2,), (3,)])
    assert gains > 0 and sorted(calls) == [(1,)] * 5 + [(2,)] * 2 + [(3,)] * 2


def test_timing_is_a_subcommand_of_the_one_parser(capsys):
    subparsers = next(a for a in cli.build_parser()._actions if a.dest == "command").choices
    options = {o for a in subparsers["timing"]._actions for o in a.option_strings}
    assert options == {
        "-h", "--help", "--json", "--steps", "--block", "--against", "--K", "--N", "--threads",
        "--scaling", "--out", "--profile", "--environments", "--workers", "--fingerprint",
    }  # fmt: skip
    with pytest.raises(SystemExit) as exit:
        cli.main(["timing", "--steps", "6", "--bogus"])
    assert exit.value.code == 2
    err = capsys.readouterr().err
    assert err == "dcmppi timing: error: unrecognized arguments: --bogus (see --help)\n"
