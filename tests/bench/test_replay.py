"""Episode traces, replay of recorded episodes, the failure gallery."""

import base64
import concurrent.futures as cf
import json
import multiprocessing
import os
import pathlib
import re
import sqlite3

import numpy as np
import pytest

from dcmppi import cli, tasks
from dcmppi.bench.episodes.runner import EpisodeSpec, decode_trace, encode_trace, run_episode
from dcmppi.bench.experiments import Experiment
from dcmppi.bench.results.database import ResultsDB
from dcmppi.bench.results.provenance import kernels
from dcmppi.bench.runs import replay as rp

BARN = pathlib.Path(__file__).parents[1] / "tasks" / "data" / "barn_worlds_0_1.csv"
# the ETH/UCY recordings: $DCMPPI_CROWDS, else ../shared/crowds beside the checkout
CROWDS = pathlib.Path(
    os.environ.get("DCMPPI_CROWDS") or pathlib.Path(__file__).parents[2].parent / "shared/crowds"
)
TINY = {"K": 16, "N": 8}
# every task, with short episodes and its own tiny parameters
TASK_PARAMS = {
    "forest": {"time_limit": 1.5},
    "crowd": {"time_limit": 1.5, "n_obstacles": 20},
    "corridor": {"time_limit": 1.5, "n_pedestrians": 4},
    "square": {"time_limit": 1.5, "n_pedestrians": 3},
    "crowdnav": {"time_limit": 1.5, "n_humans": 3},
    "crowdnav_plus": {"time_limit": 1.5, "n_humans": 3},
    "blocked": {"time_limit": 1.5},
    "crossing": {"time_limit": 1.5},
    "layout": {"time_limit": 1.5, "path": str(BARN)},
    "replay": {"time_limit": 1.5, "scene": "zara1", "episode": 0, "path": str(CROWDS)},
}


def record(
    path, task, episodes=1, noise="control", workers=1, rows=("mppi",), params=TINY,
    provenance=None, **task_params,
):  # fmt: skip
    """A results database at `path` of `episodes` tiny episodes per row of `task` (one run of
    `provenance` when given)."""
    exp = Experiment.from_dict(
        {
            "task": task,
            "noises": [noise],
            "episodes": episodes,
            "base_seed": 5,
            "task_params": {**TASK_PARAMS[task], **task_params},
            "controller_params": params,
            **({"env_param": "world"} if task == "layout" else {}),
            "rows": [{"label": r, "controller": r} for r in rows],
        },
        "test",
    )
    keys, specs = zip(*exp.specs(), strict=True)
    if workers > 1:  # fresh processes, as the bench's pool
        context = multiprocessing.get_context("spawn")
        with cf.ProcessPoolExecutor(workers, mp_context=context) as pool:
            results = list(pool.map(run_episode, specs))
    else:
        results = [run_episode(spec) for spec in specs]
    db = ResultsDB(path, exp.config(), provenance=provenance)
    if provenance is not None:
        db.begin_run(exp.to_dict())
    for key, spec, result in zip(keys, specs, results, strict=True):
        db.record(key, spec, result)
    if provenance is not None:
        db.end_run()
    db.close()
    return exp


def test_an_episode_result_holds_its_trace_and_final_pose():
    spec = EpisodeSpec("blocked", "mppi", "control", 3, {"time_limit": 1.0}, TINY)
    result = run_episode(spec, keep_path=True)
    trace = decode_trace(result["trace"])
    assert trace.shape == (result["steps"] + 1, 3) and trace.dtype == np.float32
    assert (trace[:, :2] == result["path"].astype(np.float32)).all()
    final = [result["final_x"], result["final_y"], result["final_theta"]]
    assert trace[-1].tolist() == np.float32(final).tolist()
    assert trace[0, 0] < trace[-1, 0]  # it drove toward the goal (+x)
    assert (decode_trace(encode_trace(trace)) == trace).all()


def test_every_task_replays_exactly(tmp_path):
    assert set(TASK_PARAMS) == set(tasks.TASKS)
    for task in tasks.TASKS:
        if task == "replay" and not CROWDS.is_dir():
            continue  # the recordings are absent: tests/tasks/test_replay_task.py says so
        db = tmp_path / f"{task}.db"
        record(db, task)
        r = rp.replay([db], "mppi", 0)
        assert r.reproduced, r.message
        assert "reproduced (exact)" in r.message.splitlines()[0]
        assert f"identical at all {r.record['steps'] + 1} control instants" in r.message


@pytest.mark.slow
def test_an_episode_recorded_by_a_worker_process_replays_here(tmp_path):
    record(tmp_path / "r.db", "crowd", episodes=2, workers=2)
    assert all(rp.replay(tmp_path / "r.db", "mppi", i).reproduced for i in range(2))


def _tamper(db, sql, *args):
    with sqlite3.connect(db) as con:
        con.execute(sql, args)
    con.close()


def test_a_changed_record_is_not_reproduced_and_the_departure_is_named(tmp_path):
    db = tmp_path / "r.db"
    record(db, "blocked")
    trace = decode_trace(rp.replay(db, "mppi", 0).record["trace"]).copy()
    trace[7, 1] += 0.25
    _tamper(db, "UPDATE episodes SET trace = ?", encode_trace(trace))
    r = rp.replay(db, "mppi", 0)
    assert not r.reproduced and r.departs == 7
    assert "NOT reproduced" in r.message and "departs at control instant 7" in r.message
    assert "by 0.25 m" in r.message
    _tamper(db, "UPDATE episodes SET trace = ?, steps = steps + 1", encode_trace(trace[:5]))
    r = rp.replay(db, "mppi", 0)
    assert not r.reproduced and r.departs == 5
    assert "steps: 15 (recorded 16)" in r.message
    _tamper(db, "UPDATE episodes SET final_x = final_x + 1e-9, outcome = 'collision'")
    r = rp.replay(db, "mppi", 0)
    assert "outcome: time_limit (recorded collision)" in r.message
    assert "final pose" in r.message and "(recorded" in r.message.split("final pose")[1]


def test_a_departure_names_the_kernels_when_the_record_was_made_on_others(tmp_path):
    db = tmp_path / "r.db"
    record(db, "blocked", provenance={"kernels": "numpy X86_V4, openblas SkylakeX"})
    assert rp.replay(db, "mppi", 0).reproduced  # the machine is named only where it departs
    trace = decode_trace(rp.replay(db, "mppi", 0).record["trace"]).copy()
    trace[3, 0] += 0.5
    _tamper(db, "UPDATE episodes SET trace = ?", encode_trace(trace))
    message = rp.replay(db, "mppi", 0).message
    assert f"recorded on numpy X86_V4, openblas SkylakeX, replayed on {kernels()}" in message
    _tamper(db, "UPDATE runs SET provenance = ?", json.dumps({"kernels": kernels()}))
    assert "machine:" not in rp.replay(db, "mppi", 0).message  # the same kernels: not the cause


def test_a_worker_processs_end_is_named_not_rerun(tmp_path):
    db = tmp_path / "r.db"
    record(db, "blocked")
    _tamper(db, "UPDATE episodes SET status = 'error', error = 'worker died (signal 9)'")
    r = rp.replay(db, "mppi", 0)
    assert not r.reproduced and r.result == {}
    assert "recorded as 'worker died (signal 9)', which only a worker process shows" in r.message


def test_replay_takes_the_finished_row_of_several_databases(tmp_path):
    """An episode recorded as an error in one shard and finished in another: replay takes the
    finished one, as the report does, whichever database comes first."""
    errored, finished = tmp_path / "a.db", tmp_path / "b.db"
    record(errored, "blocked")
    record(finished, "blocked")
    _tamper(errored, "UPDATE episodes SET status = 'error', error = 'worker died (signal 9)'")
    for paths in ([errored, finished], [finished, errored]):
        assert rp.replay(paths, "mppi", 0).reproduced
    assert not rp.replay([errored], "mppi", 0).reproduced


def test_replay_names_what_the_databases_hold(tmp_path):
    db = tmp_path / "r.db"
    record(db, "blocked", rows=("mppi", "dc"))
    with pytest.raises(ValueError, match=r"no episode of row 'tube', environment 0; .* dc \(noise"):
        rp.replay([db], "tube", 0)
    with pytest.raises(ValueError, match="no episode of row 'dc', environment 3"):
        rp.replay([db], "dc", 3)
    _tamper(db, "UPDATE episodes SET seed = seed + 1 WHERE label = 'dc'")
    with pytest.raises(ValueError, match="recorded seed differ from .* configuration"):
        rp.replay([db], "dc", 0)


def test_a_replay_writes_its_episode_viewer_and_bad_input_ends_in_one_line(tmp_path, capsys):
    db = tmp_path / "r.db"
    record(db, "crossing", rows=("dc",))
    page = tmp_path / "dc.html"
    r = rp.replay([db], "dc", 0, page=page)
    assert r.reproduced and r.page == page  # reading the episode for the page changed nothing
    data = json.loads(re.search(r"<script id=episode [^>]*>(.*?)</script>", page.read_text())[1])
    pose = np.frombuffer(base64.b64decode(data["arrays"]["pose"]["b64"]), "<f4")
    assert np.array_equal(pose.reshape(-1, 3), decode_trace(r.record["trace"]))
    bad = {
        "--env 5": f"{db}: no episode of row 'dc', environment 5; the database holds dc (noise "
        "control)",
        "--html x.htm": "page path must end in .html, got 'x.htm'",
        f"--html {db}/x.html": f"cannot write the page {db}/x.html: {db} is a file, not a folder; "
        "choose a path in a folder",
    }
    for options, error in bad.items():
        argv = f"replay --db {db} --label dc --env 0 --html {tmp_path}/y.html {options}".split()
        assert cli.main(argv) == 2
        assert capsys.readouterr().err == f"dcmppi replay: error: {error}\n"
    assert not (tmp_path / "y.html").exists()


def test_gallery_files_of_labels_that_slug_alike_are_apart():
    taken = set()
    rows = [{"noise": "none", "label": label, "env_index": 0} for label in ("dc+wide", "dc wide")]
    names = [rp._gif_name(row, taken) for row in rows]
    assert names == ["none-dc_wide-env0.gif", "none-dc_wide-env0-2.gif"]


@pytest.mark.slow
def test_gallery_renders_failures_and_one_success_through_the_replay(tmp_path, capsys):
    db = tmp_path / "r.db"
    # 1.5 s: every episode times out (a failure); an empty square is crossed
    record(db, "blocked", episodes=3, rows=("mppi",))
    big = {"K": 64, "N": 20}
    record(tmp_path / "s.db", "square", rows=("dc",), params=big, n_pedestrians=0, time_limit=9.0)
    out = rp.gallery([db, tmp_path / "s.db"], tmp_path / "report", 2)
    assert out == {
        ("control", "mppi"): [
            (0, "time_limit", "gallery/control-mppi-env0.gif", "gallery/control-mppi-env0.html"),
            (1, "time_limit", "gallery/control-mppi-env1.gif", "gallery/control-mppi-env1.html"),
        ],
        ("control", "dc"): [
            (0, "goal", "gallery/control-dc-env0.gif", "gallery/control-dc-env0.html")
        ],
    }
    page = (tmp_path / "report" / "gallery" / "control-dc-env0.html").read_text()
    assert "control / env 0 (seed" in page and "Replayed: reproduced (exact)" in page
    gif = tmp_path / "report" / "gallery" / "control-dc-env0.gif"
    import imageio.v3 as iio

    frames = iio.imread(gif)
    assert frames.shape[1:3] == (rp.GALLERY_SIZE[1], rp.GALLERY_SIZE[0])
    assert capsys.readouterr().err == ""  # every replay reproduced
