"""Users' controllers: package.module:ClassName, entry points, parameters, errors, warm-up.

The classes live in tests/user_controllers.py, a module of the kind a user writes (test_bench
runs them in a process pool and on Ray).
"""

import importlib.metadata
import json

import pytest
import user_controllers

from dcmppi import cli
from dcmppi.bench.episodes import plugins
from dcmppi.bench.episodes.runner import EpisodeSpec, check_specs, controller_for, run_episode

SMALL = {"K": 32, "N": 20}
MODULE = "user_controllers"


def _spec(controller, own=None, shared=None, task_params=None):
    return EpisodeSpec(
        "blocked",
        controller,
        seed=3,
        task_params={"time_limit": 20.0, **(task_params or {})},
        controller_params=own or {},
        shared_params=shared or {},
    )


def test_module_class_is_built_with_the_arguments_it_takes():
    c = controller_for(_spec(f"{MODULE}:Straight", {"gain": 2.0}, {"K": 64}))
    assert isinstance(c, user_controllers.Straight)
    assert c.gain == 2.0 and c.seed == _spec("x").controller_seed()  # K and agent: not taken
    anything = controller_for(_spec(f"{MODULE}:Anything", {"x": 1}, {"K": 64}))
    robot = {"agent": "dubins", "v": 1.0, "r_min": 1.0, "robot_radius": 0.5}  # the task's
    assert anything.params == {"x": 1, "K": 64, **robot, "seed": anything.params["seed"]}
    careful = controller_for(_spec(f"{MODULE}:Careful", {"care": 3.0}, SMALL, {"v": 1.5}))
    assert (careful.care, careful.K, careful.agent.params["v"]) == (3.0, 32, 1.5)


def test_own_parameters_must_be_taken_shared_ones_by_some_controller():
    with pytest.raises(ValueError, match="unknown parameter.s. K for controller .* takes gain"):
        controller_for(_spec(f"{MODULE}:Straight", {"K": 64}))
    with pytest.raises(ValueError, match="unknown parameter.s. care for controller 'mppi'"):
        controller_for(_spec("mppi", {"care": 1.0}))
    # K is taken by mppi only: fine; a misspelt name taken by nobody is refused
    check_specs([_spec(f"{MODULE}:Straight", shared=SMALL), _spec("mppi", shared=SMALL)])
    with pytest.raises(ValueError, match="lamda set for every controller but taken by none"):
        check_specs([_spec(f"{MODULE}:Straight", shared={"lamda": 2}), _spec("mppi")])
    # an experiment's rows not run now take theirs: the classical rows run alone
    with pytest.raises(ValueError, match="K, N set for every controller but taken by none"):
        check_specs([_spec(f"{MODULE}:Straight", shared=SMALL)])
    check_specs([_spec(f"{MODULE}:Straight", shared=SMALL)], others=[("mppi", {})])
    with pytest.raises(ValueError, match="lamda set for every controller but taken by none"):
        check_specs([_spec(f"{MODULE}:Straight", shared={"lamda": 2})], others=[("mppi", {})])


@pytest.mark.parametrize(
    "name, message",
    [
        ("no_such_module:C", "no module named 'no_such_module'; run from the directory"),
        (f"{MODULE}:Nope", "has no 'Nope'; its classes: Anything, Careful, MPPI, NoAct"),
        (f"{MODULE}:NoAct", "class NoAct has no act(); a controller needs act(state, goal"),
        (f"{MODULE}:factory", "is a function, not a class"),
        (f"{MODULE}:", "expected package.module:ClassName"),
        ("fancy", "unknown controller 'fancy'; valid: clustered, dc, dwa, hl, hrvo, mppi, orca, "),
    ],
)
def test_a_bad_controller_name_gets_one_clear_line(name, message, capsys):
    with pytest.raises(ValueError) as info:
        plugins.resolve_controller(name)
    assert message in str(info.value)
    assert cli.main(["run", "--task", "blocked", "--controller", name]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1


def test_a_module_that_fails_to_import_is_reported(tmp_path, monkeypatch):
    (tmp_path / "broken_ctrl.py").write_text("import numpyy\n")
    (tmp_path / "raising_ctrl.py").write_text("raise RuntimeError('no licence')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ValueError, match="importing broken_ctrl failed: No module named 'numpyy'"):
        plugins.resolve_controller("broken_ctrl:C")
    with pytest.raises(ValueError, match="raised RuntimeError: no licence"):
        plugins.resolve_controller("raising_ctrl:C")


def _fake_entry_points(monkeypatch, **names):
    found = [
        importlib.metadata.EntryPoint(name, value, plugins.ENTRY_POINT_GROUP)
        for name, value in names.items()
    ]
    real = importlib.metadata.entry_points

    def entry_points(**kwargs):
        if kwargs.get("group") == plugins.ENTRY_POINT_GROUP:
            return found
        return real(**kwargs)

    monkeypatch.setattr(importlib.metadata, "entry_points", entry_points)


def test_entry_points_appear_by_name(monkeypatch, capsys):
    _fake_entry_points(
        monkeypatch,
        straight=f"{MODULE}:Straight",
        mppi=f"{MODULE}:Careful",  # a built-in name wins
        broken="no_such_module:C",
    )
    names = ["clustered", "dc", "dwa", "hl", "hrvo", "mppi", "orca", "social_force", "tube"]
    names += ["broken", "straight"]
    assert plugins.available_controllers() == names
    assert plugins.resolve_controller("straight") is user_controllers.Straight
    assert plugins.resolve_controller("mppi").__name__ == "MPPI"
    with pytest.raises(ValueError, match="'broken' .entry point 'no_such_module:C' of group"):
        plugins.resolve_controller("broken")
    assert cli.main(["controllers"]) == 0
    out = capsys.readouterr().out
    assert f"straight     entry point {MODULE}:Straight (dcmppi.controllers)" in out
    assert "holonomic" in out and "mppi         built-in" in out
    assert cli.main(["run", "--task", "blocked", "--controller", "straight", "--json",
                     "--task-param", "time_limit=10", "--param", "gain=2"]) == 0  # fmt: skip
    result = json.loads(capsys.readouterr().out)
    assert result["controller"] == "straight" and result["outcome"] is not None
    assert result["ess_mean"] is None and result["clusters_mean"] is None
    assert result["final_x"] > 0 and "trace" not in result  # the trace is bytes


def test_a_user_controller_is_warmed_up_once_per_process():
    spec = _spec(f"{MODULE}:Straight", {"gain": 1.5}, task_params={"time_limit": 5.0})
    built, acted = user_controllers.Straight.built, user_controllers.Straight.acted
    first = run_episode(spec)
    second = run_episode(spec)
    same = ("outcome", "steps", "path_length", "min_clearance")
    assert [first[k] for k in same] == [second[k] for k in same]
    # two episodes' controllers and their steps, plus one warm-up copy that acted once
    assert user_controllers.Straight.built - built == 3
    assert user_controllers.Straight.acted - acted == first["steps"] + second["steps"] + 1


def test_figure_draws_a_users_sampling_controller(tmp_path, capsys):
    argv = ["figure", "--task", "blocked", "--controllers", f"mppi,{MODULE}:Careful",
            "--param", "K=64", "--out", str(tmp_path)]  # fmt: skip
    assert cli.main(argv) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("mppi       applies u = (") and f"{MODULE}:Careful" in out[1]
    assert (tmp_path / "values.png").stat().st_size > 1000
