"""The planner base: its parameters, one control step's frame and the building blocks.

    ctrl = make_controller("clustered", agent="holonomic", K=500, seed=0)
    ctrl.reset(seed=1)
    u = ctrl.act(state, goal, static, moving, obstacle_model)   # (nu,) controls to apply

Every controller accepts the shared parameters (defaults from dcmppi.control.defaults,
explained in docs/design.md): agent and its parameters (dubins: v, r_min; unicycle and holonomic:
v_max, omega_max), robot_radius, dt, K, N, lambda_, ess_target, Sigma, gamma, alpha, beta, P, seed,
perturbation, resolution, obstacle_margin, threads, prediction and its predictor's parameters,
plus its own. Each step, the predictor turns the moving obstacles into tracks, the step's Objective
scores rollouts, and the subclass's `_solve` plans with them.
"""

import functools
import numbers

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.agents import make_agent
from dcmppi.control.kernels.costs import RESOLUTION, OccupancyGrid, valid_cylinders
from dcmppi.control.kernels.perturbations import draw_box, draw_normals
from dcmppi.control.kernels.projection import NO_SUMS, bound, project_columns, project_perturbed
from dcmppi.control.kernels.sums import importance, importance_of
from dcmppi.control.kernels.threads import parts, run
from dcmppi.control.objective import Objective
from dcmppi.control.planners.diagnostics import Diagnostics
from dcmppi.control.planners.temperature import COLLISION_NATS, ESS_TARGET, choose_lambda
from dcmppi.control.predictors import predictor_class
from dcmppi.control.predictors.base import INPUTS
from dcmppi.control.timer import NO_TIMER
from dcmppi.control.validation import floats, positive

PERTURBATIONS = ("constant", "time_varying", "mixed")
AUTO = "auto"  # lambda_ chosen each step (dcmppi.control.planners.temperature)
MAX_COORDINATE = 1e6  # |state| and |goal| bound: far beyond, squared distances overflow


class Controller:
    """Sampling-based controller over an analytic agent model (base of all four).

    Args (keywords; defaults in dcmppi.control.defaults, reasons in docs/design.md):
      agent: "dubins" (default), "unicycle", "holonomic", another registered name, or an Agent
        instance; its parameters (dubins: v, r_min; others: v_max, omega_max) go alongside.
      robot_radius: collision radius [m]. dt: control period [s].
      K: samples. N: horizon steps. lambda_: cost sensitivity, a number > 0 or "auto": chosen
        each step so that the weights' effective sample size is near ess_target x K, at most
        alpha / 10 (dcmppi.control.planners.temperature; the importance term then keeps lambda = 1).
      ess_target: with lambda_="auto", the target ESS as a share of K, in (0, 1].
      Sigma: sampling variance of each control, in its own units (default: the agent's, e.g.
        0.1 (rad/s)^2 for a turn rate, 1 (m/s)^2 for a velocity); a number for 1 control.
      gamma: weight of the importance term gamma lambda sum_i u_i^T Sigma^-1 eps_i (1: paper;
        lambda = 1 there with lambda_="auto").
      alpha: static collision weight. beta: dynamic collision weight (sampled futures).
      P: futures per moving obstacle. seed: int, None or np.random.Generator.
      perturbation: "constant" (one eps per sample over the horizon, paper Sec. IV-A),
        "time_varying" (independent per step) or "mixed" (the sum of one constant and one
        time-varying draw, each N(0, Sigma / 2)); default: the agent's.
      resolution: cost-map cell size [m].
      obstacle_margin: added to every moving obstacle's radius in the cost [m].
      threads: threads that share the samples' draws, controls, rollouts, costs and importance
        terms (dcmppi.control.kernels.threads); the plans are the same for every number (the EKF
        predictor's small products call the BLAS: keep it on one thread). Default 1: a
        benchmark's workers use the cores; two threads pay from about 10^5 state-steps (K x N)
        per step (docs/performance.md).
      prediction: the obstacle predictor: a registered name (dcmppi.control.predictors) or
        package.module:ClassName; default `default_prediction` ("frozen"; dc: "prior"). Its
        own parameters go alongside.
    Attributes: agent, predictor, objective (the last step's), diagnostics (the last step's),
      timer (the profile's hook, dcmppi.control.timer).
    """

    name = None
    default_prediction = "frozen"
    diagnostics_class = Diagnostics

    def __init__(
        self,
        *,
        agent="dubins",
        robot_radius=defaults.ROBOT_RADIUS,
        dt=defaults.DT,
        K=defaults.K,
        N=defaults.N,
        lambda_=defaults.LAMBDA,
        ess_target=ESS_TARGET,
        Sigma=None,
        gamma=defaults.GAMMA,
        alpha=defaults.ALPHA,
        beta=defaults.BETA,
        P=defaults.P,
        seed=None,
        perturbation=None,
        resolution=RESOLUTION,
        obstacle_margin=0.0,
        threads=1,
        prediction=None,
        **other,
    ):
        prediction = prediction or self.default_prediction
        predictor = predictor_class(prediction)
        unknown = [n for n in predictor.inputs if n not in INPUTS]
        if unknown:
            raise ValueError(
                f"prediction {prediction!r} asks for inputs {unknown} that no controller gives; "
                f"valid inputs: {', '.join(INPUTS)}"
            )
        predictor_params = {n: other.pop(n) for n in predictor.own_params if n in other}
        self.agent = make_agent(agent, **other)
        self.robot_radius = positive("robot_radius", robot_radius, allow_zero=True)
        self.dt = positive("dt", dt)
        self.K = positive("K", K, integer=True)
        self.N = positive("N", N, integer=True)
        self.lambda_ = temperature_param(lambda_)
        self.ess_target = positive("ess_target", ess_target)
        if self.ess_target > 1.0:
            raise ValueError(f"ess_target must be in (0, 1] (a share of K); got {ess_target!r}")
        self.Sigma = self.agent.variances(Sigma)
        self.gamma = positive("gamma", gamma, allow_zero=True)
        self.alpha = positive("alpha", alpha, allow_zero=True)
        self.beta = positive("beta", beta, allow_zero=True)
        self.P = positive("P", P, integer=True)
        perturbation = self.agent.default_perturbation if perturbation is None else perturbation
        if perturbation not in PERTURBATIONS:
            raise ValueError(f"perturbation must be one of {PERTURBATIONS}; got {perturbation!r}")
        self.perturbation = perturbation
        self.resolution = positive("resolution", resolution)
        self.obstacle_margin = positive("obstacle_margin", obstacle_margin, allow_zero=True)
        self.threads = positive("threads", threads, integer=True)
        generator = isinstance(seed, np.random.Generator)
        if not (seed is None or generator or isinstance(seed, numbers.Integral) and seed >= 0):
            raise ValueError(
                f"seed must be None, an int >= 0 or a np.random.Generator; got {seed!r}"
            )
        self.seed = seed
        self.prediction = prediction
        self.predictor = predictor(
            N=self.N, dt=self.dt, robot_radius=self.robot_radius,
            max_speed=self.agent.max_speed, alpha=self.alpha, beta=self.beta, P=self.P,
            obstacle_margin=self.obstacle_margin, **predictor_params,
        )  # fmt: skip
        self.sigma = np.sqrt(self.Sigma)
        # gamma lambda Sigma^-1 of the importance term, per control (lambda = 1 with "auto")
        lam = 1.0 if self.lambda_ == AUTO else self.lambda_
        self._importance_weight = (self.gamma * lam) / self.Sigma
        self._lambda_max = self.alpha / COLLISION_NATS if self.alpha else np.inf
        self._grid = None
        self.objective = None
        self.timer = NO_TIMER
        self.rng = None
        self.reset(seed)

    own_params = (
        "agent", "robot_radius", "dt", "K", "N", "lambda_", "ess_target", "Sigma", "gamma",
        "alpha", "beta", "P", "seed", "perturbation", "resolution", "obstacle_margin",
        "threads", "prediction",
    )  # fmt: skip

    @classmethod
    def param_names(cls):
        """Keyword parameters of this controller (each class lists its own in `own_params`);
        the agent's and the predictor's parameters come on top (`make_controller` checks all)."""
        names = []
        for klass in reversed(cls.__mro__):
            names += [n for n in klass.__dict__.get("own_params", ()) if n not in names]
        return names

    @property
    def params(self):
        """All parameters as a dict (for records): the controller's, its agent's and its
        predictor's."""
        out = {n: getattr(self, n) for n in self.param_names() if n not in ("seed", "agent")}
        out["Sigma"] = self.Sigma.tolist()
        return {
            "agent": self.agent.name,
            **self.agent.params,
            **out,
            **self.predictor.params,
            "seed": None if isinstance(self.seed, np.random.Generator) else self.seed,
        }

    @property
    def nu(self):
        """Number of controls of the agent."""
        return self.agent.nu

    def reset(self, seed=None):
        """Start a new episode: the agent's first guess on the next step, the predictor
        forgets; re-seed when `seed` is given."""
        if seed is not None:
            self.seed = seed
        if self.rng is None or seed is not None:
            s = self.seed
            self.rng = s if isinstance(s, np.random.Generator) else np.random.default_rng(s)
            self._keys = self.rng.spawn(1)[0]  # its own stream: rng's draws stay the predictor's
        self._key = int(self._keys.integers(2**63))  # this episode's perturbation stream
        self._draws = 0
        self.U = None  # set from the agent's first guess at the first step
        self._last_lambda = None  # "auto": where the next step's search starts
        self.predictor.reset()
        self.diagnostics = self.diagnostics_class()

    # --- one control step -------------------------------------------------------------------

    def act(
        self,
        state,
        goal,
        static=None,
        moving=None,
        obstacle_model=None,
        bounds=None,
        moving_velocity=None,
        moving_futures=None,
    ):
        """Controls to apply now.

        Args:
          state: (3,) x, y, theta. goal: (2,) x, y.
          static: (M, 3) x, y, radius of static cylinders (radius-0 rows ignored), or None.
          moving: (L, 4) x, y, heading, radius of moving cylinders now (heading nan: not
            observed), or None.
          obstacle_model: (4,) v_mean, v_std, omega_mean, omega_std of the moving obstacles.
          bounds: (4,) xmin, ymin, xmax, ymax of the map, or None: with bounds a state whose
            centre leaves the map costs alpha, as a collision with the static map does.
          moving_velocity: (L, 2) world-frame velocities of the rows of `moving` (nan rows: not
            observed), or None; given to predictors whose `inputs` name "velocity".
          moving_futures: (L, F, N + 1, 2) the caller's F futures of each row of `moving` at the
            rollout steps, or None; given to predictors whose `inputs` name "futures" ("given").
        Returns:
          (nu,) controls within the agent's bounds (dubins: the turn rate omega).
        """
        state = floats("state", state)
        goal = floats("goal", goal)
        if state.shape != (3,) or goal.shape != (2,):
            raise ValueError(f"state must be (3,) and goal (2,); got {state.shape}, {goal.shape}")
        if not all(abs(v) < MAX_COORDINATE for v in (*state.tolist(), *goal.tolist())):  # nan too
            raise ValueError(
                f"state and goal must be finite and within {MAX_COORDINATE:.0e} (m, rad); "
                f"got {state}, {goal}"
            )
        if self._grid is None or not self._grid.matches(static, bounds):
            self._grid = OccupancyGrid(static, self.robot_radius, self.resolution, bounds)
        if self.U is None:
            self.U = self.agent.project(self.agent.first_guess(state, goal, self.N), axis=1)
        observed = moving
        moving = valid_cylinders(moving, "moving", columns=4, unobserved=2)
        velocity = observed_velocity(moving_velocity, observed)
        futures = observed_rows(moving_futures, observed, "moving_futures")
        with self.timer("prediction"):
            prediction = self.predictor.predict(
                state, moving, obstacle_model, self.rng, **self._inputs(state, velocity, futures)
            )
            self.objective = Objective(goal, self._grid, self.alpha, prediction)
        self.diagnostics.prediction = prediction
        u = self._solve(state)
        self.diagnostics.action = u
        return u

    def _solve(self, state):
        raise NotImplementedError

    def _inputs(self, state, velocity, futures):
        """The keywords named in the predictor's `inputs` (predictors.base.INPUTS)."""
        inputs = {}
        if "velocity" in self.predictor.inputs:
            inputs["velocity"] = velocity
        if "futures" in self.predictor.inputs:
            inputs["futures"] = futures
        if "robot_plan" in self.predictor.inputs:
            inputs["robot_plan"] = self.agent.rollout_one(state, self.U, self.dt)
        return inputs

    # --- building blocks --------------------------------------------------------------------

    def sample(self):
        """Perturbations eps (N, nu, K) drawn from N(0, Sigma), time-major.

        constant: one draw per sample and control (kept in self._raw (nu, K)), the same at
        every step; time_varying: independent draws per step; mixed: the sum of one of each,
        both N(0, Sigma / 2), so that every kind has the per-step variance Sigma that the
        importance term assumes.
        """
        shape = (self.N, self.nu, self.K)
        if self.perturbation == "constant":
            raw = self._normals((1, self.nu, self.K), self.sigma)
            self._raw = raw[0]
            return constant_steps(raw, self.N)
        draw, scale, add = self._per_step()
        return draw_normals(self._key, draw, shape, scale, add, self.threads)

    def _per_step(self):
        """The next per-step draw (time_varying, mixed) for sample(): its number, scale (nu,)
        and added term (nu, K) or None (mixed: half of a constant draw made now)."""
        self._raw = None  # no constant draw of the whole horizon this step
        scale, add = self.sigma, None
        if self.perturbation == "mixed":
            half = np.sqrt(0.5)  # each draw N(0, Sigma / 2): the sum has variance Sigma each step
            raw = self._normals((1, self.nu, self.K), self.sigma)[0]
            scale, add = half * self.sigma, half * raw
        self._draws += 1
        return self._draws, scale, add

    def _draws_in_pass(self):
        """Whether perturbed_rollouts may draw this step's perturbations in the pass that
        bounds them: per-step draws into a box (and a disc of two controls), with sample() and
        controls() as defined here (a subclass's or an instance's own are called instead)."""
        return (
            self._own("sample")
            and self._own("controls")
            and self.perturbation != "constant"
            and (self.agent.norm_axes is None or len(self.agent.norm_axes) == 2)
        )

    def _own(self, method):
        """Whether `method` is Controller's, not a subclass's or an instance's own."""
        return getattr(type(self), method) is getattr(Controller, method) and (
            method not in vars(self)
        )

    def _normals(self, shape, scale):
        """The next draw of this episode's perturbation stream
        (dcmppi.control.kernels.perturbations): z * scale[:, None] for standard normals z (1, nu,
        K), on this thread."""
        self._draws += 1
        return draw_normals(self._key, self._draws, shape, scale)

    def controls(self, U0, eps, sums=False):
        """Bounded controls project(U0 + eps) (N, nu, K) and the perturbations that remain
        (dcmppi.control.kernels.projection); with sums=True also their horizon sums (nu, K), the
        clustering features."""
        return project_perturbed(self.agent, U0, eps, sums)

    def perturbed_rollouts(self, x0, eps=None, starts=1, sums=False, moving=False):
        """A step's per-sample work, its samples split over `threads` threads (on this thread
        alone when controls() or evaluate() is replaced, which are then called): the controls
        project(U + eps) (Controller.controls), their rollouts from x0 and costs under this
        step's objective (Controller.evaluate), and the importance term (Controller.importance;
        with per-step draws into a box (or a disc) its sums over the steps come from the draws'
        pass).

        x0: (3,), or (3, S) with starts = S > 1: every sample rolls out from each start.
        eps: (N, nu, K) perturbations, or None: this step's (Controller.sample); per-step draws
          into a box (and the holonomic base's disc) are then bounded row by row as they are
          drawn, with the values of sample() then controls() (perturbations.draw_box), unless
          either is replaced (a subclass's or an instance's: they are called, on one thread).
        Returns e (N, nu, K) the perturbations that remain, states (3, N + 1, S K), J (S K,),
        the importance term (K,); with sums=True also the horizon sums of e (nu, K), with
        moving=True J's moving-obstacle term (S K,) (None: 0).
        """
        agent, U0 = self.agent, self.U
        in_pass = eps is None and self._draws_in_pass()
        if eps is None and not in_pass:
            with self.timer("sample"):
                eps = self.sample()
        K = self.K if in_pass else eps.shape[2]
        # a replaced controls() or evaluate() is called as it is, on this thread
        split = self._own("controls") and self._own("evaluate")
        ranges = parts(K, self.threads) if split else ((0, K),)
        # the pass that bounds the controls is ours (not a replaced controls()); then it sums the
        # importance term over the steps too, unless importance() is replaced
        ours = self._own("controls")  # so whenever the draws are in the pass or split
        fused = ours and self._own("importance")
        products = np.zeros((self.nu, K)) if fused else NO_SUMS
        if ours:
            u, e = np.empty((self.N, self.nu, K)), np.empty((self.N, self.nu, K))
            total = np.zeros((self.nu, K)) if sums else NO_SUMS
            if in_pass:
                box = agent.lower, agent.upper
                disc = None if agent.norm_axes is None else (*agent.norm_axes, agent.norm_limit)
                project = functools.partial(
                    draw_box, self._key, *self._per_step(), U0, *box, products=products, disc=disc
                )
            else:
                project = functools.partial(project_columns, agent, U0, eps, products=products)
        if len(ranges) == 1:  # the whole batch on this thread
            with self.timer("controls"):
                if ours:
                    project(u, e, total)
                else:  # a subclass's or an instance's own controls()
                    u, e, *rest = self.controls(U0, eps, sums)
                    total = rest[0] if sums else NO_SUMS
            states, J, term = self.evaluate(x0, u, starts, moving=True)
            with self.timer("importance"):
                importance = (
                    importance_of(products, self._importance_weight)
                    if fused
                    else self.importance(U0, e)
                )
            return e, states, J, importance, *([total] if sums else []), *([term] if moving else [])
        objective = self.objective
        out = np.empty((3, self.N + 1, starts, K))
        out[:, 0] = np.reshape(x0, (3, starts, -1))
        states = out.reshape(3, self.N + 1, starts * K)
        J, importance = np.empty(starts * K), np.empty(K)
        term = None if objective.tracks.empty else np.empty(starts * K)

        def part(j0, j1):
            project(u, e, total, (j0, j1))
            agent.rollout_columns(out, u, self.dt, (j0, j1))
            for s in range(starts):
                c0, c1 = s * K + j0, s * K + j1
                J[c0:c1], t = objective(states, True, (c0, c1))
                if term is not None:
                    term[c0:c1] = t
            importance[j0:j1] = (
                importance_of(products[:, j0:j1], self._importance_weight)
                if fused
                else self.importance(U0, e[:, :, j0:j1])
            )

        with self.timer("threads"):
            run(part, ranges)
        return e, states, J, importance, *([total] if sums else []), *([term] if moving else [])

    def evaluate(self, x0, u, starts=1, moving=False):
        """Rollouts and their costs under this step's objective. x0: (3,) or (3, R);
        u: (N, nu, R). Returns states (3, N + 1, R), J (R,), and with moving=True the
        moving-obstacle term of J (R,) (None: 0).

        starts = S > 1: x0 (3, S) start states that all take the R sequences; R becomes S R.
        """
        with self.timer("rollout"):
            states = self.agent.rollout(x0, u, self.dt, starts)
        with self.timer("objective"):
            J = self.objective(states, moving)
        return (states, *J) if moving else (states, J)

    def importance(self, U0, eps):
        """gamma lambda sum_i u_i^T Sigma^-1 eps_i for each sample (K,) (lambda = 1 with
        lambda_="auto")."""
        return importance(U0, eps, self._importance_weight)

    def temperature(self, S):
        """The step's lambda for the costs S (K,): lambda_, or with "auto" the one whose weights
        exp(-(S - min S) / lambda) have an ESS near ess_target x K, at most alpha / 10 (searched
        from the last step's)."""
        if self.lambda_ != AUTO:
            return self.lambda_
        with self.timer("temperature"):
            lam = choose_lambda(S, self.ess_target, self._last_lambda, self._lambda_max)
        self._last_lambda = lam
        return lam

    def finish(self, plan):
        """Apply the plan's first controls and warm-start the next step by shifting it.

        plan: (N, nu). Returns plan[0] (nu,) in the agent's bounds (a weighted mean of bounded
        controls may leave them by a rounding error).
        """
        self.U = shifted(plan)
        self.diagnostics.plan = plan
        return bound(self.agent, plan[0])


def shifted(plan):
    """The next step's warm start: plan (N, nu) one step on, its last row repeated."""
    out = np.empty_like(plan)
    out[:-1] = plan[1:]
    out[-1] = plan[-1]
    return out


def constant_steps(raw, n):
    """np.broadcast_to(raw, (n, nu, K)) of raw (1, nu, K), C-contiguous: the same read-only
    view (a zero stride along the steps), made without numpy's general broadcasting."""
    view = np.ndarray((n, *raw.shape[1:]), raw.dtype, raw, 0, (0, *raw.strides[1:]))
    view.flags.writeable = False
    return view


def temperature_param(value):
    """lambda_ as a float, or "auto"; a ValueError for anything else."""
    if isinstance(value, str) and value == AUTO:
        return AUTO
    try:
        return positive("lambda_", value)
    except ValueError:
        raise ValueError(f"lambda_ must be a number > 0 or 'auto'; got {value!r}") from None


def observed_rows(values, moving, name):
    """The rows of `values` (L, ...) that belong to rows of `moving` (L, 4) that are not padding
    (radius > 0), or None; checked only for their number of rows (the predictor checks the rest)."""
    if values is None:
        return None
    values = np.asarray(values, dtype=float)
    radius = np.zeros(0) if moving is None else np.asarray(moving, dtype=float)[:, 3]
    if values.ndim < 1 or len(values) != len(radius):
        raise ValueError(
            f"{name} must have one row per row of moving ({len(radius)}); got shape {values.shape}"
        )
    return values[radius > 0]


def observed_velocity(velocity, moving):
    """The (L', 2) velocities of the rows of `moving` that are not padding (radius > 0), or None.

    Args:
      velocity: (L, 2) world-frame velocities (nan: not observed), or None.
      moving: (L, 4) moving obstacles, already validated (costs.valid_cylinders), or None.
    """
    if velocity is None:
        return None
    velocity = np.asarray(velocity, dtype=float)
    rows = 0 if moving is None else len(moving)
    if velocity.shape != (rows, 2):
        raise ValueError(
            f"moving_velocity must have shape ({rows}, 2), one row per row of moving; "
            f"got {velocity.shape}"
        )
    if not rows:  # no moving obstacles: nothing to check or select
        return velocity
    infinite = np.isinf(velocity).any(axis=1)
    if infinite.any():
        raise ValueError(
            f"moving_velocity must be finite, or nan where not observed; infinite rows "
            f"{np.flatnonzero(infinite)}"
        )
    return observed_rows(velocity, moving, "moving_velocity")
