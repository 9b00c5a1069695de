"""The field's crowd-navigation metrics: the functions on hand-computed cases, the compiled
per-instant pass against its numpy expressions, the per-step recorder on a synthetic pedestrian
sequence and a synthetic walk (where the time goes), real episodes' collision kinds, the
database round trip, the report's table and `runner.act`'s keywords."""

import math
import re
import sqlite3
import struct
import types

import numpy as np
import pytest

from dcmppi.bench.episodes import metrics
from dcmppi.bench.episodes.metrics import FieldMetrics, mean_jerk, spl, time_to_collision
from dcmppi.bench.episodes.runner import EpisodeSpec, act, run_episode
from dcmppi.bench.experiments import load_experiment
from dcmppi.bench.reports.report import metrics_table, write_report
from dcmppi.bench.results.database import ADDED, SCHEMA_VERSION, ResultsDB
from dcmppi.bench.results.stats import bootstrap_median, field_metrics


def test_time_to_collision_by_hand():
    position = np.array([[5.0, 0.0], [5.0, 0.3], [5.0, 1.0], [5.0, 0.0], [0.4, 0.0], [3.0, 4.0]])
    velocity = np.array([[-1.0, 0.0], [-1.0, 0.0], [-1.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0, 0]])
    radius = np.array([0.6, 0.5, 0.6, 0.6, 0.6, 0.6])
    t = time_to_collision(position, velocity, radius)
    # head-on: 5 - 0.6 at 1 m/s; off-centre by 0.3 with R = 0.5: touch at x = 0.4;
    # passing 1 m off-centre, moving away, standing: never; overlapping: now
    assert t == pytest.approx([4.4, 4.6, math.inf, math.inf, 0.0, math.inf])


def test_mean_jerk_and_spl_by_hand():
    v = np.array([[0.0, 0.0], [1.0, 0.0], [4.0, 0.0], [9.0, 1.0]])
    # second differences (2, 0), (2, 1) over dt^2 = 0.25
    assert mean_jerk(v, 0.5) == pytest.approx((2.0 + math.sqrt(5.0)) / 2 / 0.25)
    assert mean_jerk(v[:2], 0.5) is None
    assert spl(True, [0, 0], [10, 0], 1.0, 12.0) == pytest.approx(9 / 12)
    assert spl(True, [0, 0], [10, 0], 1.0, 8.0) == 1.0  # shorter than the straight line
    assert spl(False, [0, 0], [10, 0], 1.0, 9.0) == 0.0


def _numpy_instant(moving, velocity, robot_xy, robot_v, robot_radius, pref):
    """FieldMetrics.read's values of one instant as the numpy expressions of its docstring."""
    rel = moving[:, :2] - robot_xy
    gap = np.hypot(rel[:, 0], rel[:, 1]) - moving[:, 3] - robot_radius
    v = velocity - robot_v
    a, b = np.einsum("ij,ij->i", v, v), np.einsum("ij,ij->i", rel, v)
    c = np.einsum("ij,ij->i", rel, rel) - (moving[:, 3] + robot_radius) ** 2
    disc = b * b - a * c
    closing = (b < 0) & (disc >= 0) & (a > 0)
    ttc = np.full(len(rel), np.inf)
    ttc[closing] = (-b[closing] - np.sqrt(disc[closing])) / a[closing]
    ttc[c <= 0] = 0.0
    assert _bits(time_to_collision(rel, v, moving[:, 3] + robot_radius)) == _bits(ttc)
    near = gap < metrics.NEAR
    loss = np.sum(1.0 - np.hypot(velocity[near, 0], velocity[near, 1]) / pref[near])
    personal = bool((gap < metrics.PERSONAL_SPACE).any())
    return float(gap.min()), personal, float(ttc.min()), float(loss), int(near.sum())


def _bits(values):
    """The values as their IEEE bits (a nan's sign aside), so that -0.0 differs from 0.0."""
    return [v if isinstance(v, bool | int) else struct.pack("<d", abs(v) if v != v else v)
            for v in values]  # fmt: skip


def test_an_instant_is_read_in_one_pass_with_the_numpy_values_bit_for_bit():
    rng = np.random.default_rng(7)
    with np.errstate(divide="ignore", invalid="ignore"):
        for trial in range(400):
            n = int(rng.integers(1, 300))
            spread = (0.5, 3.0, 20.0)[trial % 3]  # most, some or few obstacles near the robot
            moving = np.column_stack(
                [rng.uniform(-spread, spread, (n, 2)), rng.normal(size=n), rng.uniform(0.1, 0.5, n)]
            )
            velocity = rng.normal(size=(n, 2)) * (trial % 4 != 0)  # every 4th: all standing
            robot_xy, robot_v, pref = rng.normal(size=2), rng.normal(size=2), rng.uniform(0.5, 2, n)
            if trial % 5 == 0:  # -0.0, a zero preferred speed (its loss -inf or nan), a nan
                velocity[: n // 2] *= -0.0
                pref[:: max(1, n // 4)] = 0.0
                moving[-1, 0] = np.nan if trial % 10 == 0 else moving[-1, 0]
            args = moving, velocity, robot_xy, robot_v, 0.3, pref
            assert _bits(metrics._instant(*args)) == _bits(_numpy_instant(*args))
            # without preferred speeds: the same gap, personal space and time, no losses
            got = metrics._instant(*args[:-1], np.zeros(0))
            assert _bits(got) == _bits(_numpy_instant(*args)[:3]) + _bits((0.0, 0))


def test_the_clusters_are_the_distinct_labels_at_or_above_zero():
    rng = np.random.default_rng(5)
    for n in (1, 5, 500):
        labels = rng.integers(-1, n, n)
        assert metrics._clusters(labels) == len(np.unique(labels[labels >= 0]))
    assert metrics._clusters(np.array([-1, -1])) == 0
    assert metrics._clusters(np.array([7, 9, 7, -1])) == 2  # beyond n: counted by sorting
    assert metrics._clusters(np.array([0.0, 2.0, 2.0])) == 2  # not integers


class _Physics:
    """Plays a fixed sequence: robot standing at the origin (radius 0.2); pedestrian A
    (radius 0.3) walking toward it along x at 1.2 m/s, B (radius 0.3) standing at (0, 2.3)."""

    robot_radius = 0.2

    def __init__(self):
        self.k = 0

    def robot_pose(self):
        return np.zeros(3)

    def robot_position(self):
        return 0.0, 0.0

    def robot_velocity(self):
        return np.zeros(3)

    def clearance(self):
        return 0.0

    def moving_velocity(self):
        return np.array([[-1.2, 0.0], [0.0, 0.0]])

    def moving_obstacles(self):
        x = 3.0 - 0.6 * self.k  # 3.0, 2.4, 1.8, 1.2, 0.6 at dt = 0.5
        return np.array([[x, 0.0, math.pi, 0.3], [0.0, 2.3, 0.0, 0.3]])


def _env(physics, pref_speed=(1.5, 1.0), moving=2, goal=(1.0, 0.0)):
    world = types.SimpleNamespace(
        moving=np.zeros((moving, 4)),
        moving_pref_speed=np.asarray(pref_speed)[:moving],
        start=np.zeros(3),
        goal=np.asarray(goal),
    )
    task = types.SimpleNamespace(world=world, agent=types.SimpleNamespace(max_speed=1.0))
    return types.SimpleNamespace(physics=physics, task=task, control_timestep=lambda: 0.5)


def _play(physics, **world):
    metrics = FieldMetrics(_env(physics, **world))
    for _ in range(4):
        physics.k += 1
        metrics.read(physics)
    return metrics.result()


def test_field_metrics_on_a_synthetic_sequence():
    r = _play(_Physics())
    # A's gaps 2.5, 1.9, 1.3, 0.7, 0.1; B's 1.8 throughout
    assert r["min_ped_gap"] == pytest.approx(0.1)
    assert r["personal_space_share"] == pytest.approx(1 / 5)  # only A's last gap < 0.5
    assert r["discomfort_frequency"] == pytest.approx(1 / 5)  # and < 0.2
    assert r["min_ttc"] == pytest.approx(0.1 / 1.2)  # A at 0.6 m, closing at 1.2 m/s
    # within 2 m: A four times (1 - 1.2 / 1.5 = 0.2), B five times (standing: 1)
    assert r["ped_speed_loss"] == pytest.approx((4 * 0.2 + 5 * 1.0) / 9)
    assert r["jerk_mean"] == 0.0
    assert r["time_waiting"] == 2.0 and r["time_slow"] == 0.0  # standing, never in free space
    assert r["detour"] == 0.0
    # today's arcs have no preferred speeds (nan) to lose; a world without moving obstacles
    # has no pedestrian metrics at all
    assert _play(_Physics(), pref_speed=np.full(2, np.nan))["ped_speed_loss"] is None
    r = _play(_Physics(), moving=0)
    names = ("min_ped_gap", "personal_space_share", "discomfort_frequency", "min_ttc")
    assert all(r[k] is None for k in names)


class _Brushing(_Physics):
    """A passes the robot at surface gaps 2.5, 0.4, 0.15, 0.1 and 0.05 m."""

    def moving_obstacles(self):
        x = (3.0, 0.9, 0.65, 0.6, 0.55)[self.k]
        return np.array([[x, 0.0, math.pi, 0.3], [0.0, 2.3, 0.0, 0.3]])


def test_discomfort_frequency_is_the_share_of_instants_within_crowdnavs_distance():
    r = _play(_Brushing())
    assert r["personal_space_share"] == pytest.approx(4 / 5)  # below 0.5 m
    assert r["discomfort_frequency"] == pytest.approx(3 / 5)  # below 0.2 m


class _Walker(_Physics):
    """The robot along x at 0, 0.04, 0.96, 1.0 and 0.5 m/s over steps of 0.5 s, the nearest
    obstacle's surface 3, 1, 3, 3, 2 and 0 m from its own at the instants."""

    X = (0.0, 0.0, 0.02, 0.5, 1.0, 1.25)
    CLEARANCE = (3.0, 1.0, 3.0, 3.0, 2.0, 0.0)

    def robot_position(self):
        return self.X[self.k], 0.0

    def clearance(self):
        return self.CLEARANCE[self.k]


def test_where_the_time_goes_on_a_synthetic_walk():
    walker = _Walker()
    metrics = FieldMetrics(_env(walker, moving=0))
    for _ in range(5):
        walker.k += 1
        metrics.read(walker)
    r = metrics.result()
    assert r["time_waiting"] == 1.0  # the first two steps, below 0.1 m/s
    assert r["time_slow"] == 1.0  # below 0.9 m/s in free space: the first and last steps
    assert r["detour"] == 1.25  # 1.25 m of path for 1 m from start to goal
    r = FieldMetrics(_env(_Walker(), moving=0, goal=(0.0, 0.0))).result()  # no step yet
    assert (r["time_waiting"], r["time_slow"], r["detour"]) == (0.0, 0.0, None)


@pytest.mark.parametrize(("task", "kind"), [("blocked", "static"), ("crossing", "pedestrian")])
def test_an_episode_records_the_kind_of_its_collision(task, kind):
    r = run_episode(EpisodeSpec(task, "user_controllers:Straight"))
    assert r["outcome"] == "collision" and r["collision_kind"] == kind
    assert not r["success"] and not r["timeout"] and r["spl"] == 0.0
    assert r["jerk_mean"] is not None and math.isfinite(r["jerk_mean"])
    if kind == "static":  # no moving obstacles: no pedestrian metrics
        assert r["min_ped_gap"] is None and r["min_ttc"] is None
    else:  # the task's clearance covers the substeps and static obstacles too
        assert r["min_clearance"] - 1e-9 <= r["min_ped_gap"] <= 0.0 and r["min_ttc"] == 0.0


def _result(outcome, kind=None, ttc=math.inf, pedestrians=True, spl_=None):
    r = {
        "outcome": outcome,
        "success": outcome == "goal",
        "collision": outcome == "collision",
        "collision_kind": kind,
        "timeout": outcome == "time_limit",
        "failure": outcome != "goal",
        "steps": 100,
        "time_to_goal": 10.0 if outcome == "goal" else None,
        "path_length": 12.0,
        "spl": (0.75 if outcome == "goal" else 0.0) if spl_ is None else spl_,
        "jerk_mean": 2.0,
        "min_ped_gap": 0.4 if pedestrians else None,
        "personal_space_share": 0.1 if pedestrians else None,
        "discomfort_frequency": 0.05 if pedestrians else None,
        "intrusion_ratio": 0.04 if pedestrians else None,
        "social_distance": 0.45 if pedestrians else None,
        "min_ttc": ttc if pedestrians else None,
        "ped_speed_loss": 0.05 if pedestrians else None,
        "min_clearance": 0.3,
        "ctrl_ms_mean": 1.0,
        "ctrl_ms_p95": 1.0,
        "env_ms_mean": 0.1,
        "wall_s": 1.0,
    }
    return r


def test_database_round_trip_of_the_metrics(tmp_path):
    config = {"task": "crowd", "base_seed": 0, "rows": {}}
    db = ResultsDB(tmp_path / "r.db", config)
    spec = EpisodeSpec("crowd", "mppi")
    db.record(("none", "mppi", 0), spec, _result("collision", "pedestrian", ttc=0.0))
    db.record(("none", "mppi", 1), spec, _result("goal"))
    db.record(("none", "mppi", 1), spec, _result("collision", "static"))  # ignored: done
    a, b = db.rows()
    db.close()
    assert (a["collision_kind"], a["min_ttc"], a["success"], a["timeout"]) == (
        "pedestrian",
        0,
        0,
        0,
    )
    assert (b["collision_kind"], b["min_ttc"], b["success"]) == (None, math.inf, 1)
    for k in ("spl", "jerk_mean", "min_ped_gap", "personal_space_share", "ped_speed_loss"):
        assert b[k] == _result("goal")[k]


def test_an_older_database_is_read_with_dashes_and_upgraded(tmp_path):
    exp = load_experiment("static").select(2, ("mppi", "clustered"), ("none",))
    path = tmp_path / "old.db"
    db = ResultsDB(path, exp.config())
    db.begin_run(exp.to_dict())
    for label in ("mppi", "clustered"):
        db.record(("none", label, 0), EpisodeSpec("forest", label), _result("goal"))
        db.record(("none", label, 1), EpisodeSpec("forest", label), _result("collision", "static"))
    db.end_run()
    db.close()
    with sqlite3.connect(path) as c:  # as schema 3 wrote it
        for name in ADDED[4]:
            c.execute(f"ALTER TABLE episodes DROP COLUMN {name}")
        c.execute("UPDATE meta SET value = '3' WHERE key = 'schema'")
    text = write_report(path, tmp_path / "out", plots=False)
    assert not re.search(r"\bnan\b", text)  # no nan cell ("Provenance" holds "nan")
    line = next(
        x for x in metrics_table(ResultsDB(path).rows(), exp).splitlines() if "| mppi |" in x
    )
    # success and timeouts come from the outcome; the rest was not recorded
    assert line.startswith("| none | mppi | 2 | 50.0 [") and line.count("| - ") == 8
    ResultsDB(path, exp.config()).close()  # opening to write adds the columns
    with sqlite3.connect(path) as c:
        assert c.execute("SELECT value FROM meta WHERE key = 'schema'").fetchone() == (
            str(SCHEMA_VERSION),
        )
        assert {r[1] for r in c.execute("PRAGMA table_info(episodes)")} >= set(ADDED[4])


def _rows(results, label="dc", noise="none"):
    return [
        {**r, "noise": noise, "label": label, "env_index": i, "status": "ok"}
        for i, r in enumerate(results)
    ]


def test_the_metrics_table_shows_rates_intervals_and_dashes():
    crowd = _rows(
        [_result("goal", ttc=2.0), _result("goal", ttc=math.inf)]
        + [_result("collision", "pedestrian", ttc=0.0), _result("time_limit", ttc=1.0)],
    )
    static = _rows([_result("goal", pedestrians=False)] * 3, label="mppi")
    rows = crowd + static
    s = field_metrics(rows)[("none", "dc")]
    assert s["success"][0] == 50.0 and s["pedestrian"][0] == 25.0 and s["static"][0] == 0.0
    assert s["timeout"][0] == 25.0 and s["path_length"][3] == 2  # the successful episodes
    assert s["spl"][0] == pytest.approx(0.375) and s["spl"][3] == 4
    assert s["min_ttc"][:1] == (1.5,)  # median of 0, 1, 2, inf
    assert s["personal_space_share"][0] == pytest.approx(10.0)  # in %
    exp = load_experiment("static").select(4, ("mppi",), ("none",))
    text = metrics_table(rows, exp)
    dc = next(x for x in text.splitlines() if "| dc |" in x)
    assert dc.startswith("| none | dc | 4 | 50.0 [15.0, 85.0] | 25.0 [4.6, 69.9] | 0.0 [0.0, 49.0]")
    assert "| 0.375 [0.000, 0.750] |" in dc and "| 1.50 [" in dc and "| 5.0 [5.0, 5.0] |" in dc
    mppi = next(x for x in text.splitlines() if "| mppi |" in x)
    # jerk applies, pedestrians not
    assert mppi.endswith("| 2.0 [2.0, 2.0] | - | - | - | - | - | - | - |")
    assert not re.search(r"\bnan\b", text)  # no nan cell ("Provenance" holds "nan")


def test_bootstrap_median_takes_infinite_values():
    lo, hi = bootstrap_median([1.0, 2.0, math.inf, math.inf, math.inf])
    assert lo <= 2.0 and hi == math.inf
    assert bootstrap_median([3.0] * 5) == (3.0, 3.0)


class _Plain:
    def act(self, state, goal, static, moving, obstacle_model):
        self.kwargs = {}
        return [0.0]


class _Keywords:
    def act(self, state, goal, static, moving, obstacle_model, bounds=None, moving_velocity=None):
        self.kwargs = {"bounds": bounds, "moving_velocity": moving_velocity}
        return [0.0]


def test_act_passes_the_moving_velocity_to_controllers_that_take_it():
    obs = {
        "robot_pose": np.zeros(3),
        "goal": np.ones(2),
        "static_obstacles": np.zeros((1, 3)),
        "moving_obstacles": np.zeros((2, 4)),
        "obstacle_model": np.zeros(4),
        "map_bounds": np.array([0.0, 0.0, 1.0, 1.0]),
    }
    keywords, plain = _Keywords(), _Plain()
    act(keywords, obs)
    assert keywords.kwargs["moving_velocity"] is None  # the observation has none
    velocity = np.full((2, 2), 0.5)
    act(keywords, {**obs, "moving_velocity": velocity})
    assert keywords.kwargs["moving_velocity"] is velocity
    assert keywords.kwargs["bounds"] is obs["map_bounds"]
    act(plain, {**obs, "moving_velocity": velocity})  # a user's act without the keywords


def test_planner_gets_the_robot_the_task_simulates():
    """Robot parameters the task sets by default reach the planner too: the corridor's 0.3 m
    robot, the square's 1 m/s top speed; task_params still override them."""
    from dcmppi.bench.episodes.runner import EpisodeSpec, controller_for

    corridor = controller_for(EpisodeSpec("corridor", "dc", seed=0))
    assert corridor.robot_radius == 0.3 and corridor.agent.name == "holonomic"
    square = controller_for(EpisodeSpec("square", "mppi", seed=0))
    assert square.agent.v_max == 1.0 and square.robot_radius == 0.3
    faster = controller_for(EpisodeSpec("square", "mppi", seed=0, task_params={"v_max": 1.2}))
    assert faster.agent.v_max == 1.2
    assert controller_for(EpisodeSpec("forest", "mppi", seed=0)).robot_radius == 0.5
