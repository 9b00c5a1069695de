"""The forecasters the evaluation compares: the field's constant-velocity baselines and the
project's predictors through their Predictor interface.

A forecaster maps windows (dcmppi.tasks.replay.recordings.Windows) to samples (M, P, pred, 2) and a
point forecast (M, pred, 2) of each window's future, one recording frame apart.
"""

import numpy as np

from dcmppi.control.predictors import learned, make_predictor
from dcmppi.control.predictors.learned import rotate

HEADING_STD = np.deg2rad(25.0)  # Schöller et al. 2020: the heading noise of "cv-noise"
SAMPLES = 20
RADIUS = 0.3  # [m] each person's radius as a moving obstacle (social's pushes)
SOLO = ("ekf",)  # predictors that filter a fixed set of obstacles: they see the target alone


def velocity(windows) -> np.ndarray:
    """(M, 2) the last observed displacement per frame."""
    return windows.observed[:, -1] - windows.observed[:, -2]


def constant_velocity(windows, rng=None) -> tuple:
    """One sample: the last observed displacement repeated every frame (Schöller et al.)."""
    pred = windows.future.shape[1]
    steps = np.arange(1, pred + 1)[:, None]
    point = windows.observed[:, None, -1] + velocity(windows)[:, None] * steps
    return point[:, None], point


def heading_noise(windows, rng) -> tuple:
    """SAMPLES constant-velocity samples, each turned by an angle ~ N(0, HEADING_STD^2); the
    point forecast is the noise-free one."""
    M, pred = len(windows), windows.future.shape[1]
    turn = HEADING_STD * rng.standard_normal((M, SAMPLES))
    v = rotate(np.broadcast_to(velocity(windows)[:, None], (M, SAMPLES, 2)), turn)
    steps = np.arange(1, pred + 1)[:, None]
    samples = windows.observed[:, None, None, -1] + v[:, :, None] * steps
    return samples, constant_velocity(windows)[1]


def learned_tracks(model):
    """The learned model of file `model` on each window's annotated track and neighbours (the
    people's ids known, as the papers' models see them); the point forecast is the samples'
    mean. The predictor `learned` instead tracks the people by position, step by step."""
    trained = learned.load(model)

    def forecast(windows, rng=None):
        others, velocity = learned.neighbours_now(windows.neighbours)
        samples = trained.forecast(windows.observed, others, velocity, SAMPLES)
        return samples, samples.mean(axis=1)

    return forecast


class PredictorForecaster:
    """A registered predictor at the windows' frame period: N = pred steps of dt = period,
    P = SAMPLES, its own parameters at their defaults unless given. Per window it is reset and
    fed every observed frame: the target (row 0) and the neighbours annotated then (SOLO
    predictors: the target alone) as moving obstacles of radius RADIUS, heading and `velocity`
    input from the displacement since the previous frame (0 where unknown); the robot sits on the
    target (every future within reach). The samples are the target's futures, the point forecast
    their mean.

    obstacle_model: (4,) the population's v_mean, v_std, omega_mean, omega_std ("prior", "ekf").
    """

    def __init__(self, name, period, pred, obstacle_model, **params):
        self.name, self.period, self.obstacle_model = name, period, obstacle_model
        self.predictor = make_predictor(
            name,
            N=pred,
            dt=period,
            robot_radius=0.0,
            max_speed=1e3,
            alpha=1.0,
            beta=1.0,
            P=SAMPLES,
            obstacle_margin=0.0,
            **params,
        )

    def __call__(self, windows, rng) -> tuple:
        pred = windows.future.shape[1]
        samples = np.empty((len(windows), SAMPLES, pred, 2))
        for m in range(len(windows)):
            samples[m] = self.window(windows.observed[m], windows.neighbours[m], rng)
        return samples, samples.mean(axis=1)

    def window(self, track, neighbours, rng) -> np.ndarray:
        """(P, pred, 2) the target's futures from its track (obs, 2) and the neighbours' (K, obs,
        2) (nan where not annotated)."""
        p = self.predictor
        p.reset()
        people = np.concatenate([track[None], neighbours])  # (1 + K, obs, 2)
        if self.name in SOLO:
            people = people[:1]
        moving = velocity = None
        for s in range(track.shape[0]):
            seen = ~np.isnan(people[:, s, 0])
            now = people[seen, s]
            step = now - people[seen, s - 1] if s else np.full_like(now, np.nan)
            step[np.isnan(step)] = 0.0
            velocity = step / self.period
            moving = np.column_stack(
                [now, np.arctan2(step[:, 1], step[:, 0]), np.full(len(now), RADIUS)]
            )
            state = np.array([*track[s], 0.0])
            prediction = self.call(p, state, moving, velocity, rng)
        return prediction.futures[0, :, 1:]

    def call(self, p, state, moving, velocity, rng):
        """predict() with the inputs the predictor names."""
        extra = {"velocity": velocity} if "velocity" in p.inputs else {}
        return p.predict(state, moving, self.obstacle_model, rng, **extra)


def obstacle_model(windows) -> np.ndarray:
    """(4,) v_mean, v_std [m/s], omega_mean, omega_std [rad/s] of the windows' observed walks:
    speeds of every observed displacement, turn rates of consecutive ones (both moving)."""
    steps = np.diff(windows.observed, axis=1)  # (M, obs - 1, 2)
    speed = np.hypot(steps[..., 0], steps[..., 1]) / windows.period
    heading = np.arctan2(steps[..., 1], steps[..., 0])
    turn = np.angle(np.exp(1j * np.diff(heading, axis=1))) / windows.period
    moving = (speed[:, 1:] > 0.1) & (speed[:, :-1] > 0.1)
    return np.array([speed.mean(), speed.std(), turn[moving].mean(), turn[moving].std()])
