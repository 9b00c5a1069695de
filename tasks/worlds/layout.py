"""`layout`: obstacles, start and goal from a file (CSV or JSON), e.g. any BARN world.

CSV: one cylinder per line, columns `x,y,radius` or `world,x,y,radius` (the BARN file's
format); an optional header line names the columns; blank lines and lines starting with `#`
are skipped. JSON: {"cylinders": [[x, y, radius], ...], "start": [x, y, yaw],
"goal": [x, y], "map_bounds": [xmin, ymin, xmax, ymax], "time_limit": seconds}, all keys but
"cylinders" optional. Task kwargs override what the file says. Files are UTF-8 (a byte-order
mark, as Excel writes, is skipped); coordinates and radii are at most MAX_COORDINATE in size.

A layout no controller could drive is refused when the task is built, naming the file and line
of the cause: a start or goal outside the map, a robot touching a cylinder at its start, a goal
inside a cylinder (`base.impossible`).

BARN (Perille et al. 2020, MIT licence): pass world=N (0-299). Start, goal and time limit then
default to the challenge's protocol (BARN_START, BARN_GOAL, BARN_TIME_LIMIT) and the task gives
the `optimal_time` of BARN's navigation score (`barn`). The BARN file is not part of
dcmppi: it is `path`, else the file that $DCMPPI_BARN names.
"""

import csv
import dataclasses
import functools
import json
import math
import os
import pathlib

import numpy as np

from ..navigation import Navigation
from . import barn
from .base import MAX_COORDINATE, impossible, make_world

BARN_START = (-2.25, 3.0, math.pi / 2)
BARN_GOAL = (-2.25, 13.0)
BARN_TIME_LIMIT = 100.0
BARN_TOP_SPEED = 2.0  # [m/s] Clearpath Jackal; the challenge's optimal_time = length / 2 m/s
BARN_ENV = "DCMPPI_BARN"  # environment variable naming the BARN file
BOUNDS_MARGIN = 2.0  # [m] added around cylinders, start and goal when no bounds are given


@dataclasses.dataclass(frozen=True)
class LayoutFile:
    """What a layout file holds: cylinders (K, 3) and optional start, goal, bounds, limit;
    `lines` (K,) the line of each cylinder, `where` {key: line} of start, goal, map_bounds."""

    cylinders: np.ndarray
    start: tuple | None = None
    goal: tuple | None = None
    map_bounds: tuple | None = None
    time_limit: float | None = None
    lines: tuple = ()
    where: dict = dataclasses.field(default_factory=dict)


def barn_path() -> pathlib.Path:
    """The BARN cylinder file that $DCMPPI_BARN names.

    Raises:
      ValueError: naming both ways to give the file when the variable is not set.
    """
    fix = f"pass path=FILE (dcmppi run, bench: --task-param path=FILE) or set {BARN_ENV}=FILE"
    if not os.environ.get(BARN_ENV):
        raise ValueError(
            f"layout world=N needs the BARN file barn_cylinders.csv, not part of dcmppi: {fix}"
        )
    path = pathlib.Path(os.environ[BARN_ENV])
    if not path.is_file():
        raise ValueError(f"{BARN_ENV}={path}: no such file; {fix}")
    return path


def read_layout(path, world=None) -> LayoutFile:
    """Reads a CSV or JSON layout; `world` selects one world of a multi-world CSV.

    Raises:
      ValueError: naming the file, the line and the problem, for any malformed content.
    """
    path = pathlib.Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except OSError as e:
        raise ValueError(f"{path}: cannot read layout file ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise ValueError(f"{path}: not a UTF-8 text file ({e.reason} at byte {e.start})") from None
    if path.suffix.lower() == ".json":
        if world is not None:
            raise ValueError(
                f"{path}: world= selects a world of a multi-world CSV; "
                "a JSON layout holds one world"
            )
        return _read_json(path, text)
    columns, data, lines = _parse_csv(str(path), text)
    if columns[0] != "world":
        if world is not None:
            raise ValueError(f"{path}: world={world} given but the file has no 'world' column")
        return LayoutFile(data, lines=tuple(lines))
    if world is None:
        raise ValueError(
            f"{path}: the file holds several worlds; pass world=N "
            f"({int(data[:, 0].min())}..{int(data[:, 0].max())})"
        )
    mine = data[:, 0] == world
    chosen = data[mine, 1:]
    if not len(chosen):
        raise ValueError(
            f"{path}: no cylinders for world {world}; the file has worlds "
            f"{int(data[:, 0].min())}..{int(data[:, 0].max())}"
        )
    return LayoutFile(chosen, lines=tuple(lines[mine]))


@functools.lru_cache(maxsize=4)
def _parse_csv(path, text):
    """Column names, rows (read-only array) and the line of each row (array) of a CSV layout;
    cached (BARN is 79k lines)."""
    columns, rows, lines = None, [], []
    for lineno, row in enumerate(csv.reader(text.splitlines()), start=1):
        cells = [c.strip() for c in row]
        if not any(cells) or cells[0].startswith("#"):
            continue
        if columns is None and not _is_number(cells[0]):
            columns = [c.lower() for c in cells]
            if columns not in (["x", "y", "radius"], ["world", "x", "y", "radius"]):
                raise ValueError(
                    f"{path}:{lineno}: header must be 'x,y,radius' or "
                    f"'world,x,y,radius', got {','.join(cells)!r}"
                )
            continue
        if columns is None:
            columns = ["x", "y", "radius"] if len(cells) == 3 else ["world", "x", "y", "radius"]
        if len(cells) != len(columns):
            raise ValueError(
                f"{path}:{lineno}: expected {len(columns)} values "
                f"({','.join(columns)}), got {len(cells)}"
            )
        values = []
        for name, cell in zip(columns, cells, strict=True):
            if not _is_number(cell) or not math.isfinite(float(cell)):
                raise ValueError(f"{path}:{lineno}: {name} must be a finite number, got {cell!r}")
            if abs(float(cell)) > MAX_COORDINATE:
                raise ValueError(f"{path}:{lineno}: {name} {_TOO_BIG}, got {cell}")
            values.append(float(cell))
        if values[-1] <= 0:
            raise ValueError(f"{path}:{lineno}: radius must be > 0, got {cells[-1]}")
        rows.append(values)
        lines.append(lineno)
    if not rows:
        raise ValueError(f"{path}: no cylinders in the file")
    data, lines = np.array(rows), np.array(lines)
    data.flags.writeable = lines.flags.writeable = False
    return columns, data, lines


_TOO_BIG = f"must be within {MAX_COORDINATE:.0e} m of 0 (the planners' range)"


def _read_json(path, text):
    try:
        spec = json.loads(text)
    except json.JSONDecodeError as e:
        raise ValueError(f"{path}:{e.lineno}: invalid JSON ({e.msg}, column {e.colno})") from None
    if not isinstance(spec, dict) or "cylinders" not in spec:
        raise ValueError(f"{path}:1: expected an object with a 'cylinders' list")
    unknown = set(spec) - {"cylinders", "start", "goal", "map_bounds", "time_limit"}
    if unknown:
        raise ValueError(f"{path}: unknown keys {sorted(unknown)}")
    lines = text.splitlines()
    cylinders, cylinder_lines = [], []
    for i, item in enumerate(spec["cylinders"] if isinstance(spec["cylinders"], list) else [None]):
        line = _line_of(lines, i)
        where = f"{path}:{line}: cylinders[{i}]"
        if not _numbers(item, 3):
            raise ValueError(f"{where} must be [x, y, radius] numbers, got {item!r}")
        if item[2] <= 0:
            raise ValueError(f"{where}: radius must be > 0, got {item[2]}")
        if max(abs(v) for v in item) > MAX_COORDINATE:
            raise ValueError(f"{where}: each value {_TOO_BIG}, got {item!r}")
        cylinders.append(item)
        cylinder_lines.append(line)
    if not cylinders:
        raise ValueError(f"{path}: no cylinders in the file")
    out, where = {}, {}
    for key, size in (("start", 3), ("goal", 2), ("map_bounds", 4), ("time_limit", None)):
        if key in spec:
            value = spec[key]
            line = next((n for n, t in enumerate(lines, 1) if f'"{key}"' in t), None)
            at = f"{path}:{line}" if line else str(path)
            ok = _numbers([value], 1) and value > 0 if size is None else _numbers(value, size)
            if not ok:
                raise ValueError(
                    f"{at}: {key} must be "
                    f"{'a positive number' if size is None else f'{size} numbers'}, "
                    f"got {value!r}"
                )
            if size is not None and max(abs(v) for v in value) > MAX_COORDINATE:
                raise ValueError(f"{at}: {key}: each value {_TOO_BIG}, got {value!r}")
            out[key] = value if size is None else tuple(float(v) for v in value)
            where[key] = line
    cylinders = np.array(cylinders, dtype=np.float64)
    return LayoutFile(cylinders, **out, lines=tuple(cylinder_lines), where=where)


def _line_of(lines, index):
    """Best-effort line number of the index-th [x, y, r] entry of "cylinders"."""
    count = -1
    for lineno, line in enumerate(lines, start=1):
        count += line.count("[") - (1 if '"cylinders"' in line else 0)
        if count >= index:
            return lineno
    return len(lines)


def _is_number(text):
    try:
        float(text)
    except ValueError:
        return False
    return True


def _numbers(value, size):
    return (
        isinstance(value, (list, tuple))
        and len(value) == size
        and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
            for v in value
        )
    )


class Layout(Navigation):
    """A fixed world read from a layout file (the same world every episode; noise still random).

    Args:
      path: CSV or JSON layout file (see the module docstring); default: the BARN file
        ($DCMPPI_BARN).
      world: BARN world index (0-299) for multi-world CSVs.
      start: (x, y, yaw); goal: (x, y); map_bounds: (xmin, ymin, xmax, ymax): override the file.
    """

    def __init__(self, path=None, world=None, start=None, goal=None, map_bounds=None, **kwargs):
        super().__init__(**kwargs)
        if world is not None and (not isinstance(world, int) or isinstance(world, bool)):
            raise ValueError(f"world must be an int (a BARN world index), got {world!r}")
        if path is None and world is None:
            raise ValueError("layout needs path=<CSV or JSON file> or world=<BARN world index>")
        path = barn_path() if path is None else pathlib.Path(path)
        layout = read_layout(path, world)
        is_barn = world is not None
        origin = {}  # where each of start, goal, map_bounds came from, for the errors below
        start = _pick("start", 3, origin, start, (path, layout), BARN_START if is_barn else None)
        goal = _pick("goal", 2, origin, goal, (path, layout), BARN_GOAL if is_barn else None)
        if start is None or goal is None:
            raise ValueError(
                "layout: pass start=(x, y, yaw) and goal=(x, y) in task_kwargs, or "
                "put them in a JSON layout file"
            )
        bounds = _pick("map_bounds", 4, origin, map_bounds, (path, layout), None)
        if bounds is None:
            points = np.vstack(
                [
                    layout.cylinders[:, :2] - layout.cylinders[:, 2:],
                    layout.cylinders[:, :2] + layout.cylinders[:, 2:],
                    [start[:2], goal],
                ]
            )
            bounds = (*(points.min(axis=0) - BOUNDS_MARGIN), *(points.max(axis=0) + BOUNDS_MARGIN))
        bounds = np.array(bounds)
        if not (bounds[:2] < bounds[2:]).all():
            raise ValueError(
                f"map_bounds must be (xmin, ymin, xmax, ymax) with min < max, got {tuple(bounds)}"
            )
        if self._time_limit is None:
            self._time_limit = layout.time_limit or (BARN_TIME_LIMIT if is_barn else None)
        self._world = make_world(start, goal, static=layout.cylinders, bounds=bounds)
        _check_possible(self._world, self.robot_radius, path, layout, origin)
        self.num_static = len(self._world.static)
        self._bounds = bounds
        self._barn = is_barn

    @property
    def optimal_time(self) -> float | None:
        """BARN's optimal time [s] of a BARN world: the shortest collision-free path length for
        this robot radius (`barn`, planned once per world and process) over the Jackal's
        top speed BARN_TOP_SPEED, as the challenge divides by 2 m/s whatever speed a robot
        runs at. None for other layouts and for a world with no path for this radius."""
        if not self._barn:
            return None
        w = self._world
        length = barn.shortest_path_length(
            w.static, self.robot_radius, w.start[:2], w.goal, w.map_bounds
        )
        return length / BARN_TOP_SPEED if math.isfinite(length) else None

    @property
    def map_bounds(self):
        return self._bounds

    def generate_world(self, random):
        return self._world


def _pick(name, size, origin, given, file, default):
    """The first of the task parameter `given`, the layout file's value (file = (path,
    LayoutFile)) and `default` that is set, checked to be `size` finite numbers within
    MAX_COORDINATE; origin[name] says where it came from (for `_check_possible`)."""
    path, layout = file
    in_file = getattr(layout, name)
    if given is not None:
        value, origin[name] = given, f"task parameter {name}"
    elif in_file is not None:
        line = layout.where.get(name)
        value, origin[name] = in_file, f"{path}:{line}" if line else str(path)
    elif default is not None:
        value, origin[name] = default, f"the BARN {name}"
    else:
        return None
    try:
        value = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be {size} numbers, got {value!r}") from None
    if len(value) != size or not all(math.isfinite(v) for v in value):
        raise ValueError(f"{name} must be {size} finite numbers, got {value!r}")
    if max(abs(v) for v in value) > MAX_COORDINATE:
        raise ValueError(f"{name}: each value {_TOO_BIG}, got {value!r}")
    return value


def _check_possible(world, robot_radius, path, layout, origin):
    """ValueError naming the file and line of the cause if no controller could drive `world`
    (`base.impossible`): the cylinder's line, else where the start, goal or bounds came
    from."""
    problem = impossible(world, robot_radius)
    if problem is None:
        return
    reason, row = problem
    if row is not None:
        at = f"{path}:{layout.lines[row]}" if layout.lines else str(path)
    else:
        at = str(path)
    names = [n for n in ("start", "goal", "map_bounds") if n in origin]
    from_ = "; ".join(f"{n} from {origin[n]}" for n in names)
    raise ValueError(
        f"{at}: impossible layout: {reason} ({from_}); move the cylinder, the start or the goal"
    )
