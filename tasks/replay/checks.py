"""A recording file read and checked (plain numpy): its rows, its frame step, and the problems
that refuse it, each one line naming the file, the person, the frame and the fix.

A file holds rows `frame person x y` (whitespace-separated numbers; a line starting with # is a
comment, and a comment `# period P` states the seconds between annotated frames). Checked in
stages, each on rows that passed the ones before: finite numbers; whole frames and ids; no one
annotated twice in a frame; one frame step (each person's frames differ by multiples of it, all
on one grid of frames); speeds between consecutive annotations of at most max_speed. A person
absent for longer than max_gap is read as two people, and a recording whose centre lies more
than FAR from the origin is moved to it (notes say so), so that results do not depend on where
its origin lies.
"""

import dataclasses
import io
import re
import warnings

import numpy as np

MAX_SPEED = 8.0  # [m/s] between consecutive annotations (biwi_eth read at 0.4 s peaks at 6.5)
MAX_GAP = 4.0  # [s] a person absent for longer is read as two people
FAR = 100.0  # [m] a recording whose centre is farther from the origin is moved to it
WALKING = (0.3, 2.5)  # [m/s] a median speed outside this range gets a note on the period
LISTED = 5  # problems of one kind listed before "... and N more"
_STATED = re.compile(r"#\s*period\s+(\S+)")


@dataclasses.dataclass(frozen=True)
class Rows:
    """A file's rows: frame, id (R,), xy (R, 2), line (R,) their line numbers; period [s] the
    file states in a `# period P` comment (None: none)."""

    frame: np.ndarray
    id: np.ndarray
    xy: np.ndarray
    line: np.ndarray
    period: float | None


@dataclasses.dataclass(frozen=True)
class People:
    """Checked rows by person, split at long absences: ids (T,), and per person frames (n,),
    times (n,) [s] and xy (n, 2) [m], moved by -offset (2,) where the recording was far away;
    speeds [m/s] between consecutive annotations of a person; notes: what reading did (splits,
    the move)."""

    ids: tuple
    frames: tuple
    times: tuple
    xy: tuple
    offset: np.ndarray
    speeds: np.ndarray
    notes: tuple


def read(path) -> Rows:
    """The rows of the file at `path`; a ValueError of one line naming the file (and the line)
    when it is not text, empty, or not four numbers a row."""
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except UnicodeDecodeError:
        raise ValueError(f"{path}: not a text file of rows frame, id, x, y") from None
    lines = text.splitlines()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numpy's on a file without data: said below
            rows = np.loadtxt(io.StringIO(text), ndmin=2)
    except ValueError:
        rows = None
    if rows is not None and rows.shape[1:] == (4,) and len(lines) == len(rows):
        return Rows(rows[:, 0], rows[:, 1], rows[:, 2:4], np.arange(1, len(rows) + 1), None)
    numbered = [(n, line.strip()) for n, line in enumerate(lines, 1) if line.strip()]
    data = [(n, line) for n, line in numbered if not line.startswith("#")]
    if not data:
        raise ValueError(f"{path}: the file is empty; a recording has rows frame, id, x, y")
    if rows is None or rows.shape != (len(data), 4):
        raise ValueError(_bad_line(path, data))
    stated = None
    for n, line in numbered:
        match = _STATED.fullmatch(line.removesuffix(" s"))
        if match:
            stated = _seconds(match.group(1))
            if stated is None:
                raise ValueError(f"{path} line {n}: {line!r}: a period is a number of seconds > 0")
    return Rows(rows[:, 0], rows[:, 1], rows[:, 2:4], np.array([n for n, _ in data]), stated)


def _seconds(text):
    try:
        value = float(text)
    except ValueError:
        return None
    return value if np.isfinite(value) and value > 0 else None


def _bad_line(path, data) -> str:
    """The message on the first line of `data` that is not four numbers."""
    for n, line in data:
        parts = line.split()
        if len(parts) != 4:
            return (
                f"{path} line {n}: expected four numbers frame, id, x, y; got {len(parts)} "
                f"({line[:40]!r})"
            )
        for part in parts:
            if not _number(part):
                return (
                    f"{path} line {n}: {part[:20]!r} is not a number (rows are frame, id, x, y; "
                    "start a header line with #)"
                )
    return f"{path}: not a four-column file frame, id, x, y"


def _number(text) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def check(path, rows, frame_step, default_step) -> tuple:
    """(frame step, problems) of `rows`: the problems that refuse the file, one line each
    (module docstring), of the first stage that finds any; the frame step is frame_step, else
    the most common difference between consecutive frames of one person (`default_step` where
    no one is annotated twice; None while an earlier stage finds problems)."""
    for stage in (_finite, _whole, _twice):
        found = stage(path, rows)
        if found:
            return None, found
    step = float(frame_step) if frame_step is not None else _common_step(rows, default_step)
    return step, _steps(path, rows, step, frame_step is None)


def _listed(found, kind) -> list:
    """At most LISTED of `found`, and a line counting the rest."""
    more = len(found) - LISTED
    return found[:LISTED] + ([f"... and {more} more {kind}"] if more > 0 else [])


def _row(rows, i) -> str:
    return (
        f"frame {rows.frame[i]:g}, person {rows.id[i]:g}, x {rows.xy[i, 0]:g}, y {rows.xy[i, 1]:g}"
    )


def _finite(path, rows):
    values = np.column_stack([rows.frame, rows.id, rows.xy])
    found = [
        f"{path} line {rows.line[i]}: {_row(rows, i)} holds NaN or inf; fix or delete the row"
        for i in np.flatnonzero(~np.isfinite(values).all(axis=1))
    ]
    return _listed(found, "rows with NaN or inf")


def _whole(path, rows):
    found = []
    for i in np.flatnonzero((rows.frame != np.round(rows.frame)) | (rows.id != np.round(rows.id))):
        what = "person id" if rows.id[i] != np.round(rows.id[i]) else "frame"
        found.append(
            f"{path} line {rows.line[i]}: {_row(rows, i)}: the {what} is not a whole number; "
            "number frames and people by whole numbers"
        )
    return _listed(found, "rows with a fraction")


def _by_person(rows) -> tuple:
    """The rows' order by person, then frame: order (R,), and frame, id in that order."""
    order = np.lexsort((rows.frame, rows.id))
    return order, rows.frame[order], rows.id[order]


def _twice(path, rows):
    order, f, p = _by_person(rows)
    found = [
        f"{path}: person {p[i]:g} is annotated twice in frame {f[i]:g} (lines "
        f"{rows.line[order[i]]} and {rows.line[order[i + 1]]}); delete one"
        for i in np.flatnonzero((np.diff(f) == 0) & (np.diff(p) == 0))
    ]
    return _listed(found, "duplicate rows")


def _common_step(rows, default) -> float:
    _, f, p = _by_person(rows)
    steps = np.diff(f)[np.diff(p) == 0]
    if not len(steps):
        return float(default)
    values, counts = np.unique(steps, return_counts=True)
    return float(values[np.argmax(counts)])


def _steps(path, rows, step, inferred):
    _, f, p = _by_person(rows)
    within = np.flatnonzero(np.diff(p) == 0)
    how = f"the file steps by {step:g} frames" + (" (its most common step)" if inferred else "")
    found, seen = [], set()
    for i in within[np.diff(f)[within] % step != 0]:
        if p[i] not in seen:
            seen.add(p[i])
            found.append(
                f"{path}: person {p[i]:g} steps from frame {f[i]:g} to {f[i + 1]:g}, where {how}: "
                "mixed frame steps; resample the file to one step"
            )
    first = f.min()
    for i in np.flatnonzero((f - first) % step != 0):
        if p[i] not in seen:
            seen.add(p[i])
            found.append(
                f"{path}: person {p[i]:g} is annotated at frame {f[i]:g}, off the frames of the "
                f"file (every {step:g} from frame {first:g}); resample the file to one grid"
            )
    return _listed(found, "people off the frame step")


def people(path, rows, step, period, max_speed, max_gap) -> tuple:
    """(People, problems) of checked rows read at `period` [s] a frame step: a person split where
    absent for longer than max_gap [s], speeds above max_speed [m/s] refused, the recording
    moved to the origin when farther than FAR (module docstring)."""
    order, frame, pid = _by_person(rows)
    xy, line = rows.xy[order], rows.line[order]
    times = frame / step * period
    apart = np.diff(pid) != 0
    split = ~apart & (np.diff(times) > max_gap)
    ids, notes, fresh = pid.astype(int), [], int(pid.max()) + 1
    for i in np.flatnonzero(split):
        notes.append(
            f"{path}: person {ids[i]} is absent for {times[i + 1] - times[i]:.3g} s after frame "
            f"{frame[i]:g} (more than max_gap={max_gap:g} s): read as two people, from frame "
            f"{frame[i + 1]:g} as person {fresh}"
        )
        ids[i + 1 :][pid[i + 1 :] == pid[i]] = fresh  # this person's later rows: a new one
        fresh += 1
    within = ~(apart | split)
    speed = np.zeros(len(within))
    speed[within] = np.hypot(*np.diff(xy, axis=0)[within].T) / np.diff(times)[within]
    found = _too_fast(path, (frame, xy, times, line, ids), within, speed, max_speed)
    notes = _listed(notes, "people split")
    offset = np.zeros(2)
    centre = (xy.min(axis=0) + xy.max(axis=0)) / 2
    if np.hypot(*centre) > FAR and not found:
        offset = np.round(centre)
        notes.append(
            f"{path}: its people are {np.hypot(*centre):.3g} m from the origin: moved by "
            f"({-offset[0]:g}, {-offset[1]:g}) m, so that results do not depend on where its "
            "origin lies"
        )
    moved = xy - offset if offset.any() else xy
    parts = np.split(np.arange(len(frame)), np.flatnonzero(~within) + 1)
    columns = (tuple(a[p] for p in parts) for a in (frame, times, moved))
    ids = tuple(int(ids[p[0]]) for p in parts)
    return People(ids, *columns, offset, speed[within], tuple(notes)), found


def _too_fast(path, columns, within, speed, max_speed) -> list:
    """The problems of speeds (R - 1,) above max_speed between consecutive annotations of one
    person (`within`): all of them (the period is wrong) or each person's first (a jump out
    and back: one row)."""
    frame, xy, times, line, ids = columns
    if within.any() and np.median(speed[within]) > max_speed:
        return [
            f"{path}: its people move at a median {np.median(speed[within]):.3g} m/s, above "
            f"max_speed={max_speed:g} m/s: pass the seconds between its annotated frames as "
            "period=SECONDS"
        ]
    found, seen = [], set()
    for a in np.flatnonzero(within & (speed > max_speed)):
        if ids[a] in seen:
            continue
        seen.add(ids[a])
        b = a + 1
        at = f"frame {frame[b]:g} (line {line[b]})"
        c = a + 2
        back = c < len(frame) and within[b] and speed[b] > max_speed
        if back and np.hypot(*(xy[c] - xy[a])) / (times[c] - times[a]) <= max_speed:
            found.append(
                f"{path}: person {ids[a]} jumps to ({xy[b, 0]:g}, {xy[b, 1]:g}) at {at} and "
                f"back, at {speed[a]:.3g} m/s: fix or delete that row"
            )
        else:
            found.append(
                f"{path}: person {ids[a]} moves at {speed[a]:.3g} m/s from frame {frame[a]:g} "
                f"to {at}, above max_speed={max_speed:g} m/s: fix the positions, or pass "
                "max_speed=M_PER_S if people run that fast"
            )
    return _listed(found, "people too fast")


def walking_note(path, speeds, period) -> list:
    """A note where the median of `speeds` [m/s] is outside WALKING: is the period right?"""
    if not len(speeds):
        return []
    median = float(np.median(speeds))
    if WALKING[0] <= median <= WALKING[1]:
        return []
    return [
        f"{path}: its people walk at a median {median:.3g} m/s at {period:.4g} s a step, outside "
        f"{WALKING[0]:g}-{WALKING[1]:g} m/s: is period={period:.4g} right?"
    ]
