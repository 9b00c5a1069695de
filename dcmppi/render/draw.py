"""Matplotlib helpers shared by every plot of dcmppi.render (optional extra `plots`)."""

from __future__ import annotations

COLORS = {"mppi": "tab:red", "tube": "tab:orange", "clustered": "tab:blue", "dc": "tab:green"}


def pyplot():
    """matplotlib.pyplot on the Agg backend, or a RuntimeError naming the extra to install."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        raise RuntimeError(
            "plots need matplotlib: pip install 'dcmppi[plots]' (or pass --no-plots)"
        ) from e
    return plt


def save_figure(fig, path) -> None:
    """Write `fig` to the PNG `path` at 120 dpi and close it."""
    fig.savefig(path, dpi=120)
    pyplot().close(fig)


def draw_world(ax, obs, robot_label: str = "start") -> None:
    """Static and moving cylinders, the robot's position (labelled `robot_label`) and the goal
    of a task observation, to scale."""
    from matplotlib.patches import Circle

    for x, y, r in obs["static_obstacles"]:
        if r > 0:
            ax.add_patch(Circle((x, y), r, color="0.35"))
    for x, y, _, r in obs["moving_obstacles"]:
        ax.add_patch(Circle((x, y), r, color="tab:purple", alpha=0.4))
    x0, y0 = obs["robot_pose"][:2]
    ax.plot(x0, y0, "o", color="magenta", ms=8, label=robot_label)
    ax.plot(*obs["goal"], "*", color="green", ms=16, label="goal")
    xmin, ymin, xmax, ymax = obs["map_bounds"]
    ax.set_xlim(xmin, xmax)
    ax.set_ylim(ymin, ymax)
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
