"""`dcmppi timing --profile`: where a step's time goes, through the controllers' timer hook.

Every controller times the parts of its step with `with self.timer(label): ...`
(dcmppi.control.timer); the profile sets a StepTimer as `ctrl.timer` and takes its sums after
every step. Nothing else of the controller is replaced.
"""

import numpy as np
from threadpoolctl import threadpool_limits

from dcmppi.bench.timing.loop import SKIP, ClosedLoop
from dcmppi.control.timer import StepTimer

# The hook's labels in the order a step runs them; NESTED: {label: the label that includes it}.
LABELS = (
    "prediction",
    "sample",
    "controls",
    "evaluate",
    "rollout",
    "objective",
    "importance",
    "update",
    "features",
    "DBSCAN",
    "cluster updates",
)
NESTED = {"rollout": "evaluate", "objective": "evaluate"}


def profile_loop(loop, steps, skip=SKIP):
    """The median step and, per timed label, the median time and typical calls per step.

    loop: a ClosedLoop (or any object with `ctrl`, `step()` and `times`) not yet stepped; it
    runs `steps` steps, of which the first `skip` are left out. Returns {"step_us": float,
    "parts": {label: {"median_us_per_step": float, "calls": int}}}, labels in LABELS order
    (others after, sorted), only those timed at least once.
    """
    timer = StepTimer()
    loop.ctrl.timer = timer
    for _ in range(skip):
        loop.step()
    timer.take()
    taken = []
    for _ in range(steps - skip):
        loop.step()
        taken.append(timer.take())
    seen = {label for step in taken for label in step}
    labels = [label for label in LABELS if label in seen] + sorted(seen - set(LABELS))
    parts = {}
    for label in labels:
        seconds, calls = np.array([step.get(label, (0.0, 0)) for step in taken]).T
        parts[label] = {
            "median_us_per_step": float(np.median(seconds) * 1e6),
            "calls": int(np.median(calls)),
        }
    return {"step_us": float(np.median(np.array(loop.times[skip:]) * 1e6)), "parts": parts}


def profile(cases, steps):
    """{case label: {"problem", "step_us", "parts"}} (see profile_loop) of every case, one
    thread. The timers' own cost is in the times."""
    results = {}
    with threadpool_limits(1):
        for case in cases:
            loop = ClosedLoop(case.controller, case.problem, steps, **case.params)
            results[case.label] = {"problem": case.problem, **profile_loop(loop, steps)}
    return results


def print_profile(results, steps):
    """The results as text: per case its median step, then its parts (those within another timed
    part indented)."""
    print(f"dcmppi timing --profile: one thread, {steps} steps, median us per step")
    for case, r in results.items():
        print(f"{case} ({r['problem']}): step {r['step_us']:.0f} us")
        for label, part in r["parts"].items():
            name = f"  {label}" if NESTED.get(label) in r["parts"] else label
            us, calls = part["median_us_per_step"], part["calls"]
            print(f"  {name:<20} {us:7.1f} us ({calls} call{'s' if calls > 1 else ''})")
