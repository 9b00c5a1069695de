"""The profile's hook: a controller times the parts of its step through `controller.timer`.

`controller.timer(label)` returns a context manager around one part of a step. The default,
NO_TIMER, does nothing; `dcmppi timing --profile` sets a StepTimer, which adds up the seconds
and calls of each label. Labels: "sample", "controls", "evaluate", "rollout", "objective",
"importance", "update", "features", "DBSCAN", "cluster updates", "prediction"; with threads > 1
also "threads", the wall time of the parts together (controls, rollout, objective and
importance, whose labels then add up every thread's time). Per-step draws into a box (and a
disc) are made in the "controls" pass (Controller.sample returns a Draw), so "sample" times
only the others.
"""

import threading
import time
from collections import defaultdict


class _Nothing:
    __slots__ = ()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


_NOTHING = _Nothing()


def NO_TIMER(label):  # noqa: N802 (a constant that is called)
    """The default timer: times nothing."""
    return _NOTHING


class StepTimer:
    """Seconds and calls per label, added up until `take()` returns and clears them; the
    threads of a step's parts may time at once."""

    def __init__(self):
        self.spent = defaultdict(float)
        self.calls = defaultdict(int)
        self.lock = threading.Lock()

    def __call__(self, label):
        return _Part(self, label)

    def take(self):
        """{label: (seconds, calls)} since the last take(); clears the sums."""
        with self.lock:
            out = {label: (self.spent[label], self.calls[label]) for label in self.spent}
            self.spent.clear()
            self.calls.clear()
        return out


class _Part:
    __slots__ = ("timer", "label", "t0")

    def __init__(self, timer, label):
        self.timer, self.label = timer, label

    def __enter__(self):
        self.t0 = time.perf_counter()
        return self

    def __exit__(self, *exc):
        seconds, timer = time.perf_counter() - self.t0, self.timer
        with timer.lock:
            timer.spent[self.label] += seconds
            timer.calls[self.label] += 1
        return False
