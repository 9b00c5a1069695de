"""The report's failure-rate plot: episode counts on the bars, the paper's values beside them."""

import pytest

pytest.importorskip("matplotlib")

from dcmppi.bench.plots import failure_figure  # noqa: E402


def _rows(counts):
    """Result rows: counts {(noise, controller): (episodes, failures)}."""
    rows = []
    for (noise, controller), (episodes, failures) in counts.items():
        for i in range(episodes):
            failed = i < failures
            rows.append(dict(
                noise=noise, controller=controller, label=controller, env_index=i, status="ok",
                failure=failed,
                collision=failed, outcome="collision" if failed else "goal", steps=100,
                ctrl_ms_mean=5.0, time_to_goal=None if failed else 30.0, path_length=30.0,
                ess_mean=None, clusters_mean=None, fallback_share=None, tube_deviation_p95=None,
                nav_score=None,
            ))  # fmt: skip
    rows.append({**rows[0], "status": "error", "env_index": 99})  # not an episode
    return rows


COUNTS = {
    ("none", "mppi"): (40, 4),
    ("none", "clustered"): (40, 1),
    ("control", "mppi"): (25, 5),
    ("control", "clustered"): (25, 2),
}
PAPER = {("none", "mppi"): (11, 1.2, 190), ("control", "mppi"): (59, 6.0, 195),
         ("none", "clustered"): (6, None, 193)}  # fmt: skip


def _paper_marks(fig):
    return sorted(y for line in fig.axes[0].get_lines() if line.get_marker() == "D"
                  for y in line.get_ydata())  # fmt: skip


def test_every_bar_shows_its_episode_count_and_the_papers_value_where_given():
    fig = failure_figure(_rows(COUNTS), "static", PAPER, ["mppi", "clustered"])
    ax = fig.axes[0]
    counts = sorted(t.get_text() for t in ax.texts if t.get_text().startswith("n="))
    assert counts == ["n=25", "n=25", "n=40", "n=40"]
    assert _paper_marks(fig) == [1.2, 6.0]  # clustered's failure % is not given: no mark
    assert sorted(t.get_text() for t in ax.texts if not t.get_text().startswith("n=")) == [
        "1.2", "6"
    ]  # fmt: skip
    assert "paper" in ax.get_legend_handles_labels()[1]
    bars = sorted(round(p.get_height(), 6) for p in ax.patches)
    assert bars == sorted(round(100 * f / n, 6) for n, f in COUNTS.values())


def test_without_paper_figures_no_marks():
    fig = failure_figure(_rows(COUNTS), "mine")
    assert _paper_marks(fig) == []
