"""The `layout` task: BARN worlds, CSV and JSON files, and clear errors for malformed ones."""

import json
import math
import pathlib

import numpy as np
import pytest

from dcmppi import tasks
from dcmppi.tasks.worlds import layout

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
        ('{"cylinders": [[1, 2, 0.5]], "goal": [1, "x"]}', r"bad\.json:1: goal must be 2 numbers"),
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


def test_a_byte_order_mark_is_skipped(tmp_path):
    """Excel writes UTF-8 CSV files with a byte-order mark."""
    csv = tmp_path / "excel.csv"
    csv.write_bytes("\ufeffx,y,radius\r\n4,5,1\r\n".encode())
    assert layout.read_layout(csv).cylinders.tolist() == [[4, 5, 1]]
    js = tmp_path / "excel.json"
    js.write_bytes('\ufeff{"cylinders": [[4, 5, 1]], "start": [0, 0, 0], "goal": [9, 9]}'.encode())
    assert tasks.load("layout", {"path": str(js)}).task.generate_world(None).goal.tolist() == [9, 9]


@pytest.mark.parametrize(
    "name, text, kwargs, message",
    [
        ("a.csv", "x,y,radius\n1e300,0,1\n", {}, r"a\.csv:2: x must be within 1e\+06 m"),
        ("a.csv", "5,5,1e7\n", {}, r"a\.csv:1: radius must be within 1e\+06 m"),
        ("a.json", '{"cylinders": [[1, 2, 0.5],\n [1e300, 0, 1]]}', {}, r"a\.json:2: cylinders"),
        (
            "a.json",
            '{"cylinders": [[1, 2, 0.5]],\n"start": [1e300, 0, 0]}',
            {},
            r"a\.json:2: start",
        ),
        ("a.csv", "5,5,1\n", {"start": (1e300, 0, 0)}, r"^start: each value must be within"),
        ("a.csv", "5,5,1\n", {"map_bounds": (0, 0, 1e300, 9)}, r"^map_bounds: each value"),
    ],
)
def test_huge_coordinates_are_refused_in_one_line(tmp_path, name, text, kwargs, message):
    path = tmp_path / name
    path.write_text(text)
    kwargs = {"path": str(path), "start": (0, 0, 0), "goal": (9, 9), **kwargs}
    with pytest.raises(ValueError, match=message) as e:
        tasks.load("layout", kwargs)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    "text, kwargs, message",
    [
        # the robot (radius 0.5) touches the cylinder of line 3 at its start
        ("x,y,radius\n7,7,1\n0.8,0,0.3\n", {}, r"c\.csv:3: impossible layout: the robot "
         r"\(radius 0\.5 m\) at its start \(0, 0\) touches the cylinder \(0\.8, 0, 0\.3\)"),
        ("x,y,radius\n7,7,1\n0.8,0,0.3\n", {"robot_radius": 0.4}, None),  # clear: it runs
        # the goal (9, 9) inside the cylinder of line 2
        ("x,y,radius\n\n9.5,9,1\n", {}, r"c\.csv:3: impossible layout: the goal \(9, 9\) is "
         r"inside the cylinder \(9\.5, 9, 1\)"),
        ("5,5,1\n", {"map_bounds": (1, -1, 10, 10)}, r"c\.csv: impossible layout: the start "
         r"\(0, 0\) is outside the map .* map_bounds from task parameter map_bounds"),
        ("5,5,1\n", {"goal": (9, 12), "map_bounds": (-1, -1, 10, 10)}, r"the goal \(9, 12\) is "
         r"outside the map \(-1, -1, 10, 10\) \(start from task parameter start; goal from"),
    ],
)  # fmt: skip
def test_an_impossible_layout_is_refused_naming_the_line_of_its_cause(
    tmp_path, text, kwargs, message
):
    path = tmp_path / "c.csv"
    path.write_text(text)
    kwargs = {"path": str(path), "start": (0, 0, 0), "goal": (9, 9), **kwargs}
    if message is None:
        assert tasks.load("layout", kwargs).reset().observation["clearance"][0] > 0
        return
    with pytest.raises(ValueError, match=message) as e:
        tasks.load("layout", kwargs)
    assert "\n" not in str(e.value)


def test_an_impossible_json_or_barn_layout_names_its_file_and_line(tmp_path):
    path = tmp_path / "j.json"
    path.write_text('{"cylinders": [[5, 5, 1]],\n "start": [30, 0, 0],\n "goal": [9, 9],\n'
                    ' "map_bounds": [0, 0, 10, 10]}')  # fmt: skip
    with pytest.raises(ValueError, match=r"j\.json: impossible layout: the start \(30, 0\) is "
                       r"outside .*start from .*j\.json:2; goal from .*j\.json:3; map_bounds "
                       r"from .*j\.json:4"):  # fmt: skip
        tasks.load("layout", {"path": str(path)})
    # the start on BARN world 1's first cylinder, the line after world 0's
    first = 2 + len(barn_world(0))
    x, y, _ = barn_world(1)[0]
    with pytest.raises(ValueError, match=rf"barn_worlds_0_1\.csv:{first}: impossible layout"):
        tasks.load(
            "layout", {"path": str(BARN), "world": 1, "start": (x, y, 0), "robot_radius": 0.01}
        )


def test_a_task_whose_parameters_draw_an_impossible_world_is_refused():
    from dcmppi.bench.episodes.runner import EpisodeSpec, check_specs

    for params, message in [
        ({"obstacle_radius": 11.0}, r"Blocked drew an impossible world: the robot \(radius "
         r"0\.5 m\) at its start \(27\.5, 25\) touches the cylinder \(37\.5, 25, 11\)"),
        ({"distance": 100.0}, r"the start \(-12\.5, 25\) is outside the map \(0, 0, 75, 50\)"),
    ]:  # fmt: skip
        with pytest.raises(ValueError, match=message):
            tasks.load("blocked", params).reset()
        with pytest.raises(ValueError, match=message):  # before a benchmark records anything
            check_specs([EpisodeSpec("blocked", "mppi", task_params=params)])
    head_on = {"approach_angle": 0.0, "obstacle_speed": 1.0, "meet_fraction": 0.1}
    with pytest.raises(ValueError, match="touches moving obstacle 0"):
        tasks.load("crossing", head_on).reset()
