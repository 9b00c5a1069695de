"""Experiments as TOML files: the shipped ones, selection, configuration, every malformed file."""

import pytest

from dcmppi.bench.api import run
from dcmppi.bench.episodes.runner import check_specs
from dcmppi.bench.experiments import (
    TUNING_SEED,
    Experiment,
    ExperimentError,
    Paper,
    experiment_names,
    load_experiment,
)
from dcmppi.control.defaults import PRESETS

MINIMAL = 'task = "blocked"\nepisodes = 2\n[[rows]]\ncontroller = "mppi"\n'


CROWDS = (
    "corridor", "corridor-visible", "square-orca", "crowd-sf", "dynamic", "eth-ucy",
    "eth-ucy-reactive", "crowdnav", "crowdnav-visible", "crowdnav-plus",
)  # fmt: skip


def own(exp):
    """An experiment's rows but the crowds preset's row that every crowd experiment ends with."""
    return tuple(label for label in exp.labels if label != "dc-recommended")


def test_every_crowd_experiment_ends_with_one_recommended_row():
    rows = [load_experiment(name).rows[-1] for name in CROWDS]
    assert {(r.label, r.controller) for r in rows} == {("dc-recommended", "dc")}
    spec = {"prediction": "cv", "preset": "crowds", "perturbation": "correlated", "gamma": 0.1,
            "beta": 50.0}  # fmt: skip
    assert all(r.params == spec for r in rows)
    crowds = PRESETS["crowds"]  # what a row restates is the preset's own value
    assert all(crowds[n] == v for n, v in spec.items() if n in crowds)
    others = set(experiment_names()) - set(CROWDS)
    assert not any("dc-recommended" in load_experiment(name).labels for name in others)


def test_shipped_experiments_hold_the_papers_setup():
    assert experiment_names() == [
        "barn", "blocked", "corridor", "corridor-mismatch", "corridor-visible", "crowd-sf",
        "crowdnav", "crowdnav-plus", "crowdnav-visible", "dynamic", "dynamic-dubins",
        "dynamic-ekf", "eth-ucy", "eth-ucy-reactive", "square-orca", "static",
    ]  # fmt: skip
    static = load_experiment("static")
    assert (static.task, static.episodes, static.base_seed) == ("forest", 1000, 2024)
    classical = ("orca", "hrvo", "hl", "social_force", "dwa")  # tests/control/test_classical.py
    assert static.labels == ("mppi", "tube", "clustered", "dwa")
    assert static.noises == ("none", "control", "process")
    assert static.reference == "mppi"
    assert static.paper("control", "clustered") == Paper(26, 2.9, 199)
    assert static.paper("process", "tube") == Paper(49, 5.0, 376)
    dynamic = load_experiment("dynamic")
    assert dynamic.task_params == {"agent": "holonomic"}
    assert dynamic.controller_params == {
        "perturbation": "mixed",
        "gamma": 1.0,
        "beta": 100.0,
        "Sigma": [1.0, 1.0, 0.1],
    }
    smooth = ("mppi+smooth", "clustered+smooth", "mppi+margin+smooth", "clustered+margin+smooth")
    assert own(dynamic) == (
        "mppi", "clustered", "mppi+margin", "clustered+margin", "tube", "dc", *classical,
        *smooth, "tube+smooth", "dc+smooth",
    )  # fmt: skip
    assert dynamic.row("tube+smooth").params == {"preset": "smooth", "perturbation": "correlated"}
    assert dynamic.row("clustered+margin").controller == "clustered"
    assert dynamic.row("clustered+margin").params == {"obstacle_margin": 0.5}
    assert (dynamic.episodes, dynamic.reference, dynamic.noises) == (300, "dc", ("none",))
    assert dynamic.paper("none", "dc") == Paper(0, None, 454)
    assert dynamic.paper("none", "mppi+margin") == Paper()
    dubins = load_experiment("dynamic-dubins")
    assert dubins.task_params == {"agent": "dubins"} and dubins.controller_params == {}
    assert dubins.labels == ("mppi", "clustered", "tube", "dc")
    assert dubins.paper("none", "clustered") == Paper(2, None, 288)
    ekf = load_experiment("dynamic-ekf")
    assert ekf.task_params == {"agent": "holonomic", "obstacle_measurement_std": 0.1}
    assert ekf.controller_params == dynamic.controller_params
    assert ekf.labels == ("mppi+margin", "dc-prior", "dc-ekf") and ekf.reference == "dc-ekf"
    assert ekf.row("dc-ekf").params == {"prediction": "ekf", "measurement_std": 0.1}
    for name, task, behavior, visible in (
        ("corridor", "corridor", "social_force", False),
        ("corridor-visible", "corridor", "social_force", True),
        ("square-orca", "square", "orca", False),
        ("crowd-sf", "crowd", "social_force", False),
    ):
        walking = load_experiment(name)
        assert (walking.task, walking.episodes, walking.reference) == (task, 300, "mppi+margin")
        assert walking.task_params["behavior"] == behavior
        assert walking.task_params["robot_visible"] is visible
        assert walking.controller_params == dynamic.controller_params
        oracle = ("mppi-oracle", "dc-oracle", "dc-learned") if name == "square-orca" else ()
        walking_smooth = (
            "mppi+smooth", "mppi+margin+smooth", "clustered+smooth", "dc+smooth", "dc-cv+smooth"
        )  # fmt: skip
        assert own(walking) == (
            "mppi",
            "mppi+margin",
            "clustered",
            "dc",
            "dc-cv",
            "dc-social",
            "dc-social-blind",
            *oracle,
            *classical,
            *(() if name == "corridor-visible" else walking_smooth),
        )
        assert walking.row("dc-social").params == {"prediction": "social"}
    square = load_experiment("square-orca")
    assert square.row("dc-oracle").params == {"prediction": "given"}
    assert square.row("dc-cv+smooth").params == {
        "prediction": "cv",
        "preset": "smooth",
        "perturbation": "correlated",
    }
    for name, visible in (("crowdnav", False), ("crowdnav-visible", True)):
        crowdnav = load_experiment(name)
        assert (crowdnav.task, crowdnav.episodes, crowdnav.reference) == (
            "crowdnav",
            500,
            "mppi+margin",
        )
        assert crowdnav.task_params == {"behavior": "orca", "robot_visible": visible}
        assert crowdnav.env_param == "case"  # environment i: CrowdNav's test case i
        assert crowdnav.controller_params == dynamic.controller_params
        # the true futures of blind humans; a social prediction of humans who react
        extra = ("dc-social",) if visible else ("dc-oracle",)
        assert own(crowdnav) == (
            "mppi+margin", "dc", "dc-cv", *extra, "dc-learned", "orca", "hrvo", "social_force"
        )  # fmt: skip
        assert crowdnav.row("dc-learned").params == square.row("dc-learned").params
    eth_ucy, reactive = load_experiment("eth-ucy"), load_experiment("eth-ucy-reactive")
    assert reactive.task_params == {
        **eth_ucy.task_params, "reactive": True, "pedestrian_radius": 0.3, "robot_radius": 0.3
    }  # fmt: skip
    assert (reactive.task, reactive.env_param, reactive.episodes) == ("replay", "episode", 500)
    others = [load_experiment(n).base_seed for n in experiment_names() if n != "eth-ucy-reactive"]
    assert reactive.base_seed not in others  # a seed of its own
    # eth-ucy's rows but the true futures, which people who react to the robot have none of,
    # and with a social prediction of people who react
    rows = [label for label in own(eth_ucy) if label != "dc-oracle"]
    rows.insert(rows.index("dc-cv") + 1, "dc-social")
    assert own(reactive) == tuple(rows)
    assert all(reactive.row(r).params == eth_ucy.row(r).params for r in rows if r != "dc-social")
    assert reactive.controller_params == eth_ucy.controller_params
    assert "ORCA 0.43 / 0.57 / 10.86 s" in load_experiment("crowdnav").paper_note
    plus = load_experiment("crowdnav-plus")
    assert (plus.task, plus.episodes, plus.env_param) == ("crowdnav_plus", 500, "case")
    assert plus.task_params == {"behavior": "orca", "robot_visible": False}
    assert plus.controller_params == dynamic.controller_params
    # crowdnav's rows, dc-learned's model recorded from this task (a respawn starts a track)
    assert own(plus) == own(load_experiment("crowdnav"))
    note = " ".join(plus.paper_note.split())
    for figures in (
        "0.92 / 0.07 / 15.42 s / 4.23 %",
        "0.69 / 0.29 / 14.77 s",
        "0.34 / 0.64 / 19.95",
    ):
        assert figures in note
    mismatch = load_experiment("corridor-mismatch")
    assert mismatch.row("dc-ekf-walk").params["process_std"] == [0.01, 0.01, 0.3, 0.5, 1.0]
    assert mismatch.labels == (
        "mppi+margin",
        "dc",
        "dc-ekf",
        "dc-ekf-walk",
        "dc-cv",
        "dc-social",
        "dc-social-blind",
    )


@pytest.mark.parametrize(
    "name",
    [
        "static",
        "dynamic",
        "dynamic-dubins",
        "dynamic-ekf",
        "corridor",
        "square-orca",
        "crowd-sf",
        "crowdnav",
        "crowdnav-visible",
        "crowdnav-plus",
    ],  # fmt: skip
)
def test_every_shipped_row_builds(name):
    """Each row's controller takes the experiment's parameters with the task's agent (rows
    whose model a recipe trains: tests/bench/test_models.py, on a small model)."""
    exp = load_experiment(name)
    rows = tuple(r.label for r in exp.rows if not isinstance(r.params.get("model"), dict))
    check_specs([spec for _, spec in exp.select(episodes=1, rows=rows).specs()])


def test_keys_specs_and_the_configuration():
    exp = load_experiment("dynamic")
    small = exp.select(episodes=2, rows=("dc", "mppi+margin"))
    keys = [key for key, _ in small.specs()]
    assert keys == [("none", label, i) for i in range(2) for label in ("dc", "mppi+margin")]
    spec = dict(small.specs())[("none", "mppi+margin", 1)]
    assert spec.controller == "mppi" and spec.controller_params == {"obstacle_margin": 0.5}
    assert spec.shared_params == exp.controller_params and spec.seed == exp.seed(1)
    assert spec.task_params == {"agent": "holonomic"}
    # what is run does not change what a database is bound to; a parameter does
    assert small.config() == exp.config()
    assert set(exp.config()["rows"]) == set(exp.labels)
    assert exp.with_params({}, {"K": 100}).config() != exp.config()


def test_tuning_environments_are_other_seeds_and_no_benchmark_case():
    """--tuning: the same rows and parameters on environments the test never draws: a
    benchmark's draws from other seeds ("seeds") or its cases after the test's ("beyond")."""
    exp = load_experiment("crowdnav")
    tuning = exp.for_tuning()
    assert tuning.name == "crowdnav-tuning" and tuning.env_param is None
    assert tuning.base_seed == exp.base_seed + TUNING_SEED
    assert [r.params for r in tuning.rows] == [r.params for r in exp.rows]
    assert tuning.controller_params == exp.controller_params
    assert not any(r.paper for r in tuning.rows) and not tuning.paper_note
    spec = tuning.spec("none", "dc-recommended", 3)
    assert "case" not in spec.task_params and spec.seed == tuning.seed(3) != exp.seed(3)
    assert exp.spec("none", "dc-recommended", 3).task_params["case"] == 3
    assert tuning.config() != exp.config()  # a database of one refuses the other's rows
    replay = load_experiment("eth-ucy")
    beyond = replay.for_tuning().select(episodes=2)
    assert beyond.spec("none", "hrvo", 1).task_params["episode"] == replay.episodes + 1
    assert Experiment.from_dict(beyond.to_dict(), "stored").config() == beyond.config()
    with pytest.raises(ValueError, match="barn has no tuning environments: environment i is "):
        load_experiment("barn").for_tuning()
    with pytest.raises(ValueError, match="--task-param case=...: experiment crowdnav sets"):
        run("crowdnav", tuning=True, task_params={"case": 3}, episodes=1)


@pytest.mark.parametrize("name", [n for n in CROWDS if n not in ("eth-ucy", "eth-ucy-reactive")])
def test_every_crowd_experiments_tuning_rows_build(name):
    tuning = load_experiment(name).for_tuning()
    rows = tuple(r.label for r in tuning.rows if not isinstance(r.params.get("model"), dict))
    check_specs([spec for _, spec in tuning.select(episodes=1, rows=rows).specs()])


def test_repeated_rows_and_noise_profiles_run_once():
    """--controllers mppi,mppi and --noise none,none: each once (a repeated profile used to run
    every episode twice and store an experiment that the report refused)."""
    exp = load_experiment("static").select(2, ("mppi", "mppi"), ("none", "control", "none"))
    assert exp.labels == ("mppi",) and exp.noises == ("none", "control")
    assert len(list(exp.specs())) == 2 * 2


def test_a_controller_named_instead_of_a_label_becomes_a_row_of_its_own():
    exp = load_experiment("static").select(rows=("clustered", "dc"))
    assert exp.labels == ("clustered", "dc")
    assert exp.row("dc").controller == "dc" and exp.row("dc").params == {}
    assert "dc" in exp.config()["rows"]
    with pytest.raises(ValueError, match="'fancy' is no row of static .* unknown controller"):
        load_experiment("static").select(rows=("fancy",))


def test_a_file_by_path_takes_its_name_from_the_stem(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(MINIMAL + 'label = "base"\nparams = { K = 64 }\n')
    exp = load_experiment(str(path))
    assert exp.name == "mine" and exp.labels == ("base",) and exp.noises == ("none",)
    assert exp.base_seed == 0 and exp.row("base").params == {"K": 64}
    path.write_text('name = "other"\n' + MINIMAL)
    assert load_experiment(str(path)).name == "other"
    with pytest.raises(ValueError, match="cannot read"):
        load_experiment(str(tmp_path / "missing.toml"))
    with pytest.raises(ValueError, match="unknown experiment 'nope'; valid: barn, blocked, corr"):
        load_experiment("nope")


@pytest.mark.parametrize(
    "text, key, reason",
    [
        ('task = "blocked\n', "TOML syntax", "line 1"),
        (MINIMAL + "[extra]\n", "extra", "unknown key; valid keys: name"),
        (MINIMAL.replace('task = "blocked"\n', ""), "task", "missing"),
        (MINIMAL.replace("episodes = 2", 'episodes = "two"'), "episodes", "must be an integer"),
        (MINIMAL.replace("episodes = 2", "episodes = true"), "episodes", "must be an integer"),
        (MINIMAL.replace("episodes = 2", "episodes = 0"), "episodes", "must be >= 1"),
        ("base_seed = -1\n" + MINIMAL, "base_seed", "must be >= 0"),
        (MINIMAL.replace('"blocked"', '"nope"'), "task", "unknown task 'nope'; valid: forest"),
        ('noises = ["loud"]\n' + MINIMAL, "noises[0]", "unknown noise profile 'loud'"),
        ("noises = []\n" + MINIMAL, "noises", "empty"),
        ('noises = ["none", "none"]\n' + MINIMAL, "noises", "repeats a profile"),
        ("noises = 'none'\n" + MINIMAL, "noises", "must be an array"),
        ('task = "blocked"\nepisodes = 2\nrows = []\n', "rows", "empty"),
        ('task = "blocked"\nepisodes = 2\n', "rows", "missing"),
        ("task_params = 3\n" + MINIMAL, "task_params", "must be a table"),
        ('task_params = { noise = "control" }\n' + MINIMAL, "task_params.noise", "per episode"),
        ("controller_params = { seed = 1 }\n" + MINIMAL, "controller_params.seed", "per episode"),
        (MINIMAL + 'lable = "x"\n', "rows[0].lable", "unknown key; valid keys: label"),
        (MINIMAL.replace('controller = "mppi"', 'label = "x"'), "rows[0].controller", "missing"),
        (MINIMAL.replace('"mppi"', '"fancy"'), "rows[0].controller", "unknown controller"),
        (MINIMAL.replace('"mppi"', '"no_such_mod:C"'), "rows[0].controller", "no module named"),
        (MINIMAL.replace('"mppi"', "3"), "rows[0].controller", "must be a string"),
        (MINIMAL + MINIMAL[MINIMAL.index("[[") :], "rows[1].label", "'mppi' is used twice"),
        (MINIMAL + 'label = "a,b"\n', "rows[0].label", "no comma"),
        ('reference = "dc"\n' + MINIMAL, "reference", "'dc' is no row label"),
        ('selected = ["dc"]\n' + MINIMAL, "selected", "'dc': no row label; labels: mppi"),
        (MINIMAL + "params = { seed = 3 }\n", "rows[0].params.seed", "per episode"),
        (MINIMAL + "params = { when = 1979-05-27 }\n", "rows[0].params.when", "not a number"),
        (MINIMAL + "paper.loud = { collisions = 1 }\n", "rows[0].paper.loud", "unknown noise"),
        (MINIMAL + "paper.none = { wins = 1 }\n", "rows[0].paper.none.wins", "unknown key"),
        (
            MINIMAL + "paper.none = { collisions = -1 }\n",
            "rows[0].paper.none.collisions",
            "out of range",
        ),
        (
            MINIMAL + 'paper.none = { failure_pct = "1" }\n',
            "rows[0].paper.none.failure_pct",
            "must be a number",
        ),
        ('name = "a/b"\n' + MINIMAL, "name", "not a path"),
        ('tuning = "seeds"\n' + MINIMAL, "tuning", "only with env_param"),
        ('env_param = "x"\ntuning = "later"\n' + MINIMAL, "tuning", "'later'; valid: 'seeds'"),
        ('env_param = "x"\nenv_offset = -1\n' + MINIMAL, "env_offset", "must be >= 0"),
    ],
)
def test_a_malformed_file_names_the_file_the_key_and_the_reason(tmp_path, text, key, reason):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(ExperimentError) as info:
        load_experiment(str(path))
    message = str(info.value)
    assert message.startswith(f"{path}: {key}: ")
    assert reason in message
    assert "\n" not in message


def test_a_preset_held_by_a_shared_parameter_is_said(capsys):
    """A row or --param that names a preset whose perturbation the experiment's shared
    "mixed" holds gets one line saying so; the shipped smooth rows, which name both, none."""
    exp = load_experiment("corridor")
    check_specs([spec for _, spec in exp.select(episodes=1, rows=("mppi+smooth",)).specs()])
    assert "preset" not in capsys.readouterr().err
    plain = exp.with_params({}, {"preset": "smooth"}).select(episodes=1, rows=("mppi", "hrvo"))
    check_specs([spec for _, spec in plain.specs()])
    lines = [line for line in capsys.readouterr().err.splitlines() if "preset" in line]
    assert lines == [
        "dcmppi: mppi with preset='smooth': the experiment's shared perturbation='mixed' holds, "
        "not the preset's perturbation='correlated'; set perturbation in the row or with --param "
        "to choose"
    ]
    chosen = exp.with_params({}, {"preset": "smooth", "perturbation": "correlated"})
    check_specs([spec for _, spec in chosen.select(episodes=1, rows=("mppi",)).specs()])
    assert "preset" not in capsys.readouterr().err


def test_a_parameter_the_user_chose_is_not_said_to_hold_over_the_preset(capsys):
    """--param beta=30 with --param preset=crowds means beta 30: no line says it holds."""
    exp = load_experiment("corridor")
    chosen = {"preset": "crowds", "perturbation": "correlated", "gamma": 0.1, "beta": 30.0}
    specs = [spec for _, spec in exp.with_params({}, chosen).select(1, ("dc",)).specs()]
    check_specs(specs)
    assert "shared beta=30.0 holds" in capsys.readouterr().err
    check_specs(specs, chosen=tuple(chosen))
    assert "preset" not in capsys.readouterr().err
