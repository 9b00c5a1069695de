"""Analytic Dubins models: exact over a control period, consistent batched and single forms."""

import numpy as np

from dcmppi.control.kernels.dynamics import (
    dubins_step,
    obstacle_futures,
    rollout,
    rollout_time_major,
    sinc,
)


def fine_euler(state, U, v, dt, sub=2000):
    x, y, th = state
    for w in U:
        h = dt / sub
        for _ in range(sub):
            x += v * h * np.cos(th + 0.5 * w * h)
            y += v * h * np.sin(th + 0.5 * w * h)
            th += w * h
    return np.array([x, y, th])


def test_rollout_matches_fine_integration():
    rng = np.random.default_rng(0)
    U = rng.uniform(-1, 1, (3, 8))
    state = np.array([1.0, -2.0, 0.7])
    states = rollout(state, U, 1.3, 0.1)
    assert states.shape == (3, 9, 3)
    for k in range(3):
        np.testing.assert_allclose(states[k, -1], fine_euler(state, U[k], 1.3, 0.1), atol=1e-5)
    np.testing.assert_allclose(states[:, 0], np.broadcast_to(state, (3, 3)), atol=1e-15)


def test_rollout_agrees_with_single_steps_and_straight_line():
    U = np.array([0.0, 0.5, -1.0, 0.0])
    s = np.array([0.0, 0.0, 0.3])
    states = rollout(s, U, 1.0, 0.1)
    for i, w in enumerate(U):
        s = dubins_step(s, w, 1.0, 0.1)
        np.testing.assert_allclose(states[i + 1], s, atol=1e-6)
    straight = rollout(np.zeros(3), np.zeros(5), 2.0, 0.1)
    np.testing.assert_allclose(straight[:, 0], np.arange(6) * 0.2, atol=1e-7)
    np.testing.assert_allclose(straight[:, 1], 0.0, atol=1e-7)


def test_sinc_series_and_exact_branch_agree():
    a = np.linspace(-0.09, 0.09, 101)
    np.testing.assert_allclose(sinc(a), np.sinc(a / np.pi), rtol=1e-13)
    assert sinc(np.array([2.0]))[0] == np.sin(2.0) / 2.0


def test_obstacle_futures_follow_dubins_arcs():
    obstacles = np.array([[5.0, 5.0, 1.0, 1.0], [0.0, 0.0, -2.0, 1.0]])
    speed = np.array([[1.0, 0.5], [1.5, 0.0]])
    turn = np.array([[0.3, 0.0], [-0.5, 0.2]])
    fut = obstacle_futures(obstacles, speed, turn, 6, 0.1)
    assert fut.shape == (2, 2, 7, 2)
    for l in range(2):
        for p in range(2):
            s = obstacles[l, :3]
            for i in range(1, 7):
                s = dubins_step(s, turn[l, p], speed[l, p], 0.1)
                np.testing.assert_allclose(fut[l, p, i], s[:2], atol=1e-12)


def test_sharp_turns_and_shared_start_states():
    """Turns beyond sinc's series (|omega dt / 2| >= 0.1) integrate exactly too; S start states
    sharing the controls equal S separate batches."""
    rng = np.random.default_rng(3)
    U = rng.uniform(-6, 6, (2, 6))  # up to 6 rad/s: a = 0.3
    state = np.array([0.5, 1.0, -2.0])
    states = rollout(state, U, 1.0, 0.1)
    for k in range(2):
        np.testing.assert_allclose(states[k, -1], fine_euler(state, U[k], 1.0, 0.1), atol=1e-5)
    starts = rng.normal(0, 3, (3, 2))
    omega = rng.uniform(-0.4, 0.4, (7, 5))
    both = rollout_time_major(starts, omega, 1.0, 0.1, starts=2)
    for s in range(2):
        alone = rollout_time_major(starts[:, s], omega, 1.0, 0.1)
        np.testing.assert_array_equal(both[..., 5 * s : 5 * (s + 1)], alone)


def test_obstacle_futures_equal_the_closed_form_arcs():
    """The rotation recurrence (and sinc's series for tiny turn rates) against numpy's closed
    form v t sinc(w t / 2) along theta + w t / 2: equal to 1e-12 m over 5 s."""
    rng = np.random.default_rng(0)
    L, P, n, dt = 12, 25, 50, 0.1
    pose = np.column_stack([rng.uniform(0, 75, L), rng.uniform(0, 50, L), rng.uniform(-7, 7, L)])
    v = np.maximum(rng.normal(1.0, 0.3, (L, P)), 0.0)
    w = rng.normal(0.0, 0.5, (L, P))
    w[:, :3] = [0.0, 1e-7, -1.9e-2]  # straight, tiny (series), just above the recurrence's limit
    t = np.arange(n + 1) * dt
    half = 0.5 * w[..., None] * t
    dist = v[..., None] * t * np.sinc(half / np.pi)
    heading = pose[:, 2, None, None] + half
    expected = np.stack(
        [
            pose[:, 0, None, None] + dist * np.cos(heading),
            pose[:, 1, None, None] + dist * np.sin(heading),
        ],
        axis=-1,
    )
    np.testing.assert_allclose(obstacle_futures(pose, v, w, n, dt), expected, rtol=0, atol=1e-12)


def test_one_state_steps_as_a_batch_of_one_bit_for_bit():
    rng = np.random.default_rng(11)
    for k in range(2000):
        state = rng.normal(size=3) * (10.0, 10.0, 4.0)
        omega = 0.0 if k % 9 == 0 else rng.normal() * (0.05, 3.0)[k % 2]  # both sinc branches
        one = dubins_step(state, omega, 1.0, 0.1)
        batch = dubins_step(state[None], np.array([omega]), 1.0, 0.1)[0]
        assert one.shape == (3,) and one.tobytes() == batch.tobytes()


def test_carried_headings_stay_on_the_exact_arcs():
    """The rollout turns each heading's cosine and sine step by step: over 400 steps of gentle
    (series) and sharp (libm) arcs, from two start states, the positions stay within 1e-11 m of
    the arcs' closed form with numpy's cosine and sine of the exact headings."""
    rng = np.random.default_rng(5)
    n, k, dt, v = 400, 96, 0.1, 1.0
    omega = rng.uniform(-1.0, 1.0, (n, k))
    omega[:, ::3] = rng.uniform(-8.0, 8.0, (n, 32))  # a = omega dt / 2 up to 0.4: libm's sincos
    starts = np.array([[0.5, -30.0], [1.0, 12.0], [3.0, -2.5]])
    got = rollout_time_major(starts, omega, v, dt, starts=2).reshape(3, n + 1, 2, k)
    a = 0.5 * omega * dt
    chord = v * dt * sinc(a)
    for s in range(2):
        heading = np.empty((n + 1, k))
        heading[0] = (starts[2, s] + np.pi) % (2.0 * np.pi) - np.pi
        for i in range(n):
            heading[i + 1] = heading[i] + (a[i] + a[i])
        assert np.array_equal(got[2, :, s], heading)  # the headings themselves are summed
        x = starts[0, s] + np.vstack([np.zeros(k), np.cumsum(chord * np.cos(heading[:-1] + a), 0)])
        y = starts[1, s] + np.vstack([np.zeros(k), np.cumsum(chord * np.sin(heading[:-1] + a), 0)])
        np.testing.assert_allclose(got[0, :, s], x, rtol=0, atol=1e-11)
        np.testing.assert_allclose(got[1, :, s], y, rtol=0, atol=1e-11)
