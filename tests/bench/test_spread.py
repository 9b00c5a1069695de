"""`dcmppi crowds spread`: constant velocity's error in recordings by observed speed."""

import json

import numpy as np

from dcmppi import cli
from dcmppi.bench.crowds import spread
from dcmppi.tasks.replay.recordings import Recording, Track


def _track(i, xy, period=0.4):
    n = len(xy)
    return Track(i, np.arange(n) * 10, np.arange(n) * period, np.asarray(xy, dtype=float))


def _recording():
    t = np.arange(30) * 0.4
    standing = np.zeros((30, 2))
    straight = np.column_stack([1.2 * t, np.zeros(30)])  # 1.2 m/s, never errs
    turning = np.column_stack([np.where(t < 4, 0.8 * t, 3.2), np.where(t < 4, 0, 0.8 * (t - 4))])
    tracks = (_track(0, standing), _track(1, straight), _track(2, turning))
    return Recording("synthetic", 0.4, tracks)


def test_the_error_is_the_constant_velocity_formula_by_speed_bin():
    speed, error = spread.velocity_errors(_recording(), (1.2, 2.4))
    assert speed.shape == (87,) and error.shape == (87, 2, 2)
    # annotation k = 8 of the turning walker: at (2.56, 0) with v = (0.8, 0) at t = 3.2 s; 1.2 s
    # later it is at (3.2, 0.32) (turned at 4 s), not at (3.52, 0)
    np.testing.assert_allclose(error[58 + 7, 0], (np.array([3.2, 0.32]) - [3.52, 0.0]) / 1.2)
    assert np.isnan(error[28, 0]).all()  # the standing track's last annotation: no future
    rows = spread.by_speed([_recording()], (1.2, 2.4), (0.0, 0.5, 1.0))
    still, slow, fast = rows
    assert still["spread"] == [0.0, 0.0] and still["samples"][0] == 26  # annotations 1-26
    assert fast["low"] == 1.0 and fast["high"] is None and max(fast["spread"]) < 1e-12
    assert slow["spread"][0] > 0.1 and slow["high"] == 1.0  # the turning walker at 0.8 m/s
    assert "| 0-0.5 | 23 | 0.00 | 0.00 |" in spread.table(rows, (1.2, 2.4))


def test_the_command_prints_the_rows(tmp_path, capsys):
    path = tmp_path / "walkers.txt"
    rows = [f"{10 * k} 1 {0.4 * k:.3f} 0.0" for k in range(20)]
    path.write_text("\n".join(rows + [f"{10 * k} 2 3.0 1.0" for k in range(20)]) + "\n")
    assert cli.main(["crowds", "spread", str(path), "--json"]) == 0
    found = json.loads(capsys.readouterr().out)
    assert [r["low"] for r in found] == list(spread.SPEED_BINS)
    assert found[0]["samples"][0] > 0 and found[0]["spread"][0] == 0.0  # the one standing


def test_a_file_it_cannot_read_is_one_line_naming_the_flag(tmp_path, capsys):
    fast = tmp_path / "fast.txt"  # 100 m between frames 0.4 s apart: another period
    fast.write_text("".join(f"{10 * k} 1 {100.0 * k} 0.0\n" for k in range(5)))
    assert cli.main(["crowds", "spread", str(fast)]) == 2
    error = capsys.readouterr().err.strip()
    assert "above max_speed" not in error and "--period SECONDS" in error and "\n" not in error
    assert cli.main(["crowds", "spread", str(fast), "--period", "100", "--json"]) == 0
