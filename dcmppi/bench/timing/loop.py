"""A controller in a closed loop on a timing problem, and interleaved timing of many loops."""

import time

import numpy as np

from dcmppi.control import make_controller

from .worlds import crowd, forest, move_crowd, obstacle_model, push, pushed

PROBLEMS = ("forest", "forest+push", "crowd")
SKIP = 3  # first steps left out of the figures: they build the cost map and load the kernels
BLOCK = 10  # consecutive steps of one case before the next case's


class ClosedLoop:
    """One controller driving the analytic model on a timing problem, one timed step at a time.

    Args:
      name: controller name; params: its parameters (seed = 0).
      problem: one of PROBLEMS.
      steps: the number of steps the loop will run (the length of forest+push's offsets).
    """

    def __init__(self, name, problem, steps, **params):
        if problem not in PROBLEMS:
            raise ValueError(f"unknown timing problem {problem!r}; valid: {', '.join(PROBLEMS)}")
        if problem == "forest+push":
            params = {"reset_threshold": 0.0, **params}
        self.ctrl = make_controller(name, seed=0, **params)
        self.offsets = push(steps) if problem == "forest+push" else None
        if problem in ("forest", "forest+push"):
            self.static, self.state, self.goal = forest()
            self.moving = self.model = None
        else:
            self.static, self.state = None, np.array([2.0, 25.0, 0.0])
            self.goal = np.array([73.0, 25.0])
            self.moving, self.speed, self.turn = crowd()
            self.model = obstacle_model()
        self.times = []

    def step(self):
        """One control step; its controller time is appended to `times` [s]. Returns the
        action (nu,)."""
        ctrl = self.ctrl
        t0 = time.perf_counter()
        u = ctrl.act(self.state, self.goal, self.static, self.moving, self.model)
        self.times.append(time.perf_counter() - t0)
        self.state = ctrl.agent.step(self.state, u, ctrl.dt)
        if self.offsets is not None:
            self.state = pushed(self.state, self.offsets[len(self.times) - 1])
        if self.moving is not None:
            self.moving = move_crowd(self.moving, self.speed, self.turn, ctrl.dt)
        return u

    def summary(self):
        """Median and p95 ms per step, skipping the first SKIP steps."""
        times = np.array(self.times[SKIP:]) * 1e3
        return float(np.median(times)), float(np.percentile(times, 95))


def time_cases(cases, steps, block=BLOCK):
    """(median, p95) ms per step of every case (cases.Case), in order.

    The closed loops of one problem family (forest, crowd) run interleaved in blocks of
    `block` steps, each case in turn, so a change in machine load affects them alike and the
    ratios stay meaningful on a busy machine, while a block's steps find their data in the
    caches as consecutive control steps do (block = 1: every step after another controller's,
    cold, about 1.5 x slower); the families run one after the other.
    """
    loops = [ClosedLoop(c.controller, c.problem, steps, **c.params) for c in cases]
    families = {}
    for loop, case in zip(loops, cases, strict=True):
        families.setdefault(case.problem.split("+")[0], []).append(loop)
    for family in families.values():
        for start in range(0, steps, block):
            for loop in family:
                for _ in range(min(block, steps - start)):
                    loop.step()
    return [loop.summary() for loop in loops]
