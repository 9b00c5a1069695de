"""Golden trajectories: every planner's actions, bit for bit, against those stored in tests/golden/.

Each group is the sha1 of float64 actions: closed loops of the timing cases (`dcmppi timing
--fingerprint`'s cases: every planner, agent, perturbation kind and predictor) over STEPS
steps, the same over the fingerprint's 100 steps (slow), and bench episodes on the MuJoCo plant
(with their outcome and step count). The last bits of sums and transcendental functions depend
on the machine's SIMD kernels (provenance.kernels), so the hashes are stored per kernels, one
file each; on kernels without a file the tests skip and say how to record them.
"""

import hashlib
import json
import os
import pathlib
import re

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from dcmppi.bench.episodes.runner import Episode, EpisodeSpec
from dcmppi.bench.results.provenance import kernels
from dcmppi.bench.timing.cases import BASE_CASES, PRESET_VARIANTS, VARIANTS
from dcmppi.bench.timing.fingerprint import fingerprint

GOLDEN = pathlib.Path(__file__).resolve().parent / "golden"
RECORD_ENV = "DCMPPI_GOLDEN_RECORD"
RECORD = f"{RECORD_ENV}=1 pytest tests/test_golden.py"
STEPS = 25  # the quick loops' length; the fingerprint's is FINGERPRINT_STEPS
FINGERPRINT_STEPS = 100

SHORT = {"time_limit": 3.0}  # 30 control steps of 0.1 s
# (label, spec): the bench's plant, noise and observation, one episode per planner
EPISODES = (
    ("mppi forest control", EpisodeSpec("forest", "mppi", "control", 1, SHORT)),
    (
        "clustered blocked unicycle",
        EpisodeSpec("blocked", "clustered", "control", 2, {**SHORT, "agent": "unicycle"}),
    ),
    ("tube crowd", EpisodeSpec("crowd", "tube", "none", 3, SHORT)),
    ("dc crossing control", EpisodeSpec("crossing", "dc", "control", 1, SHORT)),
    (
        "dc corridor ekf",
        EpisodeSpec("corridor", "dc", "none", 4, SHORT, controller_params={"prediction": "ekf"}),
    ),
    (
        "dc crossing given",
        EpisodeSpec("crossing", "dc", "none", 5, SHORT, controller_params={"prediction": "given"}),
    ),
)


def golden_path(machine: str) -> pathlib.Path:
    """The file of a machine's kernels, e.g. golden/numpy-AVX512_SPR-openblas-SkylakeX.json."""
    return GOLDEN / (re.sub(r"[^A-Za-z0-9_]+", "-", machine).strip("-") + ".json")


def sha1(actions) -> str:
    """The sha1 of actions (steps, nu) as float64 bytes (as `dcmppi timing --fingerprint`)."""
    return hashlib.sha1(np.ascontiguousarray(actions, dtype=np.float64).tobytes()).hexdigest()


def loop_hashes(steps: int, preset: bool = False) -> dict:
    """{"label @ problem": sha1} of the fingerprint cases over `steps` closed-loop steps: the
    smooth preset's (PRESET_VARIANTS, a group of their own, so that the kernels recorded before
    them keep their other groups) or the others."""
    rows = fingerprint(PRESET_VARIANTS if preset else BASE_CASES + VARIANTS, steps)
    hashes = {f"{r['case']} @ {r['problem']}": r["sha1"] for r in rows}
    assert len(hashes) == len(rows), "two fingerprint cases share a label and problem"
    return hashes


def episode_hashes() -> dict:
    """{label: {actions: sha1, outcome, steps}} of every EPISODES episode."""
    out = {}
    with threadpool_limits(1):
        for label, spec in EPISODES:
            episode = Episode(spec)
            actions, plan = [], episode.controller.act

            def act(*args, plan=plan, actions=actions, **kwargs):
                u = plan(*args, **kwargs)
                actions.append(np.array(u, dtype=np.float64).reshape(-1))
                return u

            episode.controller.act = act  # the runner calls controller.act
            while not episode.done:
                episode.step()
            result = episode.result()
            out[label] = {
                "actions": sha1(actions),
                "outcome": result["outcome"],
                "steps": result["steps"],
            }
    return out


def check(group: str, now: dict) -> None:
    """Compare `now` with the stored group of this machine's kernels; record it instead under
    DCMPPI_GOLDEN_RECORD=1; skip where nothing is stored for these kernels."""
    machine = kernels()
    path = golden_path(machine)
    stored = json.loads(path.read_text()) if path.exists() else {"kernels": machine}
    if os.environ.get(RECORD_ENV) == "1":
        stored[group] = now
        path.parent.mkdir(exist_ok=True)
        path.write_text(json.dumps(stored, indent=1, sort_keys=True) + "\n")
        pytest.skip(f"recorded {len(now)} {group} for {machine} in {path.name}")
    if group not in stored:
        pytest.skip(f"no golden {group} for kernels {machine!r}: record them with {RECORD}")
    assert stored["kernels"] == machine, f"{path.name} holds {stored['kernels']!r}"
    old = stored[group]
    changed = [k for k in sorted(old.keys() | now.keys()) if old.get(k) != now.get(k)]
    lines = [f"  {k}: stored {old.get(k, 'nothing')}, now {now.get(k, 'nothing')}" for k in changed]
    assert not changed, (
        f"{group} changed on {machine}:\n" + "\n".join(lines) + "\n"
        "A change that keeps plans must give the same actions. If the change is meant to alter "
        "plans, show that the outcomes stay the same within chance (`dcmppi outcomes --old "
        f"OLD.db --new NEW.db`, the outcome rule in docs/performance.md), then re-record: {RECORD} "
        "(and re-record or delete the other kernels' files in tests/golden/)."
    )


def test_short_loops_of_every_planner_agent_and_perturbation():
    check("loops", loop_hashes(STEPS))


def test_short_loops_of_the_smooth_preset():
    check("preset loops", loop_hashes(STEPS, preset=True))


def test_bench_episodes_on_the_plant():
    check("episodes", episode_hashes())


@pytest.mark.slow
def test_fingerprint():
    """`dcmppi timing --fingerprint`'s hashes, the figures docs/performance.md compares."""
    check("fingerprint", loop_hashes(FINGERPRINT_STEPS))
