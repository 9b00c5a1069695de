"""The results database: SQLite (WAL), one row per finished episode.

Each row is committed in its own transaction when its episode ends, so killing the run
(even with SIGKILL) loses at most the episodes still in flight, and a rerun skips the
rows already there. A database is bound to one experiment configuration (task, its
parameters, the shared controller parameters, the base seed and each row's controller and
parameters); opening it with another raises `ConfigMismatch` instead of mixing rows. A
configuration with rows of new labels extends it.

A database of an older schema that lacks only columns added since (`ADDED`) is read with those
columns NULL, and opening it to write adds them: its rows are kept.
"""

from __future__ import annotations

import json
import os
import socket
import sqlite3
import time
from pathlib import Path

SCHEMA_VERSION = 4
FIELD_METRICS = (  # the crowd-navigation field's metrics (dcmppi.bench.runner.FieldMetrics)
    "success",
    "collision_kind",
    "timeout",
    "spl",
    "jerk_mean",
    "min_ped_gap",
    "personal_space_share",
    "min_ttc",
    "ped_speed_loss",
)
ADDED = {3: ("nav_score",), 4: FIELD_METRICS}  # columns each schema version added to the last

COLUMNS = (
    # key
    ("noise", "TEXT NOT NULL"),
    ("label", "TEXT NOT NULL"),  # the experiment's row
    ("env_index", "INTEGER NOT NULL"),
    # what was run
    ("controller", "TEXT NOT NULL"),
    ("task", "TEXT NOT NULL"),
    ("seed", "INTEGER NOT NULL"),
    ("status", "TEXT NOT NULL"),  # "ok" | "error"
    ("error", "TEXT"),
    # metrics (NULL for errors)
    ("outcome", "TEXT"),
    ("success", "INTEGER"),  # the goal reached
    ("collision", "INTEGER"),
    ("collision_kind", "TEXT"),  # "pedestrian" | "static" (walls too); NULL without collision
    ("timeout", "INTEGER"),  # the time limit reached
    ("failure", "INTEGER"),
    ("steps", "INTEGER"),
    ("time_to_goal", "REAL"),
    ("nav_score", "REAL"),  # BARN's navigation score (NULL outside BARN worlds)
    ("path_length", "REAL"),
    ("spl", "REAL"),  # success weighted by path length
    ("jerk_mean", "REAL"),  # the robot's mean jerk [m/s^3]
    # pedestrians (moving obstacles); NULL in worlds without them
    ("min_ped_gap", "REAL"),  # minimum surface distance [m]
    ("personal_space_share", "REAL"),  # share of control instants with one within 0.5 m
    ("min_ttc", "REAL"),  # minimum time-to-collision [s], Inf: never on a collision course
    ("ped_speed_loss", "REAL"),  # mean 1 - speed / preferred speed within 2 m (reactive crowds)
    ("min_clearance", "REAL"),
    ("ctrl_ms_mean", "REAL"),
    ("ctrl_ms_p95", "REAL"),
    ("env_ms_mean", "REAL"),
    ("wall_s", "REAL"),
    # controller diagnostics (NULL where the controller records none)
    ("ess_mean", "REAL"),
    ("clusters_mean", "REAL"),
    ("fallback_share", "REAL"),
    ("tube_deviation_p95", "REAL"),
    ("params", "TEXT NOT NULL"),  # JSON of the episode's full parameter set
)
COLUMN_NAMES = tuple(name for name, _ in COLUMNS)


class ConfigMismatch(ValueError):
    """The database was made with another experiment configuration."""


class ResultsDB:
    """Episode rows of one experiment configuration.

    Args:
      path: SQLite file; created if missing.
      config: the experiment configuration (JSON-serialisable dict) the rows belong to.
        None opens an existing database read-only for reports.
    """

    def __init__(self, path: str | Path, config: dict | None = None):
        self.path = Path(path)
        if config is None and not self.path.exists():
            raise FileNotFoundError(f"{self.path}: no results database; run `dcmppi bench` first")
        try:
            if config is None:  # reading: never create or convert anything
                uri = f"file:{self.path.resolve()}?mode=ro"
                self._db = sqlite3.connect(uri, uri=True, timeout=30.0)
            else:
                self._db = sqlite3.connect(self.path, timeout=30.0)
            tables = {r[0] for r in self._db.execute("SELECT name FROM sqlite_master")}
            if tables and "meta" not in tables:
                raise ValueError(
                    f"{self.path}: an SQLite file of something else (tables "
                    f"{', '.join(sorted(tables))}), not a dcmppi results database; "
                    "pass another --db path"
                )
            if config is None and not tables:
                raise ValueError(f"{self.path}: empty database, no experiment recorded")
            if config is not None:
                self._db.execute("PRAGMA journal_mode=WAL")
                self._db.execute("PRAGMA synchronous=NORMAL")
            self._init(config)
        except sqlite3.DatabaseError as e:
            raise ValueError(
                f"{self.path}: not a readable dcmppi results database ({e}); "
                "pass another --db path or move this file away"
            ) from e

    def _init(self, config: dict | None) -> None:
        db = self._db
        if config is not None:
            db.execute(
                "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)"
            )
        stored = dict(db.execute("SELECT key, value FROM meta").fetchall())
        if not stored:
            if config is None:
                raise ValueError(f"{self.path}: empty database, no experiment recorded")
            cols = ", ".join(f"{n} {t}" for n, t in COLUMNS)
            with db:
                db.execute(f"CREATE TABLE episodes ({cols}, PRIMARY KEY (noise, label, env_index))")
                db.executemany(
                    "INSERT INTO meta VALUES (?, ?)",
                    [("schema", str(SCHEMA_VERSION)), ("config", _canonical(config))],
                )
            stored = {"schema": str(SCHEMA_VERSION), "config": _canonical(config)}
        schema = stored.get("schema")
        older = [str(v - 1) for v in ADDED if v <= SCHEMA_VERSION]
        if (schema != str(SCHEMA_VERSION) and schema not in older) or "config" not in stored:
            raise ValueError(
                f"{self.path}: results schema {schema!r}, this dcmppi writes "
                f"{SCHEMA_VERSION}; use a new --db path"
            )
        if schema != str(SCHEMA_VERSION) and config is not None:
            self._upgrade(int(schema))
        present = {r[1] for r in db.execute("PRAGMA table_info(episodes)")}
        self._columns = [n for n in COLUMN_NAMES if n in present]
        self.config = json.loads(stored["config"])
        self._meta = {k: json.loads(v) for k, v in stored.items() if k not in ("schema", "config")}
        if config is not None:
            merged = _merge(self.path, self.config, config)
            if merged != self.config:
                self._set("config", merged)
                self.config = merged

    def _upgrade(self, schema: int) -> None:
        """Add the (nullable) columns of the schema versions after `schema` that are missing."""
        types = dict(COLUMNS)
        present = {r[1] for r in self._db.execute("PRAGMA table_info(episodes)")}
        with self._db:
            for version in range(schema + 1, SCHEMA_VERSION + 1):
                for name in ADDED[version]:
                    if name not in present:
                        self._db.execute(f"ALTER TABLE episodes ADD COLUMN {name} {types[name]}")
            self._db.execute(
                "UPDATE meta SET value = ? WHERE key = 'schema'", (str(SCHEMA_VERSION),)
            )

    def done(self) -> set[tuple[str, str, int]]:
        """Keys (noise, label, env_index) already finished (errored ones run again)."""
        rows = self._db.execute("SELECT noise, label, env_index FROM episodes WHERE status = 'ok'")
        return {(n, c, int(i)) for n, c, i in rows}

    def record(self, key: tuple[str, str, int], spec, result: dict) -> None:
        """Commit one episode: `result` is `run_episode`'s dict or {"error": message}."""
        noise, label, index = key
        row = {name: None for name in COLUMN_NAMES}
        row.update(
            noise=noise,
            label=label,
            env_index=index,
            controller=spec.controller,
            task=spec.task,
            seed=spec.seed,
            params=_canonical(
                {
                    "task_params": spec.task_params,
                    "controller_params": spec.controller_params,
                    "shared_params": spec.shared_params,
                }
            ),
        )
        if "error" in result:
            row.update(status="error", error=result["error"])
        else:
            row.update({k: v for k, v in result.items() if k in row}, status="ok")
        marks = ", ".join("?" for _ in COLUMN_NAMES)
        with self._db:  # a finished episode replaces an error row of the same key
            self._db.execute(
                "DELETE FROM episodes WHERE noise = ? AND label = ? AND env_index = ? "
                "AND status = 'error'",
                key,
            )
            self._db.execute(
                f"INSERT OR IGNORE INTO episodes ({', '.join(COLUMN_NAMES)}) VALUES ({marks})",
                [row[n] for n in COLUMN_NAMES],
            )

    def rows(self) -> list[dict]:
        """All episode rows, ordered by key (None in columns an older database lacks)."""
        cur = self._db.execute(
            f"SELECT {', '.join(self._columns)} FROM episodes ORDER BY noise, label, env_index"
        )
        empty = dict.fromkeys(COLUMN_NAMES)
        return [{**empty, **dict(zip(self._columns, r, strict=True))} for r in cur]

    @property
    def experiment(self) -> dict | None:
        """The definition of the experiment the latest bench run asked for (JSON form of
        `Experiment.to_dict`): names, selected rows, counts, the paper's figures."""
        return self._meta.get("experiment")

    @property
    def writer(self) -> dict | None:
        """{pid, host, started} of a bench run that is writing, or was killed while writing."""
        return self._meta.get("writer")

    def begin_run(self, experiment: dict) -> None:
        """Mark the database as being written by this process, for `experiment`."""
        self._set("experiment", experiment)
        self._set(
            "writer", {"pid": os.getpid(), "host": socket.gethostname(), "started": time.time()}
        )

    def end_run(self) -> None:
        """The run stopped (finished or interrupted, its rows committed)."""
        with self._db:
            self._db.execute("DELETE FROM meta WHERE key = 'writer'")
        self._meta.pop("writer", None)

    def _set(self, key: str, value) -> None:
        with self._db:
            self._db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (key, _canonical(value)))
        self._meta[key] = value

    def close(self) -> None:
        self._db.close()


def _merge(path: Path, stored: dict, requested: dict) -> dict:
    """The stored configuration extended by the requested one's new rows; ConfigMismatch if
    anything else differs (rows of another configuration are never mixed)."""
    rows = dict(stored.get("rows", {}))
    changed = [
        k
        for k in stored.keys() | requested.keys()
        if k != "rows" and stored.get(k) != requested.get(k)
    ]
    changed += [
        f"row {label!r}"
        for label, row in requested.get("rows", {}).items()
        if rows.setdefault(label, row) != row
    ]
    if changed:
        show = sorted(changed)
        raise ConfigMismatch(
            f"{path} holds results of another configuration ({', '.join(show)} differ):\n"
            f"  in the database: {_canonical(stored)}\n  requested:       {_canonical(requested)}\n"
            "Rows of different configurations are never mixed: pass a new --db path, "
            "or rerun with the database's parameters to extend it (new row labels may be added)."
        )
    return {**stored, "rows": rows}


def _canonical(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))
