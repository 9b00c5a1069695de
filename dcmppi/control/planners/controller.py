"""The planner base: its parameters, one control step's frame and the building blocks.

    ctrl = make_controller("clustered", agent="holonomic", K=500, seed=0)
    ctrl.reset(seed=1)
    u = ctrl.act(state, goal, static, moving, obstacle_model)   # (nu,) controls to apply

Every controller accepts the shared parameters (defaults from dcmppi.control.defaults,
explained in docs/design.md): agent and its parameters (dubins: v, r_min; unicycle and holonomic:
v_max, omega_max), robot_radius, dt, K, N, lambda_, ess_target, Sigma, gamma, alpha, beta, P, seed,
perturbation, resolution, obstacle_margin, threads, prediction and its predictor's parameters,
shield (the applied command's safety filter, dcmppi.control.planners.shield), plus its own. Each
step, the predictor turns the moving obstacles into tracks, the step's Objective scores rollouts,
and the subclass's `_solve` plans with them.
"""

import functools

import numpy as np

from dcmppi.control import defaults
from dcmppi.control.agents import make_agent
from dcmppi.control.defaults import PRESETS
from dcmppi.control.kernels.costs import RESOLUTION, OccupancyGrid, valid_cylinders
from dcmppi.control.kernels.perturbations import Draw
from dcmppi.control.kernels.projection import NO_SUMS, bound, project_columns
from dcmppi.control.kernels.sums import importance_of
from dcmppi.control.kernels.threads import parts, run
from dcmppi.control.objective import PACE_PARAMS, Objective, Pace
from dcmppi.control.planners.diagnostics import Diagnostics
from dcmppi.control.planners.observations import observed_rows, observed_velocity, state_and_goal
from dcmppi.control.planners.rollouts import Rollouts, start_states
from dcmppi.control.planners.sampling import Sampler, correlation_param, perturbation_param
from dcmppi.control.planners.shield import make_shield, shielded
from dcmppi.control.planners.smoothing import PlanFilter
from dcmppi.control.planners.temperature import (
    AUTO,
    COLLISION_NATS,
    ESS_TARGET,
    choose_lambda,
    temperature_param,
)
from dcmppi.control.predictors import predictor_class
from dcmppi.control.timer import NO_TIMER
from dcmppi.control.validation import choice, positive, seed_param, share


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
        lambda = 1 there with lambda_="auto"); a preset may set it. For a velocity-commanded
        robot the term favours samples slower than the warm start.
      alpha: static collision weight. beta: dynamic collision weight (sampled futures; a
        preset may set it).
      P: futures per moving obstacle. seed: int, None or np.random.Generator.
      perturbation: "constant" (one eps per sample over the horizon, paper Sec. IV-A),
        "time_varying" (independent per step), "mixed" (one of each) or "correlated" (each
        sample's steps an AR(1) sequence; dcmppi.control.planners.sampling); default: the
        agent's ("smooth": "correlated").
      correlation: a in [0, 1), the step-to-step correlation of "correlated" perturbations
        (default 0.9: about 1 s at dt = 0.1 s); only with that kind.
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
      preset: a name of dcmppi.control.defaults.PRESETS: "paper" (default: the paper's
        algorithms), "smooth" (plans a robot can follow) or "crowds" (among people); it sets
        the options it names where they are not given.
      filter_window, filter_order: the Savitzky-Golay filter of the plan
        (dcmppi.control.planners.smoothing), its odd window (>= 3; 0: no filter, the default;
        "smooth": 9) and polynomial order (< window; default 2).
      cost_to_go, path_align, speed_weight, way_weight: weights >= 0 of the objective's terms
        for time to the goal and for standing in a person's way (dcmppi.control.objective.Pace;
        0: off, the default).
      shield: the safety shield of the applied control (dcmppi.control.planners.shield): None or
        false (off, the default), true, or a dict of its time_horizon, margin and plan.
    Attributes: agent, predictor, sampler (sampling.Sampler), plan_filter
      (smoothing.PlanFilter), pace (objective.Pace), safety (shield.Shield or None), objective
      (the last step's), diagnostics (the last step's), timer (the profile's hook,
      dcmppi.control.timer).

    A subclass implements `_solve(state)` -> (nu,) controls, and may override the seams of a
    step's per-sample work (perturbed_rollouts). sample() runs once per step on the calling
    thread; the others run for every part of the samples, cols = (j0, j1), on the thread that
    holds the part, so that an override plans alike on any number of threads. They fill the
    step's Rollouts r in place:
      sample() -> eps (N, nu, K): an array, or a Draw made in the pass that bounds it;
      controls(r, cols): r.u, r.e, r.sums (when asked) and r.products of those samples;
      evaluate(r, cols): their r.states, r.J and r.moving (its columns: r.spans(cols));
      importance(r, cols): their r.importance.
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
        lambda_=None,
        ess_target=None,
        Sigma=None,
        gamma=None,
        alpha=defaults.ALPHA,
        beta=None,
        P=defaults.P,
        seed=None,
        perturbation=None,
        correlation=None,
        resolution=RESOLUTION,
        obstacle_margin=0.0,
        threads=1,
        prediction=None,
        preset=None,
        filter_window=None,
        filter_order=None,
        shield=None,
        **other,
    ):
        self.preset = choice("preset", "paper" if preset is None else preset, tuple(PRESETS))
        self.prediction = prediction or self.default_prediction
        predictor = predictor_class(self.prediction)
        predictor_params = self._given(predictor.own_params, other)
        pace = {n: other.pop(n, None) for n in PACE_PARAMS}
        self.agent = make_agent(agent, **other)
        self.robot_radius = positive("robot_radius", robot_radius, allow_zero=True)
        self.dt = positive("dt", dt)
        self.K = positive("K", K, integer=True)
        self.N = positive("N", N, integer=True)
        self.lambda_ = temperature_param(self.option("lambda_", lambda_, defaults.LAMBDA))
        self.ess_target = share("ess_target", self.option("ess_target", ess_target, ESS_TARGET))
        self.Sigma = self.agent.variances(Sigma)
        self.gamma = positive("gamma", self.option("gamma", gamma, defaults.GAMMA), allow_zero=True)
        self.alpha = positive("alpha", alpha, allow_zero=True)
        self.beta = positive("beta", self.option("beta", beta, defaults.BETA), allow_zero=True)
        self.P = positive("P", P, integer=True)
        perturbation = self.option("perturbation", perturbation)
        self.perturbation = perturbation_param(perturbation, self.agent)
        self.correlation = correlation_param(correlation, self.perturbation)
        self.resolution = positive("resolution", resolution)
        self.obstacle_margin = positive("obstacle_margin", obstacle_margin, allow_zero=True)
        self.threads = positive("threads", threads, integer=True)
        self.seed = seed_param(seed)
        self._components(predictor, predictor_params, filter_window, filter_order, pace, shield)
        # gamma lambda Sigma^-1 of the importance term, per control (lambda = 1 with "auto")
        lam = 1.0 if self.lambda_ == AUTO else self.lambda_
        self._importance_weight = (self.gamma * lam) / self.Sigma
        self._lambda_max = self.alpha / COLLISION_NATS if self.alpha else np.inf
        self.timer = NO_TIMER
        self._grid = self.objective = self.rng = None
        self.reset(seed)

    def _given(self, names, other):
        """{name: value} of `names` given in `other` (popped, None too) or set by the preset."""
        preset = PRESETS[self.preset]
        given = {n: other.pop(n) for n in names if n in other}
        return {**{n: preset[n] for n in names if n in preset}, **given}

    def _components(self, predictor, predictor_params, filter_window, filter_order, pace, shield):
        """The step's components from the checked parameters: the sampler, the plan's filter
        (of the given or the preset's window and order), the objective's Pace (of the given
        or the preset's weights `pace`, {name: value or None}), the predictor (of the class
        `predictor`, with its own parameters) and the safety shield (of the option `shield`)."""
        shield = self.option("shield", shield)
        self.shield, self.safety = make_shield(shield, self.agent, self.robot_radius, self.dt)
        self.sampler = Sampler(
            self.agent, self.Sigma, self.N, self.K, self.perturbation, self.correlation,
            self.threads,
        )  # fmt: skip
        self.plan_filter = PlanFilter(
            self.agent,
            self.option("filter_window", filter_window, 0),
            self.option("filter_order", filter_order, 2),
        )
        self.filter_window, self.filter_order = self.plan_filter.window, self.plan_filter.order
        weights = {n: self.option(n, v, 0.0) for n, v in pace.items()}
        self.pace = Pace.of(self.agent.max_speed, self.dt, **weights)
        self.cost_to_go, self.path_align, self.speed_weight, self.way_weight = (
            getattr(self.pace, n) for n in PACE_PARAMS
        )
        self.predictor = predictor(
            N=self.N, dt=self.dt, robot_radius=self.robot_radius,
            max_speed=self.agent.max_speed, alpha=self.alpha, beta=self.beta, P=self.P,
            obstacle_margin=self.obstacle_margin, **predictor_params,
        )  # fmt: skip

    own_params = (
        "agent", "robot_radius", "dt", "K", "N", "lambda_", "ess_target", "Sigma", "gamma",
        "alpha", "beta", "P", "seed", "perturbation", "correlation", "resolution",
        "obstacle_margin", "threads", "prediction", "preset", "filter_window", "filter_order",
        *PACE_PARAMS, "shield",
    )  # fmt: skip

    def option(self, name, value, default=None):
        """A parameter's value: `value` when given (not None), else the preset's, else
        `default`."""
        return PRESETS[self.preset].get(name, default) if value is None else value

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
            self.sampler.seed(self.rng)
        self.sampler.reset()  # this episode's perturbation stream
        self.U = None  # set from the agent's first guess at the first step
        self._last_lambda = None  # "auto": where the next step's search starts
        self.plan_filter.reset()
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
        state, goal = state_and_goal(state, goal)
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
            pace = self.pace if self.pace.on else None
            self.objective = Objective(goal, self._grid, self.alpha, prediction, pace, state[:2])
        self.diagnostics.prediction, self.diagnostics.plan = prediction, None
        u = self._solve(state)
        if self.safety is not None:
            with self.timer("shield"):
                args = (static, moving, velocity, obstacle_model, bounds, self.diagnostics.plan)
                u = shielded(self.safety, self.diagnostics, state, u, *args)
        self.diagnostics.action = u
        self.plan_filter.record(u)
        return u

    def _solve(self, state):
        raise NotImplementedError

    def _inputs(self, state, velocity, futures):
        """The keywords named in the predictor's `inputs` (predictors.base.INPUTS)."""
        inputs = {"velocity": velocity, "futures": futures}
        if "robot_plan" in self.predictor.inputs:
            inputs["robot_plan"] = self.agent.rollout_one(state, self.U, self.dt)
        return {n: v for n, v in inputs.items() if n in self.predictor.inputs}

    # --- building blocks: the seams a subclass may override -------------------------------

    def sample(self):
        """This step's perturbations eps (N, nu, K) from N(0, Sigma), time-major: an array, or
        a Draw of them (dcmppi.control.kernels.perturbations; np.asarray makes it) that
        controls() makes in the pass that bounds them (sampling.Sampler.sample)."""
        return self.sampler.sample()

    def controls(self, r, cols):
        """The samples cols = (j0, j1) of the Rollouts r: the bounded controls project(r.U0 +
        r.eps) into r.u, the perturbations that remain into r.e, and in the same pass their sums
        over the steps into r.sums (when asked) and r.products (which importance() reads)."""
        sums = NO_SUMS if r.sums is None else r.sums
        if isinstance(r.eps, Draw):
            r.eps.into_box(self.agent, r.U0, r.u, r.e, sums, r.products, cols)
        else:
            whole = None if cols == (0, r.K) else cols  # the kernels' loop without a slice
            project_columns(self.agent, r.U0, r.eps, r.u, r.e, sums, whole, r.products)

    def evaluate(self, r, cols):
        """The samples cols = (j0, j1) of the Rollouts r: their controls r.u rolled out from the
        start states r.states[:, 0] into r.states, their costs under this step's objective into
        r.J and, when r.moving is an array, J's moving-obstacle term into it (0 without one);
        r.spans(cols) gives their columns of states and J, one range per start state."""
        k = r.K
        with self.timer("rollout"):
            states = r.states.reshape(3, r.states.shape[1], -1, k)  # (3, N + 1, S, K), a view
            self.agent.rollout_columns(states, r.u, self.dt, None if cols == (0, k) else cols)
        with self.timer("objective"):
            for c0, c1 in r.spans(cols):
                whole = None if (c0, c1) == (0, len(r.J)) else (c0, c1)
                r.J[c0:c1], term = self.objective(r.states, True, whole)
                if r.moving is not None:
                    r.moving[c0:c1] = 0.0 if term is None else term

    def importance(self, r, cols):
        """The samples cols = (j0, j1) of the Rollouts r: the importance term gamma lambda sum_i
        u_i^T Sigma^-1 e_i (lambda = 1 with lambda_="auto") into r.importance, from the sums
        r.products that controls() leaves."""
        j0, j1 = cols
        r.importance[j0:j1] = importance_of(r.products[:, j0:j1], self._importance_weight)

    # --- the per-sample work of a step ------------------------------------------------------

    def perturbed_rollouts(self, x0, eps=None, starts=1, sums=False):
        """A step's per-sample work: its K samples split over `threads` threads (one part on
        one thread), each part's controls(), evaluate() and importance() in turn.

        x0: (3,), or (3, S) with starts = S > 1: every sample rolls out from each start.
        eps: (N, nu, K) perturbations, or None: this step's sample().
        sums: whether to keep the horizon sums of the perturbations (the clustering features).
        Returns the Rollouts.
        """
        if eps is None:
            with self.timer("sample"):
                eps = self.sample()
        moving = not self.objective.tracks.empty
        r = Rollouts.allocate(self.U, eps, x0, starts, sums, moving)
        ranges = parts(r.K, self.threads)
        timer = self.timer if len(ranges) > 1 else NO_TIMER  # "threads": the parts' wall time
        with timer("threads"):
            run(functools.partial(self._part, r), ranges)
        return r

    def _part(self, r, j0, j1):
        """The per-sample work of the samples j0:j1 of the Rollouts r (on any thread)."""
        with self.timer("controls"):
            self.controls(r, (j0, j1))
        self.evaluate(r, (j0, j1))
        with self.timer("importance"):
            self.importance(r, (j0, j1))

    def rollout_costs(self, x0, u, starts=1):
        """Rollouts of given controls and their costs under this step's objective (evaluate()).

        x0: (3,), (3, R) one per sequence, or (3, S) with starts = S > 1: every sequence from
        each. u: (N, nu, R) controls within the agent's bounds.
        Returns states (3, N + 1, S R) and J (S R,).
        """
        n, _, k = np.shape(u)
        r = Rollouts(u=u, states=start_states(x0, n, starts, k), J=np.empty(starts * k))
        self.evaluate(r, (0, k))
        return r.states, r.J

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

    def smoothed(self, plan):
        """The plan (N, nu) through the plan's filter (smoothing.PlanFilter), or itself without
        one."""
        if not self.filter_window:
            return plan
        with self.timer("filter"):
            return self.plan_filter(plan)

    def finish(self, plan):
        """Apply the plan's first controls and warm-start the next step by shifting it.

        plan: (N, nu), filtered first when the planner has a filter (smoothed). Returns plan[0]
        (nu,) in the agent's bounds (a weighted mean of bounded controls may leave them by a
        rounding error).
        """
        plan = self.smoothed(plan)
        self.U = shifted(plan)
        self.diagnostics.plan = plan
        return bound(self.agent, plan[0])


def shifted(plan):
    """The next step's warm start: plan (N, nu) one step on, its last row repeated."""
    out = np.empty_like(plan)
    out[:-1] = plan[1:]
    out[-1] = plan[-1]
    return out
