"""Analytic agent models, one per robot kind (docs/design.md, Agents): dubins, unicycle, holonomic.

Each is an `Agent` (dcmppi.control.agents.base) registered by name; `make_agent(name,
**params)` builds one and every controller plans with one (`make_controller(..., agent=name)`).
"""

from . import dubins, holonomic, unicycle  # noqa: F401  (registers the agents)
from .base import (
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
