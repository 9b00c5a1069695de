"""The episode viewer's data: what the page draws at each control instant of an episode."""

import base64
import json
import re

import numpy as np
import pytest

from dcmppi.bench.episodes.runner import EpisodeSpec, decode_trace, run_episode
from dcmppi.render import viewer as v

TYPES = {"f4": "<f4", "u1": "u1", "u2": "<u2", "i2": "<i2"}


def arrays(data):
    """The page's arrays, decoded as the page decodes them (web/viewer.js)."""
    out = {}
    for name, a in data["arrays"].items():
        x = np.frombuffer(base64.b64decode(a["b64"]), TYPES[a["dtype"]])
        out[name] = (x * a["scale"]).astype("<f4") if "scale" in a else x
    return out


def test_the_viewer_keeps_each_instant_its_plan_rollouts_futures_and_cost_terms(tmp_path):
    # dc among a few walkers, the prior's sampled futures: every layer of the page
    spec = EpisodeSpec("crowd", "dc", seed=2, task_params={"time_limit": 1.0, "n_obstacles": 8},
                       controller_params={"K": 64, "N": 12})  # fmt: skip
    viewer, plan_J = v.Viewer(), []

    def watch(episode):
        viewer(episode)
        d = episode.controller.diagnostics
        if episode.actions:  # J of the plan just made, as the figures compute it
            _, J = episode.controller.rollout_costs(d.states[0, 0], d.plan[:, :, None])
            plan_J.append(J[0])

    result = run_episode(spec, on_step=watch)
    data = viewer.data()
    a = arrays(data)
    n = result["steps"] + 1
    assert data["frames"] == n == len(plan_J) + 1
    assert np.array_equal(a["pose"].reshape(n, 3), decode_trace(result["trace"]))
    # the cost terms sum to the plan's J; the last instant plans nothing
    cost = a["cost"].reshape(n, 3).astype(float)
    assert cost[:-1].sum(axis=1) == pytest.approx(plan_J, rel=1e-6)
    assert np.isnan(cost[-1]).all() and (cost[:-1, 0] > 0).all()
    rollouts, futures = a["rollout_count"], a["future_count"]
    assert list(rollouts) == [v.ROLLOUTS] * (n - 1) + [0]
    assert futures.any() and futures.max() <= v.FUTURES * v.OBSTACLES  # the nearby ones
    assert len(a["rollout"]) == 2 * v.POINTS * rollouts.sum()
    assert len(a["future"]) == 2 * v.POINTS * futures.sum()
    assert data["arrays"]["rollout"]["dtype"] == "i2"  # centimetres
    colours = a["rollout_colour"]
    assert len(colours) == rollouts.sum() and (colours >= v.CHOSEN).any()  # chosen cluster
    people = a["people"].reshape(n, data["people"], 3)
    assert data["people"] == 8 and (people[..., 2] > 0).all()
    # the gap at the control instants, never below the least over the physics' substeps
    assert result["min_clearance"] <= a["gap"].min() < a["gap"].max()

    path = tmp_path / "episode.html"
    viewer.write(path, "crowd / dc", "Replayed: reproduced (exact)")
    page = path.read_text()
    found = re.search(r'<script id=episode type="application/json">(.*?)</script>', page, re.S)
    assert json.loads(found[1])["frames"] == n and "<script src" not in page  # all inline
    assert "Replayed: reproduced (exact)" in page and "rounded to 1 cm" in page
