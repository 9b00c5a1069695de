"""The predictor `learned`: P retrieved futures per pedestrian from a trained model, weight
beta / P.

Its parameter `model` is the path of a file that `Model.save` wrote (in an experiment, a recipe
that the bench trains and caches: dcmppi.bench.crowds.recipes). It keeps each pedestrian's
positions over the last (obs - 1) x period seconds, one per step, and matches the pedestrians of
a step to those of the previous one by the assignment of least total distance from where they
were heading (scipy's linear_sum_assignment; a jump over GATE + GATE_SPEED dt starts a new
track), so their number and order may change. A track shorter than the model's observation is
extended backwards at its observed velocity (the `velocity` input; else the track's mean
velocity; else standing). The model's positions at its period are resampled to the planner's
steps t_i = i dt by linear interpolation in time (the present position at t = 0); beyond
pred x period each future goes on at the velocity of its last predicted frame. The predicted
people are blind to the robot: the training crowds had none.
"""

import functools
import pathlib

import numpy as np

from dcmppi.control.predictors.base import register_predictor
from dcmppi.control.predictors.given import Given
from dcmppi.control.predictors.learned.model import APPROXIMATION, load
from dcmppi.control.validation import positive

# a pedestrian further than GATE + GATE_SPEED dt from where every track was heading starts a new
# track (a track seen once is taken as standing: its first step may be a fast walker's)
GATE, GATE_SPEED = 1.0, 3.0  # [m], [m/s]


@functools.lru_cache(maxsize=8)
def _cached(path, stamp):
    """The model at `path`, loaded once per file version (stamp: its mtime and size)."""
    return load(path)


@register_predictor("learned")
class Learned(Given):
    """P retrieved futures per pedestrian from a trained model (module docstring).

    Extra args: model: the path of the model file (`dcmppi predictor train`); approximation:
      a >= 0: the retrieved futures are those of approximate nearest neighbours, each within
      (1 + a) times the distance of the true one of its rank (scipy's k-d tree `eps`; default
      APPROXIMATION); 0: exact. The exact search slows where a crowd lies far from the training
      windows (docs/performance.md); a bounded slack trades a few neighbours for speed.
    """

    own_params = ("model", "approximation")
    inputs = ("velocity",)

    def __init__(self, *, model=None, approximation=APPROXIMATION, **shared):
        self.approximation = positive("approximation", approximation, allow_zero=True)
        if model is None:
            raise ValueError(
                "prediction 'learned' needs model=PATH, a file that `dcmppi predictor train "
                "--data FILES --out MODEL` writes"
            )
        path = pathlib.Path(model)
        if not path.is_file():
            raise ValueError(
                f"prediction 'learned': model={model}: no such file; train it with `dcmppi "
                "predictor train --data FILES --out MODEL` (or give model a recipe table in an "
                "experiment)"
            )
        stat = path.stat()
        self.model = str(model)
        self.trained = _cached(str(path.resolve()), (stat.st_mtime_ns, stat.st_size))
        super().__init__(**shared)
        self.span = int(np.ceil((self.trained.obs - 1) * self.trained.period / self.dt - 1e-9))
        self.reset()

    def reset(self):
        # history (L, span + 1, 2): each track's positions now, dt ago, ...; age (L,) steps seen
        self.history = np.zeros((0, self.span + 1, 2))
        self.age = np.zeros(0, dtype=int)

    def predict(self, state, moving, obstacle_model, rng, velocity=None):
        self.track(moving[:, :2])
        if len(moving) == 0:
            return self.none()
        velocity = _velocity(velocity, len(moving))
        observed, now_velocity = self.observed(velocity)
        others = np.broadcast_to(moving[None, :, :2], (len(moving), len(moving), 2)).copy()
        others[np.diag_indices(len(moving))] = np.nan
        others_v = np.broadcast_to(now_velocity[None], others.shape).copy()
        others_v[np.isnan(others)] = np.nan
        frames = self.trained.forecast(
            observed, others, others_v, self.P, self.approximation
        )  # (L, P, pred, 2)
        futures = self.resample(moving[:, :2], frames)
        radius = moving[:, 3] + self.obstacle_margin
        near = self.reached(state, futures, radius)
        return self.prediction(futures[near], radius[near])

    def track(self, xy):
        """Matches the pedestrians now (L, 2) to the tracks and shifts the histories in."""
        from scipy.optimize import linear_sum_assignment

        old, age = self.history, self.age
        history = np.empty((len(xy), self.span + 1, 2))
        history[:, 1:] = xy[:, None]  # new tracks: no past yet
        self.age = np.zeros(len(xy), dtype=int)
        if len(old) and len(xy):
            ahead = 2 * old[:, 0] - old[:, 1]  # where each was heading, one step on
            ahead[age < 1] = old[age < 1, 0]
            gap = np.hypot(*(xy[:, None] - ahead[None]).transpose(2, 0, 1))  # (L, L_old)
            rows, cols = linear_sum_assignment(gap)
            keep = gap[rows, cols] <= GATE + GATE_SPEED * self.dt
            rows, cols = rows[keep], cols[keep]
            history[rows, 1:] = old[cols, :-1]
            self.age[rows] = np.minimum(age[cols] + 1, self.span)
        history[:, 0] = xy
        self.history = history

    def observed(self, velocity) -> tuple:
        """The model's view of each track: positions (L, obs, 2) one period apart, the last now,
        and velocities now (L, 2) [m per frame]."""
        m = self.trained
        lag = (np.arange(m.obs)[::-1] * m.period / self.dt)[None]  # (1, obs) steps back
        age = self.age[:, None].astype(float)
        back = np.where(  # velocity [m per step] for times older than the track
            np.isfinite(velocity).all(axis=1)[:, None],
            velocity * self.dt,
            np.where(
                age > 0,
                (self.history[:, 0] - _at(self.history, age[:, 0])) / np.maximum(age, 1),
                0.0,
            ),
        )
        within = np.minimum(lag, age)
        xy = _at(self.history, within) - back[:, None] * (lag - within)[..., None]
        return xy, xy[:, -1] - xy[:, -2]

    def resample(self, now, frames) -> np.ndarray:
        """(L, P, N + 1, 2) the futures at t_i = i dt from the model's frames (L, P, pred, 2) and
        the present positions (L, 2) (module docstring)."""
        L, P = frames.shape[:2]
        path = np.concatenate([np.broadcast_to(now[:, None, None], (L, P, 1, 2)), frames], axis=2)
        futures = path.transpose(0, 1, 3, 2) @ self.interpolation  # (L, P, 2, N + 1)
        return np.ascontiguousarray(futures.transpose(0, 1, 3, 2))

    @functools.cached_property
    def interpolation(self) -> np.ndarray:
        """(pred + 1, N + 1) the weights of the model's frames 0..pred at each planner step:
        linear between the two frames around it, extrapolated from the last two beyond."""
        m = self.trained
        u = np.arange(self.N + 1) * self.dt / m.period  # the steps in frames
        i = np.minimum(np.floor(u).astype(int), m.pred - 1)
        weights = np.zeros((m.pred + 1, self.N + 1))
        weights[i, np.arange(self.N + 1)] = 1 - (u - i)
        weights[i + 1, np.arange(self.N + 1)] += u - i
        return weights


def _at(history, lag) -> np.ndarray:
    """Positions lag steps back (L, ...) from history (L, H, 2), linear between steps."""
    low = np.floor(lag).astype(int)
    high = np.minimum(low + 1, history.shape[1] - 1)
    w = (lag - low)[..., None]
    rows = np.arange(len(history)).reshape((-1,) + (1,) * (np.ndim(lag) - 1))
    return (1 - w) * history[rows, low] + w * history[rows, high]


def _velocity(velocity, L) -> np.ndarray:
    """(L, 2) the observed velocities, nan rows where not observed."""
    if velocity is None:
        return np.full((L, 2), np.nan)
    return np.asarray(velocity, dtype=float).reshape(L, 2)
