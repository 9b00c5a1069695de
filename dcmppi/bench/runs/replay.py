"""Replay a recorded episode: rerun it from its database's configuration and seed, and say
whether it reproduces the record; render a gallery of failures through the replay.

    r = replay(["r.db"], "dc", 3)                  # the row "dc", environment 3
    print(r.message); r.reproduced                 # outcome, steps, final pose, first departure
    replay(["r.db"], "dc", 3, page="dc-3.html")    # and its episode viewer (dcmppi.render.viewer)
    gallery(["r.db"], "report", 3)                 # the first 3 failures of each row, 1 success

An episode is deterministic given its spec, so the comparison is exact: the outcome and step
count must be equal, the final pose equal in float64, and the trace (the robot's pose at
every control instant, stored in float32) equal in every bit. A tolerance would hide nothing
real (float32 resolves 8e-6 m at 75 m) and would let a changed controller or library pass
whose first difference is small. Where it departs, the message names the first control
instant that differs and by how much, and, where the run recorded other kernels than this
machine's (numpy's SIMD level, the BLAS's: provenance.kernels), both: they round otherwise.
"""

from __future__ import annotations

import dataclasses
import json
import re
import sys
from pathlib import Path

import numpy as np

from dcmppi.bench.episodes.runner import Episode, EpisodeSpec, decode_trace, run_episode
from dcmppi.bench.results.database import ResultsDB
from dcmppi.bench.results.provenance import kernels

GALLERY_SIZE = (480, 270)  # [px] width, height of a gallery GIF


NOT_IN_PROCESS = ("timeout:", "worker died")  # error rows of a worker process's end


@dataclasses.dataclass(frozen=True)
class Replay:
    """What a replay found.

    reproduced: the rerun matches the record (outcome, steps, final pose, trace; see the module
    docstring); message: a few lines saying so, with the first departing control instant if
    not; record: the database row; result: the rerun's `run_episode` dict ({"error": ...} if
    it raised); departs: the first control instant whose pose differs (None: none found);
    page: the episode viewer's path where one was written.
    """

    reproduced: bool
    message: str
    record: dict
    result: dict
    departs: int | None = None
    page: Path | None = None


def replay(
    db_paths, label: str, env_index: int, noise: str | None = None, video=None,
    camera: str = "scene", progress: bool = False, size: tuple[int, int] | None = None,
    page=None,
) -> Replay:  # fmt: skip
    """Rerun episode (noise, label, env_index) of the databases `db_paths` and compare it with
    its record.

    Args:
      db_paths: one results database or several (shards of one configuration); the first
        holding the episode is used.
      label, env_index: the experiment's row and environment.
      noise: the noise profile; None: the only one the row has in that environment.
      video: optional .mp4 or .gif path: the rerun is rendered there with the controller's
        overlay (dcmppi.render.recording); camera, progress and size (width, height) go to it.
      page: optional .html path: the rerun's episode viewer (dcmppi.render.viewer) is written
        there, with the replay's verdict.
    Raises:
      ValueError: no such episode (the message lists what the databases hold), or a row whose
        recorded parameters are not those its configuration gives.
    """
    record, config, recorded_on = _find(_paths(db_paths), label, int(env_index), noise)
    replayed = _replay(record, config, video, camera, progress, size, page)
    if replayed.reproduced or recorded_on is None or recorded_on == (here := kernels()):
        return replayed
    return dataclasses.replace(
        replayed,
        message=f"{replayed.message}\n  machine: recorded on {recorded_on}, replayed on {here}: "
        "other kernels round otherwise, so the plans may depart from the first step",
    )


def gallery(db_paths, out_dir, n: int, camera: str = "scene") -> dict:
    """GIFs and episode viewer pages of the first `n` failures (by environment index) of each
    row and of its first success, made through the replay into out_dir/gallery/.

    Returns:
      {(noise, label): [(env_index, recorded outcome, GIF path, page path), ...]}, failures
      first, the paths relative to out_dir. A replay that does not reproduce its record is
      reported on stderr.
    """
    out_dir = Path(out_dir)
    rows, source = _all_rows(_paths(db_paths))
    chosen: dict[tuple[str, str], list[dict]] = {}
    successes: dict[tuple[str, str], dict] = {}
    for row in rows:
        if row["status"] != "ok":
            continue
        key = (row["noise"], row["label"])
        picks = chosen.setdefault(key, [])
        if row["outcome"] == "goal":
            successes.setdefault(key, row)
        elif len(picks) < n:
            picks.append(row)
    out, names = {}, set()
    for key, picks in chosen.items():
        entries = []
        for row in picks + ([successes[key]] if key in successes else []):
            gif = Path("gallery") / _gif_name(row, names)
            page = gif.with_suffix(".html")
            record, config, _ = _find(
                [source[id(row)]], row["label"], row["env_index"], row["noise"]
            )
            done = _replay(
                record, config, out_dir / gif, camera, False, GALLERY_SIZE, out_dir / page
            )
            if not done.reproduced:
                print(f"gallery: {done.message.splitlines()[0]}", file=sys.stderr)
            entries.append((row["env_index"], row["outcome"], gif.as_posix(), page.as_posix()))
        out[key] = entries
    return out


def _replay(record, config, video, camera, progress, size, page=None) -> Replay:
    from dcmppi.bench.runs.execution import error_message

    spec = _spec(record, config)
    error = record.get("error") or ""
    if record["status"] == "error" and error.startswith(NOT_IN_PROCESS):
        head = f"{record['task']} / {record['label']} / env {record['env_index']}"
        message = (
            f"{head}: recorded as {error!r}, which only a worker process shows (its death or "
            "its time limit); a replay runs in this process, so it does not rerun it"
        )
        return Replay(False, message, record, {}, None)
    viewer = None
    if page is not None:
        from dcmppi.render.viewer import Viewer

        viewer = Viewer()
    try:
        if video is None:
            result = run_episode(spec, on_step=viewer)
        else:
            from dcmppi.render.recording import record_episode

            width, height = size or (None, None)
            episode = Episode(spec) if viewer is None else _Watched(Episode(spec), viewer)
            result = record_episode(
                episode, video, camera, width=width, height=height, progress=progress,
                legend=size is None,
            )  # fmt: skip
    except KeyboardInterrupt:
        raise
    except BaseException as e:  # noqa: BLE001 - an error row is reproduced by the same error
        result = {"error": error_message(e)}
    replayed = compare(record, result)
    if viewer is None or viewer.world is None:  # none asked, or the episode raised at its start
        return replayed
    title, _, verdict = replayed.message.partition(": ")
    viewer.write(page, title, f"Replayed: {verdict}")
    return dataclasses.replace(replayed, page=Path(page))


class _Watched:
    """An episode that shows itself to `watch` after its reset and after every step, as
    run_episode's on_step (for a video's episode, which dcmppi.render.recording drives)."""

    def __init__(self, episode: Episode, watch):
        self._episode, self._watch = episode, watch
        watch(episode)

    def __getattr__(self, name):
        return getattr(self._episode, name)

    def step(self) -> None:
        self._episode.step()
        self._watch(self._episode)


def compare(record: dict, result: dict) -> Replay:
    """Whether `result` (run_episode's dict, or {"error": ...}) reproduces the database row
    `record`; see the module docstring."""
    head = (
        f"{record['task']} / {record['label']} / noise {record['noise']} / env "
        f"{record['env_index']} (seed {record['seed']})"
    )
    if record["status"] != "ok" or "error" in result:
        same = record.get("error") == result.get("error")
        lines = [
            f"  recorded: {record.get('error') or record['outcome']}",
            f"  replayed: {result.get('error') or result['outcome']}",
        ]
        return Replay(same, _message(head, same, lines), record, result)
    lines, same = [], True
    for name in ("outcome", "steps"):
        ok = record[name] == result[name]
        same &= ok
        lines.append(f"  {name}: {result[name]}" + ("" if ok else f" (recorded {record[name]})"))
    final = [f"final_{k}" for k in ("x", "y", "theta")]
    pose, replayed = [record.get(k) for k in final], [result[k] for k in final]
    if None in pose:
        lines.append("  final pose: not recorded (a database older than schema 5)")
    else:
        ok = pose == replayed
        same &= ok
        recorded = "" if ok else f" (recorded {_pose(pose)})"
        lines.append(f"  final pose: {_pose(replayed)}{recorded}")
    departs = None
    if record.get("trace") is None:
        lines.append("  trace: not recorded (a database older than schema 5)")
    else:
        a, b = decode_trace(record["trace"]), decode_trace(result["trace"])
        common = min(len(a), len(b))
        differ = np.flatnonzero((a[:common] != b[:common]).any(axis=1))
        departs = int(differ[0]) if len(differ) else (None if len(a) == len(b) else common)
        if departs is None:
            lines.append(f"  trace: identical at all {len(a)} control instants")
        elif departs < common:
            gap = float(np.hypot(*(a[departs, :2] - b[departs, :2])))
            lines.append(
                f"  trace: departs at control instant {departs} of {len(a)} by {gap:.3g} m "
                f"(recorded {_pose(a[departs])}, replayed {_pose(b[departs])})"
            )
        else:
            lines.append(
                f"  trace: equal for {common} control instants, then one ends ({len(a)} "
                f"recorded, {len(b)} replayed)"
            )
        same &= departs is None
    return Replay(same, _message(head, same, lines), record, result, departs)


def _message(head, same, lines) -> str:
    verdict = "reproduced (exact)" if same else "NOT reproduced"
    return "\n".join([f"{head}: {verdict}", *lines])


def _pose(pose) -> str:
    return "({:.6f}, {:.6f}, {:.6f})".format(*(float(v) for v in pose))


def _gif_name(row: dict, taken: set) -> str:
    """A gallery file name for the episode `row`, not in `taken` (which it joins): labels that
    slug alike ("dc+wide", "dc wide") get one file each."""
    stem = f"{_slug(row['noise'])}-{_slug(row['label'])}-env{row['env_index']}"
    name, copy = f"{stem}.gif", 1
    while name in taken:
        copy += 1
        name = f"{stem}-{copy}.gif"
    taken.add(name)
    return name


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", str(text))


def _paths(db_paths) -> list[Path]:
    if isinstance(db_paths, (str, Path)):
        db_paths = [db_paths]
    paths = [Path(p) for p in db_paths]
    if not paths:
        raise ValueError("replay needs at least one results database (--db PATH)")
    return paths


def _find(paths, label, env_index, noise) -> tuple[dict, dict, str | None]:
    """The row (noise, label, env_index) of the first database holding it finished (else the first
    holding it at all, as the report merges shards), its config and the kernels its run recorded
    (None: not recorded)."""
    held, first = set(), None
    for path in paths:
        db = ResultsDB(path)
        try:
            everything = db.rows()
            rows = [
                r for r in everything
                if r["label"] == label and r["env_index"] == env_index
                and (noise is None or r["noise"] == noise)
            ]  # fmt: skip
            held |= {(r["noise"], r["label"]) for r in everything}
            if len(rows) > 1:
                noises = ", ".join(r["noise"] for r in rows)
                raise ValueError(
                    f"{path}: row {label!r} has environment {env_index} under several noise "
                    f"profiles ({noises}); choose one with --noise"
                )
            if rows:
                found = db.row(rows[0]["noise"], label, env_index)
                run = next((r for r in db.runs() if r["run_id"] == found.get("run_id")), None)
                recorded_on = ((run or {}).get("provenance") or {}).get("kernels")
                if found["status"] == "ok":
                    return found, db.config, recorded_on
                first = first or (found, db.config, recorded_on)
        finally:
            db.close()
    if first is not None:
        return first
    where = ", ".join(str(p) for p in paths)
    have = "; ".join(f"{lab} (noise {noi})" for noi, lab in sorted(held)) or "no rows"
    raise ValueError(
        f"{where}: no episode of row {label!r}, environment {env_index}"
        f"{'' if noise is None else f', noise {noise}'}; the database holds {have}"
    )


def _all_rows(paths) -> tuple[list[dict], dict]:
    """The rows (their traces left out) of every database, one per key as the report merges
    them (the first finished row, else the first), ordered by key, and the database of each
    (by id(row))."""
    chosen, source = {}, {}
    for path in paths:
        db = ResultsDB(path)
        try:
            for row in db.rows():
                key = (row["noise"], row["label"], row["env_index"])
                held = chosen.get(key)
                if held is None or held["status"] != "ok" and row["status"] == "ok":
                    chosen[key] = row
                    source[id(row)] = path
        finally:
            db.close()
    return [chosen[key] for key in sorted(chosen)], source


def _spec(record: dict, config: dict) -> EpisodeSpec:
    """The episode of `record` as its experiment builds it from the database's configuration
    (dcmppi.bench.experiments.Experiment.spec), checked against what the row recorded."""
    from dcmppi.bench.experiments import Experiment, Row

    label, index = record["label"], record["env_index"]
    row = config.get("rows", {}).get(label)
    if row is None:
        raise ValueError(f"the database's configuration has no row {label!r}")
    exp = Experiment(
        name="replay",
        task=config["task"],
        rows=(Row(label, row["controller"], row.get("params", {})),),
        noises=(record["noise"],),
        episodes=index + 1,
        base_seed=config.get("base_seed", 0),
        task_params=config.get("task_params", {}),
        controller_params=config.get("controller_params", {}),
        env_param=config.get("env_param"),
        env_offset=config.get("env_offset", 0),
    )
    spec = exp.spec(record["noise"], label, index)
    recorded = EpisodeSpec(
        task=record["task"],
        controller=record["controller"],
        noise=record["noise"],
        seed=record["seed"],
        **json.loads(record["params"]),
    )
    if spec != recorded:
        differ = [
            f.name
            for f in dataclasses.fields(spec)
            if getattr(spec, f.name) != getattr(recorded, f.name)
        ]
        raise ValueError(
            f"row {label!r}, environment {index}: its recorded {', '.join(differ)} differ from "
            "what the database's configuration gives; the database is inconsistent"
        )
    return spec
