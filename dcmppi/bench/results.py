"""The results database: SQLite (WAL), one row per finished episode.

Each row is committed in its own transaction when its episode ends, so killing the run
(even with SIGKILL) loses at most the episodes still in flight, and a rerun skips the
rows already there. A database is bound to one experiment configuration; opening it
with another raises `ConfigMismatch` instead of mixing rows.
"""

from __future__ import annotations

import json
import sqlite3
from pathlib import Path

SCHEMA_VERSION = 1

COLUMNS = (
    # key
    ("noise", "TEXT NOT NULL"),
    ("controller", "TEXT NOT NULL"),
    ("env_index", "INTEGER NOT NULL"),
    # what was run
    ("task", "TEXT NOT NULL"),
    ("seed", "INTEGER NOT NULL"),
    ("status", "TEXT NOT NULL"),  # "ok" | "error"
    ("error", "TEXT"),
    # metrics (NULL for errors)
    ("outcome", "TEXT"),
    ("collision", "INTEGER"),
    ("failure", "INTEGER"),
    ("steps", "INTEGER"),
    ("time_to_goal", "REAL"),
    ("path_length", "REAL"),
    ("min_clearance", "REAL"),
    ("ctrl_ms_mean", "REAL"),
    ("ctrl_ms_p95", "REAL"),
    ("env_ms_mean", "REAL"),
    ("wall_s", "REAL"),
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
                db.execute(
                    f"CREATE TABLE episodes ({cols}, PRIMARY KEY (noise, controller, env_index))"
                )
                db.executemany(
                    "INSERT INTO meta VALUES (?, ?)",
                    [("schema", str(SCHEMA_VERSION)), ("config", _canonical(config))],
                )
            stored = {"schema": str(SCHEMA_VERSION), "config": _canonical(config)}
        if stored.get("schema") != str(SCHEMA_VERSION) or "config" not in stored:
            raise ValueError(
                f"{self.path}: results schema {stored.get('schema')!r}, this dcmppi writes "
                f"{SCHEMA_VERSION}; use a new --db path"
            )
        self.config = json.loads(stored["config"])
        if config is not None and _canonical(config) != stored["config"]:
            raise ConfigMismatch(
                f"{self.path} holds results of another configuration:\n"
                f"  in the database: {stored['config']}\n  requested:       {_canonical(config)}\n"
                "Rows of different configurations are never mixed: pass a new --db path, "
                "or rerun with the database's parameters to extend it."
            )

    def done(self) -> set[tuple[str, str, int]]:
        """Keys (noise, controller, env_index) already finished (errored ones run again)."""
        rows = self._db.execute(
            "SELECT noise, controller, env_index FROM episodes WHERE status = 'ok'"
        )
        return {(n, c, int(i)) for n, c, i in rows}

    def record(self, key: tuple[str, str, int], spec, result: dict) -> None:
        """Commit one episode: `result` is `run_episode`'s dict or {"error": message}."""
        noise, controller, index = key
        row = {name: None for name in COLUMN_NAMES}
        row.update(
            noise=noise,
            controller=controller,
            env_index=index,
            task=spec.task,
            seed=spec.seed,
            params=_canonical(
                {"task_params": spec.task_params, "controller_params": spec.controller_params}
            ),
        )
        if "error" in result:
            row.update(status="error", error=result["error"])
        else:
            row.update({k: v for k, v in result.items() if k in row}, status="ok")
        marks = ", ".join("?" for _ in COLUMN_NAMES)
        with self._db:  # a finished episode replaces an error row of the same key
            self._db.execute(
                "DELETE FROM episodes WHERE noise = ? AND controller = ? AND env_index = ? "
                "AND status = 'error'",
                key,
            )
            self._db.execute(
                f"INSERT OR IGNORE INTO episodes ({', '.join(COLUMN_NAMES)}) VALUES ({marks})",
                [row[n] for n in COLUMN_NAMES],
            )

    def rows(self) -> list[dict]:
        """All episode rows, ordered by key."""
        cur = self._db.execute(
            f"SELECT {', '.join(COLUMN_NAMES)} FROM episodes ORDER BY noise, controller, env_index"
        )
        return [dict(zip(COLUMN_NAMES, r, strict=True)) for r in cur]

    def close(self) -> None:
        self._db.close()


def _canonical(obj) -> str:
    return json.dumps(obj, sort_keys=True, separators=(",", ":"))
