"""The paper's scenarios end to end in MuJoCo: the head-on crossing (Fig. 4) with the defaults."""

import pytest

from dcmppi.bench.episodes.runner import EpisodeSpec, run_episode

pytestmark = pytest.mark.slow  # whole MuJoCo episodes, six per test


@pytest.mark.parametrize("agent", ["dubins", "holonomic"])
def test_dc_passes_the_head_on_crossing_where_mppi_collides(agent):
    """With control noise, DC-MPPI (sampled obstacle futures) passes the oncoming obstacle; MPPI,
    which sees it frozen where it is, drives into it (README: seeds 0-9 of each)."""
    dc = mppi = 0
    for seed in range(3):
        spec = EpisodeSpec(
            "crossing", "dc", noise="control", seed=seed, task_params={"agent": agent}
        )
        dc += run_episode(spec)["outcome"] == "goal"
        mppi += (
            run_episode(EpisodeSpec("crossing", "mppi", "control", seed, {"agent": agent}))[
                "outcome"
            ]
            == "collision"
        )
    assert dc == 3 and mppi >= 2
