"""A controller in a closed loop on a timing problem, and interleaved timing of many loops."""

import time

import numpy as np

from dcmppi.bench.timing.cases import with_model
from dcmppi.bench.timing.worlds import (
    PEDESTRIANS,
    moving_crowd,
    observed,
    pedestrian_task,
    push,
    pushed,
    walking_crowd,
)
from dcmppi.bench.timing.worlds import world as family_world  # `world` is ClosedLoop's argument
from dcmppi.control import make_controller

PROBLEMS = ("forest", "forest+push", "crowd", *PEDESTRIANS)
SKIP = 3  # first steps left out of the figures: they build the cost map and load the kernels
BLOCK = 10  # consecutive steps of one case before the next case's


class ClosedLoop:
    """One controller driving the analytic model on a timing problem, one timed step at a time.

    Its act() sees what the task would observe (static, moving, obstacle model, map bounds and,
    among pedestrians, moving_velocity (L, 2); else None). On a pedestrian problem the robot
    has the task's radius and the pedestrians advance once per step, from the robot's position
    at the step's start and its velocity over the step before.

    Args:
      name: controller name; params: its parameters (seed = 0; a model recipe for `model`:
        the path of its trained file, `cases.with_model`).
      problem: one of PROBLEMS.
      steps: the number of steps the loop will run (the length of forest+push's offsets).
      world: a World of the problem's family drawn by its generator with other counts
        (worlds.world, worlds.dense_forest), or None: the problem's own. Not for pedestrians.
    """

    def __init__(self, name, problem, steps, world=None, **params):
        if problem not in PROBLEMS:
            raise ValueError(f"unknown timing problem {problem!r}; valid: {', '.join(PROBLEMS)}")
        if world is not None and problem in PEDESTRIANS:
            raise ValueError(f"a pedestrian problem ({problem!r}) builds its own world")
        if problem == "forest+push":
            params = {"reset_threshold": 0.0, **params}
        params = with_model(params)
        walking = problem in PEDESTRIANS
        if walking:
            task, random = pedestrian_task(problem)
            w = task.world
            params = {"robot_radius": task.robot_radius, **params}  # the task's robot
        else:
            w = family_world(problem.split("+")[0]) if world is None else world
        self.ctrl = make_controller(name, seed=0, **params)
        self.offsets = push(steps) if problem == "forest+push" else None
        self.state, self.goal = np.array(w.start), w.goal
        self.static, self.bounds = w.static, w.map_bounds
        self.model, self.moving, self.radius = w.obstacle_model, w.moving, w.moving[:, 3]
        if walking:
            self.crowd = walking_crowd(task, random, self.ctrl.dt)
            self.velocity = self.crowd.velocity.copy()  # moving_velocity (L, 2), observed
            self.robot_velocity = np.zeros(2)  # the robot's (vx, vy) at the step's start
        else:
            self.crowd = moving_crowd(w, self.ctrl.dt) if len(w.moving) else None
            self.velocity = None
        self.times = []
        self.periods = 0  # control periods the world has moved

    def step(self):
        """One control step (`act`, then `advance` by its action). Returns the action (nu,)."""
        u = self.act()
        self.advance(u)
        return u

    def act(self):
        """The controller's action (nu,) now; its time is appended to `times` [s]."""
        t0 = time.perf_counter()
        u = self.ctrl.act(
            self.state, self.goal, self.static, self.moving, self.model, self.bounds,
            moving_velocity=self.velocity,
        )  # fmt: skip
        self.times.append(time.perf_counter() - t0)
        return u

    def advance(self, u):
        """One control period under action u (nu,), whoever chose it (a replay of another
        loop's actions): the robot moves (and on forest+push is pushed), the obstacles with it."""
        ctrl = self.ctrl
        start = self.state
        self.state = ctrl.agent.step(self.state, u, ctrl.dt)
        if self.offsets is not None:
            self.state = pushed(self.state, self.offsets[self.periods])
        self.periods += 1
        if self.velocity is not None:  # pedestrians: they plan the step from its start
            self.crowd.advance(1, start[:2], self.robot_velocity)
            self.robot_velocity = (self.state[:2] - start[:2]) / ctrl.dt
            self.velocity = self.crowd.velocity.copy()
        elif self.crowd is not None:
            self.crowd.advance(1)
        if self.crowd is not None:
            self.moving = observed(self.crowd, self.radius)

    def summary(self):
        """Median and p95 ms per step, skipping the first SKIP steps."""
        times = np.array(self.times[SKIP:]) * 1e3
        return float(np.median(times)), float(np.percentile(times, 95))


def time_cases(cases, steps, block=BLOCK):
    """(median, p95) ms per step of every case (cases.Case), in order.

    The closed loops of one problem family (forest, crowd, corridor, crowd-sf) run interleaved
    in blocks of `block` steps, each case in turn, so a change in machine load affects them
    alike and the ratios stay meaningful on a busy machine, while a block's steps find their
    data in the caches as consecutive control steps do (block = 1: every step after another
    controller's, cold, about 1.5 x slower); the families run one after the other.
    """
    loops = [ClosedLoop(c.controller, c.problem, steps, **c.params) for c in cases]
    families = {}
    for loop, case in zip(loops, cases, strict=True):
        families.setdefault(case.problem.split("+")[0], []).append(loop)
    for family in families.values():
        interleave(family, steps, block)
    return [loop.summary() for loop in loops]


def interleave(loops, steps, block=BLOCK):
    """Run every loop `steps` steps, in blocks of `block` consecutive steps, each loop in turn."""
    for start in range(0, steps, block):
        for loop in loops:
            for _ in range(min(block, steps - start)):
                loop.step()
