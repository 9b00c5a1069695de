"""The report's plots (dcmppi.render.plots) from the numbers dcmppi.bench computes: episode
counts and the paper's values on the failure bars, one box per row, one path per row, timing's
cost curves."""

import numpy as np
import pytest

pytest.importorskip("matplotlib")

from dcmppi.bench.results.stats import summarize  # noqa: E402
from dcmppi.render.plots import (  # noqa: E402
    controller_time_figure,
    failure_figure,
    paths_figure,
    scaling_figure,
)


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
    stats = summarize(_rows(COUNTS))
    fig = failure_figure(stats, ["none", "control"], ["mppi", "clustered"], "static", PAPER)
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
    fig = failure_figure(
        summarize(_rows(COUNTS)), ["none", "control"], ["mppi", "clustered"], "mine"
    )
    assert _paper_marks(fig) == []


def test_controller_time_has_one_box_per_row_in_order():
    fig = controller_time_figure({"dc": [4.0, 6.0, 5.0], "mppi": [1.0, 2.0]})
    ax = fig.axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["dc", "mppi"]
    medians = [line.get_ydata()[0] for line in ax.get_lines() if line.get_color() == "C1"]
    assert medians == [5.0, 1.5]


def test_paths_are_drawn_per_row_with_their_outcome_dashed_for_variants():
    observation = {
        "static_obstacles": np.array([[2.0, 1.0, 0.5], [0.0, 0.0, 0.0]]),  # r = 0: padding
        "moving_obstacles": np.array([[3.0, 3.0, 0.0, 0.4]]),
        "robot_pose": np.array([0.0, 0.0, 0.0]),
        "goal": np.array([8.0, 0.0]),
        "map_bounds": np.array([-1.0, -5.0, 10.0, 5.0]),
    }
    line = np.column_stack([np.linspace(0, 8, 5), np.zeros(5)])
    paths = {"mppi": (line, "goal"), "mppi+margin": (line + [0, 1], "collision")}
    ax = paths_figure(observation, paths, "static environment 0").axes[0]
    drawn = {line.get_label(): line for line in ax.get_lines()}
    assert drawn["mppi: goal"].get_linestyle() == "-"
    assert drawn["mppi+margin: collision"].get_linestyle() == "--"
    np.testing.assert_array_equal(drawn["mppi+margin: collision"].get_ydata(), np.ones(5))
    assert len(ax.patches) == 2  # one static cylinder (the padding is skipped), one moving


def test_scaling_curves_are_log_log_per_size_with_the_papers_point_dotted():
    panels = {
        "samples K": {"curves": {"mppi": ([250, 500, 1000], [0.1, 0.2, 0.4]),
                                 "dc": ([250, 500, 1000], [1.0, 2.0, 4.0])}, "base": 500},
        "moving obstacles": {"curves": {"dc": ([0, 50, 100], [0.3, 1.0, 2.0])}, "base": 100},
        "futures P": {"curves": {"dc": ([5, 25], [1.5, 2.0])}, "base": None},
        "horizon N": {"curves": {"tube": ([25, 50], [0.3, 0.6])}, "base": 50},
    }  # fmt: skip
    fig = scaling_figure(panels, "ms per step")
    k, moving, futures, n, *unused = fig.axes
    assert [ax.get_visible() for ax in unused] == [False, False]  # 4 panels on a 2 x 3 grid
    assert (k.get_xscale(), k.get_yscale()) == ("log", "log")
    assert moving.get_xscale() == "symlog"  # x = 0 drawn
    assert k.get_xlabel() == "samples K" and n.get_xlabel() == "horizon N"
    lines = {line.get_label(): line for line in k.get_lines() if line.get_linestyle() == "-"}
    assert list(lines) == ["mppi", "dc"]
    np.testing.assert_array_equal(lines["dc"].get_ydata(), [1.0, 2.0, 4.0])
    dotted = [line.get_xdata()[0] for ax in fig.axes for line in ax.get_lines()
              if line.get_linestyle() == ":"]  # fmt: skip
    assert dotted == [500, 100, 50]  # none where the base is not given
    assert [t.get_text() for t in k.get_xticklabels()] == ["250", "500", "1000"]
