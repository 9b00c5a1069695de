"""Controllers of a user's own module, for tests of `package.module:ClassName` and entry points.

Importable from every test folder and the test process's workers: tests/conftest.py puts tests/
on sys.path, spawned workers inherit it, Ray's get it from `plugins.import_roots`.
"""

import numpy as np

from dcmppi.control.planners.mppi import MPPI


class Straight:
    """Turns toward the goal at a bounded rate (Dubins: one control); no diagnostics."""

    built = 0  # instances made in this process
    acted = 0  # act() calls in this process

    def __init__(self, gain=1.0, seed=None):
        self.gain = gain
        self.seed = seed
        Straight.built += 1

    def reset(self):
        pass

    def act(self, state, goal, static, moving, obstacle_model):
        Straight.acted += 1
        heading = np.arctan2(goal[1] - state[1], goal[0] - state[0])
        error = (heading - state[2] + np.pi) % (2 * np.pi) - np.pi
        return np.array([np.clip(self.gain * error, -1.0, 1.0)])


class Anything(Straight):
    """Takes any keyword argument."""

    def __init__(self, **params):
        super().__init__()
        self.params = params


class Careful(MPPI):
    """A dcmppi.Controller subclass with a parameter of its own."""

    own_params = ("care",)

    def __init__(self, care=1.0, **params):
        self.care = care
        super().__init__(**params)


class NoAct:
    def reset(self):
        pass


def factory(**params):
    return Straight(**params)
