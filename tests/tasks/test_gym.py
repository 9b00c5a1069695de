"""The Gymnasium adapter: registration, the environment checker, spaces, seeding, outcomes."""

import json
import os
import pathlib
import subprocess
import sys
import warnings

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

import dcmppi.gym  # noqa: E402
from dcmppi.gym import NavigationEnv  # noqa: E402

DATA = pathlib.Path(__file__).parent / "data"
# the ETH/UCY files: $DCMPPI_CROWDS, else ../shared/crowds from the project's root
CROWDS = pathlib.Path(
    os.environ.get("DCMPPI_CROWDS") or pathlib.Path(__file__).parents[3] / "shared" / "crowds"
)
SMALL = {  # every id with small settings, and every agent somewhere
    "dcmppi/Forest-v0": {"n_clusters": 5, "agent": "holonomic"},
    "dcmppi/Crowd-v0": {"n_obstacles": 10},
    "dcmppi/Corridor-v0": {"n_pedestrians": 4},
    "dcmppi/Square-v0": {"n_pedestrians": 3, "agent": "unicycle"},
    "dcmppi/CrowdNav-v0": {"scenario": "square_crossing", "n_humans": 3},
    "dcmppi/CrowdNavPlus-v0": {"n_humans": 4},
    "dcmppi/Blocked-v0": {},
    "dcmppi/Crossing-v0": {"agent": "unicycle", "noise": "control"},
    "dcmppi/Layout-v0": {"path": str(DATA / "barn_worlds_0_1.csv"), "world": 0},
    "dcmppi/Replay-v0": {"scene": "zara1", "path": str(CROWDS)},
}


def test_importing_registers_every_task():
    assert set(SMALL) == set(dcmppi.gym.IDS)
    assert set(SMALL) <= set(gymnasium.registry)


@pytest.mark.parametrize("env_id", SMALL)
def test_passes_the_environment_checker(env_id):
    if env_id == "dcmppi/Replay-v0" and not (CROWDS / "crowds_zara01.txt").is_file():
        pytest.skip(f"the ETH/UCY files are absent ({CROWDS}; set DCMPPI_CROWDS)")
    env = gymnasium.make(env_id, render_width=64, render_height=48, **SMALL[env_id])
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any complaint of the checker fails the test ...
        warnings.filterwarnings("ignore", message=".*infinity")  # ... but unbounded Boxes
        check_env(env.unwrapped)  # renders an rgb_array twin through env.spec too
    env.close()


def test_action_in_minus_one_one_maps_onto_the_task_bounds(monkeypatch):
    env = NavigationEnv("crowd", n_obstacles=2)  # holonomic: u_x, u_y, u_theta
    spec = env.dm_env.action_spec()
    sent, step = [], env.dm_env.step
    monkeypatch.setattr(env.dm_env, "step", lambda u: sent.append(u.copy()) or step(u))
    env.reset(seed=0)
    env.step(np.array([-1.0, 1.0, 0.0], np.float32))
    env.step(np.array([3.0, -7.0, 0.5], np.float32))  # outside [-1, 1]: clipped
    lo, hi = spec.minimum, spec.maximum
    np.testing.assert_allclose(sent[0], [lo[0], hi[1], 0.5 * (lo[2] + hi[2])])
    np.testing.assert_allclose(sent[1], [hi[0], lo[1], lo[2] + 0.75 * (hi[2] - lo[2])])
    assert env.action_space.shape == (3,) and (env.action_space.high == 1).all()


def test_same_seed_same_world_and_noise_other_seed_other_world():
    def episode(seed):
        env = gymnasium.make("dcmppi/Forest-v0", n_clusters=5, noise="process")
        obs, _ = env.reset(seed=seed)
        poses = [env.step(np.zeros(1, np.float32))[0]["robot_pose"] for _ in range(5)]
        return obs["static_obstacles"], np.array(poses)

    world, poses = episode(4)
    world_again, poses_again = episode(4)
    np.testing.assert_array_equal(world, world_again)
    np.testing.assert_array_equal(poses, poses_again)
    assert not np.array_equal(world, episode(5)[0])
    # process noise moves the robot off the straight line it was told to drive
    assert np.abs(np.diff(poses[:, 2])).max() > 0


def test_flattened_observation_is_the_dict_in_order():
    flat = gymnasium.make("dcmppi/Crossing-v0", flatten_observation=True)
    plain = gymnasium.make("dcmppi/Crossing-v0")
    x, _ = flat.reset(seed=3)
    obs, _ = plain.reset(seed=3)
    space = flat.unwrapped.dict_observation_space
    assert flat.observation_space.shape == x.shape
    assert x.shape == (sum(int(np.prod(b.shape)) for b in space.values()),)
    back = gymnasium.spaces.unflatten(space, x)
    for name in obs:
        np.testing.assert_array_equal(back[name], obs[name])


def _drive_straight(env, seed=0):
    obs, info = env.reset(seed=seed)
    assert info["outcome"] is None
    while True:
        obs, reward, terminated, truncated, info = env.step(np.zeros(env.action_space.shape))
        if terminated or truncated:
            return reward, terminated, truncated, info


def test_terminated_at_goal_and_collision_truncated_at_the_time_limit(tmp_path):
    layout = tmp_path / "open.json"
    layout.write_text(
        json.dumps(
            {
                "cylinders": [[0, 8, 0.5]],
                "start": [0, 0, 0],
                "goal": [4, 0],
                "map_bounds": [-5, -5, 10, 10],
            }
        )  # fmt: skip
    )
    env = NavigationEnv("layout", path=str(layout))
    assert _drive_straight(env)[:3] == (1.0, True, False)
    assert env.task.outcome == "goal"
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(1))

    reward, terminated, truncated, info = _drive_straight(NavigationEnv("blocked", distance=8.0))
    assert (reward, terminated, truncated, info["outcome"]) == (0.0, True, False, "collision")
    assert info["min_clearance"] <= info["clearance"] and info["min_clearance"] < 0.05

    reward, terminated, truncated, info = _drive_straight(NavigationEnv("crossing", time_limit=0.5))
    assert (reward, terminated, truncated, info["outcome"]) == (0.0, False, True, "time_limit")


def test_make_vec_steps_and_resets_each_copy():
    envs = gymnasium.make_vec("dcmppi/Blocked-v0", num_envs=2, distance=8.0)
    obs, _ = envs.reset(seed=0)
    start = obs["robot_pose"].copy()
    assert start.shape == (2, 3) and obs["static_obstacles"].shape == (2, 1, 3)
    action = np.zeros((2, 1), np.float32)
    for _ in range(100):
        obs, reward, terminated, truncated, info = envs.step(action)
        if terminated.any():
            break
    assert terminated.all() and list(info["outcome"]) == ["collision", "collision"]
    obs, *_ = envs.step(action)  # the vector env resets a finished copy on the next step
    np.testing.assert_allclose(obs["robot_pose"], start)
    envs.close()


@pytest.mark.parametrize("camera", ["scene", "top", "chase"])
def test_rgb_array_render_has_the_requested_size(camera):
    env = gymnasium.make(
        "dcmppi/Blocked-v0", render_mode="rgb_array", render_camera=camera,
        render_width=96, render_height=64,
    )  # fmt: skip
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (64, 96, 3) and frame.dtype == np.uint8
    assert frame.std() > 5  # a picture, not a blank buffer
    env.close()
    env.close()  # closing twice is allowed


def test_bad_arguments_name_the_problem():
    with pytest.raises(ValueError, match="reset\\(seed"):
        gymnasium.make("dcmppi/Forest-v0", random=3)
    with pytest.raises(ValueError, match="render_camera"):
        gymnasium.make("dcmppi/Blocked-v0", render_camera="side")
    with pytest.raises(ValueError, match="n_cluster"):
        gymnasium.make("dcmppi/Blocked-v0", n_cluster=3)


def test_unobserved_headings_and_velocities_are_0_inside_the_space():
    """With measurement noise the task gives nan for what is not observed; a Box holds no nan,
    so the Gymnasium observation has 0 there, and the env passes gymnasium's checker."""
    env = gymnasium.make("dcmppi/Crowd-v0", obstacle_measurement_std=0.1, n_obstacles=3)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    assert not obs["moving_obstacles"][:, 2].any() and not obs["moving_velocity"].any()
    truth = env.unwrapped.dm_env.physics.moving_obstacles()[:, :2]
    assert not np.array_equal(obs["moving_obstacles"][:, :2], truth)  # noisy positions
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*infinity")  # unbounded Boxes
        check_env(env.unwrapped, skip_render_check=True)


def test_a_frame_of_no_pixels_is_refused():
    env = gymnasium.make("dcmppi/Blocked-v0", render_mode="rgb_array", render_width=0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="at least 1 pixel"):
        env.render()


def test_without_gymnasium_the_import_names_the_extra():
    code = "import sys; sys.modules['gymnasium'] = None; import dcmppi.gym"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.returncode != 0
    assert 'ImportError: dcmppi.gym needs gymnasium: pip install "dcmppi[gym]"' in out.stderr
