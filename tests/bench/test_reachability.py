"""The ideal robot's reachable set: open ground, a disc it cannot escape, one it can, walls;
the true futures the runner gives prediction="given"."""

import dataclasses

import numpy as np
import pytest

from dcmppi.bench.episodes.reachability import propagate, reach
from dcmppi.bench.episodes.runner import Episode
from dcmppi.bench.experiments import load_experiment

BOUNDS = np.array([0.0, 0.0, 10.0, 10.0])
NO_STATIC = np.empty((0, 3))


def run(tracks, radii, start=(1.0, 5.0), goal=(9.0, 5.0), static=NO_STATIC, steps=200):
    """A 0.3 m disc at 1 m/s, control period 0.1 s, goal tolerance 1 m."""
    tracks = list(tracks) if tracks is not None else [np.empty((0, 2))] * steps
    return propagate(
        np.array(start), np.array(goal), 1.0, BOUNDS, static, tracks, np.array(radii), 0.3,
        1.0, 0.1,
    )  # fmt: skip


@pytest.mark.parametrize("goal", [(9.0, 5.0), (6.0, 9.0), (1.0, 1.0)])
def test_open_ground_takes_the_straight_line_at_top_speed(goal):
    r = run(None, [], goal=goal)
    distance = np.hypot(goal[0] - 1.0, goal[1] - 5.0) - 1.0
    assert r.solvable and not r.unavoidable
    assert distance / 1.02 - 0.1 <= r.time <= distance / 0.984 + 0.1


def test_a_disc_rushing_in_from_close_by_cannot_be_escaped():
    # 0.1 m beyond contact, closing at 5 m/s: no move of 0.1 m gets out of its way
    x0 = 1.0 + 0.3 + 0.5 + 0.1
    tracks = [np.array([[x0 - 5.0 * 0.1 * k, 5.0]]) for k in range(1, 30)]
    r = run(tracks, [0.5])
    assert r.unavoidable and not r.solvable and r.time == pytest.approx(0.1)


def test_the_same_disc_from_afar_leaves_room_to_step_aside():
    x0 = 8.0  # meets the robot's straight line after about 1.2 s: time to step 0.8 m aside
    tracks = [np.array([[x0 - 5.0 * 0.1 * k, 5.0]]) for k in range(1, 200)]
    assert run(tracks, [0.5]).solvable


def test_a_wall_across_the_map_keeps_the_robot_short_of_the_goal_but_alive():
    wall = np.array([[5.0, y, 0.3] for y in np.arange(0.0, 10.01, 0.4)])
    r = run(None, [], static=wall, steps=150)
    assert not r.solvable and not r.unavoidable and r.time is None
    # the nearest centre: between two cylinders, 0.6 m from both, 0.2 m off the line
    assert r.goal_distance == pytest.approx(4.0 + np.sqrt(0.6**2 - 0.2**2), abs=0.05)


def test_a_gap_in_the_wall_is_found():
    wall = np.array([[5.0, y, 0.3] for y in np.arange(0.0, 10.01, 0.4) if abs(y - 8.0) > 0.9])
    r = run(None, [], static=wall, steps=300)
    assert r.solvable and r.time > (8.0 - 1.0) / 1.02  # a detour through the gap at y = 8


def test_a_task_whose_pedestrians_react_is_refused():
    exp = load_experiment("corridor-visible")
    with pytest.raises(ValueError, match="react to the robot .robot_visible=true."):
        reach(exp.spec("none", "mppi", 0))


@pytest.mark.slow
def test_the_goal_region_is_the_tasks_crowdnavs_0_3_m():
    """An empty CrowdNav scene: the ideal robot meets the 0.3 m goal region 7.7 m from its start
    (the 1 m region of other tasks would be met at 7 m)."""
    exp = load_experiment("crowdnav").with_params({"n_humans": 0}, {})
    r = reach(exp.spec("none", "mppi+margin", 0))
    assert r.solvable and r.goal_distance <= 0.3
    assert 7.7 / 1.02 <= r.time <= 7.7 / 0.984 + 0.1


@pytest.mark.slow
def test_square_environment_zero_is_solvable_in_about_the_straight_time():
    exp = load_experiment("square-orca")
    r = reach(exp.spec("none", "dc-cv", 0))
    assert r.solvable and 5.0 / 1.02 - 0.1 <= r.time <= 12.0


def _given(name, **task_params):
    exp = load_experiment(name).with_params({"time_limit": 3.0, **task_params}, {})
    spec = exp.spec(exp.noises[0], "dc", 1)
    return dataclasses.replace(spec, controller_params={"prediction": "given", "K": 64})


def test_a_given_prediction_gets_the_true_futures_of_blind_pedestrians():
    """What the runner hands prediction="given": at every step its futures start at the observed
    pedestrians and step k of them is where they are k steps later."""
    episode = Episode(_given("square-orca"))
    seen, handed = [], []
    while not episode.done:
        seen.append(episode.observation["moving_obstacles"][:, :2])
        handed.append(episode.observation["moving_futures"])
        episode.step()
    assert len(seen) == 30 and handed[0].shape == (7, 1, 51, 2)
    for k in range(len(seen)):
        np.testing.assert_array_equal(handed[k][:, 0, 0], seen[k])
        for j in range(1, len(seen) - k):
            np.testing.assert_array_equal(handed[k][:, 0, j], seen[k + j])
    assert episode.result()["outcome"] in ("goal", "time_limit", "collision")


def test_a_given_prediction_is_refused_where_pedestrians_react():
    with pytest.raises(ValueError, match="prediction .given. .the true futures. needs obstacles"):
        Episode(_given("corridor-visible"))


def test_the_summary_counts_collisions_among_finished_episodes():
    """An episode that ended in an error has no outcome: it is not among the episodes counted."""
    from dcmppi.bench.episodes.reachability import Reach, summary

    found = {
        0: Reach(True, False, 5.0, 0.0),
        1: Reach(False, True, 2.0, 9.0),
        2: Reach(True, False, 6.0, 0.0),
    }
    rows = [
        {"label": "dc", "env_index": 0, "status": "ok", "collision": False},
        {"label": "dc", "env_index": 1, "status": "ok", "collision": True},
        {"label": "dc", "env_index": 2, "status": "error", "collision": None},
    ]
    text = summary(found, rows)
    assert "2 solvable by the ideal robot" in text
    assert "dc: 1 of 2 episodes collided (1 more ended in an error), 1 of them where every" in text
