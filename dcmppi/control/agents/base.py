"""The analytic agent interface and its registry (docs/design.md, Agents).

Every agent has the planar state x = (x, y, theta) [m, m, rad] and nu controls u with box
bounds lower <= u <= upper and, for some, a norm bound |u[norm_axes]| <= norm_limit (a
holonomic robot's planar speed). The planners see an agent through:

    agent.controls            names of the nu controls, in order
    agent.lower, agent.upper  (nu,) box bounds; agent.norm_axes, agent.norm_limit
    agent.project(u)          controls (N, nu, K) moved into the bounds (clip, then norm)
    agent.rollout(x0, u, dt)  states (3, N + 1, K) of K control sequences u (N, nu, K)
    agent.rollout_columns(out, u, dt, cols)  the same for samples cols = (j0, j1), in place
    agent.step(x, u, dt)      one exact control period, any leading shape
    agent.jacobians(X, U, dt) A (N, 3, 3), B (N, 3, nu) of that step along a trajectory
    agent.first_guess(x, goal, N)   the warm start (N, nu) of an episode's first step
    agent.max_speed           fastest planar speed [m/s] (for what can be reached in a horizon)
    agent.omega_max           fastest turn rate [rad/s]
    agent.holonomic           whether it moves in any planar direction without turning
    agent.steers_only         whether its speed is fixed (max_speed): its controls only turn it
    agent.command(v, omega)   the controls (nu,) of a planar velocity and a turn rate
    agent.world_velocity(heading, u)  the world-frame velocity (2,) and turn rate of controls u
    agent.default_Sigma       sampling variance of each control, in its own units
    agent.default_perturbation  "constant", "time_varying" or "mixed"

A new agent is a subclass registered by name (see README, "Your own agent").
"""

from __future__ import annotations

import math

import numpy as np

from dcmppi.control.registry import Registry
from dcmppi.control.validation import floats, positive


def register_agent(name):
    """Class decorator adding an Agent subclass to the registry under `name`."""
    return AGENTS.register(name)


def agent_names() -> list[str]:
    """Registered agent names, sorted."""
    return AGENTS.names()


def agent_class(name) -> type:
    """The registered class of agent `name`; a ValueError names the valid agents."""
    return AGENTS.get(name)


def make_agent(agent="dubins", **params) -> Agent:
    """An agent by registry name (or an Agent instance, returned as is) with its parameters."""
    if isinstance(agent, Agent):
        if params:
            raise ValueError(
                f"agent parameters {sorted(params)} given with an agent instance; "
                "set them when constructing the agent"
            )
        return agent
    cls = agent_class(agent)
    unknown = sorted(set(params) - set(cls.param_names))
    if unknown:
        raise ValueError(
            f"unknown parameter(s) {', '.join(unknown)} for agent {agent!r}; "
            f"valid: {', '.join(cls.param_names) or '(none)'}"
        )
    return cls(**params)


def agent_param_names() -> list[str]:
    """Every registered agent's parameter names (the robot parameters a task and a planner
    share), in registry order without repeats."""
    names = []
    for name in agent_names():
        names += [p for p in AGENTS.get(name).param_names if p not in names]
    return names


class Agent:
    """Base of the analytic agent models (see the module docstring for the interface).

    Subclasses set `controls`, `param_names` (keyword parameters, also accepted by the tasks
    for the plant), `default_Sigma`, `default_perturbation`, `holonomic` and `steers_only`
    where true, and in __init__ `omega_max` and the bounds via `set_bounds`; they implement
    `rollout`, `step` and `jacobians`, and for the classical planners `command` and
    `world_velocity`.
    """

    name = None
    controls: tuple[str, ...] = ()
    param_names: tuple[str, ...] = ()
    default_Sigma: tuple[float, ...] = ()
    default_perturbation = "constant"
    norm_axes: tuple[int, ...] | None = None
    norm_limit = math.inf
    holonomic = False
    steers_only = False

    @property
    def nu(self) -> int:
        """Number of controls."""
        return len(self.controls)

    @property
    def params(self) -> dict:
        """The agent's parameters by name (for records and for the plant)."""
        return {n: getattr(self, n) for n in self.param_names}

    def set_bounds(self, lower, upper, norm_limit=math.inf):
        """Checks and stores the box bounds (nu,) and the norm bound."""
        lower = np.array(lower, dtype=float).reshape(-1)
        upper = np.array(upper, dtype=float).reshape(-1)
        if lower.shape != (self.nu,) or upper.shape != (self.nu,):
            raise ValueError(
                f"agent {self.name!r}: bounds must have one entry per control {self.controls}; "
                f"got lower {lower.tolist()}, upper {upper.tolist()}"
            )
        bad = [
            c
            for c, lo, hi in zip(self.controls, lower, upper, strict=True)
            if not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi)
        ]
        if bad:
            raise ValueError(
                f"agent {self.name!r}: bounds of control(s) {', '.join(bad)} must be finite "
                f"with lower <= upper; got lower {lower.tolist()}, upper {upper.tolist()}"
            )
        if self.norm_axes is not None and not norm_limit > 0:
            raise ValueError(f"agent {self.name!r}: norm limit must be > 0; got {norm_limit}")
        self.lower, self.upper, self.norm_limit = lower, upper, float(norm_limit)
        lower.flags.writeable = upper.flags.writeable = False

    @property
    def max_speed(self) -> float:
        """Fastest planar speed the controls allow [m/s]."""
        raise NotImplementedError

    # --- controls ---------------------------------------------------------------------------

    def project(self, u, axis=1):
        """Controls moved into the bounds: clipped to the box, then (norm-bounded agents)
        scaled back onto |u[norm_axes]| <= norm_limit. u: the controls along `axis`
        ((N, nu, K) by default). Returns a new array."""
        u = np.asarray(u, dtype=float)
        if u.shape[axis] != self.nu:
            raise ValueError(
                f"agent {self.name!r} has {self.nu} control(s) {self.controls}; got an array "
                f"of shape {u.shape} with {u.shape[axis]} along axis {axis}"
            )
        shape = [1] * u.ndim
        shape[axis] = self.nu
        if self.nu == 1:  # scalar bounds: the same values, less broadcasting
            u = np.clip(u, self.lower[0], self.upper[0])
        else:
            u = np.clip(u, self.lower.reshape(shape), self.upper.reshape(shape))
        if self.norm_axes is not None:
            part = np.take(u, self.norm_axes, axis=axis)
            norm = np.sqrt(np.sum(part * part, axis=axis, keepdims=True))
            scale = np.where(norm > self.norm_limit, self.norm_limit / np.maximum(norm, 1e-300), 1)
            index = [slice(None)] * u.ndim
            index[axis] = list(self.norm_axes)
            u[tuple(index)] = part * scale
        return u

    def variances(self, Sigma=None, allow_zero=False):
        """Sigma as (nu,) variances, one per control in its own units: a sequence of nu, a number
        for a 1-control agent, or None for `default_Sigma`. A ValueError names a bad entry (each
        1 / Sigma must be finite too)."""
        values = np.array(floats("Sigma", self.default_Sigma if Sigma is None else Sigma))
        if values.size != self.nu or values.ndim > 1:
            raise ValueError(
                f"Sigma must hold one variance per control {self.controls} of agent "
                f"{self.name!r} (each in its control's units); got {Sigma!r}"
            )
        for c, s in zip(self.controls, values.reshape(-1), strict=True):
            s = positive(f"Sigma of {c}", float(s), allow_zero=allow_zero)
            if s and 1.0 / s == math.inf:  # the importance term divides by it
                raise ValueError(
                    f"Sigma of {c} must be at least 1e-308 (a finite 1 / Sigma); got {s}"
                )
        return values.reshape(-1)

    def command(self, velocity, omega):
        """The controls (nu,) that command the planar velocity (2,) and the turn rate omega, as
        far as the agent can: the velocity in the world frame for a holonomic agent, else in the
        robot's (forward, lateral), whose lateral part it drops (and its forward part, where it
        steers only)."""
        raise NotImplementedError

    def world_velocity(self, heading, u):
        """The world-frame velocity (2,) and the turn rate of controls u (nu,) at `heading`."""
        raise NotImplementedError

    def first_guess(self, state, goal, N):
        """Warm start (N, nu) of an episode's first step (default: zero controls)."""
        return np.zeros((N, self.nu))

    # --- dynamics ---------------------------------------------------------------------------

    def rollout(self, x0, u, dt, starts=1):
        """Batched exact rollouts, time-major.

        Args:
          x0: (3,) common initial state, (3, K) one per rollout, or with starts = S > 1, (3, S):
            S initial states that all take the same K control sequences.
          u: (N, nu, K) controls, already within the bounds.
          dt: control period [s].
        Returns:
          (3, N + 1, S K) states x_0 .. x_N, state-major (x, y, theta: each (N + 1, S K)
          contiguous for the cost kernels); columns s K .. (s + 1) K - 1 start from x0[:, s].
        """
        raise NotImplementedError

    def rollout_columns(self, out, u, dt, cols=None):
        """The rollouts of samples cols = (j0, j1) (a thread's share of a batch; None: all) into
        their columns of out (3, N + 1, S, K), whose start states out[:, 0] are set; u: (N, nu,
        K). A sample's rollout depends on its own controls alone. Default: `rollout` on a copy
        of the columns.
        """
        starts = out.shape[2]
        j0, j1 = cols or (0, u.shape[2])
        x0 = out[:, 0, 0, j0:j1] if starts == 1 else out[:, 0, :, j0]
        part = self.rollout(x0, np.ascontiguousarray(u[:, :, j0:j1]), dt, starts)
        out[:, :, :, j0:j1] = part.reshape(3, -1, starts, j1 - j0)

    def step(self, state, u, dt):
        """One exact control period: state (..., 3), u (..., nu) -> (..., 3), theta unwrapped."""
        raise NotImplementedError

    def jacobians(self, states, U, dt):
        """A_i = d x_{i+1} / d x_i (N, 3, 3) and B_i = d x_{i+1} / d u_i (N, 3, nu) of `step`
        along the trajectory states (N + 1, 3) under controls U (N, nu)."""
        raise NotImplementedError

    def rollout_one(self, state, U, dt):
        """States (N + 1, 3) of one control sequence U (N, nu) from state (3,)."""
        U = np.asarray(U, dtype=float).reshape(-1, self.nu)
        return self.rollout(np.asarray(state, dtype=float), U[:, :, None], dt)[:, :, 0].T

    def __repr__(self):
        args = ", ".join(f"{k}={v!r}" for k, v in self.params.items())
        return f"{type(self).__name__}({args})"


AGENTS = Registry("agent", base=Agent)
