"""How well dc's obstacle filters estimate speed and turn rate over one crowd episode: the
errors, and their plot through dcmppi.render.ekf.

    from dcmppi.bench.reports.ekf_plot import ekf_spec, plot_ekf_errors
    plot_ekf_errors(ekf_spec(seed=0), "ekf_errors.png")

The episode is the crowd with noisy obstacle positions (task obstacle_measurement_std) driven by
dc with prediction="ekf"; each step's posterior (Diagnostics.prediction.posterior) is compared
with the obstacles' true, constant speeds and turn rates.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from dcmppi.bench.episodes.runner import EpisodeSpec, run_episode

MEASUREMENT_STD = 0.1  # [m] the crowd's noise in the dynamic-ekf experiment
NEAR = 3.0  # [m] obstacles whose surface came this close to the robot's are plotted
CROWD_PARAMS = dict(
    Sigma=[1.0, 1.0, 0.1], perturbation="mixed", beta=100.0
)  # docs/design.md, Experiments


def ekf_spec(seed=0, measurement_std=MEASUREMENT_STD, **controller_params) -> EpisodeSpec:
    """A crowd episode with position noise `measurement_std` [m] and dc with the EKF (the
    crowd's shared parameters; `controller_params` override them)."""
    params = {**CROWD_PARAMS, "prediction": "ekf", "measurement_std": measurement_std}
    return EpisodeSpec(
        task="crowd",
        controller="dc",
        seed=seed,
        task_params={"obstacle_measurement_std": measurement_std},
        controller_params={**params, **controller_params},
    )


@dataclasses.dataclass
class TrackErrors:
    """One episode's estimates. T posterior steps, L obstacles.

    time: (T,) [s] of each posterior. error: (T, L, 2) estimate minus truth of speed [m/s] and
    turn rate [rad/s]. std: (T, L, 2) their posterior stds. clearance: (T, L) true surface
    distance robot-obstacle [m] at that time. outcome: the episode's outcome.
    """

    time: np.ndarray
    error: np.ndarray
    std: np.ndarray
    clearance: np.ndarray
    outcome: str


def track_errors(spec: EpisodeSpec) -> TrackErrors:
    """Runs `spec` (a planner with prediction="ekf" on a task with moving obstacles) and
    records the speed and turn-rate posterior of every obstacle at every step."""
    if spec.controller_params.get("prediction") != "ekf":
        raise ValueError(
            'track_errors needs prediction="ekf" in the controller parameters, e.g. ekf_spec()'
        )
    means, variances, times, clearances, truth = [], [], [], [], []

    def record(episode):
        # After step k the diagnostics hold the posterior of observation k - 1.
        prediction = episode.controller.diagnostics.prediction  # None before the first step
        if prediction is not None and prediction.posterior is not None:
            mean, cov = prediction.posterior
            means.append(mean[:, 3:])
            variances.append(np.diagonal(cov, axis1=1, axis2=2)[:, 3:])
        physics, world = episode.env.physics, episode.env.task.world
        obstacles = physics.moving_obstacles()
        gap = np.hypot(*(obstacles[:, :2] - physics.robot_pose()[:2]).T)
        times.append(physics.data.time)
        clearances.append(gap - obstacles[:, 3] - physics.robot_radius)
        if not truth:
            truth.append(np.column_stack([world.moving_speed, world.moving_turn_rate]))

    outcome = run_episode(spec, on_step=record)["outcome"]
    T = len(means)
    return TrackErrors(
        time=np.asarray(times[:T]),
        error=np.asarray(means) - truth[0],
        std=np.sqrt(np.asarray(variances)),
        clearance=np.asarray(clearances[:T]),
        outcome=outcome,
    )


def plot_ekf_errors(spec: EpisodeSpec, path, near=NEAR) -> TrackErrors:
    """Runs `spec` (see `track_errors`) and writes to the PNG `path` the speed and turn-rate
    errors with their 2-sigma bands over time for the obstacles that came within `near` m of
    the robot (drawn by `dcmppi.render.ekf.ekf_error_figure`)."""
    from dcmppi.render.draw import save_figure
    from dcmppi.render.ekf import ekf_error_figure

    errors = track_errors(spec)
    close = np.flatnonzero(errors.clearance.min(axis=0) <= near)
    title = (
        f"{spec.controller} prediction='ekf', {spec.task} seed {spec.seed}, position noise "
        f"{spec.task_params.get('obstacle_measurement_std', 0)} m: obstacles within {near} m "
        f"({errors.outcome})"
    )
    save_figure(ekf_error_figure(errors.time, errors.error, errors.std, close, title), path)
    return errors
