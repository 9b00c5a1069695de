"""The `learned` predictor: a model of retrieved futures, trained in a second on synthetic walks,
and the predictor that tracks pedestrians step by step and resamples the futures in time."""

import types

import numpy as np
import pytest

from dcmppi.control import make_controller, make_predictor
from dcmppi.control.predictors import learned

PERIOD = 0.4
SHARED = dict(N=30, dt=0.1, robot_radius=0.3, max_speed=1.5, alpha=1000.0, beta=100.0, P=4,
              obstacle_margin=0.0)  # fmt: skip


def arc(start, heading, speed, turn, frames=20):
    """(frames, 2) a walk of `speed` [m/s] turning at `turn` [rad/s], one PERIOD apart."""
    h = heading + turn * PERIOD * np.arange(frames)
    steps = speed * PERIOD * np.stack([np.cos(h), np.sin(h)], axis=1)
    return np.asarray(start) + np.cumsum(np.vstack([[0.0, 0.0], steps[:-1]]), axis=0)


def walks(n=300, seed=0, turn=(-0.3, 0.3), still=0.0):
    """Windows (8 observed, 12 future) of n walkers on arcs, alone, from 3 'recordings'; a
    share `still` of them stand."""
    rng = np.random.default_rng(seed)
    speed = rng.uniform(0.5, 1.8, n) * (rng.uniform(size=n) >= still)
    xy = np.array([
        arc(rng.uniform(-5, 5, 2), rng.uniform(-np.pi, np.pi), v, rng.choice(turn)) for v in speed
    ])  # fmt: skip
    return types.SimpleNamespace(
        observed=xy[:, :8],
        future=xy[:, 8:],
        neighbours=tuple(np.zeros((0, 8, 2)) for _ in range(n)),
        source=np.arange(n) % 3,
        period=PERIOD,
    )


def model_file(tmp_path, **kw):
    path = tmp_path / "model.npz"
    learned.fit(walks(**kw), seed=0).save(path)
    return path


def test_the_model_retrieves_the_continuation_of_the_closest_walk():
    w = walks()
    model = learned.fit(w, seed=0)
    assert model.shrink == pytest.approx(1.0)  # held-out folds: the retrieved mean is right
    none = np.zeros((3, 0, 2))
    futures = model.forecast(w.observed[:3], none, none, P=1)
    np.testing.assert_allclose(futures[:, 0], w.future[:3], atol=1e-9)
    # a walk never seen, turned and faster: the same shape of turn, at its speed
    new = arc([20.0, -3.0], 2.0, 2.2, 0.3)
    futures = model.forecast(new[None, :8], none[:1], none[:1], P=5)
    assert np.abs(futures[0] - new[8:]).max() < 0.15
    assert futures.shape == (1, 5, 12, 2)


def test_training_is_deterministic_for_a_seed(tmp_path):
    w = walks()
    a, b, c = (learned.fit(w, seed=s, max_windows=100) for s in (3, 3, 4))
    a.save(tmp_path / "a.npz")
    b.save(tmp_path / "b.npz")
    c.save(tmp_path / "c.npz")
    assert learned.sha256(tmp_path / "a.npz") == learned.sha256(tmp_path / "b.npz")
    assert learned.sha256(tmp_path / "a.npz") != learned.sha256(tmp_path / "c.npz")
    again = learned.load(tmp_path / "a.npz")
    np.testing.assert_array_equal(again.features, a.features)
    assert (again.obs, again.period, again.shrink, again.seed) == (8, PERIOD, a.shrink, 3)
    none = np.zeros((4, 0, 2))
    np.testing.assert_array_equal(
        again.forecast(w.observed[:4], none, none, 6), a.forecast(w.observed[:4], none, none, 6)
    )


def test_the_nearest_neighbour_is_a_feature():
    """Two walkers alike but for a person close on their left: the model trained on people who
    step right when someone is on their left, and straight on when alone, tells them apart."""
    straight = arc([0, 0], 0.0, 1.2, 0.0)
    right = straight.copy()
    right[8:, 1] -= 0.1 * np.arange(1, 13)
    left_person = straight[:8] + [0.0, 0.6]
    n = 40
    w = types.SimpleNamespace(
        observed=np.array([straight[:8]] * 2 * n),
        future=np.array([straight[8:]] * n + [right[8:]] * n),
        neighbours=tuple([np.zeros((0, 8, 2))] * n + [left_person[None]] * n),
        source=np.arange(2 * n) % 2,
        period=PERIOD,
    )
    model = learned.fit(w, seed=0, social_weight=1.0)
    others, velocity = learned.neighbours_now([np.zeros((0, 8, 2)), left_person[None]])
    futures = model.forecast(np.array([straight[:8]] * 2), others, velocity, P=10)
    np.testing.assert_allclose(futures[0].mean(axis=0), straight[8:], atol=1e-9)
    np.testing.assert_allclose(futures[1].mean(axis=0), right[8:], atol=1e-9)


def test_the_predictor_tracks_resamples_and_extends_the_futures(tmp_path):
    p = make_predictor("learned", model=str(model_file(tmp_path, turn=(0.0,))), **SHARED)
    rng = np.random.default_rng(0)
    v = np.array([[1.0, 0.5], [-1.2, 0.0]])  # [m/s]
    start = np.array([[0.0, 0.0], [8.0, 3.0]])
    for i in range(40):  # 4 s, longer than the model's 2.8 s of observation
        now = start + v * i * 0.1
        order = [1, 0] if i % 2 else [0, 1]  # rows swap every step: matched by position
        moving = np.column_stack([now[order], np.zeros(2), [0.3, 0.3]])
        prediction = p.predict(np.array([3.0, 1.0, 0.0]), moving, None, rng)
    futures = prediction.futures  # the last step's rows: [1, 0]
    assert futures.shape == (2, 4, 31, 2)
    t = 0.1 * np.arange(31)
    expected = now[[1, 0], None] + v[[1, 0], None] * t[:, None]  # straight on beyond 4.8 s too
    np.testing.assert_allclose(
        futures, np.broadcast_to(expected[:, None], futures.shape), atol=1e-6
    )


def test_at_the_recordings_period_the_predictor_forecasts_as_the_model(tmp_path):
    """Fed one frame a step, a fast walker (1.2 m a frame) keeps its track: the futures are the
    model's forecast of its whole observed track."""
    path = model_file(tmp_path)
    shared = {**SHARED, "N": 12, "dt": PERIOD, "P": 5}
    p = make_predictor("learned", model=str(path), **shared)
    walk = arc([0.0, 0.0], 1.0, 3.0, 0.3)
    other = arc([3.0, 3.0], -2.0, 1.0, 0.0)  # a neighbour, met from the fourth frame
    for i in range(8):
        rows = [walk[i], other[i]] if i >= 3 else [walk[i]]
        moving = np.column_stack([rows, np.zeros(len(rows)), np.full(len(rows), 0.3)])
        prediction = p.predict(np.r_[walk[i], 0.0], moving, None, np.random.default_rng(0))
    np.testing.assert_array_equal(prediction.futures[0, :, 0], np.broadcast_to(walk[7], (5, 2)))
    others, velocity = learned.neighbours_now(
        [np.where(np.arange(8)[:, None] >= 3, other[:8], np.nan)[None]]
    )
    expected = learned.load(path).forecast(walk[None, :8], others, velocity, 5)
    np.testing.assert_allclose(prediction.futures[0, :, 1:], expected[0], atol=1e-9)


def test_a_new_track_is_extended_back_at_its_observed_velocity(tmp_path):
    model = model_file(tmp_path, turn=(0.0,), still=0.2)
    p = make_predictor("learned", model=str(model), **SHARED)
    moving = np.array([[1.0, 1.0, 0.0, 0.3]])
    velocity = np.array([[0.0, -1.1]])
    prediction = p.predict(np.zeros(3), moving, None, np.random.default_rng(0), velocity=velocity)
    t = 0.1 * np.arange(31)
    expected = moving[0, :2] + velocity[0] * t[:, None]
    np.testing.assert_allclose(
        prediction.futures[0], np.broadcast_to(expected, (4, 31, 2)), atol=1e-6
    )
    p.reset()
    still = p.predict(np.zeros(3), moving, None, np.random.default_rng(0))  # no velocity: stands
    np.testing.assert_allclose(
        still.futures[0], np.broadcast_to(moving[0, :2], (4, 31, 2)), atol=0.05
    )


def test_dc_plans_with_learned_futures(tmp_path):
    ctrl = make_controller(
        "dc", prediction="learned", model=str(model_file(tmp_path)), K=64, N=20, seed=0
    )
    moving = np.array([[2.0, 0.0, np.pi, 0.3]])
    omega = ctrl.act(np.zeros(3), np.array([5.0, 0.0]), None, moving, moving_velocity=[[-1, 0]])
    assert np.isfinite(omega).all()


def test_an_approximate_search_keeps_neighbours_within_its_slack(tmp_path):
    w = walks()
    model = learned.fit(w, seed=0)
    rng = np.random.default_rng(1)
    features = model.features[rng.choice(len(model.features), 20)]
    x = features + rng.normal(0, 0.3, features.shape)
    exact, _ = model.tree.query(x, k=10)
    loose, _ = model.tree.query(x, k=10, eps=1.0)
    assert np.all(loose <= 2.0 * exact + 1e-12) and np.any(loose > exact)
    none = np.zeros((3, 0, 2))
    exact = model.forecast(w.observed[:3], none, none, P=4, approximation=0.0)
    slack = model.forecast(w.observed[:3], none, none, P=4)  # the default slack
    assert slack.shape == exact.shape and np.isfinite(slack).all()
    predictor = make_predictor("learned", model=str(model_file(tmp_path)), **SHARED)
    assert predictor.approximation == learned.APPROXIMATION > 0


def test_errors_name_the_fix(tmp_path):
    with pytest.raises(ValueError, match=r"needs model=PATH.*dcmppi predictor train"):
        make_predictor("learned", **SHARED)
    with pytest.raises(ValueError, match=r"model=.*nowhere\.npz: no such file"):
        make_predictor("learned", model=str(tmp_path / "nowhere.npz"), **SHARED)
    bad = tmp_path / "bad.npz"
    np.savez(bad, x=np.zeros(2))
    with pytest.raises(ValueError, match=r"bad\.npz: not a learned predictor's model"):
        make_predictor("learned", model=str(bad), **SHARED)
    with pytest.raises(ValueError, match=r"approximation must be >= 0"):
        make_predictor("learned", model=str(model_file(tmp_path)), approximation=-1, **SHARED)


def test_a_broken_model_file_is_one_line_naming_it_and_how_to_retrain(tmp_path):
    good = model_file(tmp_path)
    data = good.read_bytes()
    model = learned.load(good)
    arrays = {"format": np.array("dcmppi-learned-1"), "seed": np.array(0)}
    arrays["settings"] = np.array([model.obs, PERIOD, model.shrink, 1, 0.3])
    cases = {
        "empty.npz": b"",
        "truncated.npz": data[: len(data) // 2],
        "corrupted.npz": data[:200] + bytes(200) + data[400:],
        "text.npz": b"0\t1\t2.0\t3.0\n",
    }
    for name, content in cases.items():
        (tmp_path / name).write_bytes(content)
    np.save(tmp_path / "array.npy", np.zeros(3))
    np.savez(tmp_path / "mismatched.npz", features=model.features[:, :-1], futures=model.futures,
             **arrays)  # fmt: skip
    for name in [*cases, "array.npy", "mismatched.npz"]:
        with pytest.raises(ValueError) as error:
            learned.load(tmp_path / name)
        message = str(error.value)
        assert message.startswith(f"{tmp_path / name}: ") and "\n" not in message, name
        assert "retrain it" in message and "pickle" not in message, message
    assert "arrays do not match (features of shape" in message


def test_a_model_is_written_atomically(tmp_path, monkeypatch):
    path = model_file(tmp_path)
    before = path.read_bytes()
    model = learned.load(path)

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(np.lib.format, "write_array", interrupted)
    with pytest.raises(KeyboardInterrupt):
        model.save(path)
    assert path.read_bytes() == before  # the old model, whole
    assert [p.name for p in tmp_path.iterdir()] == ["model.npz"]  # no part left behind
    with pytest.raises(ValueError, match=r"^max_windows must be > 0; got -5"):
        learned.fit(walks(n=20), max_windows=-5)
