"""PNG plots of a report (matplotlib, optional extra `dcmppi[plots]`)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from dcmppi.bench.stats import controller_order, noise_order, summarize
from dcmppi.render.draw import COLORS, draw_world, pyplot


def report_plots(rows: list[dict], config: dict, out: Path, paper: dict | None = None) -> list[str]:
    """Write failure_rates.png, controller_time.png and paths.png; return their names.

    paper: the paper's figures {(noise, controller): (collisions, failure %, ms/step)}, drawn
    beside the failure-rate bars where the failure % is given (not None).
    """
    plt = pyplot()
    controllers = sorted({r["controller"] for r in rows}, key=controller_order)
    noises = sorted({r["noise"] for r in rows}, key=noise_order)

    fig = failure_figure(rows, config["experiment"], paper)
    fig.savefig(out / "failure_rates.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    data = [
        [r["ctrl_ms_mean"] for r in rows if r["status"] == "ok" and r["controller"] == c]
        for c in controllers
    ]
    ax.boxplot(data, tick_labels=controllers, showfliers=False)
    ax.set_ylabel("controller ms per step (episode means)")
    ax.set_title("controller time per control step")
    fig.tight_layout()
    fig.savefig(out / "controller_time.png", dpi=120)
    plt.close(fig)

    noise = noises[0]
    index = min(r["env_index"] for r in rows if r["noise"] == noise)
    plot_paths(config, index, noise, controllers, out / "paths.png")
    return ["failure_rates.png", "controller_time.png", "paths.png"]


def failure_figure(rows: list[dict], experiment: str, paper: dict | None = None):
    """Failure % per noise profile and controller with 95 % Wilson intervals, the episode count
    on each bar and, where `paper` gives one (see `report_plots`), the paper's value beside
    it (a black diamond, labelled). Returns the matplotlib Figure."""
    plt = pyplot()
    paper = paper or {}
    stats = summarize(rows)
    noises = sorted({n for n, _ in stats}, key=noise_order)
    controllers = sorted({c for _, c in stats}, key=controller_order)
    width = 0.8 / len(controllers)
    fig, ax = plt.subplots(figsize=(7, 4))
    labelled = set()
    for j, c in enumerate(controllers):
        for i, n in enumerate(noises):
            s = stats.get((n, c))
            if not s or not s["episodes"]:
                continue
            x = i + (j - (len(controllers) - 1) / 2) * width
            y, (lo, hi) = s["failure_pct"], s["failure_ci_pct"]
            label = None if c in labelled else c
            ax.bar(
                x, y, width, yerr=[[y - lo], [hi - y]], capsize=3, color=COLORS.get(c), label=label
            )
            labelled.add(c)
            ax.annotate(f"n={s['episodes']}", (x, hi), xytext=(0, 2), textcoords="offset points",
                        ha="center", va="bottom", fontsize=6)  # fmt: skip
            value = paper.get((n, c), (None, None, None))[1]
            if value is not None:
                label = None if "paper" in labelled else "paper (Table I)"
                ax.plot(x + 0.3 * width, value, "D", color="k", mfc="none", ms=5, label=label)
                ax.annotate(f"{value:g}", (x + 0.3 * width, value), xytext=(3, 0), fontsize=6,
                            textcoords="offset points", va="center")  # fmt: skip
                labelled.add("paper")
    ax.set_xticks(range(len(noises)), noises)
    ax.set_ylabel("failure % (95 % Wilson CI; n = episodes)")
    ax.set_title(f"{experiment}: failure rate per noise profile")
    ax.margins(y=0.15)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_paths(config: dict, index: int, noise: str, controllers, path: Path) -> None:
    """Re-run environment `index` under each controller (deterministic) and draw the paths."""
    from dcmppi.bench.experiments import get_experiment
    from dcmppi.bench.runner import EpisodeSpec, make_env, run_episode

    plt = pyplot()
    exp = dataclasses.replace(
        get_experiment(config["experiment"]),
        base_seed=config["base_seed"],
        task_params=config["task_params"],
        controller_params=config["controller_params"],
    )
    spec = EpisodeSpec(
        exp.task, controllers[0], noise, exp.seed(index), exp.task_params, exp.controller_params
    )
    obs = make_env(spec).reset().observation
    fig, ax = plt.subplots(figsize=(9, 6.5))
    draw_world(ax, obs)
    for c in controllers:
        result = run_episode(dataclasses.replace(spec, controller=c), keep_path=True)
        p = result["path"]
        ax.plot(p[:, 0], p[:, 1], color=COLORS.get(c), lw=1.8, label=f"{c}: {result['outcome']}")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"{config['experiment']} environment {index}, noise {noise}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
