"""`dcmppi timing --against pytorch_mppi`: the peer's problem equals ours (dynamics, cost, plan
from the same perturbations), and the flag without torch or pytorch-mppi says how to install."""

import json
import sys

import numpy as np
import pytest

from dcmppi import cli
from dcmppi.bench.timing import peer
from dcmppi.bench.timing.loop import ClosedLoop
from dcmppi.bench.timing.worlds import world
from dcmppi.control import make_controller
from dcmppi.control.agents import make_agent
from dcmppi.control.kernels.costs import OccupancyGrid


def test_against_without_the_packages_prints_the_install_command(monkeypatch, capsys):
    # the command line loads the planners (scipy.stats), whose array API shim reads
    # sys.modules["torch"] on import: loaded first, as with torch absent
    make_controller("clustered")
    monkeypatch.setitem(sys.modules, "torch", None)  # `import torch` raises ImportError
    assert cli.main(["timing", "--against", "pytorch_mppi", "--steps", "5"]) == 2
    out = capsys.readouterr()
    assert out.out == ""
    assert out.err.count("\n") == 1
    assert "missing: torch" in out.err
    assert "pip install torch==2.13.0 pytorch-mppi" in out.err
    assert 'pip install "dcmppi[peer]"' in out.err


def _peer():
    torch = pytest.importorskip("torch")
    pytest.importorskip("pytorch_mppi")
    return torch


FOREST = world("forest")  # timing's forest
STATIC, GOAL, BOUNDS = FOREST.static, FOREST.goal, FOREST.map_bounds
SOLID = STATIC[STATIC[:, 2] > 0]
NEAR = SOLID[np.argmin(np.hypot(*(SOLID[:, :2] - FOREST.start[:2]).T))]  # nearest the start
AHEAD = (NEAR[:2] - FOREST.start[:2]) / np.hypot(*(NEAR[:2] - FOREST.start[:2]))
START = np.array([*(NEAR[:2] - (NEAR[2] + 2.0) * AHEAD), np.arctan2(*AHEAD[::-1])])  # 2 m before


def _problem(**params):
    """A small controller after one step from START and the peer's problem: ctrl.evaluate then
    sees the same start, goal, static map and bounds."""
    ctrl = make_controller("mppi", seed=0, perturbation="time_varying", **params)
    ctrl.act(START, GOAL, STATIC, bounds=BOUNDS)
    return ctrl, peer.PeerProblem(ctrl, STATIC, GOAL, BOUNDS)


def test_dynamics_equal_our_agents_step():
    torch = _peer()
    ctrl, problem = _problem(K=8, N=5)
    rng = np.random.default_rng(1)
    states = rng.uniform([-100, -100, -10], [100, 100, 10], (1000, 3))
    omega = rng.uniform(-3, 3, (1000, 1))  # beyond the bounds too: the arc, not its clipping
    omega[:10] = 0.0  # straight lines: sinc(0)
    ours = make_agent("dubins").step(states, omega, ctrl.dt)
    theirs = problem.dynamics(torch.from_numpy(states), torch.from_numpy(omega)).numpy()
    np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-9)


def test_cost_of_rollouts_equals_evaluate():
    torch = _peer()
    ctrl, problem = _problem(K=8, N=30)
    rng = np.random.default_rng(2)
    # (N, nu, R) within the bounds: a fan of arcs, from hard right to hard left
    u = np.clip(np.linspace(-1, 1, 64) + rng.normal(0, 0.3, (ctrl.N, 1, 64)), -1, 1)
    states, J = ctrl.rollout_costs(START, u)
    theirs = problem.cost(START, torch.from_numpy(u.transpose(2, 0, 1))).numpy()
    hits = OccupancyGrid(STATIC, ctrl.robot_radius, ctrl.resolution, BOUNDS).count(*states[:2])
    assert 0 < np.count_nonzero(hits) < len(hits)  # the occupancy lookup matters
    assert len(np.unique(hits)) > 3
    np.testing.assert_allclose(theirs, J, rtol=1e-6)


@pytest.mark.parametrize("K, N", [(200, 30), (64, 20)])
def test_pytorch_mppi_plans_as_ours_from_the_same_perturbations(K, N):
    """Same start, warm start and perturbations: the configured peer's plan is ours (the x_0
    cost it leaves out shifts every sample's S alike). The warm start turns, so the control
    cost lambda U^T Sigma^-1 eps matters, and its end is 0, pytorch_mppi's u_init."""
    torch = _peer()
    ctrl, problem = _problem(K=K, N=N)
    ctrl.reset(seed=0)
    U0 = np.linspace(0.9, 0.0, ctrl.N)[:, None]  # (N, nu)
    ctrl.U = U0.copy()
    eps = np.asarray(ctrl.sample())  # (N, nu, K)
    ctrl.sample = lambda: eps
    ctrl.act(START, GOAL, STATIC)
    mppi = peer.make_peer(ctrl, problem)
    assert (mppi.K, mppi.T) == (K, N)
    mppi.U = torch.roll(torch.from_numpy(U0), 1, 0)  # command() shifts it back to U0 first
    noise = torch.from_numpy(np.ascontiguousarray(eps.transpose(2, 0, 1)))  # (K, N, nu)
    mppi._sample_noise = lambda shape: noise
    mppi.command(torch.from_numpy(START))
    plan = ctrl.diagnostics.plan
    assert np.abs(plan - U0).max() > 0.05  # the update moved the plan
    assert np.any(np.abs(U0 + eps[:, :, 0]) > 1)  # some sampled controls were clipped
    np.testing.assert_allclose(mppi.U.numpy(), plan, rtol=0, atol=1e-6)


def test_passing_names_the_first_cylinder_on_the_way_not_a_padding_row():
    static = np.array([[3.0, 0.0, 0.0], [5.0, 0.0, 1.0]])  # a radius-0 row on the line first
    x = np.linspace(0, 10, 11)
    path = np.column_stack([x, 0.4 * x])  # 1.2 m left of the padding row, 2 m of the cylinder
    phrase = peer.passing(static, np.zeros(3), np.array([10.0, 0.0]), 0.5, [path, -path * [-1, 1]])
    assert (
        phrase
        == "they pass the first obstacle on the way on its left (+2.000 m) and right (-2.000 m)"
    )


def test_the_peer_needs_a_fixed_temperature():
    ctrl = make_controller("mppi", seed=0, lambda_="auto")
    with pytest.raises(ValueError, match="pytorch_mppi has a fixed temperature"):
        peer.make_peer(ctrl, None)


def test_against_takes_the_problem_size(capsys):
    _peer()
    argv = ["--against", "pytorch_mppi", "--K", "64", "--N", "20", "--steps", "5", "--json"]
    assert cli.main(["timing", *argv]) == 0
    result = json.loads(capsys.readouterr().out)
    assert (result["settings"]["K"], result["settings"]["N"]) == (64, 20)
    ours = ClosedLoop("mppi", "forest", 5, perturbation="time_varying", K=64, N=20)
    theirs = peer.PeerLoop(ours).mppi
    assert (theirs.K, theirs.T) == (64, 20)


def test_against_times_our_threads_in_the_same_run(capsys):
    """--threads 2: a third row, ours on two threads, interleaved; it drives the same path."""
    _peer()
    argv = ["--against", "pytorch_mppi", "--K", "200", "--N", "15", "--steps", "8"]
    assert cli.main(["timing", *argv, "--threads", "2", "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    t = result["threaded"]
    assert t["threads"] == 2 and t["same_path"] and t["median_ms"] > 0
    assert t["speedup"] == pytest.approx(result["ours"]["median_ms"] / t["median_ms"])
    assert sorted(t["speedup_blocks"]) == t["speedup_blocks"] and len(t["speedup_blocks"]) == 3
    gains = result["machine_gains"]
    assert gains["threads"] == 2 and min(gains[k] for k in ("compute", "vector", "stream")) > 0
    assert cli.main(["timing", *argv, "--threads", "2"]) == 0
    out = capsys.readouterr().out
    assert "mppi (dcmppi, threads=2)" in out and "ours / ours with threads=2 = " in out
    assert "the same path: yes" in out
    assert "this machine, 2 threads at once (the bounds of a split): scalar arithmetic " in out
    assert ", vector arithmetic in L1 " in out
    assert "between the quartiles" in out and ", per block " in out
    assert cli.main(["timing", *argv, "--json"]) == 0
    assert not {"threaded", "machine_gains"} & json.loads(capsys.readouterr().out).keys()


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["--against", "pytorch_mppi", "--K", "0"],
            "--K must be a whole number in 1 .. 100000; got 0",
        ),
        (["--against", "pytorch_mppi", "--N", "2.5"], "argument --N: invalid int value: '2.5'"),
        (["--N", "100"], "--N sets the size of --against's problem: add --against pytorch_mppi"),
        (["--out", "x"], "--out is where --scaling writes its JSON and plot; add --scaling"),
        (
            ["--threads", "2"],
            "--threads is --against's second row of ours: add --against pytorch_mppi",
        ),
        (
            ["--against", "pytorch_mppi", "--threads", "0"],
            "--threads must be a whole number in 1 .. 64; got 0",
        ),
    ],
)
def test_a_bad_size_is_one_line_naming_it(argv, message, capsys):
    with pytest.raises(SystemExit) as exit:
        cli.main(["timing", *argv])
    assert exit.value.code == 2
    out = capsys.readouterr()
    assert out.out == "" and out.err == f"dcmppi timing: error: {message} (see --help)\n"


def test_block_ratios_are_the_quartiles_of_each_blocks_medians():
    """Per block of interleaved steps, median over median; the warm-up steps left out."""

    class Loop:
        def __init__(self, times):
            self.times = times

    slow = Loop([9.0, 9.0, 9.0, 2.0, 2.0, 2.0, 4.0, 4.0, 4.0, 6.0, 6.0, 6.0])
    fast = Loop([1.0] * 12)
    # blocks of 3: the first is warm-up only; then ratios 2, 4, 6
    assert peer.block_ratios(slow, fast, 3) == [3.0, 4.0, 5.0]
    # blocks of 4: steps 3 (the first after warm-up), 4-7, 8-11: 2, 3 and 6
    assert peer.block_ratios(slow, fast, 4) == [2.5, 3.0, 4.5]
    # ratios 1/2, 1/4, 1/6: quartiles halfway between neighbours
    assert peer.block_ratios(fast, slow, 3) == pytest.approx([5 / 24, 1 / 4, 3 / 8])
