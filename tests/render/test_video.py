"""Offscreen episode videos."""

import os
import subprocess
import sys

import numpy as np
import pytest
from video_frames import frames_of

from dcmppi import tasks
from dcmppi.render import video

pytestmark = pytest.mark.slow  # every test writes a video through ffmpeg


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
    with pytest.raises(ValueError, match="offscreen buffer"):
        video.render_episode(env, lambda ts: [0.0], tmp_path / "clip.mp4", height=1200)
    assert not (tmp_path / "clip.mp4").exists()  # no frame: no file that is not a video


@pytest.mark.skipif(not os.path.isdir("/proc/self"), reason="needs Linux's /proc")
def test_a_video_path_that_takes_no_file_is_named_before_the_episode(tmp_path, capsys):
    """/proc takes no new file: one line before anything runs (ffmpeg's broken pipe came at the
    first frame, with a traceback and the exit status of a crashed controller)."""
    from dcmppi import cli

    argv = ["run", "--task", "blocked", "--controller", "mppi", "--video", "/proc/clip.mp4"]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert "cannot write the video /proc/clip.mp4: /proc takes no new file" in err
    assert err.count("\n") == 1


def test_ffmpeg_ending_mid_video_is_one_line(tmp_path):
    writer = video.VideoWriter(tmp_path / "clip.mp4", 64, 48, 10.0)
    writer.write(np.zeros((48, 64, 3), np.uint8))
    ffmpeg, writer._writer = writer._writer, Broken()
    with pytest.raises(RuntimeError, match=r"ffmpeg stopped writing the video .*clip.mp4 \(Broken"):
        writer.write(np.zeros((48, 64, 3), np.uint8))
    writer._writer = ffmpeg
    writer.close()
    assert writer.frames == 1 and not (tmp_path / "clip.mp4").exists()  # unusable: removed


class Broken:
    """ffmpeg's frame generator after ffmpeg ended."""

    def send(self, frame):
        raise BrokenPipeError(32, "Broken pipe")


def test_broken_backend_gives_one_clear_error(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "nonsense")
    monkeypatch.setattr(video._gl, "user_choice", "nonsense")
    env = tasks.load("blocked", {})
    with pytest.raises(video.RenderError, match="MUJOCO_GL='nonsense'.*apt-get install libegl1"):
        video.Renderer(env.physics.model.ptr, 64, 48)


# MUJOCO_GL=osmesa on a machine whose OSMesa library cannot be loaded (made so if installed)
NO_OSMESA = """
import ctypes, sys
load = ctypes.CDLL.__init__
def refuse_osmesa(self, name, *args, **kwargs):
    if "OSMesa" in str(name):
        raise OSError(f"{name}: cannot open shared object file: No such file or directory")
    load(self, name, *args, **kwargs)
ctypes.CDLL.__init__ = refuse_osmesa
from dcmppi import cli, tasks
env = tasks.load("blocked", {"time_limit": 0.2})
env.reset(), env.step([0.0])  # simulation works without the library
sys.exit(cli.main(["run", "--task", "blocked", "--controller", "mppi", "--param", "K=16",
                   "--task-param", "time_limit=0.2", "--video", sys.argv[1]]))
"""


def test_a_backend_without_its_library_ends_in_one_line_naming_the_package(tmp_path):
    env = {**os.environ, "MUJOCO_GL": "osmesa"}
    run = subprocess.run(
        [sys.executable, "-c", NO_OSMESA, str(tmp_path / "clip.mp4")],
        env=env, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert run.returncode == 2
    assert run.stderr.count("\n") == 1, run.stderr
    assert "MUJOCO_GL=osmesa needs the OSMesa library" in run.stderr
    assert "apt-get install libosmesa6" in run.stderr
    assert not (tmp_path / "clip.mp4").exists()


@pytest.mark.parametrize(
    "value, out", [("EGL", "2 frames"), ("bogus", "MUJOCO_GL=bogus is no backend: set egl")]
)
def test_mujoco_gl_is_taken_in_any_case_and_a_wrong_one_named(value, out, tmp_path):
    """dm_control takes lower case only: EGL renders as egl; a value that names no backend
    leaves the simulation working and ends a video in one line."""
    clip = tmp_path / "clip.mp4"
    run = subprocess.run(
        [sys.executable, "-m", "dcmppi.cli", "run", "--task", "blocked", "--controller", "mppi",
         "--param", "K=16", "--task-param", "time_limit=0.1", "--video", str(clip)],
        env={**os.environ, "MUJOCO_GL": value}, capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert out in run.stdout + run.stderr, run.stderr
    assert run.returncode == (0 if value == "EGL" else 2) and clip.exists() == (value == "EGL")


def test_importing_dcmppi_does_not_import_mujoco():
    code = "import sys, dcmppi; assert not {'mujoco', 'dcmppi.render.video'} & set(sys.modules)"
    subprocess.run([sys.executable, "-c", code], check=True)


def _pixels(frame, rgb, tol=40):
    """How many pixels of `frame` are within `tol` of the colour rgb (0-255)."""
    return int((np.abs(frame.astype(int) - rgb).max(axis=-1) < tol).sum())


@pytest.mark.parametrize("size", [(640, 360), (640, 480), (320, 240), (360, 640)])
def test_the_top_camera_shows_the_whole_map_at_any_frame_size(size):
    """The map's corners project inside the frame, whatever its aspect (the camera's height was
    fitted to 16:9 only: a 4:3 tile cut the corridor's ends off)."""
    env = tasks.load("corridor", {"random": 0})
    env.reset()
    width, height = size
    renderer = video.Renderer(env.physics.model.ptr, width, height)
    renderer.render(env.physics, "top")
    m = env.physics.model
    cam = m.camera("top").id
    scale = (height / 2) / (m.cam_pos[cam, 2] * np.tan(np.deg2rad(m.cam_fovy[cam]) / 2))  # px/m
    xmin, ymin, xmax, ymax = env.task.world.map_bounds
    for x, y in ((xmin, ymin), (xmax, ymax)):
        px = width / 2 + (x - m.cam_pos[cam, 0]) * scale
        py = height / 2 - (y - m.cam_pos[cam, 1]) * scale
        assert 0 < px < width and 0 < py < height
    assert min(width / ((xmax - xmin) * scale), height / ((ymax - ymin) * scale)) < 1.5  # fills it


def test_scene_camera_frames_robot_and_obstacle_much_larger_than_top():
    env = tasks.load("blocked", {})
    observation = env.reset().observation
    region = video.scene_region(observation)
    # start (27.5, 25), goal (47.5, 25), the obstacle (37.5, 25, r 2) and 3 m margins
    np.testing.assert_allclose(region, [24.5, 20.0, 50.5, 30.0])
    renderer = video.Renderer(env.physics.model.ptr, 640, 360)
    try:
        top = renderer.render(env.physics, "top")
        renderer.look_at(region)
        scene = renderer.render(env.physics, "scene")
    finally:
        renderer.close()
    robot, obstacle = (217, 26, 217), (153, 38, 31)  # the hull and static obstacle materials
    for rgb in (robot, obstacle):
        assert _pixels(top, rgb) > 10
        assert _pixels(scene, rgb) > 8 * _pixels(top, rgb)  # about 13 x the area
    # upright like the top view: world x to the right, world y up
    env.physics.data.qpos[1] += 3.0
    env.physics.forward()
    renderer = video.Renderer(env.physics.model.ptr, 320, 180)
    try:
        renderer.look_at(region)
        frame = renderer.render(env.physics, "scene")
    finally:
        renderer.close()
    where = {}
    for name, rgb in (("robot", robot), ("obstacle", obstacle)):
        rows, cols = np.nonzero(np.abs(frame.astype(int) - rgb).max(axis=-1) < 40)
        where[name] = rows.mean(), cols.mean()
    assert where["robot"][1] < where["obstacle"][1] - 50  # start x 27.5 < obstacle x 37.5
    assert where["robot"][0] < where["obstacle"][0] - 20  # robot y 28 > obstacle y 25


def test_scene_region_keeps_obstacles_near_the_line_and_the_map():
    observation = {
        "robot_pose": np.array([10.0, 10.0, 0.0]),
        "goal": np.array([30.0, 10.0]),
        "static_obstacles": np.array([[20.0, 14.0, 1.0], [20.0, 40.0, 1.0], [0.0, 0.0, 0.0]]),
        "moving_obstacles": np.array([[33.0, 5.0, 0.0, 0.5]]),  # 5.3 m past the goal: in
        "map_bounds": np.array([0.0, 0.0, 75.0, 50.0]),
    }
    # corridor max(5, 0.4 x 20) = 8 m: the cylinder 3 m off the line counts, 29 m off not
    np.testing.assert_allclose(video.scene_region(observation, margin=1.0), [9, 3.5, 34.5, 16])
    observation["robot_pose"][:2] = [1.0, 1.0]
    observation["static_obstacles"][0] = [2.0, 1.0, 4.0]  # reaches past the map's corner
    assert video.scene_region(observation, margin=3.0)[:2].tolist() == [-3.0, -3.0]  # map + 3 m
    with pytest.raises(RuntimeError, match="look_at"):
        env = tasks.load("blocked", {})
        env.reset()
        renderer = video.Renderer(env.physics.model.ptr, 64, 48)
        try:
            renderer.render(env.physics, "scene")
        finally:
            renderer.close()


def test_legend_is_drawn_at_the_bottom_left_in_rows_that_fit_the_width():
    env = tasks.load("blocked", {})
    env.reset()
    legend = [((1.0, 0.0, 0.0, 1.0), "plan"), ((0.0, 0.0, 1.0, 1.0), "trail (path driven)")]
    boxes = {}
    for width in (320, 160):
        renderer = video.Renderer(env.physics.model.ptr, width, 180)
        try:
            plain = renderer.render(env.physics, "top")
            with_legend = renderer.render(env.physics, "top", legend=legend)
        finally:
            renderer.close()
        rows, cols = np.nonzero(np.any(plain != with_legend, axis=-1))
        boxes[width] = rows.min(), cols.min(), cols.max()
        assert _pixels(with_legend, (255, 0, 0), 10) > 20  # the colour bars
        assert _pixels(with_legend, (0, 0, 255), 10) > 20
        assert _pixels(with_legend, (255, 255, 255), 10) > _pixels(plain, (255, 255, 255), 10)
    top, left, right = boxes[320]
    assert top > 180 - 40 and left < 10 and right < 320 - 10  # one row at the bottom left
    top, left, right = boxes[160]
    assert top < 180 - 40 and right < 160  # two rows: the labels do not fit one


def test_a_gif_keeps_at_most_its_frame_count_with_the_last_frame():
    """Every stride-th frame and the last: 240 frames at stride 2 would keep 121."""
    for frames in range(1, 3000):
        stride = video.gif_stride(frames)
        kept = set(range(0, frames, stride)) | {frames - 1}
        assert len(kept) == video.gif_frames(frames, stride) <= video.GIF_MAX_FRAMES
        assert stride == 1 or video.gif_frames(frames, stride - 1) > video.GIF_MAX_FRAMES
    assert video.gif_stride(240) == 3


def test_long_episode_gif_is_subsampled_to_a_bounded_frame_count(tmp_path):
    # 40 s of circling (400 steps) at full turn, clear of the obstacle
    env = tasks.load("blocked", {"time_limit": 40.0})
    info = video.render_episode(
        env, lambda ts: [1.0], tmp_path / "long.gif", camera="top", width=160, height=96
    )
    assert info["frames"] == 401 and info["outcome"] == "time_limit"
    assert info["stride"] == video.gif_stride(401) == 4
    meta, frames = frames_of(info["path"])
    assert len(frames) == len(range(0, 401, 4)) <= video.GIF_MAX_FRAMES  # 0, 4, ..., 400
    assert (tmp_path / "long.gif").stat().st_size < 1_000_000


@pytest.mark.parametrize("suffix", [".mp4", ".gif"])
def test_interrupted_video_is_finished_with_the_frames_so_far(tmp_path, suffix):
    path = tmp_path / f"cut{suffix}"
    frame = np.zeros((48, 64, 3), np.uint8)
    with pytest.raises(KeyboardInterrupt):
        with video.VideoWriter(path, 64, 48, 10.0) as writer:
            for i in range(7):
                frame[:, : 8 * i] = 200
                writer.write(frame)
            raise KeyboardInterrupt
    frames = frames_of(path)[1]
    assert len(frames) == 7
    assert frames[-1][:, :40].mean() > 150 and frames[0].mean() < 20


def test_video_path_in_a_file_or_with_a_bad_suffix_is_refused(tmp_path):
    (tmp_path / "notes.txt").write_text("")
    with pytest.raises(ValueError, match="notes.txt is a file, not a folder"):
        video.check_path(tmp_path / "notes.txt" / "sub" / "clip.mp4")
    with pytest.raises(ValueError, match="mp4 or .gif"):
        video.check_path(tmp_path / "clip.webm")
    assert video.check_path(tmp_path / "new" / "clip.GIF").suffix == ".GIF"
