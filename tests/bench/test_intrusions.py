"""CrowdNav++'s intrusion ratio and social distance (metrics.intrusions) on hand-made tracks:
the robot's centre at each instant against the pedestrians' positions 0.25 .. 1.25 s later."""

import numpy as np
import pytest

from dcmppi.bench.episodes.metrics import intrusions

DT = 0.1


def _track(x, y=0.0):
    """Centres (K + 1, 2) along x (K + 1,) at height y."""
    return np.column_stack([x, np.full(len(x), y)])


def test_a_standing_human_is_intruded_while_the_robot_passes_within_reach():
    # the robot drives past a human of radius 0.3 at 1 m/s: |x| < 0.6 at x = -0.55 .. 0.55
    robot = _track(-3.05 + DT * np.arange(61))
    crowd = np.zeros((61, 1, 3))
    crowd[..., 2] = 0.3
    ratio, social = intrusions(robot, crowd, 0.3, DT)
    assert ratio == pytest.approx(12 / 60)  # 12 of the 60 instants it acts at
    assert social == pytest.approx(0.3)  # the mean of 0.55, 0.45, ..., 0.05, 0.05, ..., 0.55


def test_only_the_future_counts_not_the_present():
    # a human walks at 1 m/s through a standing robot: within reach of its future (0.25 .. 1.25
    # s ahead) at instants 12 .. 33, of 50; at 34 and 35 it is within 0.6 m now, but past
    crowd = np.zeros((51, 1, 3))
    crowd[:, 0, 0] = 3.0 - DT * np.arange(51)
    crowd[..., 2] = 0.3
    robot = np.zeros((51, 2))
    assert intrusions(robot, crowd, 0.3, DT)[0] == pytest.approx(22 / 50)
    # ending at instant 33, the samples after it are left out: 12 .. 30 of 33 (k + 0.25 s <= 3.3 s)
    assert intrusions(robot[:34], crowd[:34], 0.3, DT)[0] == pytest.approx(19 / 33)


def test_a_respawn_is_not_a_walk_across_the_map():
    # a human far away jumps next to the robot at instant 12 only: its samples between 11 and
    # 12 stay far (the earlier instant), those from 12 up to 13 are near (0.5 m < 0.6 m)
    crowd = np.zeros((21, 1, 3))
    crowd[:, 0, 0] = 8.0
    crowd[12, 0, 0] = 0.5
    crowd[..., 2] = 0.3
    ratio, social = intrusions(np.zeros((21, 2)), crowd, 0.3, DT)
    assert ratio == pytest.approx(5 / 20)  # instants 0, 2, 5, 7, 10 (k + 2.5 j in [12, 13))
    assert social == pytest.approx(0.5)


def test_absent_rows_and_short_episodes():
    crowd = np.zeros((11, 2, 3))  # radius 0: no one there
    assert intrusions(np.zeros((11, 2)), crowd, 0.3, DT) == (0.0, None)
    assert intrusions(np.zeros((1, 2)), crowd[:1], 0.3, DT) == (None, None)
