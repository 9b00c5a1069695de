"""The task suite: dm_env conformance, determinism, observation contract, bad input, for every
task with every agent."""

import pathlib

import numpy as np
import pytest
from absl.testing import absltest
from dm_env import test_utils

from dcmppi import tasks
from dcmppi.control import defaults
from dcmppi.tasks.worlds import base as world_base
from dcmppi.tasks.worlds import paper

DATA = pathlib.Path(__file__).parent / "data"
BARN = str(DATA / "barn_worlds_0_1.csv")

# Small, fast instances of every task (short time limits so episodes end in the tests).
SMALL = {
    "forest": dict(n_clusters=10),
    "crowd": dict(n_obstacles=12),
    "corridor": dict(n_pedestrians=4),
    "square": dict(n_pedestrians=3),
    "crowdnav": dict(n_humans=3),
    "crowdnav_plus": dict(n_humans=3),
    "blocked": dict(),
    "crossing": dict(),
    "layout": dict(path=BARN, world=0),
}
AGENTS = ("dubins", "unicycle", "holonomic")
KEYS = (
    "robot_pose",
    "robot_velocity",
    "goal",
    "static_obstacles",
    "moving_obstacles",
    "moving_velocity",
    "obstacle_model",
    "map_bounds",
    "clearance",
)


def make(name, **kwargs):
    return tasks.load(name, {**SMALL[name], "random": 0, **kwargs})


def wiggle(step, spec=None):
    """A deterministic action sequence over 90 % of the action range, both signs of each
    control (dubins: the turn rate 0.9 sin(0.3 step))."""
    if spec is None:
        return np.array([0.9 * np.sin(0.3 * step)])
    middle, half = 0.5 * (spec.maximum + spec.minimum), 0.5 * (spec.maximum - spec.minimum)
    return middle + 0.9 * half * np.sin(0.3 * step + np.arange(len(middle)))


def run(env, steps, policy=None):
    """Observations of one episode (reset included), at most `steps` steps."""
    policy = policy or (lambda i: wiggle(i, env.action_spec()))
    ts = env.reset()
    out = [ts.observation]
    for i in range(steps):
        ts = env.step(policy(i))
        out.append(ts.observation)
        if ts.last():
            break
    return out


def _conformance_case(name, agent):
    class Conformance(test_utils.EnvironmentTestMixin, absltest.TestCase):
        def make_object_under_test(self):
            return make(name, noise="process", time_limit=1.5, agent=agent)

        def make_action_sequence(self):
            spec = make(name, agent=agent).action_spec()
            for i in range(40):  # several episodes of 15 steps: LAST, then FIRST again
                yield wiggle(i, spec)

    Conformance.__name__ = Conformance.__qualname__ = f"TestConformance_{name}_{agent}"
    return Conformance


for _name in SMALL:
    for _agent in AGENTS:
        globals()[f"TestConformance_{_name}_{_agent}"] = _conformance_case(_name, _agent)


def test_registry_lists_every_task_with_a_description():
    assert set(tasks.TASKS) == {
        "forest",
        "crowd",
        "corridor",
        "square",
        "crowdnav",
        "crowdnav_plus",
        "blocked",
        "crossing",
        "layout",
        "replay",
    }
    assert all(isinstance(d, str) and d for d in tasks.TASKS.values())


@pytest.mark.parametrize("name", SMALL)
def test_observation_matches_spec_and_contract(name):
    env = make(name, agent="dubins")
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


@pytest.mark.parametrize("agent", AGENTS)
@pytest.mark.parametrize("name", SMALL)
def test_same_seed_same_world_noise_and_trajectory(name, agent):
    a = run(make(name, noise="process", agent=agent), 25)
    b = run(make(name, noise="process", agent=agent), 25)
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
        ts = env.step(wiggle(2, env.action_spec()))
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
    v_mean, v_std = world_base.uniform_mean_std(*world_base.OBSTACLE_SPEED_RANGE)
    w_mean, w_std = world_base.uniform_mean_std(*world_base.OBSTACLE_TURN_RATE_RANGE)
    np.testing.assert_allclose(obs["obstacle_model"], [v_mean, v_std, w_mean, w_std])
    assert obs["moving_obstacles"].shape == (12, 4)
    np.testing.assert_allclose(obs["moving_obstacles"][:, 3], paper.MOVING_OBSTACLE_RADIUS)


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
    assert np.hypot(final[0] - 5, final[1]) <= world_base.GOAL_TOLERANCE
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
        (dict(agent="tank"), "unknown agent 'tank'; valid names: dubins, holonomic, unicycle"),
        (dict(v_max=2.0), "unknown parameter.*v_max.*'dubins'"),
        (dict(agent="holonomic", v_max=-1.0), "v_max"),
        (dict(agent="holonomic", Sigma=[1.0, 1.0]), "one variance per control"),
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
    for task, kwargs, message in [
        ("crowd", {"speed_range": (0.5, float("inf"))}, "speed_range must be a pair of finite"),
        ("crowd", {"turn_rate_range": (float("nan"), 0.1)}, "turn_rate_range must be a pair of"),
        ("crossing", {"approach_angle": float("nan")}, "approach_angle must be a finite number"),
        ("crossing", {"obstacle_turn_rate": "left"}, "obstacle_turn_rate must be a finite"),
    ]:
        with pytest.raises(ValueError, match=message):
            tasks.load(task, kwargs)


def test_a_crowd_with_no_room_clear_of_the_start_is_refused():
    """Obstacles too large to start clear of the robot: one line at reset, not a loop forever."""
    env = tasks.load("crowd", {"random": 0, "obstacle_radius": 50.0})
    with pytest.raises(ValueError, match="find no place 3 m clear of the start.*obstacle_radius"):
        env.reset()


def test_a_crowd_of_thousands_loads_and_steps():
    """MuJoCo's broadphase needs a stack of about two bytes per pair of bodies: the arena grows
    with thousands of moving obstacles (its default holds about 1500)."""
    env = tasks.load("crowd", {"random": 0, "n_obstacles": 2500, "agent": "holonomic"})
    env.reset()
    assert len(env.step([0.0, 0.0, 0.0]).observation["moving_obstacles"]) == 2500


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
    env = make("crowd", agent="holonomic")
    env.reset()
    with pytest.raises(ValueError, match=r"3 finite number\(s\) \('u_x', 'u_y', 'u_theta'\)"):
        env.step([0.1, 0.2])


@pytest.mark.parametrize("agent", AGENTS)
def test_action_spec_has_the_agents_controls_and_bounds(agent):
    from dcmppi.control.agents import make_agent

    model = make_agent(agent)
    spec = make("blocked", agent=agent).action_spec()
    assert spec.shape == (model.nu,) and spec.name == ",".join(model.controls)
    np.testing.assert_array_equal(spec.minimum, model.lower)
    np.testing.assert_array_equal(spec.maximum, model.upper)


def test_holonomic_action_beyond_the_speed_disc_is_scaled_onto_it():
    """(1.5, 1.5) is inside the box but outside |(u_x, u_y)| <= 1.5: it drives as (1.06, 1.06);
    (9, 9) is clipped to the box first, so it drives the same."""
    c = 1.5 / np.sqrt(2)
    ends = [
        run(make("blocked", agent="holonomic"), 10, policy=lambda i, a=a: a)[-1]["robot_pose"]
        for a in ([1.5, 1.5, 0.0], [c, c, 0.0], [9.0, 9.0, 0.0])
    ]
    np.testing.assert_allclose(ends[0], ends[1])
    np.testing.assert_allclose(ends[0], ends[2])


def test_crowd_defaults_to_the_holonomic_agent_others_to_dubins():
    assert make("crowd").task.agent.name == "holonomic"
    assert make("crossing").task.agent.name == "dubins"
    assert tasks.default_agent("crowd") == "holonomic"


def test_leaving_the_map_ends_the_episode_as_a_failure():
    env = make("blocked", agent="holonomic")  # start (27.5, 25) facing +x in a 75 x 50 map
    env.reset()
    steps = 0
    while True:
        ts = env.step([0.0, 1.5, 0.0])  # straight up at 1.5 m/s: y = 50 after ~17 s
        steps += 1
        if ts.last():
            break
    assert env.task.outcome == "left_map"
    assert ts.discount == 0.0 and ts.reward == 0.0
    assert 160 <= steps <= 175
    assert ts.observation["robot_pose"][1] > 50.0
