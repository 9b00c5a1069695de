"""The numbers behind a report's plots; dcmppi.render.plots draws them (extra `dcmppi[plots]`)."""

from __future__ import annotations

from pathlib import Path

from dcmppi.bench.episodes.runner import make_env, run_episode
from dcmppi.bench.results.stats import noise_order, row_order, summarize
from dcmppi.render.draw import save_figure
from dcmppi.render.plots import controller_time_figure, failure_figure, paths_figure


def report_plots(rows: list[dict], exp, out: Path) -> list[str]:
    """Write failure_rates.png, controller_time.png and paths.png (the paths of the rows that
    finished in one environment, re-run; none without such rows); return their names.

    exp: the `dcmppi.bench.experiments.Experiment` of the rows (row order, paper figures)."""
    labels = row_order({r["label"] for r in rows}, [row.label for row in exp.rows])
    noises = sorted({r["noise"] for r in rows}, key=noise_order)
    paper = {(n, c): tuple(exp.paper(n, c)) for n in noises for c in labels}
    fig = failure_figure(summarize(rows), noises, labels, exp.name, paper)
    save_figure(fig, out / "failure_rates.png")

    ok = [r for r in rows if r["status"] == "ok"]
    times = {c: [r["ctrl_ms_mean"] for r in ok if r["label"] == c] for c in labels}
    save_figure(controller_time_figure(times), out / "controller_time.png")

    if not ok:
        return ["failure_rates.png", "controller_time.png"]
    noise, index, rerun = paths_environment(ok, labels)
    observation, paths = episode_paths(exp, index, noise, rerun)
    title = f"{exp.name} environment {index}, noise {noise}"
    save_figure(paths_figure(observation, paths, title), out / "paths.png")
    return ["failure_rates.png", "controller_time.png", "paths.png"]


def paths_environment(ok: list[dict], labels) -> tuple[str, int, list[str]]:
    """The noise profile and environment index whose paths a report draws, and the rows (in
    the order of `labels`) that finished there (status "ok": an episode that raised or timed out
    is not re-run): the environment where most rows finished, then the first noise profile and
    the lowest index. ok: finished rows (at least one)."""
    finished = {}
    for r in ok:
        finished.setdefault((r["noise"], r["env_index"]), set()).add(r["label"])
    noise, index = min(finished, key=lambda k: (-len(finished[k]), noise_order(k[0]), *k))
    return noise, index, [c for c in labels if c in finished[noise, index]]


def episode_paths(exp, index: int, noise: str, labels) -> tuple[dict, dict]:
    """Re-run environment `index` under each row (deterministic): its first observation and
    {label: (path (T, 2) of x, y [m], outcome)}."""
    observation = make_env(exp.spec(noise, labels[0], index)).reset().observation
    paths = {}
    for c in labels:
        result = run_episode(exp.spec(noise, c, index), keep_path=True)
        paths[c] = (result["path"], result["outcome"])
    return observation, paths
