"""Analytic agent models, one per robot kind (docs/design.md, Agents): dubins, unicycle, holonomic.

Each is an `Agent` (dcmppi.control.agents.base) registered by name; `make_agent(name,
**params)` builds one and every controller plans with one (`make_controller(..., agent=name)`).
The compiled kernels that move perturbed controls into an agent's bounds live in
dcmppi.control.kernels.projection.

May import numpy, numba, dcmppi.control's kernels (dynamics, threads), defaults, validation and
registry; the tasks import these agents (their plants follow them), so they import nothing of
the planners.
"""

from dcmppi.control.agents import dubins, holonomic, unicycle  # noqa: F401  (registers the agents)
from dcmppi.control.agents.base import (
    Agent,
    agent_class,
    agent_names,
    agent_param_names,
    make_agent,
    register_agent,
)

__all__ = [
    "Agent",
    "agent_class",
    "agent_names",
    "agent_param_names",
    "make_agent",
    "register_agent",
]
