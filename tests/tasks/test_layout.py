"""The `layout` task: BARN worlds, CSV and JSON files, and clear errors for malformed ones."""

import json
import math
import pathlib

import numpy as np
import pytest

from dcmppi import tasks
from dcmppi.tasks import layout

BARN = pathlib.Path(__file__).parent / "data" / "barn_worlds_0_1.csv"


def barn_world(world):
    rows = np.loadtxt(BARN, delimiter=",", skiprows=1)
    return rows[rows[:, 0] == world, 1:]


@pytest.mark.parametrize("world", [0, 1])
def test_loads_a_barn_world_with_the_challenge_protocol(world):
    env = tasks.load("layout", {"path": str(BARN), "world": world, "robot_radius": 0.2})
    obs = env.reset().observation
    np.testing.assert_allclose(obs["static_obstacles"], barn_world(world))
    np.testing.assert_allclose(obs["robot_pose"], layout.BARN_START)
    np.testing.assert_allclose(obs["goal"], layout.BARN_GOAL)
    assert env.task.time_limit == layout.BARN_TIME_LIMIT
    xmin, ymin, xmax, ymax = obs["map_bounds"]
    cylinders = obs["static_obstacles"]
    assert xmin < cylinders[:, 0].min() and xmax > cylinders[:, 0].max()
    assert ymin < layout.BARN_START[1] and ymax > layout.BARN_GOAL[1]


def test_barn_file_found_through_the_environment_variable(monkeypatch):
    monkeypatch.setenv("DCMPPI_BARN", str(BARN))
    env = tasks.load("layout", {"world": 1})
    np.testing.assert_allclose(env.reset().observation["static_obstacles"], barn_world(1))
    monkeypatch.delenv("DCMPPI_BARN")
    with pytest.raises(ValueError, match=r"not part of dcmppi: pass path=FILE .* DCMPPI_BARN="):
        tasks.load("layout", {"world": 1})


def test_full_barn_file_when_available():
    """The shipped excerpt is the BARN file's worlds 0 and 1 (with $DCMPPI_BARN set)."""
    try:
        path = layout.barn_path()
    except ValueError:
        pytest.skip("the BARN file is not available (set DCMPPI_BARN)")
    for world in (0, 1):
        cylinders = layout.read_layout(path, world=world).cylinders
        np.testing.assert_allclose(cylinders, barn_world(world))


def test_csv_without_header_and_start_goal_from_kwargs(tmp_path):
    path = tmp_path / "three.csv"
    path.write_text("# my cylinders\n1,2,0.5\n\n4,5,1.0\n7,8,0.25\n")
    env = tasks.load("layout", {"path": str(path), "start": (0, 0, 0), "goal": (10, 10)})
    obs = env.reset().observation
    np.testing.assert_allclose(obs["static_obstacles"], [[1, 2, 0.5], [4, 5, 1.0], [7, 8, 0.25]])
    bounds = obs["map_bounds"]
    assert env.task.time_limit == pytest.approx(
        3 * 2 * ((bounds[2] - bounds[0]) + (bounds[3] - bounds[1]))
    )


def test_json_layout_with_everything(tmp_path):
    path = tmp_path / "room.json"
    spec = {
        "cylinders": [[3, 0, 1.0], [3, 4, 0.5]],
        "start": [0, 0, math.pi / 2],
        "goal": [6, 0],
        "map_bounds": [-2, -2, 8, 6],
        "time_limit": 30,
    }
    path.write_text(json.dumps(spec, indent=1))
    env = tasks.load("layout", {"path": str(path)})
    obs = env.reset().observation
    np.testing.assert_allclose(obs["map_bounds"], spec["map_bounds"])
    np.testing.assert_allclose(obs["robot_pose"], spec["start"])
    assert env.task.time_limit == 30
    # Task kwargs override the file.
    env = tasks.load("layout", {"path": str(path), "goal": (6, 3), "time_limit": 12})
    np.testing.assert_allclose(env.reset().observation["goal"], [6, 3])
    assert env.task.time_limit == 12


@pytest.mark.parametrize(
    "text, message",
    [
        ("x,y,radius\n1,2,0.5\n3,4\n", r"bad\.csv:3: expected 3 values"),
        ("x,y,radius\n1,2,0.5\n3,four,1\n", r"bad\.csv:3: y must be a finite number"),
        ("1,2,0.5\n3,4,-1\n", r"bad\.csv:2: radius must be > 0"),
        ("1,2,nan\n", r"bad\.csv:1: radius must be a finite number"),
        ("a,b,c\n1,2,3\n", r"bad\.csv:1: header must be"),
        ("# nothing\n\n", r"bad\.csv: no cylinders"),
    ],
)
def test_malformed_csv_names_file_line_and_reason(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        layout.read_layout(path)


@pytest.mark.parametrize(
    "text, message",
    [
        ('{"cylinders": [[1, 2, 0.5],\n [3, 4]]}', r"bad\.json:2: cylinders\[1\] must be"),
        ('{"cylinders": [[1, 2, 0.5],\n  [3, 4, 0]\n]}', r"bad\.json:2: cylinders\[1\]: radius"),
        ('{"cylinders": [[1, 2, 0.5]],\n "start": [1, 2]', r"bad\.json:2: invalid JSON"),
        ('{"cylinders": [[1, 2, 0.5]], "goal": [1, "x"]}', r"bad\.json: goal must be 2 numbers"),
        ('{"cylinders": [[1, 2, 0.5]], "speed": 3}', r"bad\.json: unknown keys"),
        ("[1, 2, 3]", r"bad\.json:1: expected an object"),
    ],
)
def test_malformed_json_names_file_line_and_reason(tmp_path, text, message):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(ValueError, match=message):
        layout.read_layout(path)


def test_world_selection_errors(tmp_path):
    with pytest.raises(ValueError, match="several worlds; pass world="):
        layout.read_layout(BARN)
    with pytest.raises(ValueError, match="no cylinders for world 7"):
        layout.read_layout(BARN, world=7)
    plain = tmp_path / "plain.csv"
    plain.write_text("1,2,0.5\n")
    with pytest.raises(ValueError, match="no 'world' column"):
        layout.read_layout(plain, world=0)


def test_layout_task_kwarg_errors(tmp_path):
    with pytest.raises(ValueError, match="path=.*world="):
        tasks.load("layout", {})
    plain = tmp_path / "plain.csv"
    plain.write_text("1,2,0.5\n")
    with pytest.raises(ValueError, match="start=.*goal="):
        tasks.load("layout", {"path": str(plain)})
    with pytest.raises(ValueError, match="goal must be 2"):
        tasks.load("layout", {"path": str(plain), "start": (0, 0, 0), "goal": (1, 2, 3)})
    with pytest.raises(ValueError, match="cannot read"):
        tasks.load("layout", {"path": str(tmp_path / "missing.csv")})
