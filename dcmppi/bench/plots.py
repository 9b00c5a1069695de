"""PNG plots of a report (matplotlib, optional extra `dcmppi[plots]`)."""

from __future__ import annotations

from pathlib import Path

from dcmppi.bench.stats import noise_order, row_order, summarize
from dcmppi.render.draw import COLORS, draw_world, pyplot


def report_plots(rows: list[dict], exp, out: Path) -> list[str]:
    """Write failure_rates.png, controller_time.png and paths.png; return their names.

    exp: the `dcmppi.bench.experiments.Experiment` of the rows."""
    plt = pyplot()
    stats = summarize(rows)
    noises = sorted({n for n, _ in stats}, key=noise_order)
    controllers = row_order({c for _, c in stats}, [row.label for row in exp.rows])
    width = 0.8 / len(controllers)

    fig, ax = plt.subplots(figsize=(7, 4))
    for j, c in enumerate(controllers):
        xs, ys, err = [], [], [[], []]
        for i, n in enumerate(noises):
            s = stats.get((n, c))
            if s and s["episodes"]:
                lo, hi = s["failure_ci_pct"]
                xs.append(i + (j - (len(controllers) - 1) / 2) * width)
                ys.append(s["failure_pct"])
                err[0].append(s["failure_pct"] - lo)
                err[1].append(hi - s["failure_pct"])
        ax.bar(xs, ys, width, yerr=err, capsize=3, label=c, color=COLORS.get(c))
    ax.set_xticks(range(len(noises)), noises)
    ax.set_ylabel("failure % (95 % Wilson CI)")
    ax.set_title(f"{exp.name}: failure rate per noise profile")
    ax.legend()
    fig.tight_layout()
    fig.savefig(out / "failure_rates.png", dpi=120)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(7, 4))
    data = [
        [r["ctrl_ms_mean"] for r in rows if r["status"] == "ok" and r["label"] == c]
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
    plot_paths(exp, index, noise, controllers, out / "paths.png")
    return ["failure_rates.png", "controller_time.png", "paths.png"]


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
        ax.plot(p[:, 0], p[:, 1], color=COLORS.get(c), lw=1.8, label=f"{c}: {result['outcome']}")
    ax.legend(loc="upper right", fontsize=8)
    ax.set_title(f"{exp.name} environment {index}, noise {noise}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
