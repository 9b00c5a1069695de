"""The predictor interface, its result, the registry and the check of the obstacle model."""

from __future__ import annotations

import dataclasses
import importlib

import numpy as np

from dcmppi.control.registry import Registry
from dcmppi.control.validation import floats

# what a controller gives a predictor on top of the observation, for the names in its `inputs`:
# velocity (L, 2) the moving obstacles' observed velocities (nan rows: not observed) or None;
# robot_plan (N + 1, 3) the robot's states along the planner's warm start from the current state;
# futures (L, F, N + 1, 2) the caller's own futures of the obstacles (act's moving_futures)
INPUTS = ("velocity", "robot_plan", "futures")


@dataclasses.dataclass(frozen=True)
class Prediction:
    """What a predictor says of the moving obstacles for one control step.

    tracks: (T, N + 1, 2) obstacle centres at the rollout steps t_0 .. t_N.
    distance: (T,) collision distance of each track (robot radius + obstacle radius + margin)
      [m]: a state x_i collides with track j when |p_i - tracks[j, i]| <= distance[j].
    weight: cost of one collision of one state with one track (frozen: alpha; sampled futures:
      beta theta with theta = 1 / P).
    collision_cost: what one state pays for a certain collision with one obstacle (all its
      tracks hit): frozen alpha, sampled futures beta. Clustered MPPI measures the
      moving-obstacle term in this unit (dcmppi.control.planners.clustered). None: `weight`.
    futures: (L', P, N + 1, 2) the sampled futures by obstacle (tracks grouped by obstacle:
      tracks = futures.reshape(-1, N + 1, 2), with distance alike), for diagnostics, videos and
      the objective's way term, or None.
    posterior: (mean (L, 5), cov (L, 5, 5)) of each obstacle's x, y, heading, speed, turn rate
      where the predictor filters them ("ekf"), or None.
    """

    tracks: np.ndarray
    distance: np.ndarray
    weight: float
    futures: np.ndarray | None = None
    posterior: tuple | None = None
    collision_cost: float | None = None

    @property
    def unit(self) -> float:
        """collision_cost, or weight when it is not given."""
        return self.weight if self.collision_cost is None else self.collision_cost


def check_obstacle_model(obstacle_model, name):
    """The (4,) array v_mean, v_std, omega_mean, omega_std, or a ValueError."""
    if obstacle_model is None:
        raise ValueError(
            f"prediction {name!r} needs obstacle_model (v_mean, v_std, omega_mean, omega_std)"
        )
    model = floats("obstacle_model", obstacle_model)
    if model.shape != (4,) or not np.isfinite(model).all() or model[1] < 0 or model[3] < 0:
        raise ValueError(
            f"obstacle_model must be (4,) finite v_mean, v_std >= 0, omega_mean, "
            f"omega_std >= 0; got {obstacle_model}"
        )
    return model


class Predictor:
    """Base of the obstacle predictors.

    Args (keywords, given by the planner): N horizon steps, dt control period [s],
    robot_radius [m], max_speed the agent's fastest planar speed [m/s], alpha and beta the
    static and dynamic collision weights, P futures per obstacle, obstacle_margin added to
    every moving obstacle's radius [m]. A subclass lists its own keyword parameters in
    `own_params` and implements `predict`; `reset` forgets what it learnt in an episode.
    `inputs` names the extra keywords its `predict` takes from the controller (INPUTS:
    "velocity", "robot_plan", "futures"); without them predict is called with the four arguments
    alone.
    """

    name = None
    own_params: tuple[str, ...] = ()
    inputs: tuple[str, ...] = ()

    def __init__(self, *, N, dt, robot_radius, max_speed, alpha, beta, P, obstacle_margin):
        self.N, self.dt, self.robot_radius = N, dt, robot_radius
        self.max_speed, self.alpha, self.beta, self.P = max_speed, alpha, beta, P
        self.obstacle_margin = obstacle_margin
        self._none = None

    @property
    def params(self) -> dict:
        """The predictor's own parameters by name (for records)."""
        return {n: getattr(self, n) for n in self.own_params}

    def reset(self):
        """Start a new episode."""

    def predict(self, state, moving, obstacle_model, rng) -> Prediction:
        """The tracks of this step.

        Args:
          state: (3,) the robot's x, y, theta. moving: (L, 4) x, y, heading, radius of the
            moving obstacles now (heading nan: not observed; padding rows removed).
          obstacle_model: (4,) v_mean, v_std, omega_mean, omega_std of the obstacles, or None.
          rng: the planner's np.random.Generator (draw only from it: same seed, same plans).
          velocity=, robot_plan=, futures=: where named in `inputs` (INPUTS).
        """
        raise NotImplementedError

    def none(self) -> Prediction:
        """No track (no moving obstacle near): one read-only Prediction, made once."""
        if self._none is None:
            self._none = self.empty()
            for array in (self._none.tracks, self._none.distance, self._none.futures):
                if array is not None:
                    array.flags.writeable = False
        return self._none

    def empty(self) -> Prediction:
        """A new Prediction without tracks (what `none` returns)."""
        return Prediction(np.zeros((0, self.N + 1, 2)), np.zeros(0), self.alpha)


PREDICTORS = Registry(
    "predictor",
    base=Predictor,
    hint="or package.module:ClassName of your own Predictor subclass",
)


def register_predictor(name):
    """Class decorator adding a Predictor subclass to the registry under `name`."""
    return PREDICTORS.register(name)


def predictor_names() -> list[str]:
    """Registered predictor names, sorted."""
    return PREDICTORS.names()


def predictor_class(name) -> type:
    """The class of predictor `name`: a registered name, or `package.module:ClassName` of a
    Predictor subclass (imported here, so that every worker of a benchmark finds it); a
    ValueError names the valid ones, or the inputs it asks for that no controller gives."""
    if isinstance(name, str) and ":" in name and name not in PREDICTORS:
        cls = _import(name)
    else:
        cls = PREDICTORS.get(name)
    unknown = [n for n in cls.inputs if n not in INPUTS]
    if unknown:
        raise ValueError(
            f"prediction {name!r} asks for inputs {unknown} that no controller gives; "
            f"valid inputs: {', '.join(INPUTS)}"
        )
    return cls


def _import(name):
    module_name, _, attr = name.partition(":")
    try:
        cls = getattr(importlib.import_module(module_name), attr)
    except (ImportError, AttributeError) as e:
        raise ValueError(
            f"prediction {name!r}: {e}; run from the directory that holds {module_name}, or "
            "add it to PYTHONPATH"
        ) from e
    if not (isinstance(cls, type) and issubclass(cls, Predictor)):
        raise ValueError(f"prediction {name!r} is not a subclass of dcmppi.control.Predictor")
    return cls


def make_predictor(name, **params) -> Predictor:
    """A predictor by name with the planner's shared keywords and its own parameters."""
    return predictor_class(name)(**params)
