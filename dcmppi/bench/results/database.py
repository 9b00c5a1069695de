"""The results database: SQLite (WAL), one row per finished episode, one per run.

Each row is committed in its own transaction when its episode ends, so killing the run
(even with SIGKILL) loses at most the episodes still in flight, and a rerun skips the
rows already there. A database is bound to one experiment configuration (task, its
parameters, the shared controller parameters, the base seed and each row's controller and
parameters); opening it with another raises `ConfigMismatch` instead of mixing rows. A
configuration with rows of new labels extends it. Reading, merging and writing the
configuration, and each row's insert, are single `BEGIN IMMEDIATE` transactions, so runs
writing one database at once cannot add one label with different parameters, and an episode
already recorded with other parameters is an error, never silently dropped.

Each run (`begin_run` .. `end_run`) is a row of the table `runs` with its provenance
(`dcmppi.bench.results.provenance.collect`: code, resolved parameters, input files' sha256,
libraries, machine) and times; each episode names its run (`run_id`). A run under other
provenance than the recorded ones is refused (`ProvenanceMismatch`) unless `allow_mixed`.

A database of an older schema that lacks only columns added since (`ADDED`) is read with those
columns NULL, and opening it to write adds them (and the runs table): its rows are kept.
Storage failures (a read-only file or directory, a full disk, a lock held too long) raise
`StorageError`, one line naming the cause and the fix. Reading works on a read-only file or
directory and on a copied (archived) WAL database.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import socket
import sqlite3
import sys
import tempfile
import time
from pathlib import Path

from dcmppi.bench.episodes import columns

# The episodes table (dcmppi.bench.episodes.columns declares each column): (name, SQL type)
COLUMNS = tuple((c.name, c.sql) for c in columns.COLUMNS)
COLUMN_NAMES = tuple(name for name, _ in COLUMNS)
SCHEMA_VERSION = max(c.since for c in columns.COLUMNS)
# the columns each schema version after the first added
ADDED = {
    version: tuple(c.name for c in columns.COLUMNS if c.since == version)
    for version in range(columns.FIRST_SCHEMA + 1, SCHEMA_VERSION + 1)
}
TABLE_COLUMNS = tuple(c.name for c in columns.COLUMNS if c.type != "BLOB")  # rows(), CSV
RUNS = (
    "CREATE TABLE IF NOT EXISTS runs (run_id INTEGER PRIMARY KEY, provenance TEXT, "
    "started REAL, ended REAL)"
)
TIMEOUT = 30.0  # [s] a writer waits this long for another's transaction


class ConfigMismatch(ValueError):
    """The database was made with another experiment configuration."""


class ProvenanceMismatch(ValueError):
    """The database was recorded under another code version, resolved parameter or input."""


class StorageError(OSError):
    """The database cannot be written (read-only, disk full, locked): one line, the fix."""


class ResultsDB:
    """Episode rows of one experiment configuration.

    Args:
      path: SQLite file; created if missing.
      config: the experiment configuration (JSON-serialisable dict) the rows belong to.
        None opens an existing database read-only for reports.
      provenance: this run's `dcmppi.bench.results.provenance.collect` dict, recorded by `begin_run`
        (None: runs are not recorded, episodes get no run_id).
      allow_mixed: extend a database recorded under another provenance (`begin_run`).
    """

    def __init__(
        self,
        path: str | Path,
        config: dict | None = None,
        provenance: dict | None = None,
        allow_mixed: bool = False,
    ):
        self.path = Path(path)
        self.provenance, self.allow_mixed = provenance, allow_mixed
        self.run_id: int | None = None
        self._copy = None  # a temporary copy a read-only WAL database is read from
        if config is None and not self.path.exists():
            raise FileNotFoundError(f"{self.path}: no results database; run `dcmppi bench` first")
        if self.path.is_dir():
            raise IsADirectoryError(f"{self.path}: a directory; --db takes a database file's path")
        self._db = None
        try:
            if config is None:  # reading: never create or convert anything
                self._db = self._open_read()
            else:
                self._db = sqlite3.connect(self.path, timeout=TIMEOUT, isolation_level=None)
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
            self.close()
            storage = self._storage_error(e)
            if storage is not None:
                raise storage from None
            raise ValueError(
                f"{self.path}: not a readable dcmppi results database ({e}); "
                "pass another --db path or move this file away"
            ) from e
        except BaseException:
            self.close()
            raise

    def _open_read(self) -> sqlite3.Connection:
        """A read-only connection. Where SQLite cannot open the -shm/-wal files beside the
        database (a read-only directory, an archived WAL database), it reads a temporary copy
        of the database and its -wal file, or without them the file as immutable."""
        uri = self.path.resolve().as_uri()
        try:
            db = sqlite3.connect(f"{uri}?mode=ro", uri=True, timeout=TIMEOUT)
            db.execute("SELECT name FROM sqlite_master").fetchall()
            return db
        except sqlite3.OperationalError:
            pass
        wal = Path(f"{self.path}-wal")
        if wal.is_file() and wal.stat().st_size:
            self._copy = tempfile.TemporaryDirectory(prefix="dcmppi-db-")
            copy = Path(self._copy.name) / self.path.name
            shutil.copyfile(self.path, copy)
            shutil.copyfile(wal, f"{copy}-wal")
            return sqlite3.connect(copy, timeout=TIMEOUT)
        return sqlite3.connect(f"{uri}?immutable=1", uri=True, timeout=TIMEOUT)

    def _storage_error(self, e: sqlite3.DatabaseError) -> StorageError | None:
        """The one-line StorageError of an SQLite failure to write; None for other errors."""
        if not isinstance(e, sqlite3.OperationalError):
            return None
        message, where = str(e), self.path.resolve().parent
        if "readonly" in message or "read-only" in message:
            fix = (
                "it is read-only: make it (its -wal, -shm files and directory too) writable, or "
                "pass a new --db; `dcmppi report` reads it as it is"
            )
        elif "full" in message:
            fix = "free space on that disk and rerun to resume (finished episodes are saved)"
        elif "unable to open" in message:
            fix = (
                f"SQLite creates {self.path.name}-wal and -shm beside it: make {where} "
                "writable or pass a --db in a writable directory"
            )
        elif "locked" in message or "busy" in message:
            fix = (
                f"another process held its write lock for {TIMEOUT:.0f} s; rerun when it is "
                "done, or pass another --db"
            )
        elif "disk I/O" in message:
            fix = "check the disk (full, removed, a network mount) and rerun to resume"
        else:
            return None
        return StorageError(f"{self.path}: cannot write the results database ({message}); {fix}")

    @contextlib.contextmanager
    def _write(self):
        """One BEGIN IMMEDIATE transaction: no other writer between its reads and writes.
        SQLite's storage failures become StorageError."""
        try:
            self._db.execute("BEGIN IMMEDIATE")
            try:
                yield self._db
            except BaseException:
                if self._db.in_transaction:
                    self._db.execute("ROLLBACK")
                raise
            self._db.execute("COMMIT")
        except sqlite3.OperationalError as e:
            if self._db.in_transaction:
                self._db.execute("ROLLBACK")
            storage = self._storage_error(e)
            if storage is None:
                raise
            raise storage from None

    def _init(self, config: dict | None) -> None:
        if config is None:
            self._read_meta(dict(self._db.execute("SELECT key, value FROM meta").fetchall()))
            return
        with self._write() as db:
            db.execute(
                "CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)"
            )
            stored = dict(db.execute("SELECT key, value FROM meta").fetchall())
            if not stored:
                cols = ", ".join(f"{n} {t}" for n, t in COLUMNS)
                db.execute(f"CREATE TABLE episodes ({cols}, PRIMARY KEY (noise, label, env_index))")
                stored = {"schema": str(SCHEMA_VERSION), "config": _canonical(config)}
                db.executemany("INSERT INTO meta VALUES (?, ?)", list(stored.items()))
            schema = self._read_meta(stored)
            if schema != SCHEMA_VERSION:
                self._upgrade(schema)
            db.execute(RUNS)
            merged = _merge(self.path, self.config, config)  # ConfigMismatch: rolled back
            if merged != self.config:
                db.execute("UPDATE meta SET value = ? WHERE key = 'config'", (_canonical(merged),))
                self.config = merged

    def _read_meta(self, stored: dict) -> int:
        """Check the schema, load the configuration and the other meta keys; the schema."""
        if not stored:
            raise ValueError(f"{self.path}: empty database, no experiment recorded")
        schema = stored.get("schema")
        known = [str(v) for v in range(columns.FIRST_SCHEMA, SCHEMA_VERSION + 1)]
        if schema not in known or "config" not in stored:
            raise ValueError(
                f"{self.path}: results schema {schema!r}, this dcmppi writes "
                f"{SCHEMA_VERSION}; use a new --db path"
            )
        self.config = json.loads(stored["config"])
        self._meta = {k: json.loads(v) for k, v in stored.items() if k not in ("schema", "config")}
        self._refresh_columns()
        return int(schema)

    def _refresh_columns(self) -> None:
        present = {r[1] for r in self._db.execute("PRAGMA table_info(episodes)")}
        self._columns = [n for n in COLUMN_NAMES if n in present]
        tables = {r[0] for r in self._db.execute("SELECT name FROM sqlite_master")}
        self._has_runs = "runs" in tables

    def _upgrade(self, schema: int) -> None:
        """Add the (nullable) columns of the schema versions after `schema` that are missing
        (inside _init's transaction)."""
        types = dict(COLUMNS)
        present = {r[1] for r in self._db.execute("PRAGMA table_info(episodes)")}
        for version in range(schema + 1, SCHEMA_VERSION + 1):
            for name in ADDED[version]:
                if name not in present:
                    self._db.execute(f"ALTER TABLE episodes ADD COLUMN {name} {types[name]}")
        self._db.execute("UPDATE meta SET value = ? WHERE key = 'schema'", (str(SCHEMA_VERSION),))
        self._db.execute(RUNS)
        self._refresh_columns()

    def done(self) -> set[tuple[str, str, int]]:
        """Keys (noise, label, env_index) already finished (errored ones run again)."""
        rows = self._db.execute("SELECT noise, label, env_index FROM episodes WHERE status = 'ok'")
        return {(n, c, int(i)) for n, c, i in rows}

    def record(self, key: tuple[str, str, int], spec, result: dict) -> None:
        """Commit one episode: `result` is `run_episode`'s `EpisodeResult` (or a dict of some of
        its columns) or {"error": message, "traceback": text (optional)}.

        A finished episode replaces an error row of its key and is ignored where another run
        recorded it first; a key recorded with other parameters raises ConfigMismatch.
        """
        noise, label, index = key
        row = dict.fromkeys(COLUMN_NAMES)
        row.update(
            noise=noise,
            label=label,
            env_index=index,
            controller=spec.controller,
            task=spec.task,
            seed=spec.seed,
            run_id=self.run_id,
            params=_canonical(
                {
                    "task_params": spec.task_params,
                    "controller_params": spec.controller_params,
                    "shared_params": spec.shared_params,
                }
            ),
        )
        if "error" in result:
            row.update(status="error", error=result["error"], traceback=result.get("traceback"))
        else:
            row.update({k: v for k, v in result.items() if k in row}, status="ok")
        names = [n for n in COLUMN_NAMES if n in self._columns]
        where = "noise = ? AND label = ? AND env_index = ?"
        with self._write() as db:
            found = db.execute(f"SELECT status, params FROM episodes WHERE {where}", key).fetchone()
            if found is not None:
                status, params = found
                before, now = json.loads(params), json.loads(row["params"])
                if before != now:  # values: 1 and 1.0 alike
                    changed = _changed(before, now)
                    raise ConfigMismatch(
                        f"{self.path}: episode {noise}/{label}/{index} is already recorded with "
                        f"other parameters ({changed}): another run wrote this database with "
                        "another configuration; pass a new --db path"
                    )
                if status == "ok":
                    return  # another run recorded it first (episodes are deterministic)
                db.execute(f"DELETE FROM episodes WHERE {where}", key)
            marks = ", ".join("?" for _ in names)
            db.execute(
                f"INSERT INTO episodes ({', '.join(names)}) VALUES ({marks})",
                [row[n] for n in names],
            )

    def rows(self) -> list[dict]:
        """All episode rows but their traces, ordered by key (None in columns an older
        database lacks)."""
        names = [n for n in self._columns if n != "trace"]
        cur = self._db.execute(
            f"SELECT {', '.join(names)} FROM episodes ORDER BY noise, label, env_index"
        )
        empty = dict.fromkeys(TABLE_COLUMNS)
        return [{**empty, **dict(zip(names, r, strict=True))} for r in cur]

    def row(self, noise: str, label: str, env_index: int) -> dict | None:
        """Every column of one episode, its trace (bytes) included; None if not recorded."""
        cur = self._db.execute(
            f"SELECT {', '.join(self._columns)} FROM episodes "
            "WHERE noise = ? AND label = ? AND env_index = ?",
            (noise, label, int(env_index)),
        )
        found = cur.fetchone()
        if found is None:
            return None
        return {**dict.fromkeys(COLUMN_NAMES), **dict(zip(self._columns, found, strict=True))}

    def runs(self) -> list[dict]:
        """The recorded runs, oldest first: {run_id, provenance (dict or None), started, ended
        (None: still running or killed), episodes (rows it recorded)}; [] before schema 5."""
        if not self._has_runs:
            return []
        cur = self._db.execute(
            "SELECT run_id, provenance, started, ended, "
            "(SELECT COUNT(*) FROM episodes e WHERE e.run_id = runs.run_id) "
            "FROM runs ORDER BY run_id"
        )
        return [
            {
                "run_id": run_id,
                "provenance": json.loads(prov) if prov else None,
                "started": started,
                "ended": ended,
                "episodes": count,
            }
            for run_id, prov, started, ended, count in cur
        ]

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
        """Mark the database as being written by this process, for `experiment`, and record
        the run with its provenance (given to the constructor). Raises ProvenanceMismatch when
        a recorded run's provenance differs (unless allow_mixed); warns on stderr when another
        live process is writing."""
        from dcmppi.bench.results.provenance import differences

        me = {"pid": os.getpid(), "host": socket.gethostname(), "started": time.time()}
        with self._write() as db:
            found = db.execute("SELECT value FROM meta WHERE key = 'writer'").fetchone()
            other = json.loads(found[0]) if found else None
            if self.provenance is not None:
                # the runs that own finished rows, and those still being written by a live
                # process (a shard started beside this one has no rows yet)
                runs = db.execute(
                    "SELECT run_id, provenance, ended, EXISTS (SELECT 1 FROM episodes e WHERE "
                    "e.run_id = runs.run_id AND e.status = 'ok') FROM runs WHERE provenance IS "
                    "NOT NULL ORDER BY run_id DESC"
                )
                for run_id, text, ended, owns in runs.fetchall():
                    stored = json.loads(text)
                    writer = stored.get("writer")
                    if not owns and not (ended is None and writer and writer_alive(writer)):
                        continue
                    diffs = differences(stored, self.provenance)
                    if diffs and not self.allow_mixed:
                        more = f"; and {len(diffs) - 1} more" if len(diffs) > 1 else ""
                        raise ProvenanceMismatch(
                            f"{self.path} was recorded under other conditions (run {run_id}: "
                            f"{diffs[0]}{more}); pass --allow-mixed to extend it anyway (the "
                            "report then shows the versions per row) or a new --db path"
                        )
                cur = db.execute(
                    "INSERT INTO runs (provenance, started) VALUES (?, ?)",
                    (_canonical({**self.provenance, "writer": me}), me["started"]),
                )
                self.run_id = cur.lastrowid
            for key, value in (("experiment", experiment), ("writer", me)):
                db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (key, _canonical(value)))
        self._meta.update(experiment=experiment, writer=me)
        if other and other["pid"] != me["pid"] and writer_alive(other):
            started = time.strftime("%Y-%m-%d %H:%M", time.localtime(other["started"]))
            print(
                f"warning: {self.path} is also being written by pid {other['pid']} on "
                f"{other['host']} (started {started}); the rows of both are kept, an episode "
                "both select runs twice (--shard I/N splits the work)",
                file=sys.stderr,
            )

    def end_run(self) -> None:
        """The run stopped (finished or interrupted, its rows committed): its end time is
        recorded (a run that recorded nothing is dropped) and the writer mark removed."""
        with self._write() as db:
            if self.run_id is not None:
                db.execute(
                    "DELETE FROM runs WHERE run_id = ? AND NOT EXISTS "
                    "(SELECT 1 FROM episodes e WHERE e.run_id = runs.run_id)",
                    (self.run_id,),
                )
                db.execute("UPDATE runs SET ended = ? WHERE run_id = ?", (time.time(), self.run_id))
            found = db.execute("SELECT value FROM meta WHERE key = 'writer'").fetchone()
            if found and json.loads(found[0])["pid"] == os.getpid():
                db.execute("DELETE FROM meta WHERE key = 'writer'")
        self._meta.pop("writer", None)

    def _set(self, key: str, value) -> None:
        with self._write() as db:
            db.execute("INSERT OR REPLACE INTO meta VALUES (?, ?)", (key, _canonical(value)))
        self._meta[key] = value

    def close(self) -> None:
        if self._db is not None:
            self._db.close()
        if self._copy is not None:
            self._copy.cleanup()
            self._copy = None


def writer_alive(writer: dict) -> bool:
    """Whether the process of a writer mark {pid, host} still runs (False on another host:
    unknown)."""
    if writer.get("host") != socket.gethostname():
        return False
    try:
        os.kill(writer["pid"], 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _changed(old: dict, new: dict, prefix: str = "") -> str:
    """'a.b: 1 -> 2, ...' of the leaves that differ between two nested dicts."""
    out = []
    for k in sorted(old.keys() | new.keys()):
        a, b = old.get(k), new.get(k)
        if isinstance(a, dict) and isinstance(b, dict):
            inner = _changed(a, b, f"{prefix}{k}.")
            out += [inner] if inner else []
        elif a != b:
            out.append(f"{prefix}{k}: {json.dumps(a)} -> {json.dumps(b)}")
    return ", ".join(out)


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
