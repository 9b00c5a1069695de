"""The report's plots: failure rates, controller time, the paths of one environment, and
timing's cost curves.

Each function takes numbers that dcmppi.bench computed (summaries, per-episode timings, paths)
and returns a matplotlib Figure; `dcmppi.render.draw.save_figure` writes it.
"""

from __future__ import annotations

import math

from dcmppi.render.draw import COLORS, draw_world, pyplot


def failure_figure(stats: dict, noises, labels, title: str, paper: dict | None = None):
    """Failure % per noise profile and row with their 95 % intervals, the episode count on each
    bar and, where `paper` gives a failure %, the paper's value beside it (a black diamond,
    labelled).

    Args:
      stats: {(noise, label): {"episodes": int, "failure_pct": float, "failure_ci_pct":
        (lo, hi)}}, as `dcmppi.bench.results.stats.summarize` returns; missing or empty groups are
        left out.
      noises, labels: the x groups and the bars in each, in drawing order.
      title: the experiment's name.
      paper: {(noise, label): (collisions, failure %, ms/step)}, None where not given.
    """
    plt = pyplot()
    paper = paper or {}
    noises, labels = list(noises), list(labels)
    width = 0.8 / len(labels)
    fig, ax = plt.subplots(figsize=(7, 4))
    labelled = set()
    for j, c in enumerate(labels):
        for i, n in enumerate(noises):
            s = stats.get((n, c))
            if not s or not s["episodes"]:
                continue
            x = i + (j - (len(labels) - 1) / 2) * width
            y, (lo, hi) = s["failure_pct"], s["failure_ci_pct"]
            label = None if c in labelled else c
            color = COLORS.get(c.split("+")[0])
            ax.bar(x, y, width, yerr=[[y - lo], [hi - y]], capsize=3, color=color, label=label,
                   hatch="//" if "+" in c else None)  # fmt: skip
            labelled.add(c)
            ax.annotate(f"n={s['episodes']}", (x, hi), xytext=(0, 2), textcoords="offset points",
                        ha="center", va="bottom", fontsize=6)  # fmt: skip
            value = paper.get((n, c), (None, None, None))[1]
            if value is not None:
                label = None if "paper" in labelled else "paper"
                ax.plot(x + 0.3 * width, value, "D", color="k", mfc="none", ms=5, label=label)
                ax.annotate(f"{value:g}", (x + 0.3 * width, value), xytext=(3, 0), fontsize=6,
                            textcoords="offset points", va="center")  # fmt: skip
                labelled.add("paper")
    ax.set_xticks(range(len(noises)), noises)
    ax.set_ylabel("failure % (95 % Wilson CI; n = episodes)")
    ax.set_title(f"{title}: failure rate per noise profile")
    ax.margins(y=0.15)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def controller_time_figure(times: dict):
    """Box plot of controller ms per step. times: {label: [episode means in ms]}, in drawing
    order."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.boxplot(list(times.values()), tick_labels=list(times), showfliers=False)
    ax.set_ylabel("controller ms per step (episode means)")
    ax.set_title("controller time per control step")
    fig.tight_layout()
    return fig


def paths_figure(observation, paths: dict, title: str):
    """The robot's path under each row over the world of `observation` (a task observation).

    paths: {label: (path (T, 2) of x, y [m], outcome)}; a label with a
    "+" (a row with changed parameters) is drawn dashed in its controller's colour."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 6.5))
    draw_world(ax, observation)
    for c, (p, outcome) in paths.items():
        color = COLORS.get(c.split("+")[0])
        style = "--" if "+" in c else "-"
        ax.plot(p[:, 0], p[:, 1], style, color=color, lw=1.8, label=f"{c}: {outcome}")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(title)
    fig.tight_layout()
    return fig


def scaling_figure(panels: dict, title: str):
    """Log-log curves of ms per step against one size each: a panel per size.

    panels: {x label: {"curves": {controller: (x list, ms list)}, "base": the paper's x or
    None (a dotted vertical line)}}, in drawing order; an axis with x = 0 is drawn linear
    below its smallest positive x (symlog).
    """
    plt = pyplot()
    from matplotlib import ticker

    columns = min(3, len(panels))
    rows = -(-len(panels) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.4 * rows), squeeze=False)
    for ax, (label, panel) in zip(axes.flat, panels.items(), strict=False):
        xs = [x for x, _ in panel["curves"].values()]
        positive = [v for x in xs for v in x if v > 0]
        if min(v for x in xs for v in x) <= 0:
            ax.set_xscale("symlog", linthresh=min(positive))
        else:
            ax.set_xscale("log")
        ax.set_yscale("log")
        ticks = sorted({v for x in xs for v in x})
        ax.set_xticks(ticks, [f"{v:g}" for v in ticks])
        ax.xaxis.set_minor_formatter(ticker.NullFormatter())
        ax.yaxis.set_major_formatter(ticker.FuncFormatter(lambda v, _: f"{v:g}"))
        ax.yaxis.set_minor_formatter(ticker.FuncFormatter(_two_five))
        for c, (x, ms) in panel["curves"].items():
            ax.plot(x, ms, "o-", ms=3, color=COLORS.get(c), label=c)
        if panel["base"] is not None:
            ax.axvline(panel["base"], color="k", ls=":", lw=1)
        ax.set_xlabel(label)
        ax.set_ylabel("ms per step")
        ax.grid(True, which="both", lw=0.3)
    for ax in axes.flat[len(panels) :]:
        ax.set_visible(False)
    axes.flat[0].legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    return fig


def _two_five(value, _):
    """A minor log tick's label: plain (0.2, 50) at 2 and 5 times a power of ten, else none."""
    digit = round(value / 10 ** math.floor(math.log10(value)))
    return f"{value:g}" if digit in (2, 5) else ""
