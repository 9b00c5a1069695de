"""Futures learned from recorded crowds: the continuations of the most similar recorded
situations (nearest-neighbour retrieval of whole trajectories), weight beta / P.

The model (`Model`, trained by `fit` on forecasting windows: `obs` observed positions and the
`pred` that follow, one recording frame `period` apart) describes a person by a feature vector:
- their track in their own heading frame (origin: the last observed position; x along the last
  displacement), the earlier obs - 1 positions divided by the scale s = max(speed, SPEED_FLOOR)
  (speed: the last displacement per frame), and log s: a walk of another speed looks alike;
- their `neighbours` nearest other people now: position and velocity (per frame) relative to
  theirs, in metres in the heading frame, times `social_weight` (missing ones at FAR ahead).
Training stores every window's features and its future in the heading frame divided by s.

A forecast retrieves the P training windows nearest in the features (scipy's k-d tree) and
takes their futures, times the person's s, rotated back: P whole trajectories, each consistent
over the horizon, as varied as the people who were in that situation. The set is then shifted
so that its mean is the shrunk point forecast c + lambda (m - c), c the person's constant
velocity, m the retrieved futures' mean and lambda = `shrink` fitted at training by least
squares on held-out folds (each recording held out in turn): the mean of few neighbours is
noisy and a model trained on other scenes biased, so it moves only as far from constant velocity
as held-out data supports.

The predictor `learned` (parameter `model`: the path of a file that `Model.save` wrote; in an
experiment, a recipe that the bench trains and caches: dcmppi.bench.experiments.models) keeps
each pedestrian's positions over the last (obs - 1) x period seconds, one per step, and matches
the pedestrians of a step to those of the previous one by the assignment of least total distance
from where they were heading (scipy's linear_sum_assignment; a jump over GATE + GATE_SPEED dt
starts a new track), so their number and order may change. A track shorter than the model's
observation is extended backwards at its observed velocity (the `velocity` input; else the
track's mean velocity; else standing). The model's positions at its period are resampled to the
planner's steps t_i = i dt by linear interpolation in time (the present position at t = 0);
beyond pred x period each future goes on at the velocity of its last predicted frame. The
predicted people are blind to the robot: the training crowds had none.
"""

import functools
import hashlib
import pathlib
import zipfile

import numpy as np

from dcmppi.control.predictors.base import register_predictor
from dcmppi.control.predictors.given import Given
from dcmppi.control.validation import positive

FORMAT = "dcmppi-learned-1"  # the model file's format (checked on load)
SPEED_FLOOR = 0.1  # [m per frame]: the smallest scale s; slower people are read at this speed
NEIGHBOURS = 1  # nearest other people described in the features
SOCIAL_WEIGHT = 0.3  # weight of their relative position and velocity [1/m]
FAR = 6.0  # [m] ahead: where a missing neighbour is placed
FIT_K = 20  # retrieved futures per window when fitting the shrink
# the k-d tree's slack: each retrieved neighbour within (1 + APPROXIMATION) x the distance of the
# true one of its rank (scipy's eps); it bounds the search far from the training windows, and on
# ETH/UCY's leave-one-out models its forecasts match the exact search's to 0.01 m (docs/crowds.md)
APPROXIMATION = 1.0
FOLDS = 5  # held-out folds of the shrink when the windows come from one recording
# a pedestrian further than GATE + GATE_SPEED dt from where every track was heading starts a new
# track (a track seen once is taken as standing: its first step may be a fast walker's)
GATE, GATE_SPEED = 1.0, 3.0  # [m], [m/s]


class Model:
    """A trained model (module docstring).

    features: (M, D) of the training windows; futures: (M, pred, 2) their futures in the heading
    frame divided by the scale; obs: observed frames; period [s] between frames; shrink: lambda;
    neighbours, social_weight: the social features' settings; seed: of the training.
    """

    def __init__(self, features, futures, obs, period, shrink, neighbours, social_weight, seed):
        self.features = np.ascontiguousarray(features, dtype=float)
        self.futures = np.ascontiguousarray(futures, dtype=float)
        self.obs, self.period, self.shrink = int(obs), float(period), float(shrink)
        self.neighbours, self.social_weight = int(neighbours), float(social_weight)
        self.seed = int(seed)
        from scipy.spatial import KDTree  # loaded with a model, not with the predictors

        self.tree = KDTree(self.features)

    @property
    def pred(self) -> int:
        """Predicted frames."""
        return self.futures.shape[1]

    def save(self, path):
        """Writes the model to `path`: a numpy .npz of arrays only, the same bytes for the same
        model (its sha256 identifies it)."""
        arrays = {
            "format": np.array(FORMAT),
            "features": self.features,
            "futures": self.futures,
            "settings": np.array(
                [self.obs, self.period, self.shrink, self.neighbours, self.social_weight]
            ),
            "seed": np.array(self.seed),
        }
        with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
            for name, value in arrays.items():
                entry = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
                entry.compress_type = zipfile.ZIP_DEFLATED
                with archive.open(entry, "w") as f:
                    np.lib.format.write_array(f, np.asarray(value), allow_pickle=False)

    def forecast(self, observed, others, others_velocity, P, approximation=APPROXIMATION):
        """(L, P, pred, 2) P futures of each of L people at the model's frames 1..pred.

        observed: (L, obs, 2) each person's positions one period apart, the last now;
        others, others_velocity: (L, K, 2) the other people's positions now and velocities
        [m per frame] (nan rows: none; K may be 0); approximation: the k-d tree's slack
        (APPROXIMATION; 0: exact). Returns the futures (L, P, pred, 2).
        """
        L = len(observed)
        if L == 0:
            return np.zeros((0, P, self.pred, 2))
        heading, speed = _heading(observed)
        scale = np.maximum(speed, SPEED_FLOOR)
        x = _features(observed, others, others_velocity, heading, scale, self.neighbours)
        x *= _weights(self.obs, self.neighbours, self.social_weight)
        k = min(P, len(self.features))
        index = self.tree.query(x, k=k, eps=approximation)[1].reshape(L, k)
        index = np.resize(index, (L, P)) if k < P else index  # a tiny model repeats its own
        local = self.futures[index] * scale[:, None, None, None]  # (L, P, pred, 2)
        mean = local.mean(axis=1)
        cv = np.zeros_like(mean)
        cv[..., 0] = speed[:, None] * np.arange(1, self.pred + 1)
        local -= (1 - self.shrink) * (mean - cv)[:, None]
        return rotate(local, heading[:, None]) + observed[:, None, None, -1]


def fit(
    windows,
    seed=0,
    max_windows=None,
    neighbours=NEIGHBOURS,
    social_weight=SOCIAL_WEIGHT,
) -> Model:
    """A Model of `windows`: any object with observed (M, obs, 2), future (M, pred, 2),
    neighbours ((K_m, obs, 2) per window, nan where not seen), source (M,) its recording, period.

    max_windows: train on this many windows drawn without replacement by `seed` (None: all).
    Deterministic for a seed.
    """
    observed = np.asarray(windows.observed, dtype=float)
    future = np.asarray(windows.future, dtype=float)
    source = np.asarray(windows.source)
    chosen = np.arange(len(observed))
    if max_windows is not None and max_windows < len(chosen):
        chosen = np.sort(np.random.default_rng(seed).choice(len(chosen), max_windows, False))
    if len(chosen) < 2:
        raise ValueError(f"a model needs at least 2 windows; got {len(chosen)}")
    observed, future, source = observed[chosen], future[chosen], source[chosen]
    others, velocity = neighbours_now([windows.neighbours[i] for i in chosen])
    heading, speed = _heading(observed)
    scale = np.maximum(speed, SPEED_FLOOR)
    features = _features(observed, others, velocity, heading, scale, neighbours)
    features *= _weights(observed.shape[1], neighbours, social_weight)
    local = rotate(future - observed[:, None, -1], -heading[:, None]) / scale[:, None, None]
    shrink = _shrink(features, local, source, speed, scale)
    return Model(
        features, local, observed.shape[1], windows.period, shrink, neighbours, social_weight, seed
    )


def _shrink(features, local, source, speed, scale) -> float:
    """lambda in [0, 1] of least squares over held-out folds: each recording (or, from one
    recording, each of FOLDS blocks) forecast by a tree of the others' windows.

    features: (M, D) weighted; local: (M, pred, 2) the futures in the heading frame / scale.
    """
    from scipy.spatial import KDTree

    folds = np.unique(source)
    groups = source if len(folds) > 1 else np.arange(len(source)) * FOLDS // len(source)
    t = np.arange(1, local.shape[1] + 1)
    num = den = 0.0
    for g in np.unique(groups):
        held = groups == g
        if held.all():
            continue
        rest = np.flatnonzero(~held)
        k = min(FIT_K, len(rest))
        index = rest[KDTree(features[rest]).query(features[held], k=k)[1]]
        s = scale[held, None, None]
        mean = (local[index.reshape(held.sum(), k)] * s[..., None]).mean(axis=1)
        cv = np.zeros_like(mean)
        cv[..., 0] = speed[held, None] * t
        truth = local[held] * s
        num += np.sum((mean - cv) * (truth - cv))
        den += np.sum((mean - cv) ** 2)
    return float(np.clip(num / den, 0.0, 1.0)) if den > 0 else 1.0


def load(path) -> Model:
    """The Model saved at `path`, or a ValueError naming the file."""
    try:
        with np.load(path, allow_pickle=False) as f:
            if str(f["format"]) != FORMAT:
                raise ValueError(f"format {str(f['format'])!r}, expected {FORMAT!r}")
            obs, period, shrink, neighbours, social_weight = f["settings"]
            return Model(
                f["features"],
                f["futures"],
                obs,
                period,
                shrink,
                neighbours,
                social_weight,
                int(f["seed"]),
            )
    except (OSError, KeyError, ValueError) as e:
        raise ValueError(f"{path}: not a learned predictor's model ({e})") from None


def sha256(path) -> str:
    """The hex SHA-256 of the model file at `path` (its provenance)."""
    return hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()


@functools.lru_cache(maxsize=8)
def _cached(path, stamp):
    """The model at `path`, loaded once per file version (stamp: its mtime and size)."""
    return load(path)


def _weights(obs, neighbours, social_weight) -> np.ndarray:
    """(D,) the features' weights: 1 for the track and log scale, social_weight for the
    neighbours'."""
    return np.r_[np.ones(2 * (obs - 1) + 1), np.full(4 * neighbours, social_weight)]


def neighbours_now(neighbours) -> tuple:
    """The other people's positions now and velocities per frame from their observed tracks:
    (M, K, 2) each, K the most of any window, nan-padded; a velocity unknown (seen only now) is
    0. neighbours: M arrays (K_m, obs, 2) (nan where not seen)."""
    K = max((len(n) for n in neighbours), default=0)
    now = np.full((len(neighbours), K, 2), np.nan)
    velocity = np.full((len(neighbours), K, 2), np.nan)
    for m, n in enumerate(neighbours):
        now[m, : len(n)] = n[:, -1]
        velocity[m, : len(n)] = np.nan_to_num(n[:, -1] - n[:, -2])
    velocity[np.isnan(now)] = np.nan
    return now, velocity


def _heading(observed) -> tuple:
    """(L,) heading [rad] and speed [m per frame] of the last displacement (heading of the whole
    observed displacement where the last one is nil)."""
    step = observed[:, -1] - observed[:, -2]
    speed = np.hypot(step[:, 0], step[:, 1])
    still = speed < 1e-6
    step[still] = observed[still, -1] - observed[still, 0]
    return np.arctan2(step[:, 1], step[:, 0]), speed


def _features(observed, others, velocity, heading, scale, neighbours) -> np.ndarray:
    """(L, D) unweighted features (module docstring): the track (2 (obs - 1)), log scale,
    then per neighbour relative x, y, vx, vy."""
    L, obs, _ = observed.shape
    last = observed[:, -1]
    track = rotate(observed[:, :-1] - last[:, None], -heading[:, None]) / scale[:, None, None]
    social = np.zeros((L, neighbours, 4))
    social[..., 0] = FAR
    if neighbours and others.shape[1]:
        own = observed[:, -1] - observed[:, -2]
        rel = rotate(others - last[:, None], -heading[:, None])  # (L, K, 2)
        rel_v = rotate(velocity - own[:, None], -heading[:, None])
        distance = np.hypot(rel[..., 0], rel[..., 1])
        distance[np.isnan(distance)] = np.inf
        order = np.argsort(distance, axis=1, kind="stable")[:, :neighbours]
        near = np.take_along_axis(distance, order, axis=1)
        found = np.isfinite(near)
        social[..., :2] = np.where(
            found[..., None], np.take_along_axis(rel, order[..., None], 1), social[..., :2]
        )
        social[..., 2:] = np.where(
            found[..., None], np.take_along_axis(rel_v, order[..., None], 1), 0.0
        )
    return np.concatenate(
        [track.reshape(L, -1), np.log(scale)[:, None], social.reshape(L, -1)], axis=1
    )


def rotate(xy, angle) -> np.ndarray:
    """xy (..., 2) rotated by angle (broadcast against xy[..., 0]) [rad]."""
    c, s = np.cos(angle), np.sin(angle)
    while np.ndim(c) < xy.ndim - 1:
        c, s = c[..., None], s[..., None]
    return np.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], axis=-1)


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
