"""Recorded crowds from any source, checked when they load: the frame step inferred, the period
given, stated or known, each damaged file refused in one line naming the file, the person, the
frame and the fix, long absences split, far recordings moved to the origin."""

import numpy as np
import pytest

from dcmppi import tasks
from dcmppi.tasks.replay import recordings, scenes, tracks


def walk(step=10, frames=30, speed=1.2, period=0.4):
    """Rows of three people walking at `speed` [m/s] a frame step of `step` video frames apart
    (one step: `period` s): 1 along +x, 2 along -x 1 m beside, 3 across, from frame 5 steps on."""
    rows = []
    d = speed * period
    for k in range(frames):
        rows.append((step * k, 1, d * k, 0.0))
        rows.append((step * k, 2, d * (frames - k), 1.0))
        if k >= 5:
            rows.append((step * k, 3, 4.0, 3.0 - d * (k - 5)))
    return np.array(rows, float)


def write(tmp_path, rows, name="walk.txt", header=""):
    path = tmp_path / name
    np.savetxt(path, rows, delimiter="\t", fmt="%.10g", header=header, comments="")
    return path


def test_frame_steps_of_1_10_and_12_read_as_one_period_each(tmp_path):
    read = {s: recordings.load(write(tmp_path, walk(s), f"s{s}.txt")) for s in (1, 10, 12)}
    for step, rec in read.items():
        assert rec.frame_step == step and rec.period == recordings.PERIOD
        speeds = np.hypot(*np.diff(rec.tracks[0].xy, axis=0).T) / np.diff(rec.tracks[0].times)
        np.testing.assert_allclose(speeds, 1.2)  # 1.2 m/s: not 10 x or 0.83 x as fast
        np.testing.assert_allclose(rec.tracks[2].times, read[10].tracks[2].times)
    assert len({len(recordings.windows(r)) for r in read.values()}) == 1
    # given: one annotated step of 12 frames read as 2 steps of 6, at 0.8 s
    slow = recordings.load(tmp_path / "s12.txt", frame_step=6)
    assert slow.frame_step == 6 and slow.tracks[0].times[1] == pytest.approx(0.8)
    # the replay task plays them at the same speed: the same time limit and top speed
    envs = [
        tasks.load("replay", {"scene": str(tmp_path / f"s{s}.txt"), "episode": 0}) for s in (1, 12)
    ]
    assert envs[0].task.time_limit == envs[1].task.time_limit == pytest.approx(2 * 29 * 0.4)
    assert envs[0].task.agent.v_max == envs[1].task.agent.v_max == 1.5


def test_the_period_is_given_stated_in_the_file_or_known(tmp_path):
    rows = walk(10, speed=0.6)
    stated = write(tmp_path, rows, "stated.txt", header="# period 0.8\n")
    assert recordings.load(stated).period == 0.8
    assert recordings.load(write(tmp_path, rows, "plain.txt")).period == recordings.PERIOD
    assert recordings.load(tmp_path / "plain.txt", period=0.8).period == 0.8
    with pytest.raises(ValueError, match=r"stated.txt: the file states 0.8 s .* pass period=0.8"):
        recordings.load(stated, period=0.4)
    # save writes the period that load reads back, and the frame step asked for
    rec = recordings.load(stated)
    recordings.save(rec, tmp_path / "copy.txt", frame_step=1)
    again = recordings.load(tmp_path / "copy.txt")
    assert again.period == 0.8 and again.frame_step == 1
    np.testing.assert_allclose(again.tracks[1].times, rec.tracks[1].times)
    # a replay of a file that states its period walks at the file's speed
    env = tasks.load("replay", {"scene": str(stated), "episode": 0})
    assert env.task.time_limit == pytest.approx(2 * 29 * 0.8)


def one_line(path, **reading):
    """The message of the ValueError that loading `path` raises (one line)."""
    with pytest.raises(ValueError) as error:
        recordings.load(path, **reading)
    message = str(error.value)
    assert "\n" not in message and str(path) in message
    return message


def damaged(rows, row, column, value):
    rows = rows.copy()
    rows[row, column] = value
    return rows


def shifted(rows, person, frames):
    rows = rows.copy()
    rows[rows[:, 1] == person, 0] += frames
    return rows


W = walk()  # rows in the order frame 0: 1, 2; frame 10: 1, 2; ... frame 50: 1, 2, 3; ...
CASES = {
    "nan": (damaged(W, 4, 3, np.nan), r"line 5: frame 20, person 1, x 0.96, y nan holds NaN"),
    "inf": (damaged(W, 5, 2, np.inf), r"line 6: frame 20, person 2, x inf, .* holds NaN or inf"),
    "id": (damaged(W, 3, 1, 2.5), r"line 4: .*person 2.5.*: the person id is not a whole number"),
    "frame": (damaged(W, 3, 0, 12.5), r"line 4: frame 12.5, .*: the frame is not a whole number"),
    "twice": (np.vstack([W, W[2]]), r"person 1 is annotated twice in frame 10 \(lines 3 and 86\)"),
    "mixed": (damaged(W, 4, 0, 26), r"person 1 steps from frame 10 to 26, where the file steps by"),
    "grid": (shifted(W, 3, 5), r"person 3 is annotated at frame 55, off the frames of the file"),
    "jump": (damaged(W, 8, 2, 1e6), r"person 1 jumps to \(1e\+06, 0\) at frame 40 \(line 9\) and"),
    "fast": (damaged(W, 0, 2, -30), r"person 1 moves at 76.2 m/s from frame 0 to frame 10 \(line"),
}


@pytest.mark.parametrize("case", CASES)
def test_each_damaged_file_is_one_line_naming_the_file_the_person_and_the_frame(tmp_path, case):
    rows, match = CASES[case]
    assert pytest.raises(ValueError, recordings.load, write(tmp_path, rows)).match(match)
    one_line(tmp_path / "walk.txt")


def test_foreign_and_broken_text_is_one_line_each(tmp_path):
    cases = {
        "": r"the file is empty",
        "# period 0.4\n\n": r"the file is empty",
        "frame id x y\n0 1 0 0\n": r"line 1: 'frame' is not a number .*start a header line with #",
        "0 1 0.0\n": r"line 1: expected four numbers frame, id, x, y; got 3",
        "# period soon\n0 1 0 0\n": r"line 1: '# period soon': a period is a number of seconds",
        "\x89PNG\x00\xff": "not a text file",
    }
    for text, match in cases.items():
        path = tmp_path / "bad.txt"
        path.write_bytes(text.encode("latin-1"))
        assert pytest.raises(ValueError, recordings.load, path).match(match), text
        one_line(path)


def test_a_wrong_period_or_speed_bound_names_the_argument(tmp_path):
    path = write(tmp_path, walk(1))
    message = one_line(path, period=0.04)
    assert "a median 12 m/s, above max_speed=8 m/s" in message and "period=SECONDS" in message
    assert recordings.load(path, max_speed=1.5).period == recordings.PERIOD
    fast = damaged(W, 0, 2, -30)
    assert len(recordings.load(write(tmp_path, fast), max_speed=100).tracks) == 3
    for argument in ("period", "frame_step", "max_speed", "max_gap"):
        with pytest.raises(ValueError, match=f"^{argument} must be"):
            recordings.load(path, **{argument: -1})


def test_a_long_absence_splits_a_person_in_two_and_says_so(tmp_path):
    later = walk()[walk()[:, 1] == 1]
    later[:, 0] += 2670  # person 1 again 95.2 s (238 steps) after their last frame, elsewhere
    later[:, 3] += 5.0
    path = write(tmp_path, np.vstack([walk(), later]))
    found = recordings.examine(path)
    assert [t.id for t in found.recording.tracks] == [1, 2, 3, 4]
    assert found.recording.tracks[3].frames[0] == 2670
    (note,) = found.notes
    assert f"{path}: person 1 is absent for 95.2 s after frame 290" in note
    assert "read as two people, from frame 2670 as person 4" in note
    assert len(recordings.load(path, max_gap=100).tracks) == 3  # one person again


def test_a_far_recording_is_moved_to_the_origin_and_replays_alike(tmp_path):
    near = write(tmp_path, walk())
    far_rows = walk()
    far_rows[:, 2:] += [3e5, -2e5]
    (tmp_path / "far").mkdir()
    far = write(tmp_path / "far", far_rows)  # the same name: the same order of episodes
    found = recordings.examine(far)
    assert found.recording.offset == (300007.0, -200003.0)  # the centre, whole metres
    assert "3.61e+05 m from the origin: moved by (-300007, 200003) m" in found.notes[0]
    a, b = recordings.load(near), found.recording
    for s, t in zip(a.tracks, b.tracks, strict=True):
        np.testing.assert_allclose(t.xy + b.offset, s.xy + [3e5, -2e5], rtol=0, atol=1e-9)
    assert recordings.load(near).offset == (0.0, 0.0)  # near the origin: not moved
    recordings.save(b, tmp_path / "back.txt")  # where the file had them
    np.testing.assert_allclose(recordings.load(tmp_path / "back.txt").tracks[0].xy, b.tracks[0].xy)
    # the replay of either has the same episodes, its people shifted by whole metres
    pair = [scenes.load_scene([path]) for path in (near, far)]
    assert pair[0].episodes == pair[1].episodes
    moved = pair[1].recordings[0].tracks[0].xy + b.offset - [3e5, -2e5]
    np.testing.assert_allclose(moved, pair[0].recordings[0].tracks[0].xy, rtol=0, atol=1e-9)


def test_a_person_faster_than_the_goal_region_per_control_step_has_a_reference(tmp_path):
    path = write(tmp_path, walk(speed=20.0))  # 8 m a frame: 18.6 m/s at 0.43 s
    reference = tracks.human(recordings.load(path, period=0.43, max_speed=20), 0)
    assert reference.time_to_goal == pytest.approx(12.5)  # the instant after the last, 12.47 s
    assert reference.path_length == pytest.approx(8.0 * 29)
