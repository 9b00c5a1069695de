"""The EKF error plot: speed and turn-rate errors of obstacle filters over one episode.

`dcmppi.bench.reports.ekf_plot` runs the episode and hands the errors in.
"""

from __future__ import annotations

from dcmppi.render.draw import pyplot


def ekf_error_figure(time, error, std, obstacles, title: str):
    """Estimate minus truth of speed and turn rate over time, each with its 2-sigma band, one
    line per obstacle in `obstacles`. Returns the matplotlib Figure.

    Args:
      time: (T,) [s] of each posterior.
      error: (T, L, 2) estimate minus truth of speed [m/s] and turn rate [rad/s].
      std: (T, L, 2) their posterior stds.
      obstacles: indices into L of the obstacles to draw (a legend up to 10 of them).
      title: the figure's title.
    """
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    labels = ("speed error [m/s]", "turn-rate error [rad/s]")
    for ax, j, label in zip(axes, (0, 1), labels, strict=True):
        for n, l in enumerate(obstacles):
            color = plt.cm.tab10(n % 10)
            e, s = error[:, l, j], 2.0 * std[:, l, j]
            ax.plot(time, e, color=color, lw=1.0, label=f"obstacle {l}")
            ax.fill_between(time, -s, s, color=color, alpha=0.12, lw=0)
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_ylabel(label)
    axes[-1].set_xlabel("time [s]  (lines: estimate - truth; bands: +-2 posterior std)")
    axes[0].set_title(title)
    if len(obstacles) <= 10:
        axes[0].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    return fig
