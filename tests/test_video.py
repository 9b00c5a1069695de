"""Offscreen episode videos."""

import subprocess
import sys

import numpy as np
import pytest
from conftest import frames_of

from dcmppi import tasks
from dcmppi.render import video


@pytest.mark.parametrize("suffix, camera", [(".mp4", "top"), (".gif", "chase")])
def test_short_video_has_every_frame_at_the_requested_size(tmp_path, suffix, camera):
    env = tasks.load("blocked", {"time_limit": 0.6})
    info = video.render_episode(
        env, lambda ts: [0.5], tmp_path / f"clip{suffix}", camera=camera, width=160, height=96
    )
    assert info["steps"] == 6 and info["frames"] == 7  # the reset frame plus one per step
    assert info["outcome"] == "time_limit"
    meta, frames = frames_of(info["path"])
    assert meta["size"] == (160, 96)
    assert len(frames) == 7
    if suffix == ".mp4":
        assert meta["codec"].startswith("h264")
        assert meta["fps"] == pytest.approx(10.0)


def test_top_view_is_upright_and_shows_the_robot_where_it_is():
    env = tasks.load("blocked", {})
    env.reset()
    env.physics.data.qpos[:2] = [20.0, 40.0]  # left of and above the map centre (37.5, 25)
    env.physics.forward()
    renderer = video.Renderer(env.physics.model.ptr, 640, 360)
    try:
        frame = renderer.render(env.physics, "top")
    finally:
        renderer.close()
    magenta = (frame[..., 0] > 150) & (frame[..., 1] < 90) & (frame[..., 2] > 150)
    rows, cols = np.nonzero(magenta)
    assert len(rows) > 20
    assert cols.mean() < 320 - 50  # image x grows with world x
    assert rows.mean() < 180 - 50  # image rows grow downwards, world y upwards


def test_decorate_hook_adds_geoms_within_maxgeom():
    env = tasks.load("blocked", {})
    env.reset()
    renderer = video.Renderer(env.physics.model.ptr, 64, 48, max_geom=40)
    drawn = []

    def decorate(scene, physics):
        free = scene.maxgeom - scene.ngeom
        drawn.append(
            (
                free,
                video.add_polyline(
                    scene, np.random.default_rng(0).uniform(0, 50, (100, 2)), [0, 1, 1, 1]
                ),
            )
        )
        assert not video.add_geom(scene, 2, [1, 1, 1], [0, 0, 1], [1, 1, 1, 1])

    try:
        frame = renderer.render(env.physics, "top", decorate)
    finally:
        renderer.close()
    assert frame.shape == (48, 64, 3)
    free, segments = drawn[0]
    assert segments == free < 99


def test_bad_arguments(tmp_path):
    env = tasks.load("blocked", {})
    with pytest.raises(ValueError, match="mp4 or .gif"):
        video.render_episode(env, lambda ts: [0.0], tmp_path / "clip.avi")
    with pytest.raises(ValueError, match="camera"):
        video.render_episode(env, lambda ts: [0.0], tmp_path / "clip.mp4", camera="side")
    with pytest.raises(ValueError, match="even"):
        video.render_episode(env, lambda ts: [0.0], tmp_path / "clip.mp4", width=101)
    with pytest.raises(ValueError, match="offscreen buffer"):
        video.render_episode(env, lambda ts: [0.0], tmp_path / "clip.mp4", width=4000)


def test_broken_backend_gives_one_clear_error(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "nonsense")
    monkeypatch.setattr(video._gl, "user_choice", "nonsense")
    env = tasks.load("blocked", {})
    with pytest.raises(video.RenderError, match="MUJOCO_GL='nonsense'.*apt-get install libegl1"):
        video.Renderer(env.physics.model.ptr, 64, 48)


def test_importing_dcmppi_does_not_import_mujoco():
    code = "import sys, dcmppi; assert not {'mujoco', 'dcmppi.render.video'} & set(sys.modules)"
    subprocess.run([sys.executable, "-c", code], check=True)
