"""The replay task: a robot replaces one recorded person among the others' recorded tracks."""

import os
import pathlib

import numpy as np
import pytest

from dcmppi import tasks
from dcmppi.bench.episodes.reachability import reach
from dcmppi.bench.episodes.runner import EpisodeSpec, TrueFutures, run_episode
from dcmppi.tasks.replay import people, recordings, scenes
from dcmppi.tasks.replay import task as replay_task

ROOT = pathlib.Path(__file__).resolve().parents[2]
WALK = [(10 * k, 1, 0.4 * k, 0.0) for k in range(21)]  # person 1: 8 m along +x at 1 m/s
# person 2 crosses person 1's way (x = 4) from y = 3 to y = -3 at 1 m/s, seen from t = 2 s
CROSS = [(10 * k, 2, 4.0, 3.0 - 0.4 * (k - 5)) for k in range(5, 21)]
CROSS_T, CROSS_Y = np.array([row[0] / 25 for row in CROSS]), np.array([row[3] for row in CROSS])


def crowds():
    """The ETH/UCY folder ($DCMPPI_CROWDS, else ../shared/crowds), or skip saying why."""
    folder = pathlib.Path(os.environ.get(recordings.CROWDS_ENV) or ROOT.parent / "shared/crowds")
    if not (folder / "biwi_eth.txt").is_file():
        pytest.skip(f"the ETH/UCY files are absent ({folder}; set {recordings.CROWDS_ENV})")
    return folder


def scene_file(tmp_path, *people, name="walk"):
    """A four-column file of the rows (frame, id, x, y) of `people`."""
    path = tmp_path / f"{name}.txt"
    np.savetxt(path, np.array([row for rows in people for row in rows], float), delimiter="\t")
    return str(path)


def episode_of(path, person):
    """The index of the episode of `path` that replaces `person`."""
    scene = scenes.load_scene(scenes.scene_files(path))
    ids = [scene.recordings[r].tracks[i].id for r, i in scene.episodes]
    return ids.index(person)


def load(path, person=1, **kwargs):
    return tasks.load("replay", {"scene": path, "episode": episode_of(path, person), **kwargs})


def stand(env, steps=None):
    """Steps the robot standing still; the observations after each step."""
    seen, ts = [], env.reset()
    while not ts.last() and (steps is None or len(seen) < steps):
        ts = env.step(np.zeros(3))
        seen.append(ts.observation)
    return seen


def test_people_move_linearly_between_frames_and_are_absent_outside_their_track(tmp_path):
    path = scene_file(tmp_path, WALK, CROSS)
    env = load(path)
    seen = stand(env, 40)
    rec = recordings.load(path)
    row = 0  # the one other person, in the one row
    assert env.task.num_moving == 1
    for k, obs in enumerate(seen, start=1):
        t = 0.1 * k
        ids, xy = rec.positions_at(t)
        moving = obs["moving_obstacles"]
        if 2 in ids and t > 2.0 + 1e-9:
            np.testing.assert_allclose(moving[row, :2], xy[list(ids).index(2)], atol=1e-12)
            assert moving[row, 3] == people.PEDESTRIAN_RADIUS
            np.testing.assert_allclose(obs["moving_velocity"][row], [0.0, -1.0], atol=1e-12)
        elif t < 2.0 - 1e-9:  # before its first frame: a padding row, parked, still
            assert moving[row, 3] == 0 and moving[row, 0] < -100
            assert not obs["moving_velocity"][row].any()
    # at the substeps too: linear between annotated frames
    motion = env.physics.obstacle_motion
    z = motion.advance(10, np.array([1e6, 1e6]), np.zeros(2))
    t = 4.0 + 0.01 * np.arange(1, 11)
    np.testing.assert_allclose(z[:, row].real, 4.0, atol=1e-12)
    np.testing.assert_allclose(z[:, row].imag, np.interp(t, CROSS_T, CROSS_Y), atol=1e-12)


def test_a_person_who_left_frees_the_row_for_the_next_after_a_padding_instant(tmp_path):
    first = [(10 * k, 3, 1.0, 1.0 + 0.4 * k) for k in range(0, 5)]  # frames 0..4, meets 1
    second = [(10 * k, 4, 6.0, -2.0 - 0.4 * k) for k in range(6, 12)]  # frames 6..11
    env = load(scene_file(tmp_path, WALK, first, second))
    assert env.task.num_moving == 1  # the most present at once
    seen = stand(env, 60)
    ids = [env.physics.obstacle_motion.ids[0]]  # after the last step
    radius = [obs["moving_obstacles"][0, 3] for obs in seen]
    assert radius[10] > 0 and radius[18] == 0 and radius[30] > 0  # 3 left at 1.6 s, 4 at 2.4 s
    assert ids == [-1]  # 4 left at 4.4 s


def test_episodes_are_people_who_walk_far_enough_and_meet_someone(tmp_path):
    short = [(10 * k, 5, 4.0, 1.0 + 0.1 * k) for k in range(10)]  # 0.9 m, meets 1 and 2
    alone = [(10 * k, 6, 50.0 + 0.5 * k, 50.0) for k in range(30)]  # 14.5 m, meets no one
    scene = scenes.load_scene(scenes.scene_files(scene_file(tmp_path, WALK, CROSS, short, alone)))
    people = sorted(scene.recordings[0].tracks[i].id for _, i in scene.episodes)
    assert people == [1, 2]


def test_the_episode_list_is_seeded_and_random_picks_from_it():
    folder = crowds()
    files = scenes.scene_files("zara1", folder)
    first = scenes.load_scene(files).episodes
    assert scenes._load_scene.__wrapped__(files, ()).episodes == first  # the same afresh
    assert len(first) >= 100 and first != tuple(sorted(first))

    def picked(seed):
        env = tasks.load("replay", {"scene": "zara1", "path": str(folder), "random": seed})
        env.reset()
        return env.task.episode_index, env.task.human.id

    assert picked(3) == picked(3)
    assert len({picked(seed) for seed in range(6)}) > 1


def test_time_limit_is_twice_the_persons_own_time(tmp_path):
    env = load(scene_file(tmp_path, WALK, CROSS))
    assert env.task.time_limit == pytest.approx(2 * 8.0)
    stand(env)
    assert env.task.outcome == "time_limit"
    assert env.physics.data.time == pytest.approx(16.0)
    assert env.task.human.duration == pytest.approx(8.0)
    assert env.task.human.time_to_goal == pytest.approx(7.0)  # within 1 m of the goal


def test_the_robot_is_at_least_as_fast_as_the_person_it_replaces(tmp_path):
    slow = scene_file(tmp_path, WALK, CROSS)
    fast = [(10 * k, 1, 0.8 * k, 0.0) for k in range(21)]  # 2 m/s ...
    beside = [(10 * k, 2, 0.8 * k, 1.5) for k in range(21)]  # ... beside another
    v_max = load(scene_file(tmp_path, fast, beside, name="fast")).task.agent.v_max
    assert v_max == pytest.approx(replay_task.SPEED_MARGIN * 2.0)
    assert load(slow).task.agent.v_max == 1.5  # the holonomic default
    assert load(slow, v_max=0.7).task.agent.v_max == 0.7  # given: kept


def test_a_person_who_would_appear_on_the_robot_waits_until_its_track_is_clear(tmp_path):
    # person 7 first appears at t = 2 s right on the standing robot, then walks away at 1 m/s
    enters = [(10 * k, 7, 0.0, 0.05 + 0.4 * (k - 5)) for k in range(5, 15)]
    env = load(scene_file(tmp_path, WALK, CROSS, enters))
    seen = stand(env, 40)
    assert env.task.outcome is None  # no collision
    row = [i for i in range(env.task.num_moving) if env.physics.obstacle_motion.ids[i] == 7][0]
    radius = np.array([obs["moving_obstacles"][row, 3] for obs in seen])
    appears = int(np.flatnonzero(radius > 0)[0]) + 1  # the step after which it is seen
    assert 20 < appears <= 23  # held for a step or two, then where its track is
    gap = np.hypot(*seen[appears - 1]["moving_obstacles"][row, :2])
    assert gap > 2 * people.PEDESTRIAN_RADIUS


@pytest.mark.slow
def test_self_collisions_are_rare_under_the_collision_distance():
    folder = crowds()
    for scene, bound in (("eth", 0.05), ("hotel", 0.05), ("zara1", 0.05), ("zara2", 0.1)):
        hits = people.self_collisions(scene, folder, episodes=20)
        assert len(hits) == 20 and hits.mean() <= bound, scene
    # with CrowdNav's 0.3 m discs the same people "collide" often: the check can fail
    wide = people.self_collisions("zara2", folder, episodes=20, radius=0.3, robot_radius=0.3)
    assert wide.mean() > 0.3
    picked = people.self_collisions("zara2", folder, episodes=[19, 3], radius=0.3, robot_radius=0.3)
    assert picked.tolist() == [wide[19], wide[3]]  # episodes by index


def test_self_collisions_find_a_person_who_walks_through_another(tmp_path):
    through = [(10 * k, 8, 8.0 - 0.4 * k, 0.0) for k in range(21)]  # head-on along person 1
    path = scene_file(tmp_path, WALK, through)
    scene = scenes.load_scene(scenes.scene_files(path))
    assert people.self_collisions(path).tolist() == [True] * len(scene.episodes)


def test_eth_people_walk_at_a_walking_speed_at_its_frame_period():
    env = tasks.load("replay", {"scene": "eth", "path": str(crowds()), "episode": 0})
    seen = stand(env, 30)
    speeds = np.concatenate(
        [np.hypot(*obs["moving_velocity"][obs["moving_obstacles"][:, 3] > 0].T) for obs in seen]
    )
    assert 1.0 < np.median(speeds) < 2.0  # 2.45 m/s at 0.4 s


def test_an_episode_runs_through_the_runner_with_the_human_reference():
    spec = EpisodeSpec(
        "replay", "dc", "none", 1, {"scene": "zara1", "path": str(crowds()), "episode": 2},
        {"prediction": "given", "K": 64, "N": 20},
    )  # fmt: skip
    result = run_episode(spec)
    assert result["outcome"] in ("goal", "collision", "time_limit")
    assert result["scene"] == "zara1" and result["recording"] == "crowds_zara01"
    assert result["human_time"] > 0
    assert 5.0 <= result["human_path_length"] and 0 < result["frame_path_length"]
    assert result["frame_path_length"] <= result["path_length"] + 1e-9


def test_the_oracle_sees_people_who_appear_within_its_horizon(tmp_path):
    path = scene_file(tmp_path, WALK, CROSS)
    spec = EpisodeSpec("replay", "dc", "none", 0, {"scene": path, "episode": episode_of(path, 1)})
    futures = TrueFutures(spec, 30)
    env = tasks.load("replay", spec.task_params | {"random": 0})
    moving = env.reset().observation["moving_obstacles"]
    assert moving[0, 3] == 0  # person 2 appears at t = 2 s
    assert futures.visible(0, moving)[0, 3] == people.PEDESTRIAN_RADIUS
    assert futures.visible(0, moving) is not moving and moving[0, 3] == 0
    robot = np.array([0.0, 0.0])
    f = futures.at(0, robot)[0, 0]  # (31, 2)
    np.testing.assert_allclose(f[25], [4.0, 3.0 - 0.5], atol=1e-9)  # t = 2.5 s
    assert np.hypot(*(f[15] - robot)) > futures.away - 1e-9  # absent: out of reach
    assert np.isfinite(f).all()


def test_reach_runs_on_a_replay_and_finds_it_solvable(tmp_path):
    path = scene_file(tmp_path, WALK, CROSS)
    spec = EpisodeSpec("replay", "mppi", "none", 0, {"scene": path, "episode": episode_of(path, 1)})
    found = reach(spec)
    assert found.solvable and found.time < 8.0


def test_reactive_people_avoid_the_robot_and_are_no_longer_a_recording(tmp_path):
    through = [(10 * k, 9, -2.0 + 0.4 * (k - 10), 0.0) for k in range(10, 21)]  # via (0, 0)
    path = scene_file(tmp_path, WALK, CROSS, through)

    def beside(env):
        """Person 9's distance from its recorded line (y = 0) when it passes the robot."""
        env.reset()
        while env.task.outcome is None:
            env.step(np.zeros(3))
            motion = env.physics.obstacle_motion
            row = list(motion.ids).index(9) if 9 in motion.ids else None
            if row is not None and motion.z[row].real > -0.3:
                return abs(motion.z[row].imag)

    recorded = load(path)
    assert beside(recorded) < 1e-12  # blind, on its track ...
    stand(recorded)
    assert recorded.task.outcome == "collision"  # ... into the standing robot
    assert recorded.task.recorded and recorded.task.world.behavior == replay_task.RECORDED
    reactive = load(path, reactive=True)
    assert beside(reactive) > 0.15  # ORCA: it steps aside (reciprocal: half of the way)
    assert not reactive.task.recorded and reactive.task.world.behavior == replay_task.REACTIVE
    spec = EpisodeSpec("replay", "mppi", "none", 0, {"scene": path, "episode": 0, "reactive": True})
    with pytest.raises(ValueError, match=r"robot \(reactive=true\): use reactive=false"):
        reach(spec)


def test_bad_scenes_and_folders_are_one_line_errors(tmp_path, monkeypatch):
    monkeypatch.delenv(recordings.CROWDS_ENV, raising=False)
    cases = (
        ({"scene": "mall"}, r"unknown scene 'mall'; scenes: eth, hotel"),
        ({"scene": "eth"}, r"not part of dcmppi: set DCMPPI_CROWDS=DIR, .* path=DIR"),
        ({"scene": "eth", "path": str(tmp_path / "none")}, r"no such folder"),
        ({"scene": str(tmp_path / "none.txt")}, r"none.txt: no such recording"),
        ({"scene": scene_file(tmp_path, WALK, CROSS), "episode": 5}, r"has 2 episodes"),
        ({"scene": scene_file(tmp_path, WALK, name="alone"), "episode": 0}, r"has no episode"),
    )
    for kwargs, message in cases:
        with pytest.raises(ValueError, match=message) as error:
            tasks.load("replay", kwargs)
        assert "\n" not in str(error.value)
