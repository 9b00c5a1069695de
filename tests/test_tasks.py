"""The task suite: dm_env conformance, determinism, observation contract, bad input."""

import pathlib

import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils

from dcmppi import tasks
from dcmppi.control import defaults

DATA = pathlib.Path(__file__).parent / "data"
BARN = str(DATA / "barn_worlds_0_1.csv")

# Small, fast instances of every task (short time limits so episodes end in the tests).
SMALL = {
    "forest": dict(n_clusters=10),
    "crowd": dict(n_obstacles=12),
    "blocked": dict(),
    "crossing": dict(),
    "layout": dict(path=BARN, world=0),
}
KEYS = (
    "robot_pose",
    "goal",
    "static_obstacles",
    "moving_obstacles",
    "obstacle_model",
    "map_bounds",
    "clearance",
)


def make(name, **kwargs):
    return tasks.load(name, {**SMALL[name], "random": 0, **kwargs})


def wiggle(step):
    """A deterministic turn-rate sequence that exercises both signs."""
    return np.array([0.9 * np.sin(0.3 * step)])


def run(env, steps, policy=wiggle):
    """Observations of one episode (reset included), at most `steps` steps."""
    ts = env.reset()
    out = [ts.observation]
    for i in range(steps):
        ts = env.step(policy(i))
        out.append(ts.observation)
        if ts.last():
            break
    return out


def _conformance_case(name):
    class Conformance(test_utils.EnvironmentTestMixin, absltest.TestCase):
        def make_object_under_test(self):
            return make(name, noise="process", time_limit=1.5)

        def make_action_sequence(self):
            for i in range(40):  # several episodes of 15 steps: LAST, then FIRST again
                yield wiggle(i)

    Conformance.__name__ = Conformance.__qualname__ = f"TestConformance_{name}"
    return Conformance


for _name in SMALL:
    globals()[f"TestConformance_{_name}"] = _conformance_case(_name)


def test_registry_lists_every_task_with_a_description():
    assert set(tasks.TASKS) == {"forest", "crowd", "blocked", "crossing", "layout"}
    assert all(isinstance(d, str) and d for d in tasks.TASKS.values())


@pytest.mark.parametrize("name", SMALL)
def test_observation_matches_spec_and_contract(name):
    env = make(name)
    spec = env.observation_spec()
    assert tuple(spec) == KEYS
    for obs in run(env, 5):
        assert tuple(obs) == KEYS
        for key, value in obs.items():
            spec[key].validate(value)
        assert -np.pi <= obs["robot_pose"][2] < np.pi
        static = obs["static_obstacles"]
        assert (static[:, 2] >= 0).all()
        assert obs["map_bounds"][0] < obs["map_bounds"][2]
    action = env.action_spec()
    assert action.shape == (1,)
    np.testing.assert_allclose(action.maximum, defaults.omega_max())


@pytest.mark.parametrize("name", SMALL)
def test_same_seed_same_world_noise_and_trajectory(name):
    a = run(make(name, noise="process"), 25)
    b = run(make(name, noise="process"), 25)
    assert len(a) == len(b)
    for oa, ob in zip(a, b, strict=True):
        for key in KEYS:
            np.testing.assert_array_equal(oa[key], ob[key])


@pytest.mark.parametrize("name", ["forest", "crowd"])
def test_other_seed_other_world(name):
    a = make(name, random=1).reset().observation
    b = make(name, random=2).reset().observation
    assert not np.array_equal(a["goal"], b["goal"])


@pytest.mark.parametrize("name", SMALL)
def test_observation_shapes_stable_across_episodes(name):
    env = make(name)
    shapes = {k: v.shape for k, v in env.reset().observation.items()}
    for _ in range(4):
        ts = env.reset()
        ts = env.step([0.5])
        assert {k: v.shape for k, v in ts.observation.items()} == shapes


def test_episode_worlds_do_not_depend_on_episode_lengths():
    """Paired comparisons: episode k's world and noise are the same whatever came before."""
    short, long = make("forest", noise="control"), make("forest", noise="control")
    for steps in (3, 40):
        short.reset()
        for _ in range(steps):
            short.step([0.0])
        long.reset()
        for _ in range(2 * steps):
            long.step([0.7])
    a, b = run(short, 10), run(long, 10)
    for oa, ob in zip(a, b, strict=True):
        np.testing.assert_array_equal(oa["robot_pose"], ob["robot_pose"])
        np.testing.assert_array_equal(oa["static_obstacles"], ob["static_obstacles"])


def test_noise_profiles_change_the_trajectory():
    final = {}
    for noise in ("none", "control", "process"):
        final[noise] = run(make("blocked", noise=noise), 30)[-1]["robot_pose"]
    assert not np.allclose(final["none"], final["control"])
    assert not np.allclose(final["control"], final["process"])
    # Zero-variance control noise is no noise.
    silent = run(make("blocked", noise="control", Sigma=0.0), 30)[-1]["robot_pose"]
    np.testing.assert_allclose(silent, final["none"])


def test_action_is_clipped_to_the_turn_rate_bound():
    a = run(make("blocked"), 10, policy=lambda i: [5.0])[-1]["robot_pose"]
    b = run(make("blocked"), 10, policy=lambda i: [defaults.omega_max()])[-1]["robot_pose"]
    np.testing.assert_allclose(a, b)


def test_crowd_reports_the_known_gaussian_not_the_truth():
    env = make("crowd")
    obs = env.reset().observation
    v_mean, v_std = defaults.uniform_mean_std(*defaults.OBSTACLE_SPEED_RANGE)
    w_mean, w_std = defaults.uniform_mean_std(*defaults.OBSTACLE_TURN_RATE_RANGE)
    np.testing.assert_allclose(obs["obstacle_model"], [v_mean, v_std, w_mean, w_std])
    assert obs["moving_obstacles"].shape == (12, 4)
    np.testing.assert_allclose(obs["moving_obstacles"][:, 3], defaults.MOVING_OBSTACLE_RADIUS)


def test_default_time_limit_is_three_perimeters():
    env = tasks.load("forest", {"random": 0, "n_clusters": 5})
    assert env.task.time_limit == pytest.approx(3 * 2 * (75 + 50) / defaults.V)


def test_time_limit_ends_episode_with_discount_one():
    env = make("blocked", time_limit=1.0)
    env.reset()
    steps = 0
    while True:
        ts = env.step([1.0])  # circle in free space
        steps += 1
        if ts.last():
            break
    assert steps == 10
    assert env.task.outcome == "time_limit"
    assert ts.discount == 1.0 and ts.reward == 0.0


def test_goal_ends_episode_with_reward(tmp_path):
    path = tmp_path / "open.json"
    path.write_text('{"cylinders": [[0, 20, 0.5]], "start": [0, 0, 0], "goal": [5, 0]}')
    env = tasks.load("layout", {"path": str(path)})
    obs = run(env, 100, policy=lambda i: [0.0])
    assert env.task.outcome == "goal"
    final = obs[-1]["robot_pose"]
    assert np.hypot(final[0] - 5, final[1]) <= defaults.GOAL_TOLERANCE
    # Driving straight at v = 1 m/s the goal disc (radius 1) is entered after about 4 s.
    assert len(obs) - 1 == pytest.approx(40, abs=1)


def test_unknown_task_lists_valid_names():
    with pytest.raises(ValueError, match="forest.*crowd"):
        tasks.load("nope")


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(noise="loud"), "noise"),
        (dict(v=0.0), "v"),
        (dict(r_min=-1.0), "r_min"),
        (dict(robot_radius="big"), "robot_radius"),
        (dict(Sigma=float("nan")), "Sigma"),
        (dict(process_yaw_rate_std=-0.1), "process_yaw_rate_std"),
        (dict(time_limit=0), "time_limit"),
        (dict(n_clusters=0), "n_clusters"),
        (dict(speed=1.0), "unknown task_kwargs"),
    ],
)
def test_bad_task_kwargs_name_the_parameter(kwargs, word):
    with pytest.raises(ValueError, match=word):
        tasks.load("forest", kwargs)


def test_bad_crowd_and_crossing_kwargs():
    with pytest.raises(ValueError, match="speed_range"):
        tasks.load("crowd", {"speed_range": (2.0, 1.0)})
    with pytest.raises(ValueError, match="meet_fraction"):
        tasks.load("crossing", {"meet_fraction": 1.5})


def test_environment_time_limit_is_redirected_to_the_task():
    with pytest.raises(ValueError, match="task_kwargs"):
        tasks.load("blocked", environment_kwargs={"time_limit": 5})


def test_bad_action_raises():
    env = make("blocked")
    env.reset()
    with pytest.raises(ValueError, match="action"):
        env.step([float("nan")])
    with pytest.raises(ValueError, match="action"):
        env.step([0.1, 0.2])
