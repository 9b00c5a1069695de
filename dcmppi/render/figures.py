"""The paper's Fig. 2 and Fig. 4 for one control step of a task.

Every controller has planned the same step (same observation, same seed, hence the same K
perturbations: `dcmppi.bench.episodes.snapshot.first_step`); the figures show

- `values.png`: the value exp(-(J - min J) / lambda) of each sampled perturbation against
  the perturbation, coloured by DBSCAN cluster (grey: noise, or no clustering), with the
  control each algorithm applies marked by a star (paper Fig. 2 and Fig. 4, bottom row);
- `rollouts.png`: the sampled agent rollouts coloured by cluster, the sampled futures of the
  moving obstacles (a panel only where `dc` sampled any), and each algorithm's plan (paper
  Fig. 4, top row), drawn widest first with its own line style and markers, so that a plan
  under another stays visible.

The value is shifted by min J so that it does not underflow (J is in the hundreds); the
shape, which is what the figure is about, is unchanged.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dcmppi.control import Diagnostics
from dcmppi.render.draw import COLORS, draw_world, pyplot
from dcmppi.render.overlay import cluster_labels, cluster_rgb, obstacle_futures


def plan_cost(controller, state) -> float:
    """J of the controller's plan rolled out without noise from `state`."""
    plan = controller.diagnostics.plan
    _, J = controller.rollout_costs(np.asarray(state, dtype=float), plan[:, :, None])
    return float(J[0])


def require_diagnostics(controllers: dict) -> None:
    """A ValueError naming the controllers {name: controller} that record no sampled rollouts
    (no dcmppi.control Diagnostics), which the figures draw."""
    plain = [
        n for n, c in controllers.items()
        if not isinstance(getattr(c, "diagnostics", None), Diagnostics)
    ]  # fmt: skip
    if plain:
        raise ValueError(
            f"figure draws sampled rollouts and their values: {', '.join(plain)} records none "
            "(subclass dcmppi.Controller to get the diagnostics)"
        )


def write_figures(observation, runs, out_dir, title: str) -> dict:
    """Write values.png and rollouts.png of one planning step.

    Args:
      observation: the task observation every controller planned from.
      runs: {name: (controller, applied action)} after each controller's step, for example
        from `dcmppi.bench.episodes.snapshot.first_step`.
      out_dir: folder for the PNG files.
      title: what the step is (task and seed), for the figure titles.
    Returns:
      {"files": [paths], "actions": {controller: applied control marked in the figure},
       "control": the name of the control on the value plot's axis}.
    """
    require_diagnostics({n: c for n, (c, _) in runs.items()})
    plt = pyplot()
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    state = observation["robot_pose"]
    first = next(iter(runs.values()))[0]
    j = steering_control(first, observation["goal"])
    control = first.agent.controls[j]
    U0 = first.agent.first_guess(state, observation["goal"], 1)[0, j]  # the warm start

    fig, axes = plt.subplots(1, len(runs), figsize=(4.2 * len(runs), 3.6), sharey=True)
    axes = np.atleast_1d(axes)
    for ax, (name, (ctrl, action)) in zip(axes, runs.items(), strict=True):
        d = ctrl.diagnostics
        J0 = d.J.min()
        value = np.exp(-(d.J - J0) / d.lambda_)  # the step's lambda (a number under "auto")
        labels = cluster_labels(d)
        ax.scatter(d.eps[:, 0, j], value, s=9, c=cluster_rgb(labels, len(value)), lw=0)
        star = np.exp(-(plan_cost(ctrl, state) - J0) / d.lambda_)
        ax.plot(
            action[j] - U0, star, "*", ms=18, color="gold", mec="k",
            label=f"applied {action[j]:+.3f}",
        )  # fmt: skip
        clusters = "" if labels is None else f": {int(labels.max()) + 1} clusters"
        ax.set_title(f"{name}{clusters}")
        ax.set_xlabel(f"perturbation of {control} (first step)")
        ax.legend(loc="upper right", fontsize=8)
    axes[0].set_ylabel("value exp(-(J - min J) / lambda)")
    t = observation["robot_pose"]
    fig.suptitle(f"{title}: value of each sampled perturbation at x = ({t[0]:.1f}, {t[1]:.1f})")
    fig.tight_layout()
    values_png = out / "values.png"
    fig.savefig(values_png, dpi=120)
    plt.close(fig)

    fig = rollouts_figure(observation, runs)
    rollouts_png = out / "rollouts.png"
    fig.savefig(rollouts_png, dpi=120)
    plt.close(fig)
    return {
        "files": [str(values_png), str(rollouts_png)],
        "actions": {name: action for name, (_, action) in runs.items()},
        "control": control,
    }


# (line style, width, marker) of the plans in drawing order: widest first, so every plan
# drawn over another leaves the one below visible at its edges.
PLAN_STYLES = (("-", 6.0, "o"), ("--", 4.2, "s"), ("-.", 2.8, "^"), (":", 1.8, "D"))


def rollouts_figure(observation, runs):
    """The matplotlib Figure of rollouts.png (see the module docstring and `write_figures`):
    panels sampled rollouts, obstacle futures (only if `dc` sampled some) and plans."""
    plt = pyplot()
    state = observation["robot_pose"]
    futures = obstacle_futures(runs["dc"][0].diagnostics) if "dc" in runs else None
    has_futures = futures is not None
    fig, axes = plt.subplots(1, 3 if has_futures else 2, figsize=(15 if has_futures else 10, 5))
    clustered = next((runs[c][0] for c in ("dc", "clustered") if c in runs), None)
    shown = clustered or next(iter(runs.values()))[0]
    d = shown.diagnostics
    rgb = cluster_rgb(cluster_labels(d), len(d.states))
    for ax in axes:
        draw_world(ax, observation, robot_label="robot at the planned step")
        _zoom(ax, state, observation["goal"])
    for k in range(0, len(d.states), max(1, len(d.states) // 150)):
        axes[0].plot(d.states[k, :, 0], d.states[k, :, 1], color=rgb[k], lw=0.6, alpha=0.6)
    axes[0].set_title(f"sampled rollouts of {shown.name}, by cluster")
    if has_futures:
        for track in futures.reshape(-1, futures.shape[2], 2):
            axes[1].plot(track[:, 0], track[:, 1], color="tab:orange", lw=0.6, alpha=0.5)
        axes[1].set_title("sampled obstacle futures (dc)")
    for i, (name, (ctrl, _)) in enumerate(runs.items()):
        style, width, marker = PLAN_STYLES[i % len(PLAN_STYLES)]
        path = ctrl.agent.rollout_one(state, ctrl.diagnostics.plan, ctrl.dt)
        every = max(1, len(path) // 8)
        axes[-1].plot(
            path[:, 0], path[:, 1], style, color=COLORS.get(name), lw=width, marker=marker,
            ms=width + 3, markevery=(i * every // len(runs), every), label=name, zorder=3 + i,
        )  # fmt: skip
    axes[-1].legend(fontsize=8)
    axes[-1].set_title("each algorithm's plan")
    fig.tight_layout()
    return fig


def steering_control(controller, goal) -> int:
    """Index of the control that moves the last step's rollouts sideways the most: the one whose
    first-step perturbation correlates most with the rollouts' final offset across the line to
    the goal (dubins and unicycle: omega; holonomic: the lateral velocity)."""
    d = controller.diagnostics
    start = d.states[0, 0, :2]
    direction = np.asarray(goal, dtype=float) - start
    normal = np.array([-direction[1], direction[0]]) / max(np.hypot(*direction), 1e-12)
    lateral = (d.states[:, -1, :2] - start) @ normal
    eps = d.eps[:, 0, :]
    spread = eps.std(axis=0) * lateral.std()
    corr = np.abs(((eps - eps.mean(0)) * (lateral - lateral.mean())[:, None]).mean(0))
    return int(np.argmax(np.where(spread > 0, corr / np.where(spread > 0, spread, 1), -1)))


def _zoom(ax, state, goal, margin=4.0) -> None:
    """Frame the start, the goal and the 5 s horizon around them."""
    xs, ys = [state[0], goal[0]], [state[1], goal[1]]
    ax.set_xlim(min(xs) - margin, max(xs) + margin)
    ax.set_ylim(min(ys) - margin - 6, max(ys) + margin + 6)
