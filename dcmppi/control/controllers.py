"""The controller interface, its parameters, the diagnostics record and the registry.

    ctrl = make_controller("clustered", K=500, seed=0)
    ctrl.reset(seed=1)
    omega = ctrl.act(state, goal, static, moving, obstacle_model)

Every controller accepts the shared parameters (SPEC section 3 defaults from
dcmppi.control.defaults):
v, r_min, robot_radius, dt, K, N, lambda_, Sigma, alpha, beta, P, seed, plus its own.
"""

import dataclasses
import math
import numbers

import numpy as np

from . import defaults
from ._malloc import tune_malloc
from .costs import RESOLUTION, OccupancyGrid, collision_counts, goal_distance, valid_cylinders
from .dynamics import rollout_time_major

PERTURBATIONS = ("constant", "time_varying")
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


def make_controller(name, **params):
    """A controller by registry name ("mppi", "clustered", "dc", "tube") and keyword parameters."""
    if name not in _REGISTRY:
        raise ValueError(
            f"unknown controller {name!r}; valid names: {', '.join(controller_names())}"
        )
    cls = _REGISTRY[name]
    unknown = sorted(set(params) - set(cls.param_names()))
    if unknown:
        raise ValueError(
            f"unknown parameter(s) {', '.join(unknown)} for controller {name!r}; "
            f"valid parameters: {', '.join(cls.param_names())}"
        )
    return cls(**params)


@dataclasses.dataclass
class Diagnostics:
    """The last control step, by reference (arrays are not copied). Shapes for K samples, N steps.

    eps: (K, N) perturbations actually applied (clipped to the control bound).
    states: (K, N + 1, 3) rollout states.
    J: (K,) costs; S: (K,) costs plus the importance term.
    weights: (K,) weights that produced the plan (zero outside the chosen cluster).
    ess: effective sample size 1 / sum(weights^2).
    plan: (N,) the optimised control sequence; action: the applied turn rate.
    labels: (K,) DBSCAN labels (-1: noise), clustered/dc only.
    cluster_controls: (M, N) and cluster_costs: (M,) per-cluster control sequences and their J.
    chosen: index of the chosen cluster, -1 for the fallback to Alg. 1 over all samples.
    nominal_state: (3,) and nominal_reset: bool, tube only.
    obstacle_samples: (L', P, N + 1, 2) sampled futures of the obstacles within reach, dc only.
    """

    eps: np.ndarray = None
    states: np.ndarray = None
    J: np.ndarray = None
    S: np.ndarray = None
    weights: np.ndarray = None
    ess: float = float("nan")
    plan: np.ndarray = None
    action: float = float("nan")
    labels: np.ndarray = None
    cluster_controls: np.ndarray = None
    cluster_costs: np.ndarray = None
    chosen: int = -1
    nominal_state: np.ndarray = None
    nominal_reset: bool = None
    obstacle_samples: np.ndarray = None


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
    """Sampling-based controller over the analytic Dubins model (base of all four).

    Args (keywords; SPEC section 3 defaults):
      v: forward speed [m/s]. r_min: minimum turning radius [m]; |omega| <= v / r_min.
      robot_radius: collision radius [m]. dt: control period [s].
      K: samples. N: horizon steps. lambda_: cost sensitivity. Sigma: variance of omega noise.
      alpha: static collision weight. beta: dynamic collision weight (dc). P: futures per
      moving obstacle (dc). seed: int, None or np.random.Generator.
      perturbation: "constant" (one eps per sample over the horizon, the paper's choice) or
        "time_varying" (independent eps per step).
      resolution: cost-map cell size [m].
    """

    name = None

    def __init__(
        self,
        *,
        v=defaults.V,
        r_min=defaults.R_MIN,
        robot_radius=defaults.ROBOT_RADIUS,
        dt=defaults.DT,
        K=defaults.K,
        N=defaults.N,
        lambda_=defaults.LAMBDA,
        Sigma=defaults.SIGMA,
        alpha=defaults.ALPHA,
        beta=defaults.BETA,
        P=defaults.P,
        seed=None,
        perturbation="constant",
        resolution=RESOLUTION,
    ):
        self.v = _positive("v", v)
        self.r_min = _positive("r_min", r_min)
        self.robot_radius = _positive("robot_radius", robot_radius, allow_zero=True)
        self.dt = _positive("dt", dt)
        self.K = _positive("K", K, integer=True)
        self.N = _positive("N", N, integer=True)
        self.lambda_ = _positive("lambda_", lambda_)
        Sigma = np.asarray(Sigma, dtype=float)
        if Sigma.size != 1:
            raise ValueError(f"Sigma must be a scalar variance (one control input); got {Sigma!r}")
        self.Sigma = _positive("Sigma", float(Sigma.ravel()[0]))
        self.alpha = _positive("alpha", alpha, allow_zero=True)
        self.beta = _positive("beta", beta, allow_zero=True)
        self.P = _positive("P", P, integer=True)
        if perturbation not in PERTURBATIONS:
            raise ValueError(f"perturbation must be one of {PERTURBATIONS}; got {perturbation!r}")
        self.perturbation = perturbation
        self.resolution = _positive("resolution", resolution)
        if seed is not None and not isinstance(seed, (numbers.Integral, np.random.Generator)):
            raise ValueError(f"seed must be None, an int or a np.random.Generator; got {seed!r}")
        self.seed = seed
        tune_malloc()
        self.omega_max = defaults.omega_max(self.v, self.r_min)
        self.sigma = math.sqrt(self.Sigma)
        self._grid = None
        self.rng = None
        self.reset(seed)

    own_params = (
        "v", "r_min", "robot_radius", "dt", "K", "N", "lambda_", "Sigma", "alpha", "beta", "P",
        "seed", "perturbation", "resolution",
    )  # fmt: skip

    @classmethod
    def param_names(cls):
        """Keyword parameters of this controller (each class lists its own in `own_params`)."""
        names = []
        for klass in reversed(cls.__mro__):
            names += [n for n in klass.__dict__.get("own_params", ()) if n not in names]
        return names

    @property
    def params(self):
        """All parameters as a dict (for records)."""
        return {n: getattr(self, n) for n in self.param_names() if n != "seed"} | {
            "seed": None if isinstance(self.seed, np.random.Generator) else self.seed
        }

    def reset(self, seed=None):
        """Start a new episode: straight-ahead warm start; re-seed when `seed` is given."""
        if seed is not None:
            self.seed = seed
        if self.rng is None or seed is not None:
            s = self.seed
            self.rng = s if isinstance(s, np.random.Generator) else np.random.default_rng(s)
        self.U = np.zeros(self.N)
        self.diagnostics = Diagnostics()

    # --- one control step -------------------------------------------------------------------

    def act(self, state, goal, static=None, moving=None, obstacle_model=None):
        """Turn rate to apply now.

        Args:
          state: (3,) x, y, theta. goal: (2,) x, y.
          static: (M, 3) x, y, radius of static cylinders (radius-0 rows ignored), or None.
          moving: (L, 4) x, y, heading, radius of moving cylinders now, or None.
          obstacle_model: (4,) v_mean, v_std, omega_mean, omega_std of the moving obstacles.
        Returns:
          omega (float) within [-v / r_min, v / r_min].
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
        if self._grid is None or not self._grid.matches(static):
            self._grid = OccupancyGrid(static, self.robot_radius, self.resolution)
        self._goal = goal
        moving = valid_cylinders(moving, "moving", columns=4)
        self._prepare_obstacles(state, moving, obstacle_model)
        omega = self._solve(state)
        self.diagnostics.action = omega
        return omega

    def _prepare_obstacles(self, state, moving, obstacle_model):
        """Moving obstacles seen as static at their current positions (alpha weight)."""
        reach = self.v * self.N * self.dt + self.robot_radius + moving[:, 3]
        near = np.hypot(moving[:, 0] - state[0], moving[:, 1] - state[1]) <= reach
        frozen = moving[near]
        self._tracks = np.broadcast_to(frozen[:, None, :2], (len(frozen), self.N + 1, 2))
        self._track_distance = frozen[:, 3] + self.robot_radius
        self._track_weight = self.alpha

    def _solve(self, state):
        raise NotImplementedError

    # --- building blocks --------------------------------------------------------------------

    def sample(self):
        """Perturbations eps (N, K) drawn from N(0, Sigma), time-major."""
        if self.perturbation == "constant":
            self._raw = self.rng.standard_normal(self.K) * self.sigma  # (K,) one eps per sample
            return np.broadcast_to(self._raw, (self.N, self.K))
        return self.rng.standard_normal((self.N, self.K)) * self.sigma

    def controls(self, U0, eps):
        """Bounded controls clip(U0 + eps) (N, K) and the perturbations that remain (N, K).

        The remaining (clipped) perturbation enters the importance term, the weighted update and
        the clustering features, so the update U0 + sum_k w_k eps_k stays within the bound.
        """
        u = np.clip(U0[:, None] + eps, -self.omega_max, self.omega_max)
        return u, u - U0[:, None]

    def evaluate(self, x0, u, starts=1):
        """Rollouts and costs. x0: (3,) or (3, R); u: (N, R). Returns states (N+1, 3, R), J (R,).

        starts = S > 1: x0 (3, S) start states that all take the R sequences; R becomes S R.
        """
        states = rollout_time_major(x0, u, self.v, self.dt, starts)
        x, y = states[:, 0], states[:, 1]
        J = goal_distance(x, y, self._goal)
        if not self._grid.empty and self.alpha:
            J += self.alpha * self._grid.count(x, y)
        if len(self._tracks):
            J += self._track_weight * collision_counts(x, y, self._tracks, self._track_distance)
        return states, J

    def importance(self, U0, eps):
        """lambda * sum_i u_i Sigma^-1 eps_i for each sample (K,)."""
        return (self.lambda_ / self.Sigma) * (U0 @ eps)

    def finish(self, plan):
        """Apply the plan's first control and warm-start the next step by shifting it."""
        self.U = np.concatenate([plan[1:], plan[-1:]])
        self.diagnostics.plan = plan
        return float(plan[0])
