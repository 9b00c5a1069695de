"""The step's shortcuts give the floats of the plain computation: the actuator commands of
controls on, inside and beyond the agent's bounds are those of agent.project, bit for bit."""

import numpy as np
import pytest

from dcmppi import tasks


def _controls(agent):
    """(n, nu) controls: the box's corners and centre, one ulp inside and outside its edges,
    signed zeros, random points around the box and, for norm-bounded agents, on and next to the
    norm circle."""
    lo, hi = agent.lower, agent.upper
    span = hi - lo
    rng = np.random.default_rng(0)
    rows = [lo, hi, 0.5 * (lo + hi), np.nextafter(lo, hi), np.nextafter(hi, lo)]
    rows += [np.nextafter(lo, -np.inf), np.nextafter(hi, np.inf), np.zeros(agent.nu)]
    rows += [-np.zeros(agent.nu), lo - 1.0, hi + 1.0]
    rows += list(rng.uniform(lo - 0.1 * span, hi + 0.1 * span, size=(200, agent.nu)))
    if agent.norm_axes is not None:
        for angle in rng.uniform(-np.pi, np.pi, size=50):
            for scale in (1.0 - 1e-12, 1.0, 1.0 + 1e-12, 1.0 - 1e-9):
                u = 0.5 * (lo + hi)
                u[list(agent.norm_axes)] = (
                    scale * agent.norm_limit * np.array([np.cos(angle), np.sin(angle)])
                )
                rows.append(u)
    return np.array(rows, dtype=np.float64)


@pytest.mark.parametrize("agent", ["dubins", "unicycle", "holonomic"])
def test_commands_are_those_of_the_projected_controls(agent):
    env = tasks.load("forest", {"random": 0, "agent": agent, "n_clusters": 5})
    env.reset()
    task, physics = env.task, env.physics
    for u in _controls(task.agent):
        task.before_step(u, physics)
        projected = task.agent.project(u[:, None], axis=0)[:, 0]
        expected = np.array(task.plant.command(task.agent, projected), dtype=np.float64)
        assert physics.data.ctrl.tobytes() == expected.tobytes(), u
