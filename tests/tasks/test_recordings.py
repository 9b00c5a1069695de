"""Recorded crowds: reading the four-column files, time, presence, the split and the windows."""

import os
import pathlib

import numpy as np
import pytest

from dcmppi.tasks.replay import recordings, scenes

ROOT = pathlib.Path(__file__).resolve().parents[2]


def crowds():
    """The ETH/UCY folder ($DCMPPI_CROWDS, else ../shared/crowds), or skip saying why."""
    folder = pathlib.Path(os.environ.get(recordings.CROWDS_ENV) or ROOT.parent / "shared/crowds")
    if not (folder / "biwi_eth.txt").is_file():
        pytest.skip(f"the ETH/UCY files are absent ({folder}; set {recordings.CROWDS_ENV})")
    return folder


def walker_file(tmp_path, rows):
    """A four-column file of `rows` (frame, id, x, y)."""
    path = tmp_path / "walk.txt"
    np.savetxt(path, np.array(rows, dtype=float), delimiter="\t")
    return path


def straight(tmp_path, frames=30):
    """Person 1 walks +x at 0.5 m per annotated frame; person 2 stands at (0, 3) for frames
    5..9 only."""
    rows = [(10 * k, 1, 0.5 * k, 0.0) for k in range(frames)]
    rows += [(10 * k, 2, 0.0, 3.0) for k in range(5, 10)]
    return walker_file(tmp_path, rows)


def test_eth_walks_at_a_walking_speed_at_its_own_frame_rate():
    rec = recordings.load("biwi_eth", crowds())
    assert rec.period == pytest.approx(10 / 15)
    speeds = np.concatenate(
        [np.hypot(*np.diff(t.xy, axis=0).T) / np.diff(t.times) for t in rec.tracks]
    )
    assert 1.3 < np.median(speeds) < 1.6  # 1.47 m/s; read at 0.4 s it would be 2.45
    assert recordings.load("biwi_eth", crowds(), period=0.4).period == 0.4


def test_every_standard_file_loads_with_its_period_and_the_split_leaves_one_scene_out():
    folder = crowds()
    for name in recordings.FILES:
        rec = recordings.load(name, folder)
        assert len(rec.tracks) > 100 and rec.period == (0.4 if name != "biwi_eth" else 10 / 15)
    assert [r.name for r in recordings.scene("univ", folder)] == ["students001", "students003"]
    train = recordings.train_files("zara1")
    assert "crowds_zara01" not in train and {"crowds_zara03", "uni_examples"} <= set(train)
    assert len(train) == len(recordings.FILES) - 1


def test_environment_variable_names_the_folder(monkeypatch):
    monkeypatch.setenv(recordings.CROWDS_ENV, str(crowds()))
    assert recordings.load("biwi_hotel").name == "biwi_hotel"


def test_a_missing_folder_is_one_error_line_naming_both_ways(monkeypatch, tmp_path):
    monkeypatch.delenv(recordings.CROWDS_ENV, raising=False)
    with pytest.raises(
        ValueError, match=r"not part of dcmppi: set DCMPPI_CROWDS=DIR, .*folder=DIR"
    ):
        recordings.load("biwi_eth")
    with pytest.raises(ValueError, match=r"^folder=.*nowhere: no such folder.*DCMPPI_CROWDS") as e:
        recordings.scene("eth", tmp_path / "nowhere")
    assert "\n" not in str(e.value)
    with pytest.raises(ValueError, match="no such recording"):
        recordings.load("biwi_ethz", tmp_path)
    with pytest.raises(ValueError, match="unknown scene 'zara4'"):
        recordings.train_files("zara4")


def test_a_malformed_file_names_itself(tmp_path):
    path = tmp_path / "bad.txt"
    path.write_text("0\t1\t2.0\n")
    with pytest.raises(ValueError, match=r"bad\.txt line 1: expected four numbers .* got 3"):
        recordings.load(path)
    path.write_text("0\t1\t2.0\t3.0\n0\t1\t2.0\tx\n")
    with pytest.raises(ValueError, match=r"bad\.txt line 2: 'x' is not a number"):
        recordings.load(path)


def test_positions_interpolate_between_frames_and_people_are_present_while_annotated(tmp_path):
    rec = recordings.load(straight(tmp_path), period=0.4)
    assert rec.name == "walk" and rec.duration == (0.0, 29 * 0.4)
    ids, xy = rec.positions_at(0.3)  # 0.75 of the way from frame 0 to frame 1
    np.testing.assert_array_equal(ids, [1])
    np.testing.assert_allclose(xy, [[0.375, 0.0]])
    ids, xy = rec.positions_at(2.0)  # frame 5: person 2 appears
    np.testing.assert_array_equal(ids, [1, 2])
    np.testing.assert_allclose(xy, [[2.5, 0.0], [0.0, 3.0]])
    assert list(rec.positions_at(3.7)[0]) == [1]  # after person 2's last annotation (3.6 s)
    assert len(rec.positions_at(12.0)[0]) == 0


def test_save_writes_what_load_reads(tmp_path):
    rec = recordings.load(straight(tmp_path), period=0.4)
    recordings.save(rec, tmp_path / "copy.txt")
    again = recordings.load(tmp_path / "copy.txt", period=0.4)
    assert [t.id for t in again.tracks] == [1, 2]
    for a, b in zip(rec.tracks, again.tracks, strict=True):
        np.testing.assert_allclose(a.xy, b.xy)
        np.testing.assert_array_equal(a.frames, b.frames)


def test_windows_are_every_run_of_consecutive_frames_with_the_observed_neighbours(tmp_path):
    rows = [(10 * k, 1, 0.5 * k, 0.0) for k in range(25)]
    rows += [(10 * k, 1, 0.5 * k, 0.0) for k in range(27, 48)]  # a gap: frames 25, 26 missing
    rows += [(10 * k, 2, 0.0, 3.0) for k in range(5, 10)]
    w = recordings.windows(recordings.load(walker_file(tmp_path, rows), period=0.4))
    assert len(w) == (25 - 19) + (21 - 19)  # none spans the gap
    assert w.observed.shape == (8, 8, 2) and w.future.shape == (8, 12, 2)
    np.testing.assert_allclose(w.xy[0, :, 0], 0.5 * np.arange(20))
    np.testing.assert_array_equal(w.frame[:3], [70, 80, 90])
    # person 2 (frames 5..9) is seen by the windows observing frames 0..7 to 5..12 ...
    assert [len(n) for n in w.neighbours] == [1] * 6 + [0] * 2
    np.testing.assert_allclose(w.neighbours[0][0, 5:], [[0.0, 3.0]] * 3)
    assert np.isnan(w.neighbours[0][0, :5]).all()  # ... not annotated before frame 5


def test_standard_window_counts():
    folder = crowds()
    counts = {name: len(recordings.windows(recordings.scene(name, folder))) for name in ["eth"]}
    assert counts == {"eth": 364}


def test_biwi_eth_is_known_by_its_rows_under_another_name(tmp_path):
    copy = tmp_path / "renamed.txt"
    copy.write_bytes((crowds() / "biwi_eth.txt").read_bytes())
    assert recordings.load(copy).period == pytest.approx(10 / 15)
    assert recordings.load(copy, period=0.4).period == 0.4


def test_the_eight_files_are_read_as_before(tmp_path):
    folder = crowds()
    for name in recordings.FILES:
        found = recordings.examine(name, folder)
        assert found.frame_step == 10 and not found.problems and not found.notes, name
        assert found.recording.offset == (0.0, 0.0)
    assert len(scenes.load_scene(scenes.scene_files("eth", folder)).episodes) == 305
