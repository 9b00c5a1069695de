"""The controller interface, its parameters, the diagnostics record and the registry.

    ctrl = make_controller("clustered", agent="holonomic", K=500, seed=0)
    ctrl.reset(seed=1)
    u = ctrl.act(state, goal, static, moving, obstacle_model)   # (nu,) controls to apply

Every controller accepts the shared parameters (defaults from dcmppi.control.defaults,
explained in docs/design.md): agent and its parameters (dubins: v, r_min; unicycle and holonomic:
v_max, omega_max), robot_radius, dt, K, N, lambda_, Sigma, gamma, alpha, beta, P, seed,
perturbation, resolution, obstacle_margin, plus its own.
"""

import dataclasses
import math
import numbers

import numba
import numpy as np

from . import defaults
from ._malloc import tune_malloc
from .agents import Agent, agent_class, make_agent
from .costs import (
    RESOLUTION,
    OccupancyGrid,
    TrackIndex,
    goal_distance,
    static_costs,
    valid_cylinders,
)
from .normal import scaled_normal, standard_normal

PERTURBATIONS = ("constant", "time_varying", "mixed")
MAX_COORDINATE = 1e6  # |state| and |goal| bound: far beyond, squared distances overflow

_REGISTRY = {}


def register(name):
    """Class decorator adding a controller to the registry under `name`."""

    def add(cls):
        _REGISTRY[name] = cls
        cls.name = name
        return cls

    return add


def controller_names():
    """Registered controller names."""
    return sorted(_REGISTRY)


def controller_class(name):
    """The registered class of controller `name`; a ValueError names the valid ones."""
    if name not in _REGISTRY:
        raise ValueError(
            f"unknown controller {name!r}; valid names: {', '.join(controller_names())}"
        )
    return _REGISTRY[name]


def make_controller(name, **params):
    """A controller by registry name ("mppi", "clustered", "dc", "tube") and keyword parameters.

    `agent` (default "dubins") names the analytic model, or is an Agent instance; the agent's
    own parameters (e.g. v_max) are passed alongside the controller's.
    """
    cls = controller_class(name)
    agent = params.get("agent", "dubins")
    agent_params = () if isinstance(agent, Agent) else agent_class(agent).param_names
    valid = [*cls.param_names(), *agent_params]
    unknown = sorted(set(params) - set(valid))
    if unknown:
        raise ValueError(
            f"unknown parameter(s) {', '.join(unknown)} for controller {name!r} with agent "
            f"{getattr(agent, 'name', agent)!r}; valid parameters: {', '.join(valid)}"
        )
    return cls(**params)


@dataclasses.dataclass
class Diagnostics:
    """The last control step, by reference (arrays are not copied). K samples, N steps, nu
    controls.

    eps: (K, N, nu) perturbations actually applied (projected into the control bounds).
    states: (K, N + 1, 3) rollout states.
    J: (K,) costs; S: (K,) costs plus the importance term.
    weights: (K,) weights that produced the plan (zero outside the chosen cluster).
    ess: effective sample size 1 / sum(weights^2).
    warm_start: (N, nu) the reference controls U0 the step started from (eps is relative to it).
    plan: (N, nu) the optimised control sequence; action: (nu,) the applied controls.
    labels: (K,) DBSCAN labels (-1: noise) and features: (K, nu + 1) the points DBSCAN
      clustered, clustered/dc only.
    cluster_controls: (M, N, nu) and cluster_costs: (M,) per-cluster sequences and their J.
    chosen: index of the chosen cluster, -1 for the fallback to Alg. 1 over all samples.
    nominal_state: (3,), nominal_reset: bool and nominal_deviation: the real-to-nominal
      position distance at the start of the step, before any reset [m], tube only.
    obstacle_samples: (L', P, N + 1, 2) sampled futures of the obstacles within reach, dc only.
    obstacle_mean: (L, 5) and obstacle_cov: (L, 5, 5) posterior of every moving obstacle's
    x, y, heading, speed, turn rate (dc with prediction="ekf").
    """

    eps: np.ndarray = None
    states: np.ndarray = None
    J: np.ndarray = None
    S: np.ndarray = None
    weights: np.ndarray = None
    ess: float = float("nan")
    warm_start: np.ndarray = None
    plan: np.ndarray = None
    action: np.ndarray = None
    labels: np.ndarray = None
    features: np.ndarray = None
    cluster_controls: np.ndarray = None
    cluster_costs: np.ndarray = None
    chosen: int = -1
    nominal_state: np.ndarray = None
    nominal_reset: bool = None
    nominal_deviation: float = float("nan")
    obstacle_samples: np.ndarray = None
    obstacle_mean: np.ndarray = None
    obstacle_cov: np.ndarray = None


@numba.njit(cache=True)
def _clip_box(U0, eps, lower, upper, sums):
    """u = min(max(U0 + eps, lower), upper) and u - U0, both (N, nu, K), in one pass.

    U0: (N, nu); eps: (N, nu, K), or (1, nu, K): the same perturbation at every step (constant),
    read from one contiguous block; lower, upper: (nu,); sums: (nu, K) zeros that get the
    horizon sums of u - U0 (step by step, in order), or an empty array for none.
    """
    n, nu = U0.shape
    k = eps.shape[2]
    each, add = eps.shape[0] > 1, len(sums) > 0
    u = np.empty((n, nu, k))
    e = np.empty((n, nu, k))
    for i in range(n):
        for c in range(nu):
            u0, lo, hi = U0[i, c], lower[c], upper[c]
            row, out_u, out_e = eps[i if each else 0, c], u[i, c], e[i, c]
            for j in range(k):
                v = min(max(u0 + row[j], lo), hi)
                out_u[j] = v
                out_e[j] = v - u0
            if add:
                total = sums[c]
                for j in range(k):
                    total[j] += out_e[j]
    return u, e


@numba.njit(cache=True)
def _clip_box_disc(U0, eps, lower, upper, p, q, limit, sums):
    """As _clip_box, then controls p and q scaled back onto |(u_p, u_q)| <= limit; one pass,
    the scale selected without a branch (1 inside the disc) so the loop vectorises."""
    n, nu = U0.shape
    k = eps.shape[2]
    each, add = eps.shape[0] > 1, len(sums) > 0
    u = np.empty((n, nu, k))
    e = np.empty((n, nu, k))
    for i in range(n):
        for c in range(nu):
            u0, lo, hi = U0[i, c], lower[c], upper[c]
            row, out_u = eps[i if each else 0, c], u[i, c]
            for j in range(k):
                out_u[j] = min(max(u0 + row[j], lo), hi)
        up, uq = u[i, p], u[i, q]
        for j in range(k):
            norm = np.sqrt(up[j] * up[j] + uq[j] * uq[j])
            scale = limit / max(norm, 1e-300) if norm > limit else 1.0
            up[j] *= scale
            uq[j] *= scale
        for c in range(nu):
            u0, out_u, out_e = U0[i, c], u[i, c], e[i, c]
            for j in range(k):
                out_e[j] = out_u[j] - u0
            if add:
                total = sums[c]
                for j in range(k):
                    total[j] += out_e[j]
    return u, e


_NO_SUMS = np.zeros((0, 0))  # the clip kernels' `sums` when none are asked for


@numba.njit(cache=True)
def horizon_sums(eps):
    """(nu, K) sums of eps (N, nu, K) over the horizon, step by step in order (the values the
    clip kernels add up)."""
    n, nu, k = eps.shape
    sums = np.zeros((nu, k))
    for i in range(n):
        for c in range(nu):
            row, total = eps[i, c], sums[c]
            for j in range(k):
                total[j] += row[j]
    return sums


def _positive(name, value, integer=False, allow_zero=False):
    ok_type = isinstance(value, numbers.Integral) if integer else isinstance(value, numbers.Real)
    if isinstance(value, bool) or not ok_type or not math.isfinite(value):
        kind = "an integer" if integer else "a finite number"
        raise ValueError(f"{name} must be {kind}; got {value!r}")
    if value < 0 or (value == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise ValueError(f"{name} must be {bound}; got {value!r}")
    return int(value) if integer else float(value)


class Controller:
    """Sampling-based controller over an analytic agent model (base of all four).

    Args (keywords; defaults in dcmppi.control.defaults, reasons in docs/design.md):
      agent: "dubins" (default), "unicycle", "holonomic", another registered name, or an Agent
        instance; its parameters (dubins: v, r_min; others: v_max, omega_max) go alongside.
      robot_radius: collision radius [m]. dt: control period [s].
      K: samples. N: horizon steps. lambda_: cost sensitivity.
      Sigma: sampling variance of each control, in its own units (default: the agent's, e.g.
        0.1 (rad/s)^2 for a turn rate, 1 (m/s)^2 for a velocity); a number for 1 control.
      gamma: weight of the importance term gamma lambda sum_i u_i^T Sigma^-1 eps_i (1: paper).
      alpha: static collision weight. beta: dynamic collision weight (dc). P: futures per
        moving obstacle (dc). seed: int, None or np.random.Generator.
      perturbation: "constant" (one eps per sample over the horizon, paper Sec. IV-A),
        "time_varying" (independent per step) or "mixed" (the sum of one constant and one
        time-varying draw, each N(0, Sigma / 2)); default: the agent's.
      resolution: cost-map cell size [m].
      obstacle_margin: added to every moving obstacle's radius in the cost [m].
    """

    name = None

    def __init__(
        self,
        *,
        agent="dubins",
        robot_radius=defaults.ROBOT_RADIUS,
        dt=defaults.DT,
        K=defaults.K,
        N=defaults.N,
        lambda_=defaults.LAMBDA,
        Sigma=None,
        gamma=defaults.GAMMA,
        alpha=defaults.ALPHA,
        beta=defaults.BETA,
        P=defaults.P,
        seed=None,
        perturbation=None,
        resolution=RESOLUTION,
        obstacle_margin=0.0,
        **agent_params,
    ):
        self.agent = make_agent(agent, **agent_params)
        self.robot_radius = _positive("robot_radius", robot_radius, allow_zero=True)
        self.dt = _positive("dt", dt)
        self.K = _positive("K", K, integer=True)
        self.N = _positive("N", N, integer=True)
        self.lambda_ = _positive("lambda_", lambda_)
        self.Sigma = self.agent.variances(Sigma)
        self.gamma = _positive("gamma", gamma, allow_zero=True)
        self.alpha = _positive("alpha", alpha, allow_zero=True)
        self.beta = _positive("beta", beta, allow_zero=True)
        self.P = _positive("P", P, integer=True)
        perturbation = self.agent.default_perturbation if perturbation is None else perturbation
        if perturbation not in PERTURBATIONS:
            raise ValueError(f"perturbation must be one of {PERTURBATIONS}; got {perturbation!r}")
        self.perturbation = perturbation
        self.resolution = _positive("resolution", resolution)
        self.obstacle_margin = _positive("obstacle_margin", obstacle_margin, allow_zero=True)
        if seed is not None and not isinstance(seed, (numbers.Integral, np.random.Generator)):
            raise ValueError(f"seed must be None, an int or a np.random.Generator; got {seed!r}")
        self.seed = seed
        tune_malloc()
        self.sigma = np.sqrt(self.Sigma)
        # gamma lambda Sigma^-1 of the importance term, per control
        self._importance_weight = (self.gamma * self.lambda_) / self.Sigma
        self._grid = None
        self._free_tracks = np.zeros((0, self.N + 1, 2))
        self._free = TrackIndex(self._free_tracks, np.zeros(0))  # no moving obstacle near
        self.rng = None
        self.reset(seed)

    own_params = (
        "agent", "robot_radius", "dt", "K", "N", "lambda_", "Sigma", "gamma", "alpha", "beta",
        "P", "seed", "perturbation", "resolution", "obstacle_margin",
    )  # fmt: skip

    @classmethod
    def param_names(cls):
        """Keyword parameters of this controller (each class lists its own in `own_params`);
        the agent's parameters come on top (`make_controller` checks both)."""
        names = []
        for klass in reversed(cls.__mro__):
            names += [n for n in klass.__dict__.get("own_params", ()) if n not in names]
        return names

    @property
    def params(self):
        """All parameters as a dict (for records): the controller's and its agent's."""
        out = {n: getattr(self, n) for n in self.param_names() if n not in ("seed", "agent")}
        out["Sigma"] = self.Sigma.tolist()
        return {
            "agent": self.agent.name,
            **self.agent.params,
            **out,
            "seed": None if isinstance(self.seed, np.random.Generator) else self.seed,
        }

    @property
    def nu(self):
        """Number of controls of the agent."""
        return self.agent.nu

    def reset(self, seed=None):
        """Start a new episode: the agent's first guess on the next step; re-seed when `seed`
        is given."""
        if seed is not None:
            self.seed = seed
        if self.rng is None or seed is not None:
            s = self.seed
            self.rng = s if isinstance(s, np.random.Generator) else np.random.default_rng(s)
        self.U = None  # set from the agent's first guess at the first step
        self.diagnostics = Diagnostics()

    # --- one control step -------------------------------------------------------------------

    def act(self, state, goal, static=None, moving=None, obstacle_model=None, bounds=None):
        """Controls to apply now.

        Args:
          state: (3,) x, y, theta. goal: (2,) x, y.
          static: (M, 3) x, y, radius of static cylinders (radius-0 rows ignored), or None.
          moving: (L, 4) x, y, heading, radius of moving cylinders now (heading nan: not
            observed), or None.
          obstacle_model: (4,) v_mean, v_std, omega_mean, omega_std of the moving obstacles.
          bounds: (4,) xmin, ymin, xmax, ymax of the map, or None: with bounds a state whose
            centre leaves the map costs alpha, as a collision with the static map does.
        Returns:
          (nu,) controls within the agent's bounds (dubins: the turn rate omega).
        """
        state = np.asarray(state, dtype=float)
        goal = np.asarray(goal, dtype=float)
        if state.shape != (3,) or goal.shape != (2,):
            raise ValueError(f"state must be (3,) and goal (2,); got {state.shape}, {goal.shape}")
        if not (np.abs(state) < MAX_COORDINATE).all() or not (np.abs(goal) < MAX_COORDINATE).all():
            raise ValueError(
                f"state and goal must be finite and within {MAX_COORDINATE:.0e} (m, rad); "
                f"got {state}, {goal}"
            )
        if self._grid is None or not self._grid.matches(static, bounds):
            self._grid = OccupancyGrid(static, self.robot_radius, self.resolution, bounds)
        self._goal = goal
        if self.U is None:
            self.U = self.agent.project(self.agent.first_guess(state, goal, self.N), axis=1)
        moving = valid_cylinders(moving, "moving", columns=4, unobserved=2)
        self._prepare_obstacles(state, moving, obstacle_model)
        tracks = self._tracks
        self._track_index = TrackIndex(tracks, self._track_distance) if len(tracks) else self._free
        u = self._solve(state)
        self.diagnostics.action = u
        return u

    def _prepare_obstacles(self, state, moving, obstacle_model):
        """Moving obstacles seen as static at their current positions (alpha weight)."""
        self._track_weight = self.alpha
        if len(moving) == 0:  # the static tasks: none of the work below
            self._tracks, self._track_distance = self._free_tracks, self._free_tracks[:, 0, 0]
            return
        radius = moving[:, 3] + self.obstacle_margin
        reach = self.agent.max_speed * self.N * self.dt + self.robot_radius + radius
        near = np.hypot(moving[:, 0] - state[0], moving[:, 1] - state[1]) <= reach
        frozen = moving[near]
        self._tracks = np.broadcast_to(frozen[:, None, :2], (len(frozen), self.N + 1, 2))
        self._track_distance = radius[near] + self.robot_radius

    def _solve(self, state):
        raise NotImplementedError

    # --- building blocks --------------------------------------------------------------------

    def sample(self):
        """Perturbations eps (N, nu, K) drawn from N(0, Sigma), time-major.

        constant: one draw per sample and control (kept in self._raw (nu, K)), the same at
        every step; time_varying: independent draws per step; mixed: the sum of one of each,
        both N(0, Sigma / 2), so that every kind has the per-step variance Sigma that the
        importance term assumes.
        """
        shape = (self.N, self.nu, self.K)
        self._raw = None
        if self.perturbation == "time_varying":
            return scaled_normal(self.rng, shape, self.sigma)
        raw = standard_normal(self.rng, (self.nu, self.K)) * self.sigma[:, None]
        if self.perturbation == "constant":
            self._raw = raw
            return np.broadcast_to(raw, shape)
        half = np.sqrt(0.5)  # each draw N(0, Sigma / 2): the sum has variance Sigma at every step
        return scaled_normal(self.rng, shape, half * self.sigma, half * raw)

    def controls(self, U0, eps, sums=False):
        """Bounded controls project(U0 + eps) (N, nu, K) and the perturbations that remain.

        The remaining (projected) perturbation enters the importance term, the weighted update
        and the clustering features, so the update U0 + sum_k w_k eps_k stays within the
        bounds (they are convex). With sums=True also their horizon sums (nu, K) (the
        clustering features), added up in the same pass.
        """
        a = self.agent
        if eps.strides[0] == 0:  # constant: one contiguous (1, nu, K) block for every step
            eps = eps[:1]
        out = np.zeros((self.nu, eps.shape[2])) if sums else _NO_SUMS
        if a.norm_axes is None:  # a box: one pass, the same values as np.clip
            u, e = _clip_box(U0, eps, a.lower, a.upper, out)
        elif len(a.norm_axes) == 2:  # box and disc (holonomic): one pass, Agent.project's values
            u, e = _clip_box_disc(U0, eps, a.lower, a.upper, *a.norm_axes, a.norm_limit, out)
        else:
            u = a.project(U0[:, :, None] + eps)
            e = u - U0[:, :, None]
            out = horizon_sums(e) if sums else out
        return (u, e, out) if sums else (u, e)

    def evaluate(self, x0, u, starts=1):
        """Rollouts and costs. x0: (3,) or (3, R); u: (N, nu, R). Returns states (3, N + 1, R),
        J (R,).

        starts = S > 1: x0 (3, S) start states that all take the R sequences; R becomes S R.
        """
        states = self.agent.rollout(x0, u, self.dt, starts)
        x, y = states[0], states[1]
        if self._grid.empty or not self.alpha:
            J = goal_distance(x, y, self._goal)
        else:
            J = static_costs(x, y, self._goal, self._grid, self.alpha)
        if not self._track_index.empty:
            J += self._track_weight * self._track_index.count(x, y)
        return states, J

    def importance(self, U0, eps):
        """gamma lambda sum_i u_i^T Sigma^-1 eps_i for each sample (K,)."""
        w = self._importance_weight
        S = w[0] * (U0[:, 0] @ eps[:, 0])
        for j in range(1, self.nu):
            S += w[j] * (U0[:, j] @ eps[:, j])
        return S

    def finish(self, plan):
        """Apply the plan's first controls and warm-start the next step by shifting it.

        plan: (N, nu). Returns plan[0] (nu,).
        """
        self.U = np.concatenate([plan[1:], plan[-1:]])
        self.diagnostics.plan = plan
        return plan[0].copy()
