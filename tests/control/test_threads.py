"""threads=: the samples' work split over threads gives the plans of one thread, bit for bit."""

import dataclasses
import multiprocessing
import os
import threading
import time

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

import dcmppi
from dcmppi.control import controller_class
from dcmppi.control.kernels.dynamics import arc_columns, dubins_step
from dcmppi.control.kernels.threads import ALIGN, parts, run
from dcmppi.control.planners.tube import TubeMPPI

GOAL = np.array([12.0, 1.0])
STATIC = np.array([[4.0, 0.5, 0.6], [7.0, -1.0, 0.8], [9.0, 2.0, 0.5]])
MODEL = np.array([0.8, 0.2, 0.0, 0.3])  # v_mean, v_std, omega_mean, omega_std
PUSH = np.array([0.03, -0.02, 0.01])  # tube: the real state leaves the nominal every step


def moving(step):
    """(4, 4) moving cylinders at step `step`: crossing the robot's way."""
    x = np.array([5.0, 8.0, 10.0, 3.0]) - 0.08 * step
    y = np.array([-2.0, 2.5, 0.0, 3.0]) + 0.05 * step
    return np.column_stack([x, y, np.full(4, np.pi), np.full(4, 0.4)])


def closed_loop(name, agent, threads, steps=4, **params):
    """The actions and per-step diagnostics of `steps` closed-loop steps."""
    ctrl = dcmppi.make_controller(name, agent=agent, K=300, N=20, seed=3, threads=threads, **params)
    return drive(ctrl, steps)


def drive(ctrl, steps):
    """The actions and per-step diagnostics of the controller `ctrl` in `steps` closed-loop steps
    (tube: the real state pushed off the nominal every step)."""
    state, actions, records = np.array([0.0, 0.0, 0.2]), [], []
    push = PUSH if isinstance(ctrl, TubeMPPI) else 0.0
    for step in range(steps):
        u = ctrl.act(state, GOAL, STATIC, moving(step), MODEL, bounds=(-5, -5, 20, 8))
        actions.append(u)
        records.append(dataclasses.asdict(ctrl.diagnostics))
        state = ctrl.agent.step(state, u, ctrl.dt) + push
    return np.array(actions), records


def assert_same(a, b, path=""):
    """Values equal bit for bit (nan equal to nan), recursing into dicts and predictions."""
    if isinstance(a, dict):
        assert a.keys() == b.keys(), path
        for key in a:
            assert_same(a[key], b[key], f"{path}.{key}")
    elif dataclasses.is_dataclass(a):
        assert_same(dataclasses.asdict(a), dataclasses.asdict(b), path)
    elif isinstance(a, (np.ndarray, float, int, np.floating)) and not isinstance(a, bool):
        a, b = np.asarray(a), np.asarray(b)
        assert a.shape == b.shape and np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), path
    else:
        assert a == b, path


@pytest.mark.parametrize("agent", ["dubins", "unicycle", "holonomic"])
@pytest.mark.parametrize("name", ["mppi", "clustered", "dc", "tube"])
def test_two_threads_plan_as_one(name, agent):
    with threadpool_limits(1):  # BLAS's own threads split its products by its own rule
        one, records_one = closed_loop(name, agent, threads=1)
        two, records_two = closed_loop(name, agent, threads=2)
    assert np.array_equal(one, two)
    for a, b in zip(records_one, records_two, strict=True):
        assert_same(a, b)
    assert records_one[-1]["J"].std() > 0  # the samples differ: a split could show


def test_three_threads_and_the_auto_temperature():
    with threadpool_limits(1):
        one, _ = closed_loop("clustered", "holonomic", 1, lambda_="auto")
        three, _ = closed_loop("clustered", "holonomic", 3, lambda_="auto")
    assert len(parts(300, 3)) == 3 and np.array_equal(one, three)


class HalfPerturbations:
    """Its own controls(): half of every perturbation, an array or a Draw."""

    def controls(self, r, cols):
        self.calls.append(cols)
        super().controls(dataclasses.replace(r, eps=0.5 * np.asarray(r.eps)), cols)


class HeadingCost:
    """Its own evaluate(): the final heading's square added to J."""

    def evaluate(self, r, cols):
        self.calls.append(cols)
        super().evaluate(r, cols)
        for c0, c1 in r.spans(cols):
            r.J[c0:c1] += 100.0 * r.states[2, -1, c0:c1] ** 2


class HalfImportance:
    """Its own importance(): half of the importance term."""

    def importance(self, r, cols):
        self.calls.append(cols)
        super().importance(r, cols)
        r.importance[cols[0] : cols[1]] *= 0.5


@pytest.mark.parametrize("seam", [HalfPerturbations, HeadingCost, HalfImportance])
@pytest.mark.parametrize("perturbation", ["constant", "time_varying"])
@pytest.mark.parametrize("name", ["mppi", "clustered", "tube"])
def test_a_replaced_seam_is_called_for_every_part_and_plans_alike_on_any_threads(
    seam, perturbation, name
):
    """A subclass's own controls(), evaluate() or importance() is called for every part of the
    samples, whatever the threads, and plans alike on one thread and two (tube: from two start
    states); it changes the plans."""
    base = controller_class(name)
    own = type(seam.__name__, (seam, base), {})
    params = dict(K=256, N=10, seed=0, perturbation=perturbation)
    runs = []
    with threadpool_limits(1):
        for threads in (1, 2):
            ctrl = own(threads=threads, **params)
            ctrl.calls = []
            runs.append(drive(ctrl, 3))
            for part in parts(256, threads):  # once a batch, 3 steps (tube: 2 batches a step)
                assert ctrl.calls.count(part) >= 3  # clustered: its clusters' evaluate() too
        (one, records_one), (two, records_two) = runs
        assert len(parts(256, 2)) == 2 and np.array_equal(one, two)
        for a, b in zip(records_one, records_two, strict=True):
            assert_same(a, b)
        plain, _ = drive(base(**params), 3)
    assert not np.array_equal(one, plain)


def test_sharp_arcs_in_one_part_only():
    """An arc beyond sinc's series in one part: each arc takes its own sinc, so a part rolled
    out alone gives the whole batch's columns, and the sharp arc is exact."""
    ctrl = dcmppi.make_controller("mppi", r_min=0.1, K=300, N=20, seed=0, threads=2)
    state = np.zeros(3)
    ctrl.act(state, GOAL)  # sets the warm start and the step's objective
    eps = np.zeros((ctrl.N, 1, ctrl.K))
    eps[:, 0, 250] = 8.0  # |omega dt / 2| = 0.4: beyond the series, in the second part
    eps[:, 0, :250] = np.linspace(-0.5, 0.5, 250)  # within it
    with threadpool_limits(1):
        split = ctrl.perturbed_rollouts(state, eps)
        ctrl.threads = 1
        whole = ctrl.perturbed_rollouts(state, eps)
    for field in ("u", "e", "products", "states", "J", "importance"):
        assert np.array_equal(getattr(split, field), getattr(whole, field)), field
    u = np.clip(ctrl.U[:, :, None] + eps, -10.0, 10.0)
    out = np.zeros((3, ctrl.N + 1, 1, ctrl.K))
    arc_columns(out, u, ctrl.dt, 1.0, (0, 192))
    assert np.array_equal(out[:, :, 0, :192], whole.states[:, :, :192])
    omega = u[:, 0, 250]
    x = np.zeros(3)
    for w in omega:  # libm's sines: the exact arc of dubins_step
        x = dubins_step(x, w, 1.0, ctrl.dt)
    assert abs(omega[0] * ctrl.dt / 2) > 0.1
    np.testing.assert_allclose(whole.states[:, -1, 250], x, rtol=0, atol=1e-12)


def test_parts_cover_the_samples_at_aligned_boundaries():
    for k, threads in [(300, 2), (2048, 2), (2048, 3), (500, 4), (64, 2), (1, 8)]:
        ranges = parts(k, threads)
        assert ranges[0][0] == 0 and ranges[-1][1] == k and len(ranges) <= threads
        for (_, end), (start, _) in zip(ranges[:-1], ranges[1:], strict=True):
            assert end == start and start % ALIGN == 0
    assert parts(64, 2) == ((0, 64),)


@pytest.mark.parametrize("bad", [0, -1, 1.5, "2", True, None])
def test_threads_must_be_a_positive_integer(bad):
    with pytest.raises(ValueError, match="^threads must be"):
        dcmppi.make_controller("mppi", threads=bad)


def test_run_gives_each_part_in_order_and_uses_other_threads():
    ranges = parts(4 * ALIGN, 4)
    together = threading.Barrier(4, timeout=10)  # passed only if the four parts run at once
    seen = []

    def part(j0, j1):
        seen.append(threading.get_ident())
        together.wait()
        return j0, j1

    assert run(part, ranges) == list(ranges)
    assert len(set(seen)) == 4 and threading.get_ident() in seen


@pytest.mark.parametrize("failing", [0, 1])
def test_run_raises_a_parts_error_after_every_part_is_done(failing):
    finished = []

    def part(j0, j1):
        if j0 == failing * ALIGN:
            raise ValueError(f"part {j0}")
        time.sleep(0.02)
        finished.append(j0)

    with pytest.raises(ValueError, match=f"part {failing * ALIGN}"):
        run(part, parts(3 * ALIGN, 3))
    assert len(finished) == 2  # the others were not left writing
    assert run(lambda j0, j1: j1 - j0, parts(2 * ALIGN, 2)) == [ALIGN, ALIGN]  # workers go on


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs fork")
def test_run_works_in_a_child_forked_after_the_workers_started():
    assert run(lambda j0, j1: j0, parts(2 * ALIGN, 2)) == [0, ALIGN]  # the parent's workers
    context = multiprocessing.get_context("fork")
    out = context.Queue()
    child = context.Process(target=lambda: out.put(run(lambda j0, j1: j1, parts(2 * ALIGN, 2))))
    child.start()
    child.join(timeout=30)
    alive = child.is_alive()
    if alive:
        child.kill()
    assert not alive and child.exitcode == 0  # the parent's workers would leave it waiting
    assert out.get(timeout=5) == [ALIGN, 2 * ALIGN]
