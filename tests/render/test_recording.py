"""Episode videos with controller overlays, side-by-side comparisons, and the figures."""

import os
import subprocess
import sys

import imageio.v3 as iio
import numpy as np
import pytest
from video_frames import frames_of

from dcmppi import cli
from dcmppi.bench.episodes import runner
from dcmppi.bench.episodes.runner import Episode, EpisodeSpec, act, controller_for, make_env
from dcmppi.bench.episodes.snapshot import first_step
from dcmppi.render import video
from dcmppi.render.figures import PLAN_STYLES, rollouts_figure, write_figures
from dcmppi.render.overlay import Overlay
from dcmppi.render.recording import compare, record_episode

SMALL = {"K": 64, "N": 20}


def spec(controller, task="blocked", seed=0, **task_params):
    return EpisodeSpec(task, controller, seed=seed, task_params=task_params,
                       controller_params=SMALL)  # fmt: skip


@pytest.mark.slow
def test_comparison_video_is_synchronised_and_tiles_differ(tmp_path):
    path = tmp_path / "cmp.mp4"
    world = {"distance": 8.0, "time_limit": 5.0}
    specs = [spec("mppi", **world), spec("clustered", **world)]
    results = compare([Episode(s) for s in specs], path, width=160, height=120, progress=False)
    frames = np.asarray(frames_of(path)[1])
    # one frame per control step of the longest episode, plus the reset frame
    assert frames.shape == (max(r["steps"] for r in results) + 1, 120, 320, 3)
    left, right = frames[..., :160, :].astype(int), frames[..., 160:, :].astype(int)
    assert np.abs(left - right).mean() > 1.0  # same world, different controllers and overlays
    # the first frame shows the same world and robot: the tiles are far more alike there
    assert np.abs(left[0] - right[0]).mean() < np.abs(left - right).mean(axis=(1, 2, 3)).max()


@pytest.mark.slow
def test_record_episode_gif_has_one_frame_per_step(tmp_path):
    path = tmp_path / "one.gif"
    episode = spec("dc", task="crossing", time_limit=3.0)
    result = record_episode(Episode(episode), path, width=128, height=96, progress=False)
    frames = np.asarray(frames_of(path)[1])
    assert result["steps"] == 30
    assert frames.shape[:3] == (result["steps"] + 1, 96, 128)


def _scene_after_overlay(max_geom):
    episode = Episode(spec("dc", task="crowd"))
    for _ in range(2):
        episode.step()
    overlay = Overlay(episode.controller, rollouts=40, segments=10)
    overlay.record(np.zeros(3))
    overlay.record(np.ones(3))
    renderer = video.Renderer(episode.env.physics.model.ptr, 64, 64, max_geom=max_geom)
    try:
        renderer.render(episode.env.physics, "top")
        base = renderer.scene.ngeom
        renderer.render(episode.env.physics, "top", overlay)
        return base, renderer.scene.ngeom
    finally:
        renderer.close()


def test_overlay_adds_geoms_within_the_scene_budget():
    base, full = _scene_after_overlay(max_geom=20000)
    assert full - base >= 40 * 10  # every drawn rollout, the plan, the trail, the futures
    tight = base + 57
    base2, drawn = _scene_after_overlay(max_geom=tight)
    assert base2 == base and drawn == tight  # filled up to the budget, never past it


@pytest.mark.parametrize("task", ["blocked", "crossing"])
def test_figures_mark_the_controllers_actual_outputs(tmp_path, task):
    s = spec("mppi", task=task, seed=3)
    observation, runs, approach = first_step(s, ("mppi", "clustered", "dc"))
    result = write_figures(observation, runs, tmp_path, f"{task}, seed 3")
    for png in result["files"]:
        assert iio.imread(png).size > 0
    # rollouts.png: a futures panel only where dc sampled some, plans widest first, each in
    # its own style, and the robot's marker named for what it is
    fig = rollouts_figure(observation, runs)
    assert len(fig.axes) == {"blocked": 2, "crossing": 3}[task]
    plans = [line for line in fig.axes[-1].get_lines() if line.get_label() in runs]
    assert [line.get_label() for line in plans] == list(runs)
    widths = [line.get_linewidth() for line in plans]
    assert widths == sorted(widths, reverse=True)
    assert len({(line.get_linestyle(), line.get_marker()) for line in plans}) == len(runs)
    labels = fig.axes[-1].get_legend_handles_labels()[1]
    assert "robot at the planned step" in labels and "start" not in labels
    assert len(PLAN_STYLES) >= len(runs)
    # replay the same step independently: drive straight, then each controller acts once
    env = make_env(s)
    time_step = env.reset()
    for _ in range(approach):
        time_step = env.step(np.zeros(1))
    assert approach > 0  # the obstacle is out of reach at the start
    for name, marked in result["actions"].items():
        controller = controller_for(EpisodeSpec(task, name, seed=3, controller_params=SMALL))
        controller.reset()
        assert act(controller, time_step.observation)[0] == marked


def test_overlay_legend_names_what_is_drawn():
    mppi = Episode(spec("mppi", task="crossing"))
    dc = Episode(spec("dc", task="crowd"))  # obstacles near from the start
    assert Overlay(mppi.controller).legend() == []  # nothing planned yet, nothing drawn
    for episode in (mppi, dc):
        for _ in range(2):
            episode.step()
    overlay = Overlay(mppi.controller)
    overlay.record(np.zeros(3))
    overlay.record(np.ones(3))
    assert [label for _, label in overlay.legend()] == [
        "sampled rollouts", "plan", "trail",
    ]  # fmt: skip
    labels = [label for _, label in Overlay(dc.controller).legend()]
    assert labels[:2] == ["rollouts by cluster", "in no cluster"]
    assert labels[-1] == "obstacle futures"


def test_cli_video_path_under_a_file_is_one_line_exit_2(tmp_path, capsys):
    (tmp_path / "notes").write_text("")
    argv = ["--task", "blocked", "--video", str(tmp_path / "notes" / "clip.mp4")]
    assert cli.main(["run", "--controller", "mppi", *argv]) == 2
    assert cli.main(["compare", "--controllers", "mppi", *argv]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 2 and all("notes is a file, not a folder" in line for line in lines)
    assert lines[0].startswith("dcmppi run: error: ")


@pytest.mark.slow
def test_cli_ctrl_c_during_a_video_prints_one_line_and_keeps_a_playable_video(
    tmp_path, capsys, monkeypatch
):
    step, calls = runner.Episode.step, []

    def interrupted(self):
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        step(self)

    monkeypatch.setattr(runner.Episode, "step", interrupted)
    path = tmp_path / "cut.mp4"
    argv = ["run", "--task", "blocked", "--controller", "mppi", "--param", "K=32",
            "--param", "N=10", "--video", str(path)]  # fmt: skip
    assert cli.main(argv) == 130
    err = capsys.readouterr().err
    assert err == f"dcmppi run: interrupted; the video so far (4 frames) is in {path}\n"
    meta, frames = frames_of(path)  # the reset frame and the three steps before Ctrl-C
    assert len(frames) == 4 and meta["size"] == (1280, 720)


@pytest.mark.slow
@pytest.mark.parametrize("argv", [["tasks"], ["--help"]])
def test_cli_output_into_a_closed_pipe_is_quiet(argv):
    read, write = os.pipe()
    os.close(read)  # the reader has gone, as `dcmppi tasks | head -1` after one line
    try:
        out = subprocess.run(
            [sys.executable, "-m", "dcmppi.cli", *argv], stdout=write, stderr=subprocess.PIPE
        )
    finally:
        os.close(write)
    assert out.stderr == b""
    assert out.returncode in (0, 141)  # argparse's --help swallows the error itself


@pytest.mark.slow
def test_users_controller_without_diagnostics_records_a_video_but_no_figure(tmp_path):
    """A user's controller (reset/act only): the video draws its trail; the figure, which plots
    sampled rollouts, names what it needs."""
    user = EpisodeSpec("blocked", "user_controllers:Straight", task_params={"time_limit": 1.0})
    result = record_episode(Episode(user), tmp_path / "u.mp4", width=96, height=64, progress=False)
    assert result["steps"] == 10 and (tmp_path / "u.mp4").stat().st_size > 0
    observation, runs, _ = first_step(spec("mppi"), ("mppi",))
    runs["mine"] = (Episode(user).controller, np.zeros(1))
    with pytest.raises(ValueError, match="mine records none.*subclass dcmppi.Controller"):
        write_figures(observation, runs, tmp_path, "blocked")
