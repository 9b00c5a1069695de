"""Model recipes (dcmppi.bench.crowds.recipes): placeholders resolved per environment, the
file trained on first use by the train command's code and cached, the clear error lines; and
`dcmppi record` (dcmppi.bench.crowds.recording): simulated crowds as ETH/UCY files."""

import dataclasses
import json

import numpy as np
import pytest

from dcmppi import cli, tasks
from dcmppi.bench.crowds import recipes, recording
from dcmppi.bench.episodes.runner import check_specs
from dcmppi.bench.episodes.seeds import environment_seed
from dcmppi.bench.experiments import Experiment, ExperimentError, load_experiment
from dcmppi.control.predictors import learned
from dcmppi.tasks.replay import recordings

ETH_UCY = {
    "task": "replay",
    "episodes": 10,
    "base_seed": 2027,
    "env_param": "episode",
    "task_params": {"scene": ["eth", "hotel", "univ", "zara1", "zara2"]},
    "rows": [
        {
            "label": "dc-learned",
            "controller": "dc",
            "params": {"prediction": "learned", "model": {"leave_out": "{scene}"}},
        }
    ],
}


@pytest.fixture(autouse=True)
def cache(tmp_path, monkeypatch):
    """Models trained into a folder of the test's own; no $DCMPPI_CROWDS."""
    folder = tmp_path / "models"
    monkeypatch.setenv(recipes.MODELS_ENV, str(folder))
    monkeypatch.delenv(recordings.CROWDS_ENV, raising=False)
    return folder


def fake_crowds(folder, seed=0):
    """A folder of every ETH/UCY file name, each a few people walking for 24 frames."""
    folder.mkdir()
    rng = np.random.default_rng(seed)
    for name in recordings.FILES:
        rows = []
        for person in range(1, 4):
            start, velocity = rng.uniform(-3, 3, 2), rng.uniform(-0.5, 0.5, 2)
            turn = rng.uniform(-0.05, 0.05)
            for k in range(24):
                c, s = np.cos(turn * k), np.sin(turn * k)
                step = np.array(
                    [c * velocity[0] - s * velocity[1], s * velocity[0] + c * velocity[1]]
                )
                start = start + step
                rows.append((10 * k, person, *start))
        np.savetxt(folder / f"{name}.txt", np.array(rows), delimiter="\t")
    return folder


def test_a_placeholder_picks_each_environments_scene_and_trains_once(tmp_path, cache):
    folder = fake_crowds(tmp_path / "crowds")
    exp = Experiment.from_dict(
        {**ETH_UCY, "task_params": {**ETH_UCY["task_params"], "path": str(folder)}}, "t"
    )
    paths = [exp.spec("none", "dc-learned", i).controller_params["model"] for i in range(7)]
    scenes = ["eth", "hotel", "univ", "zara1", "zara2", "eth", "hotel"]
    for path, scene in zip(paths, scenes, strict=True):
        assert f"learned-without-{scene}-" in path  # environment i plays scene i % 5
        info = json.loads(open(path.replace(".npz", ".json")).read())
        assert info["recipe"]["data"] == list(recordings.train_files(scene))
        assert info["sha256"] == learned.sha256(path)  # the hash, recoverable beside the file
    assert paths[5] == paths[0] and len(set(paths)) == 5
    assert sorted(p.name for p in cache.glob("*.npz")) == sorted({p.split("/")[-1] for p in paths})
    # the config keeps the recipe; a later spec finds the file and does not train it again
    assert exp.config()["rows"]["dc-learned"]["params"]["model"] == {"leave_out": "{scene}"}
    stamp = (cache / paths[0].split("/")[-1]).stat().st_mtime_ns
    assert exp.spec("none", "dc-learned", 0).controller_params["model"] == paths[0]
    assert (cache / paths[0].split("/")[-1]).stat().st_mtime_ns == stamp
    # the same bytes as `dcmppi predictor train --leave-out eth`
    out = tmp_path / "eth.npz"
    argv = ["predictor", "train", "--leave-out", "eth", "--folder", str(folder), "--out", str(out)]
    assert cli.main(argv) == 0
    assert learned.sha256(out) == learned.sha256(paths[0])
    # other data (one file changed) is another model
    with open(folder / "biwi_hotel.txt", "a") as f:
        f.write("0\t9\t0.0\t0.0\n")
    assert exp.spec("none", "dc-learned", 0).controller_params["model"] != paths[0]


def test_missing_crowd_files_end_the_bench_in_one_line_naming_the_fix(capsys, tmp_path):
    argv = ["bench", "--experiment", "eth-ucy", "--controllers", "dc-learned", "--episodes", "1"]
    assert cli.main([*argv, "--db", str(tmp_path / "e.db"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "row 'dc-learned': model recipe:" in err[0]
    assert f"set {recordings.CROWDS_ENV}=DIR" in err[0]
    assert not (tmp_path / "e.db").exists()


@pytest.mark.parametrize(
    "recipe, match",
    [
        ({"leave_out": "eth", "data": ["a.txt"]}, "exactly one of leave_out, data, record"),
        ({"leave_out": "eth", "sed": 1}, "sed: unknown key"),
        ({"record": {"episodes": 2}}, "record.base_seed: missing"),
        ({"record": {"episodes": 2, "base_seed": 1, "seeds": 3}}, "seeds: unknown key"),
        ({"data": []}, "non-empty array"),
        ({"leave_out": "eth", "period": 0}, "period: must be > 0"),
    ],
)
def test_a_malformed_recipe_names_its_key(recipe, match):
    data = {**ETH_UCY, "rows": [{"controller": "dc", "params": {"model": recipe}}]}
    with pytest.raises(ExperimentError, match=r"t: rows\[0\]\.params\.model: model recipe: ") as e:
        Experiment.from_dict(data, "t")
    assert match in str(e.value)


def test_unresolvable_recipes_say_why(tmp_path):
    def spec(recipe, **task_params):
        row = {
            "label": "x",
            "controller": "dc",
            "params": {"prediction": "learned", "model": recipe},
        }
        data = {**ETH_UCY, "rows": [row], "task_params": {**ETH_UCY["task_params"], **task_params}}
        return Experiment.from_dict(data, "t").spec("none", "x", 0)

    with pytest.raises(
        ValueError, match=r"\{place\} names no task parameter; task parameters: episode, scene"
    ):
        spec({"leave_out": "{place}"})
    with pytest.raises(ValueError, match="leave_out: unknown scene 'mars'"):
        spec({"leave_out": "mars"})
    with pytest.raises(ValueError, match="data nowhere.txt: no such file"):
        spec({"data": ["nowhere.txt"]})
    with pytest.raises(ValueError, match="record.base_seed 2027 is the experiment's own"):
        spec({"record": {"episodes": 1, "base_seed": 2027}})
    folder = tmp_path / "empty"
    folder.mkdir()
    with pytest.raises(ValueError, match=r"biwi_hotel.txt: no such recording"):
        spec({"leave_out": "{scene}"}, path=str(folder))


def test_the_square_rows_recipe_records_other_seeds_and_builds(cache):
    exp = load_experiment("square-orca")
    recipe = exp.row("dc-learned").params["model"]
    assert recipe["record"]["base_seed"] != exp.base_seed
    # the shipped recipe, smaller: 2 episodes of 8 s
    small = {**recipe, "record": {**recipe["record"], "episodes": 2, "seconds": 8.0}}
    row = dataclasses.replace(
        exp.row("dc-learned"), params={**exp.row("dc-learned").params, "model": small}
    )
    exp = dataclasses.replace(exp, rows=(row,), selected=())
    spec = exp.spec("none", "dc-learned", 0)
    check_specs([spec])  # the controller loads the trained file
    info = json.loads(open(spec.controller_params["model"].replace(".npz", ".json")).read())
    record = info["recipe"]["record"]
    assert record["task"] == "square" and record["task_params"] == exp.task_params
    # the recorded episodes' seeds are none of the test environments'
    recorded = {environment_seed(record["base_seed"], e) for e in range(200)}
    assert not recorded & {exp.seed(i) for i in range(exp.episodes)}


@pytest.mark.slow
@pytest.mark.parametrize("name", ["crowdnav", "crowdnav-visible", "crowdnav-plus"])
def test_the_crowdnav_rows_record_humans_of_no_test_case(name):
    """The recorded episodes of the dc-learned row (drawn as `recording.record` draws them)
    hold none of the humans of CrowdNav's (CrowdNav++'s) test cases, environment i's case i."""
    exp = load_experiment(name)
    env_params = {**exp.task_params, exp.env_param: 0}
    recipe = recipes.resolve(
        "dc-learned", exp.row("dc-learned").params["model"], exp, env_params, 0
    )
    record = recipe["record"]
    assert record["task"] == exp.task and exp.env_param not in record["task_params"]
    case = tasks.task_class(exp.task)(**exp.task_params, case=0)

    def humans(world):
        return tuple(np.round(world.moving[:, :2], 9).ravel())

    tested = set()
    for k in range(exp.episodes):
        case.case = k
        tested.add(humans(case.generate_world(None)))
    assert len(tested) == exp.episodes
    for e in range(record["episodes"]):
        seed = environment_seed(record["base_seed"], e)
        env = tasks.load(exp.task, task_kwargs={**record["task_params"], "random": seed})
        env.reset()
        assert humans(env.task.world) not in tested, f"recorded episode {e} is a test case"


def test_record_writes_eth_ucy_files_that_train(tmp_path, capsys):
    out = tmp_path / "square.txt"
    argv = ["record", "--task", "square", "--task-param", "behavior=orca", "--episodes", "2"]
    argv += ["--base-seed", "5", "--seconds", "10", "--out", str(out)]
    assert cli.main(argv) == 0
    assert "14 people" in capsys.readouterr().out
    read = recordings.load(out, period=0.4)
    made = recording.record("square", {"behavior": "orca"}, 2, 5, 0.4, 10.0)
    assert [t.id for t in read.tracks] == [t.id for t in made.tracks] == list(range(1, 15))
    for a, b in zip(read.tracks, made.tracks, strict=True):
        np.testing.assert_array_equal(a.frames, b.frames)
        np.testing.assert_allclose(a.xy, b.xy, atol=1e-6)
    frames = [t.frames for t in read.tracks]
    assert all(len(f) == 26 for f in frames)  # 10 s at 0.4 s, the reset's frame included
    assert frames[7][0] == frames[0][-1] + 20  # the second episode after a frame's gap
    steps = np.concatenate([np.hypot(*np.diff(t.xy, axis=0).T) for t in read.tracks])
    assert 0.1 < np.median(steps) < 0.9  # people walking 1-2 m/s, 0.4 s apart
    # deterministic for a seed, another with another seed
    again = tmp_path / "again.txt"
    assert cli.main([*argv[:-1], str(again)]) == 0
    assert again.read_bytes() == out.read_bytes()
    other = recording.record("square", {"behavior": "orca"}, 2, 6, 0.4, 10.0)
    assert not np.allclose(other.tracks[0].xy, made.tracks[0].xy)
    model = tmp_path / "m.npz"
    assert cli.main(["predictor", "train", "--data", str(out), "--out", str(model)]) == 0
    assert learned.load(model).features.shape[0] == 14 * (26 - 19)


def test_a_respawned_human_is_recorded_as_another_person():
    """crowdnav_plus's humans respawn on arrival: each stretch between respawns is a track of
    its own, whose steps stay within walking speed, and no frame is lost."""
    made = recording.record("crowdnav_plus", {"n_humans": 4}, 1, 3, 0.4, 30.0)
    assert len(made.tracks) > 4  # someone arrived and respawned within 30 s
    steps = np.concatenate([np.hypot(*np.diff(t.xy, axis=0).T) for t in made.tracks])
    assert steps.max() <= 1.0 * 0.4 + 1e-6  # v_pref 1 m/s, 0.4 s apart
    # the 76 frames of each of the 4 rows, less the stretches of a single frame
    assert sum(len(t.frames) for t in made.tracks) <= 4 * 76
    assert sum(len(t.frames) for t in made.tracks) >= 4 * 76 - 2 * (len(made.tracks) - 4)
    # a run cut where a row jumps, and only there
    cut = recording._runs(np.ones(6, bool), np.array([0, 0, 0, 1, 0, 0], bool))
    assert [list(r) for r in cut] == [[0, 1, 2], [3, 4, 5]]


@pytest.mark.parametrize(
    "argv, match",
    [
        (["--task", "forest"], "task forest has no moving obstacles to record"),
        (["--task", "replay"], "the replay task's people are recordings already"),
        (["--task", "square", "--period", "0.25"], "period 0.25 s is no whole number"),
        (["--task", "square", "--task-param", "random=3"], "choose them by --base-seed"),
    ],
)
def test_record_refuses_in_one_line(argv, match, capsys, tmp_path):
    assert cli.main(["record", *argv, "--out", str(tmp_path / "x.txt")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and match in err[0]
