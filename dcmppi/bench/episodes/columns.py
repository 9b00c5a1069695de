"""Every column of an episode's row, declared once: its name, SQLite type, unit, the schema
version that added it, what it holds, and how the report shows it.

    COLUMNS        the row's columns in order: the results database's table, episodes.csv
    EPISODE        those `run_episode` measures (the rest the database writes: key, run, params)
    EpisodeResult  `run_episode`'s values, checked against EPISODE
    shown(table)   the columns a report table shows, in order

The database's schema and migrations (dcmppi.bench.results.database), the statistics per column
(dcmppi.bench.results.stats) and the report's headings, digits and notes
(dcmppi.bench.reports.report) derive from these declarations: a new metric is its declaration
here and its computation (dcmppi.bench.episodes.metrics).
"""

from __future__ import annotations

import dataclasses

from dcmppi.bench.episodes.metrics import (
    DISCOMFORT,
    FREE_SPACE,
    INTRUSION_HORIZON,
    INTRUSION_STEP,
    NEAR,
    PERSONAL_SPACE,
    SLOW_SHARE,
    STOP_SPEED,
    TURN_DEADBAND,
    WAIT_SPEED,
)

FIRST_SCHEMA = 2  # the oldest schema the database reads: its columns are `since` this
PYTHON = {"TEXT": (str,), "INTEGER": (int,), "REAL": (float, int), "BLOB": (bytes,)}
TABLES = ("metrics", "smoothness", "diagnostics")  # the report's tables of declared columns
STATISTICS = ("mean", "median", "per_step")


@dataclasses.dataclass(frozen=True)
class Column:
    """One column of an episode's row.

    name: the column's (the result's key); type: its SQLite type (TEXT, INTEGER, REAL, BLOB),
    whose Python types (PYTHON) the result's value must have; note: what it holds, a phrase
    (the report's notes quote it); since: the schema version that added it; unit: the stored
    value's ("m", "s", "1/m"; "" for none); episode: `run_episode` measures it (False: the
    database writes it); required: NOT NULL.

    How the report shows it: tables, those of TABLES that show it; title, its heading before
    the unit; digits; percent: a share shown x 100 in %; statistic: a row's figure over its
    finished episodes, "mean" or "median" (with bootstrap intervals where the table gives
    intervals) or "per_step" (the mean over all steps, of a per-step mean); over: the episodes
    it is taken over, "all" or "goal" (the successful ones).
    """

    name: str
    type: str
    note: str
    since: int = FIRST_SCHEMA
    unit: str = ""
    episode: bool = True
    required: bool = False
    tables: tuple[str, ...] = ()
    title: str = ""
    digits: int = 2
    percent: bool = False
    statistic: str = "mean"
    over: str = "all"

    def __post_init__(self):
        checks = {
            "type": self.type in PYTHON,
            "statistic": self.statistic in STATISTICS,
            "over": self.over in ("all", "goal"),
            "tables": set(self.tables) <= set(TABLES) and bool(self.title or not self.tables),
        }
        bad = [f"{k}={getattr(self, k)!r}" for k, ok in checks.items() if not ok]
        if bad:
            raise ValueError(f"column {self.name}: {', '.join(bad)}; see Column's docstring")

    @property
    def sql(self) -> str:
        """Its type in CREATE TABLE."""
        return f"{self.type} NOT NULL" if self.required else self.type

    @property
    def heading(self) -> str:
        """The report's heading: the title with the shown unit ("Path [m]", "Personal space %",
        "Turn sign changes per m"), and "(median)" for a median."""
        if self.percent:
            text = f"{self.title} %"
        elif self.unit.startswith("1/"):
            text = f"{self.title} per {self.unit[2:]}"
        else:
            text = f"{self.title} [{self.unit}]" if self.unit else self.title
        return f"{text} (median)" if self.statistic == "median" else text

    @property
    def scale(self) -> float:
        """The factor from the stored value to the shown one."""
        return 100.0 if self.percent else 1.0

    @property
    def explained(self) -> str:
        """The report note's sentence: the heading, the note, and where the row's figure is not
        the mean over its finished episodes, how it is taken."""
        how = {
            "median": "; the median over episodes",
            "per_step": "; the mean over all steps",
        }.get(self.statistic, "; over the successful episodes" if self.over == "goal" else "")
        return f"{self.heading}: {self.note}{how}."


def _record(name: str, type: str, note: str, **kw) -> Column:
    """A column the database writes (not `run_episode`)."""
    return Column(name, type, note, episode=False, **kw)


_CROWD = "a pedestrian (moving obstacle)"
_TURNS = (
    "how often the turn rate of the robot's path (the rate of its direction of travel) changes "
    f"sign (steps below {STOP_SPEED:g} m/s and turns below {TURN_DEADBAND:g} rad/s skipped)"
)
COLUMNS = (
    # the key
    _record("noise", "TEXT", "the noise profile", required=True),
    _record("label", "TEXT", "the experiment's row", required=True),
    _record("env_index", "INTEGER", "the environment's index in the experiment", required=True),
    # what was run
    _record("controller", "TEXT", "the row's controller", required=True),
    _record("task", "TEXT", "the task", required=True),
    _record("seed", "INTEGER", "the environment's seed", required=True),
    _record("run_id", "INTEGER", "the run (table runs) that recorded it", since=5),
    _record("status", "TEXT", '"ok", or "error" where the episode raised', required=True),
    _record("error", "TEXT", "the error's type and message"),
    _record("traceback", "TEXT", "an error's traceback, where the executor caught one", since=5),
    # the outcome
    Column("outcome", "TEXT", '"goal", "collision", "left_map" or "time_limit"'),
    Column("success", "INTEGER", "the goal reached", since=4),
    Column("collision", "INTEGER", "a collision ended it"),
    Column(
        "collision_kind",
        "TEXT",
        '"pedestrian" (the first contact a moving obstacle) or "static" (walls too); none '
        "without collision",
        since=4,
    ),
    Column("timeout", "INTEGER", "the time limit reached", since=4),
    Column("failure", "INTEGER", "any outcome but the goal"),
    Column("steps", "INTEGER", "control steps"),
    Column(
        "time_to_goal",
        "REAL",
        "from the start until the goal was reached",
        unit="s",
        tables=("metrics",),
        title="Time to goal",
        over="goal",
    ),
    Column(
        "nav_score",
        "REAL",
        "BARN's navigation score (BARN worlds only)",
        since=3,
    ),
    Column(
        "path_length",
        "REAL",
        "the length of the robot's path through its positions at the control instants",
        unit="m",
        tables=("metrics",),
        title="Path",
        over="goal",
    ),
    Column(
        "spl",
        "REAL",
        "success weighted by path length, success x shortest / max(path, shortest), shortest "
        "the straight line from the start to within the goal tolerance",
        since=4,
        tables=("metrics",),
        title="SPL",
        digits=3,
    ),
    Column(
        "jerk_mean",
        "REAL",
        "the mean norm of the second difference of the robot's planar velocity at the control "
        "instants / dt^2",
        since=4,
        unit="m/s^3",
        tables=("metrics", "smoothness"),
        title="Jerk",
        digits=1,
    ),
    # smoothness and indecision (dcmppi.bench.episodes.metrics)
    Column(
        "control_rate_linear",
        "REAL",
        "the mean over steps of |u_k - u_(k-1)| / dt of the velocity controls the controller "
        "commanded (before control noise), the norm over holonomic u_x, u_y or unicycle v (none "
        "for the Dubins car, whose speed is fixed)",
        since=6,
        unit="m/s^2",
        tables=("smoothness",),
        title="Control rate, velocity",
    ),
    Column(
        "control_rate_angular",
        "REAL",
        "the same of the turn-rate control (holonomic u_theta; unicycle and Dubins omega)",
        since=6,
        unit="rad/s^2",
        tables=("smoothness",),
        title="Control rate, turn",
    ),
    Column(
        "turn_sign_changes",
        "INTEGER",
        _TURNS,
        since=6,
    ),
    Column(
        "indecision_per_m",
        "REAL",
        f"{_TURNS}, per metre travelled",
        since=6,
        unit="1/m",
        tables=("smoothness",),
        title="Turn sign changes",
        digits=3,
    ),
    Column(
        "indecision_per_s",
        "REAL",
        "the same per second of the episode",
        since=6,
        unit="1/s",
        tables=("smoothness",),
        title="Turn sign changes",
        digits=3,
    ),
    # the task blocked's side of the obstacle (none in other tasks)
    Column(
        "commit_time",
        "REAL",
        "from the start until the side of the obstacle it keeps",
        since=6,
        unit="s",
        title="Commit time",
    ),
    Column(
        "commit_delay",
        "REAL",
        "from the first side taken until the side it keeps",
        since=6,
        unit="s",
    ),
    Column("side_switches", "INTEGER", "changes of side after the first", since=6),
    # the same of the side each step's plan takes (none without a plan)
    Column(
        "plan_commit_time",
        "REAL",
        "from the start until the planned side it keeps",
        since=7,
        unit="s",
        title="Plan: commit time",
    ),
    Column(
        "plan_commit_delay",
        "REAL",
        "from the first planned side until the side it keeps",
        since=7,
        unit="s",
    ),
    Column("plan_side_switches", "INTEGER", "changes of the planned side after the first", since=7),
    # pedestrians (moving obstacles); none in worlds without them
    Column(
        "min_ped_gap",
        "REAL",
        f"the minimum surface gap to {_CROWD}",
        since=4,
        unit="m",
        tables=("metrics",),
        title="Min gap",
        digits=3,
    ),
    Column(
        "personal_space_share",
        "REAL",
        f"the share of the control instants with a pedestrian's surface within "
        f"{PERSONAL_SPACE:g} m of the robot's",
        since=4,
        tables=("metrics",),
        title="Personal space",
        digits=1,
        percent=True,
    ),
    Column(
        "discomfort_frequency",
        "REAL",
        f"CrowdNav's discomfort frequency: the share of the control instants with a pedestrian's "
        f"surface within {DISCOMFORT:g} m of the robot's",
        since=9,
        tables=("metrics",),
        title="Discomfort",
        digits=1,
        percent=True,
    ),
    Column(
        "intrusion_ratio",
        "REAL",
        f"CrowdNav++'s intrusion ratio: the share of the control instants at which the robot's "
        f"centre lies within a pedestrian's radius + its own of where that pedestrian is "
        f"{INTRUSION_STEP:g} to {INTRUSION_HORIZON * INTRUSION_STEP:g} s later (every "
        f"{INTRUSION_STEP:g} s)",
        since=10,
        tables=("metrics",),
        title="Intrusion",
        digits=1,
        percent=True,
    ),
    Column(
        "social_distance",
        "REAL",
        "CrowdNav++'s social distance: over the instants with an intrusion, the mean of the "
        "smallest centre distance from the robot to an intruded future position",
        since=10,
        unit="m",
        tables=("metrics",),
        title="Social distance",
    ),
    Column(
        "min_ttc",
        "REAL",
        f"the minimum time-to-collision with {_CROWD} at constant velocities (inf: never on a "
        "collision course)",
        since=4,
        unit="s",
        tables=("metrics",),
        title="Min TTC",
        statistic="median",
    ),
    Column(
        "ped_speed_loss",
        "REAL",
        f"the mean 1 - speed / preferred speed of the pedestrians within {NEAR:g} m of the "
        "robot's surface (reactive crowds only)",
        since=4,
        tables=("metrics",),
        title="Speed loss",
        digits=1,
        percent=True,
    ),
    # the recorded person the robot replaces (the task replay; none in other tasks)
    Column(
        "scene",
        "TEXT",
        "the test scene (eth, hotel, univ, zara1, zara2) or the recording",
        since=6,
    ),
    Column("recording", "TEXT", "the recording's file name", since=6),
    Column("person", "INTEGER", "the person's id in the recording", since=6),
    Column("human_time", "REAL", "the person's time to the goal region", since=6, unit="s"),
    Column(
        "human_path_length",
        "REAL",
        "their path, sampled at the recording's frame period",
        since=6,
        unit="m",
    ),
    Column(
        "frame_path_length",
        "REAL",
        "the robot's path, sampled at the recording's frame period",
        since=6,
        unit="m",
    ),
    Column(
        "min_clearance",
        "REAL",
        "the minimum surface distance to any obstacle over the physics substeps",
        unit="m",
    ),
    Column(
        "ctrl_ms_mean",
        "REAL",
        "the controller's time per step (first-call costs excluded)",
        unit="ms",
    ),
    Column("ctrl_ms_p95", "REAL", "its 95th percentile over the steps", unit="ms"),
    Column("env_ms_mean", "REAL", "env.step's time per step", unit="ms"),
    Column("wall_s", "REAL", "the episode's wall-clock time in its worker", unit="s"),
    # controller diagnostics (none where the controller records none)
    Column(
        "ess_mean",
        "REAL",
        "the effective sample size 1 / sum(w^2) of the weights that made a step's plan",
        tables=("diagnostics",),
        title="ESS per step",
        digits=1,
        statistic="per_step",
    ),
    Column(
        "clusters_mean",
        "REAL",
        "the DBSCAN clusters of a step's samples (clustered and dc only)",
        tables=("diagnostics",),
        title="Clusters per step",
        statistic="per_step",
    ),
    Column(
        "fallback_share",
        "REAL",
        "the share of the steps with no cluster, where Alg. 1 ran over all samples (clustered "
        "and dc only)",
        tables=("diagnostics",),
        title="Fallback to Alg. 1",
        digits=1,
        percent=True,
        statistic="per_step",
    ),
    Column(
        "tube_deviation_p95",
        "REAL",
        "the 95th percentile over the episode's steps of |real - nominal| position (Tube-MPPI)",
        unit="m",
        tables=("diagnostics",),
        title="Tube deviation p95",
        digits=3,
    ),
    Column(
        "shield_share",
        "REAL",
        "the share of the steps at which the safety shield changed the planner's command (rows "
        "with a shield only)",
        since=11,
        tables=("diagnostics",),
        title="Shield changed",
        digits=1,
        percent=True,
        statistic="per_step",
    ),
    # where the time goes
    Column(
        "time_waiting",
        "REAL",
        f"the time of the steps at which the robot's mean speed was below {WAIT_SPEED:g} m/s",
        since=8,
        unit="s",
        tables=("diagnostics",),
        title="Waiting",
        digits=1,
    ),
    Column(
        "time_slow",
        "REAL",
        "the time of the steps that started in free space, no obstacle's surface (static, wall "
        f"or moving) within {FREE_SPACE:g} m of the robot's, at which its mean speed was below "
        f"{100 * SLOW_SHARE:g} % of the agent's top speed (waiting included)",
        since=8,
        unit="s",
        tables=("diagnostics",),
        title="Slow in free space",
        digits=1,
    ),
    Column(
        "detour",
        "REAL",
        "the path's length over the straight distance from the start to the goal's centre",
        since=8,
        tables=("diagnostics",),
        title="Detour",
        over="goal",
    ),
    # where the episode ended, and how it got there (replay compares them)
    Column("final_x", "REAL", "the robot's final x", since=5, unit="m"),
    Column("final_y", "REAL", "the robot's final y", since=5, unit="m"),
    Column("final_theta", "REAL", "the robot's final yaw", since=5, unit="rad"),
    Column(
        "goal_distance",
        "REAL",
        "from the final position to the goal's centre",
        since=6,
        unit="m",
    ),
    Column(
        "trace",
        "BLOB",
        "zlib of float32 (steps + 1, 3): x, y, yaw at each control instant (runner.encode_trace)",
        since=5,
    ),
    _record("params", "TEXT", "JSON of the episode's full parameter set", required=True),
)
EPISODE = tuple(c for c in COLUMNS if c.episode)
BY_NAME = {c.name: c for c in COLUMNS}


def shown(table: str) -> tuple[Column, ...]:
    """The columns the report's `table` (one of TABLES) shows, in order."""
    return tuple(c for c in COLUMNS if table in c.tables)


class EpisodeResult(dict):
    """`run_episode`'s values: one per column of EPISODE (None where it does not apply), in
    their order, by name; `run_episode` adds "path" where asked.

    Made from a dict of them, which is checked: a missing or unknown column, or a value that is
    neither None nor of its column's Python types (PYTHON: numpy's integers, which SQLite
    cannot store, are not int), raises TypeError naming them.
    """

    def __init__(self, values: dict):
        names = [c.name for c in EPISODE]
        missing = [n for n in names if n not in values]
        unknown = [n for n in values if n not in BY_NAME or not BY_NAME[n].episode]
        if missing or unknown:
            raise TypeError(
                f"episode result: missing {missing}, undeclared {unknown}; declare each "
                "column in dcmppi.bench.episodes.columns and compute it"
            )
        wrong = [
            f"{c.name}={values[c.name]!r} ({type(values[c.name]).__name__}, not {c.type})"
            for c in EPISODE
            if values[c.name] is not None and not isinstance(values[c.name], PYTHON[c.type])
        ]
        if wrong:
            raise TypeError(f"episode result: {', '.join(wrong)}; convert it (int(), float())")
        super().__init__((n, values[n]) for n in names)
