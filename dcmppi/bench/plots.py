"""PNG plots of a report (matplotlib, optional extra `dcmppi[plots]`)."""

from __future__ import annotations

from pathlib import Path

from dcmppi.bench.stats import noise_order, row_order, summarize
from dcmppi.render.draw import COLORS, draw_world, pyplot


def report_plots(rows: list[dict], exp, out: Path) -> list[str]:
    """Write failure_rates.png, controller_time.png and paths.png; return their names.

    exp: the `dcmppi.bench.experiments.Experiment` of the rows (row order, paper figures)."""
    plt = pyplot()
    labels = row_order({r["label"] for r in rows}, [row.label for row in exp.rows])
    noises = sorted({r["noise"] for r in rows}, key=noise_order)
    paper = {(n, c): tuple(exp.paper(n, c)) for n in noises for c in labels}
    fig = failure_figure(rows, exp.name, paper, labels)
    fig.savefig(out / "failure_rates.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    data = [
        [r["ctrl_ms_mean"] for r in rows if r["status"] == "ok" and r["label"] == c] for c in labels
    ]
    ax.boxplot(data, tick_labels=labels, showfliers=False)
    ax.set_ylabel("controller ms per step (episode means)")
    ax.set_title("controller time per control step")
    fig.tight_layout()
    fig.savefig(out / "controller_time.png", dpi=120)
    plt.close(fig)

    noise = noises[0]
    index = min(r["env_index"] for r in rows if r["noise"] == noise)
    plot_paths(exp, index, noise, labels, out / "paths.png")
    return ["failure_rates.png", "controller_time.png", "paths.png"]


def failure_figure(rows: list[dict], title: str, paper: dict | None = None, labels=None):
    """Failure % per noise profile and row with 95 % Wilson intervals, the episode count on
    each bar and, where `paper` {(noise, label): (collisions, failure %, ms/step)} gives a
    failure %, the paper's value beside it (a black diamond, labelled). labels: the rows in
    order (default: by name). Returns the matplotlib Figure."""
    plt = pyplot()
    paper = paper or {}
    stats = summarize(rows)
    noises = sorted({n for n, _ in stats}, key=noise_order)
    labels = list(labels) if labels is not None else sorted({c for _, c in stats})
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


def plot_paths(exp, index: int, noise: str, labels, path: Path) -> None:
    """Re-run environment `index` under each row (deterministic) and draw the paths."""
    from dcmppi.bench.runner import make_env, run_episode

    plt = pyplot()
    obs = make_env(exp.spec(noise, labels[0], index)).reset().observation
    fig, ax = plt.subplots(figsize=(9, 6.5))
    draw_world(ax, obs)
    for c in labels:
        result = run_episode(exp.spec(noise, c, index), keep_path=True)
        p = result["path"]
        color = COLORS.get(c.split("+")[0])
        style = "--" if "+" in c else "-"
        ax.plot(p[:, 0], p[:, 1], style, color=color, lw=1.8, label=f"{c}: {result['outcome']}")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"{exp.name} environment {index}, noise {noise}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
