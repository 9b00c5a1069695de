"""The learned model: a person described by features, the training windows' futures retrieved
by their nearest features (nearest-neighbour retrieval of whole trajectories).

A window is `obs` observed positions and the `pred` that follow, one recording frame `period`
apart. A person's feature vector (`features`):
- their track in their own heading frame (origin: the last observed position; x along the last
  displacement), the earlier obs - 1 positions divided by the scale s = max(speed, SPEED_FLOOR)
  (speed: the last displacement per frame), and log s: a walk of another speed looks alike;
- their `neighbours` nearest other people now: position and velocity (per frame) relative to
  theirs, in metres in the heading frame, times `social_weight` (missing ones at FAR ahead).
A `Model` stores every training window's features and its future in the heading frame divided
by s (`training.fit` makes it).

A forecast (`Model.forecast`) retrieves the P training windows nearest in the features (scipy's
k-d tree) and takes their futures, times the person's s, rotated back: P whole trajectories,
each consistent over the horizon, as varied as the people who were in that situation. The set is
then shifted so that its mean is the shrunk point forecast c + lambda (m - c), c the person's
constant velocity, m the retrieved futures' mean and lambda = `shrink` (fitted at training).
"""

import hashlib
import os
import pathlib
import zipfile
import zlib

import numpy as np

FORMAT = "dcmppi-learned-1"  # the model file's format (checked on load)
SPEED_FLOOR = 0.1  # [m per frame]: the smallest scale s; slower people are read at this speed
NEIGHBOURS = 1  # nearest other people described in the features
SOCIAL_WEIGHT = 0.3  # weight of their relative position and velocity [1/m]
FAR = 6.0  # [m] ahead: where a missing neighbour is placed
# the k-d tree's slack: each retrieved neighbour within (1 + APPROXIMATION) x the distance of the
# true one of its rank (scipy's eps); it bounds the search far from the training windows, and on
# ETH/UCY's leave-one-out models its forecasts match the exact search's to 0.01 m (docs/crowds.md)
APPROXIMATION = 1.0


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
        model (its sha256 identifies it); atomically (a temporary file beside it, then renamed),
        so that an interrupted save leaves no partial model."""
        arrays = {
            "format": np.array(FORMAT),
            "features": self.features,
            "futures": self.futures,
            "settings": np.array(
                [self.obs, self.period, self.shrink, self.neighbours, self.social_weight]
            ),
            "seed": np.array(self.seed),
        }
        path = pathlib.Path(path)
        part = path.with_name(f".{path.name}.{os.getpid()}.part")
        try:
            with zipfile.ZipFile(part, "w", zipfile.ZIP_DEFLATED) as archive:
                for name, value in arrays.items():
                    entry = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
                    entry.compress_type = zipfile.ZIP_DEFLATED
                    with archive.open(entry, "w") as f:
                        np.lib.format.write_array(f, np.asarray(value), allow_pickle=False)
            os.replace(part, path)
        finally:
            part.unlink(missing_ok=True)

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
        heading, speed = heading_and_speed(observed)
        scale = np.maximum(speed, SPEED_FLOOR)
        x = features(observed, others, others_velocity, heading, scale, self.neighbours)
        x *= feature_weights(self.obs, self.neighbours, self.social_weight)
        k = min(P, len(self.features))
        index = self.tree.query(x, k=k, eps=approximation)[1].reshape(L, k)
        index = np.resize(index, (L, P)) if k < P else index  # a tiny model repeats its own
        local = self.futures[index] * scale[:, None, None, None]  # (L, P, pred, 2)
        mean = local.mean(axis=1)
        cv = np.zeros_like(mean)
        cv[..., 0] = speed[:, None] * np.arange(1, self.pred + 1)
        local -= (1 - self.shrink) * (mean - cv)[:, None]
        return rotate(local, heading[:, None]) + observed[:, None, None, -1]


def load(path) -> Model:
    """The Model saved at `path`; a ValueError of one line naming the file and how to retrain it
    when it is missing, not a model (empty, truncated, corrupted, another file) or one whose
    arrays do not hold together."""
    arrays = _arrays(path)
    problem = _mismatch(arrays)
    if problem:
        raise ValueError(
            f"{path}: a learned predictor's model whose arrays do not match ({problem}); {RETRAIN}"
        )
    obs, period, shrink, neighbours, social_weight = arrays["settings"]
    return Model(
        arrays["features"],
        arrays["futures"],
        obs,
        period,
        shrink,
        neighbours,
        social_weight,
        int(arrays["seed"]),
    )


RETRAIN = (
    "retrain it (`dcmppi predictor train ... --out FILE`; a recipe's cached model: delete it and "
    "the bench trains it again)"
)
_ARRAYS = ("format", "features", "futures", "settings", "seed")


def _arrays(path) -> dict:
    """The arrays of the model file at `path`, or the ValueError of `load`."""
    try:
        with open(path, "rb") as file, np.load(file, allow_pickle=False) as f:
            return {name: f[name] for name in _ARRAYS}
    except FileNotFoundError:
        raise ValueError(f"{path}: no such model file; {RETRAIN}") from None
    except KeyError as e:
        missing = str(e.args[0]).removesuffix(".npy")
        raise ValueError(
            f"{path}: not a learned predictor's model (no {missing} in it); {RETRAIN}"
        ) from None
    except (OSError, ValueError, TypeError, EOFError, zipfile.BadZipFile, zlib.error):
        raise ValueError(
            f"{path}: not a learned predictor's model (empty, truncated, corrupted or another "
            f"kind of file); {RETRAIN}"
        ) from None


def _mismatch(arrays) -> str | None:
    """What is inconsistent in a model file's arrays, or None."""
    if arrays["format"].shape != () or str(arrays["format"]) != FORMAT:
        return f"format {str(arrays['format'])!r}, expected {FORMAT!r}"
    settings, features, futures = arrays["settings"], arrays["features"], arrays["futures"]
    if any(arrays[k].dtype.kind not in "fiu" for k in ("features", "futures", "settings", "seed")):
        return "arrays that are not numbers"
    if settings.shape != (5,) or arrays["seed"].shape != () or not np.isfinite(settings).all():
        return f"settings {settings.tolist()}, expected five numbers"
    obs, period, _, neighbours, _ = settings
    width = 2 * (int(obs) - 1) + 1 + 4 * int(neighbours)
    if features.ndim != 2 or features.shape[1] != width or len(features) < 1:
        return f"features of shape {features.shape}, expected (M, {width})"
    if futures.ndim != 3 or futures.shape[0] != len(features) or futures.shape[2] != 2:
        return f"futures of shape {futures.shape}, expected ({len(features)}, pred, 2)"
    if not (np.isfinite(features).all() and np.isfinite(futures).all() and period > 0):
        return "values that are not finite"
    return None


def sha256(path) -> str:
    """The hex SHA-256 of the model file at `path` (its provenance)."""
    return hashlib.sha256(pathlib.Path(path).read_bytes()).hexdigest()


def feature_weights(obs, neighbours, social_weight) -> np.ndarray:
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


def heading_and_speed(observed) -> tuple:
    """(L,) heading [rad] and speed [m per frame] of the last displacement (heading of the whole
    observed displacement where the last one is nil)."""
    step = observed[:, -1] - observed[:, -2]
    speed = np.hypot(step[:, 0], step[:, 1])
    still = speed < 1e-6
    step[still] = observed[still, -1] - observed[still, 0]
    return np.arctan2(step[:, 1], step[:, 0]), speed


def features(observed, others, velocity, heading, scale, neighbours) -> np.ndarray:
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
