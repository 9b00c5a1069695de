"""Offscreen videos of episodes: MP4 (H.264) or GIF, from three cameras.

    from dcmppi import tasks
    from dcmppi.render import video
    env = tasks.load("forest", task_kwargs={"random": 0})
    info = video.render_episode(env, lambda ts: [0.0], "forest.mp4", camera="scene")

Cameras: "scene" looks straight down at the region of the start, the goal and the obstacles
near the line between them (`scene_region`, fixed per episode); "top" shows the whole map;
"chase" rides behind the robot.

One GL context and one MuJoCo scene serve all frames, and each frame goes straight to an
ffmpeg pipe, so memory does not grow with the episode. A GIF keeps at most GIF_MAX_FRAMES
frames (see `VideoWriter`); an MP4 keeps every frame. The backend comes from MUJOCO_GL; if it
is unset, the first of egl, osmesa whose library is installed (set before MuJoCo is imported).
MuJoCo is imported here and by the tasks (dcmppi.tasks.physics), never by
`import dcmppi` or dcmppi.control.
"""

import atexit
import importlib
import math
import os
import pathlib
import subprocess
import tempfile
import weakref

from dcmppi.render import CAMERAS
from dcmppi.render.files import writable
from dcmppi.tasks import _gl

_gl.choose_backend()

import imageio_ffmpeg  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

_CAMERA_IN_MODEL = {"top": "top", "chase": "robot/chase"}  # the chase camera rides the robot
SCENE_MARGIN = 3.0  # [m] around what the scene camera frames
SCENE_CORRIDOR = (5.0, 0.4)  # obstacles within max(5 m, 0.4 x start-goal distance) of the line
GIF_MAX_FRAMES = 120  # a GIF keeps every gif_stride(frames)-th frame and the last, 120 at most
_OFFSCREEN_BACKENDS = ("egl", "osmesa", "glfw")


class RenderError(RuntimeError):
    """No working OpenGL backend for offscreen rendering."""


def render_episode(
    env, policy, path, camera="scene", width=1280, height=720, fps=None, decorate=None,
    max_steps=None,
) -> dict:  # fmt: skip
    """Runs one episode of `env` under `policy` and writes every frame to `path`.

    Args:
      env: a dcmppi task Environment (see `dcmppi.tasks.load`); it is reset first.
      policy: callable(time_step) -> action.
      path: output file; ".mp4" (H.264, every frame) or ".gif" (subsampled, see VideoWriter).
      camera: "scene" (start, goal and the obstacles between), "top" (whole map) or "chase"
        (behind the robot).
      width, height: frame size in pixels (even numbers, at most the model's offscreen buffer,
        1920 x 1080).
      fps: frames per second; default real time (1 / control timestep).
      decorate: optional callable(scene, physics) run after the scene is built and before it
        is drawn, to add geoms to the mujoco.MjvScene (see `add_geom`, `add_polyline`; both
        respect scene.maxgeom).
      max_steps: stop after this many steps even if the episode has not ended.

    Returns:
      dict with path, frames (steps + 1, the reset frame included: the frames rendered; a GIF
      holds every `stride`-th of them), stride, steps, width, height, fps, camera, outcome and
      min_clearance of the task.
    """
    check_camera(camera)
    physics = env.physics
    fps = 1.0 / env.control_timestep() if fps is None else float(fps)
    frames = steps = 0
    with VideoWriter(path, width, height, fps) as writer:
        renderer = Renderer(physics.model.ptr, width, height)
        try:
            time_step = env.reset()
            if camera == "scene":
                renderer.look_at(scene_region(time_step.observation))
            while True:
                writer.write(renderer.render(physics, camera, decorate))
                frames += 1
                if time_step.last() or (max_steps is not None and steps >= max_steps):
                    break
                time_step = env.step(policy(time_step))
                steps += 1
        finally:
            renderer.close()
    task = env.task
    return dict(
        path=str(path),
        frames=frames,
        stride=writer.stride,
        steps=steps,
        width=width,
        height=height,
        fps=fps,
        camera=camera,
        outcome=getattr(task, "outcome", None),
        min_clearance=getattr(task, "min_clearance", None),
    )


def check_camera(camera: str) -> None:
    """ValueError unless `camera` is one of CAMERAS."""
    if camera not in CAMERAS:
        raise ValueError(f"camera must be one of {', '.join(CAMERAS)}; got {camera!r}")


def check_path(path) -> pathlib.Path:
    """The video path, or a ValueError naming what is wrong with it (suffix, parent a file, a
    folder or file that cannot be written), before an episode is run for it."""
    return writable(path, (".mp4", ".gif"), "video")


def gif_stride(frames: int) -> int:
    """Every how many frames a GIF of `frames` frames keeps one (and the last) so that it
    keeps at most GIF_MAX_FRAMES."""
    stride = max(1, math.ceil(frames / GIF_MAX_FRAMES))
    while gif_frames(frames, stride) > GIF_MAX_FRAMES:
        stride += 1
    return stride


def gif_frames(frames: int, stride: int) -> int:
    """The frames a GIF keeps of `frames`: every stride-th from the first, and the last."""
    return math.ceil(frames / stride) + ((frames - 1) % stride != 0) if frames else 0


class VideoWriter:
    """Frames (height, width, 3) uint8 piped straight into ffmpeg: MP4 (H.264) or GIF.

    MP4 keeps every frame at `fps`. A GIF keeps every `stride`-th frame and the last one, with
    stride = gif_stride(frames) (about frames / GIF_MAX_FRAMES), played at `fps`: a long
    episode plays `stride` times faster than real time and its GIF keeps at most
    GIF_MAX_FRAMES (about 3 MB at 480 x 270 for the crowd with the overlay). Since the length
    is known only at the end, the frames go to a temporary MP4 first, which `close()` converts
    (ffmpeg with a palette made for the clip) and deletes.

    Use as a context manager; nothing is buffered, so memory does not grow with the video.
    If the block is interrupted (Ctrl-C) or fails, the file is still finished: a playable
    video of the frames written so far. `frames` counts frames written, `stride` is set
    when the video is finished.
    """

    def __init__(self, path, width, height, fps):
        path = check_path(path)
        if width <= 0 or height <= 0 or width % 2 or height % 2:
            raise ValueError(
                f"width and height must be positive even numbers, got {width}x{height}"
            )
        if fps <= 0:
            raise ValueError(f"fps must be > 0, got {fps}")
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path, self.fps, self.frames, self.stride = path, float(fps), 0, 1
        self._broken = False
        self._gif = path.suffix.lower() == ".gif"
        target = path
        if self._gif:  # lossless-ish 4:4:4 intermediate, converted in close()
            handle, name = tempfile.mkstemp(suffix=".mp4", prefix="dcmppi-gif-")
            os.close(handle)
            target = self._temp = pathlib.Path(name)
            codec = dict(codec="libx264", pix_fmt_out="yuv444p", quality=9)
        else:
            codec = dict(codec="libx264", pix_fmt_out="yuv420p", quality=7)
        self._writer = imageio_ffmpeg.write_frames(
            str(target), (width, height), fps=fps, macro_block_size=1, ffmpeg_log_level="error",
            output_params=["-preset", "veryfast"], **codec,
        )  # fmt: skip
        self._writer.send(None)

    def write(self, frame: np.ndarray) -> None:
        try:
            self._writer.send(frame)
        except OSError as e:  # ffmpeg ended (a full disk, a folder gone): one line
            self._broken = True
            raise RuntimeError(
                f"ffmpeg stopped writing the video {self.path} ({type(e).__name__}: "
                f"{e.strerror or e}); check the folder and its free space"
            ) from None
        except BaseException:
            self._broken = True  # ffmpeg was stopped mid-frame: its file is unusable
            raise
        self.frames += 1

    def close(self) -> None:
        """Finish the file (idempotent); a GIF is made from the frames written. A file that
        ffmpeg could not finish (stopped in the middle of a frame), or one of no frame (not a
        video), is removed."""
        if self._writer is None:
            return
        writer, self._writer = self._writer, None
        writer.close()
        if self._broken or not self.frames:
            self.path.unlink(missing_ok=True)
        if self._gif:
            try:
                if self.frames and not self._broken:
                    self._to_gif()
            finally:
                self._temp.unlink(missing_ok=True)

    def _to_gif(self) -> None:
        self.stride = gif_stride(self.frames)
        last = self.frames - 1
        keep = f"select='not(mod(n\\,{self.stride}))+eq(n\\,{last})',setpts=N/({self.fps}*TB)"
        palette = "split[a][b];[a]palettegen[p];[b][p]paletteuse=dither=bayer"
        command = [
            imageio_ffmpeg.get_ffmpeg_exe(), "-y", "-v", "error", "-i", str(self._temp),
            "-vf", f"{keep},{palette}", "-r", f"{self.fps}", str(self.path),
        ]  # fmt: skip
        try:
            subprocess.run(command, check=True, capture_output=True)
        except BaseException as e:
            self.path.unlink(missing_ok=True)  # no half-written GIF
            if isinstance(e, subprocess.CalledProcessError):
                raise RuntimeError(
                    f"ffmpeg could not write {self.path}: {e.stderr.decode().strip()}"
                ) from None
            raise

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def scene_region(observation, margin: float = SCENE_MARGIN) -> np.ndarray:
    """What the "scene" camera frames: (4,) xmin, ymin, xmax, ymax.

    The box around the robot (its pose in `observation`, usually the episode's first), the
    goal and every obstacle, static or moving (where it is now), whose surface comes within
    max(5 m, 0.4 x the start-goal distance) of the segment between them; grown by `margin`
    and cut to the map (plus `margin`). observation: a task observation (dcmppi.tasks).
    """
    start = np.asarray(observation["robot_pose"], dtype=float)[:2]
    goal = np.asarray(observation["goal"], dtype=float)
    static = np.asarray(observation["static_obstacles"], dtype=float).reshape(-1, 3)
    moving = np.asarray(observation["moving_obstacles"], dtype=float).reshape(-1, 4)
    cylinders = np.vstack([static[static[:, 2] > 0], moving[:, [0, 1, 3]]])
    line = goal - start
    length = float(np.hypot(*line))
    t = np.clip((cylinders[:, :2] - start) @ line / max(length**2, 1e-12), 0.0, 1.0)
    gap = np.linalg.norm(cylinders[:, :2] - (start + t[:, None] * line), axis=1) - cylinders[:, 2]
    near = cylinders[gap <= max(SCENE_CORRIDOR[0], SCENE_CORRIDOR[1] * length)]
    points = np.vstack([start, goal, near[:, :2] - near[:, 2:], near[:, :2] + near[:, 2:]])
    bounds = np.asarray(observation["map_bounds"], dtype=float)
    lo = np.maximum(points.min(axis=0) - margin, bounds[:2] - margin)
    hi = np.minimum(points.max(axis=0) + margin, bounds[2:] + margin)
    return np.concatenate([lo, hi])


class Renderer:
    """Offscreen renderer: one GL context, one MjrContext and one MjvScene for many frames.

    The "scene" camera is a free MuJoCo camera looking straight down; `look_at(region)` aims
    it (once per episode) before frames are rendered from it.
    """

    def __init__(self, model, width, height, max_geom=20000):
        buffer = model.vis.global_.offwidth, model.vis.global_.offheight
        if not (width >= 1 and height >= 1):
            raise ValueError(f"frame {width}x{height}: width and height must be at least 1 pixel")
        if width > buffer[0] or height > buffer[1]:
            raise ValueError(
                f"frame {width}x{height} exceeds the model's offscreen buffer "
                f"{buffer[0]}x{buffer[1]}"
            )
        self._model = model
        font = mujoco.mjtFontScale(_font_scale(height))
        self._context, self._mjr = _make_context(model, width, height, font)
        _open_renderers.add(self)
        self.scene = mujoco.MjvScene(model, maxgeom=max_geom)
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._scene_camera = None
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._pixels = np.empty((height, width, 3), dtype=np.uint8)

    def look_at(self, region) -> None:
        """Aim the "scene" camera straight down at region (4,) xmin, ymin, xmax, ymax, from
        the height at which all of it fits the frame (x to the right, y up)."""
        xmin, ymin, xmax, ymax = np.asarray(region, dtype=float)
        if not (xmax > xmin and ymax > ymin):
            raise ValueError(f"region must have xmin < xmax and ymin < ymax, got {region}")
        half = np.tan(np.deg2rad(self._model.vis.global_.fovy) / 2.0)
        aspect = self._rect.width / self._rect.height
        camera = mujoco.MjvCamera()
        camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        camera.lookat[:] = [0.5 * (xmin + xmax), 0.5 * (ymin + ymax), 0.0]
        camera.distance = max(ymax - ymin, (xmax - xmin) / aspect) / (2.0 * half)
        camera.azimuth, camera.elevation = 90.0, -90.0
        self._scene_camera = camera

    def render(self, physics, camera="top", decorate=None, text=None, legend=None) -> np.ndarray:
        """The current frame (height, width, 3) uint8 from the named camera (CAMERAS, or any
        camera of the model by name).

        text: optional (left column, right column) strings drawn at the top left, with
          lines separated by newlines.
        legend: optional [(rgba, label)] drawn at the bottom left, a colour bar per label
          (rows of them, as many as the frame's width needs).
        """
        self._context.make_current()
        if camera == "scene":
            if self._scene_camera is None:
                raise RuntimeError("the scene camera needs look_at(region) first")
            view = self._scene_camera
        else:
            if camera == "top" and hasattr(physics, "fit_top_camera"):  # the whole map
                physics.fit_top_camera(self._rect.width, self._rect.height)
            self._camera.fixedcamid = self._model.camera(_CAMERA_IN_MODEL.get(camera, camera)).id
            view = self._camera
        mujoco.mjv_updateScene(
            self._model,
            physics.data.ptr,
            self._option,
            None,
            view,
            mujoco.mjtCatBit.mjCAT_ALL,
            self.scene,
        )
        if decorate is not None:
            decorate(self.scene, physics)
        mujoco.mjr_render(self._rect, self.scene, self._mjr)
        if text is not None:
            mujoco.mjr_overlay(
                mujoco.mjtFont.mjFONT_NORMAL, mujoco.mjtGridPos.mjGRID_TOPLEFT, self._rect,
                text[0], text[1], self._mjr,
            )  # fmt: skip
        if legend:
            self._legend(legend)
        mujoco.mjr_readPixels(self._pixels, None, self._rect, self._mjr)
        return np.ascontiguousarray(self._pixels[::-1])

    def _legend(self, entries) -> None:
        """A translucent box at the bottom left: a colour bar and a white label per entry,
        left to right, in as many rows as the frame's width needs."""
        con, pad = self._mjr, 5
        h = con.charHeight
        bar = 3 * h // 2
        rows, width = [[]], 0
        for rgba, label in entries:
            w = bar + pad + sum(con.charWidth[ord(c)] for c in label)
            if rows[-1] and width + w + 2 * pad > self._rect.width - 2 * pad:
                rows.append([])
                width = 0
            rows[-1].append((rgba, label, w))
            width += w + 2 * pad
        box_w = pad + max(sum(w + 2 * pad for *_, w in row) for row in rows)
        box_h = pad + len(rows) * (h + pad)
        mujoco.mjr_rectangle(mujoco.MjrRect(pad, pad, box_w, box_h), 0, 0, 0, 0.55)
        for k, row in enumerate(rows):
            x, y = 2 * pad, pad + box_h - (k + 1) * (h + pad)
            for rgba, label, w in row:
                r, g, b = rgba[:3]
                mujoco.mjr_rectangle(mujoco.MjrRect(x, y + h // 3, bar, max(2, h // 3)), r, g, b, 1)
                cell = mujoco.MjrRect(x + bar + pad, y, w - bar, h)
                mujoco.mjr_rectangle(cell, 0, 0, 0, 0)  # sets the viewport mjr_text draws into
                mujoco.mjr_text(mujoco.mjtFont.mjFONT_NORMAL, label, con, 0.0, 0.2, 1, 1, 1)
                x += w + 2 * pad

    def close(self):
        if self._mjr is not None:
            self._mjr.free()
            self._context.free()
            self._mjr = None


# Renderers never closed are closed at exit, before the GL backend shuts down (its atexit
# hook, registered when the first context is made, runs after ours: atexit is LIFO).
_open_renderers = weakref.WeakSet()


def _close_open_renderers() -> None:
    for renderer in list(_open_renderers):
        renderer.close()


def _font_scale(height: int) -> int:
    """MuJoCo's font scale (%) for frames `height` pixels tall: 150 at 720, in steps of 50."""
    return int(np.clip(round(height / 720 * 150 / 50) * 50, 50, 300))


def _make_context(model, width, height, font):
    """A current GL context and MjrContext (font: a mjtFontScale), from MUJOCO_GL or a
    headless fallback."""
    if _gl.problem is not None:  # the user's backend has no library (see _gl.choose_backend)
        raise RenderError(f"offscreen rendering failed: {_gl.problem}")
    backend = os.environ.get("MUJOCO_GL", "")
    tried = [backend]
    if _gl.user_choice is None:  # we picked the backend, so we may try the others
        tried += [name for name, _ in _gl.HEADLESS if name != backend]
    errors = []
    for name in tried:
        if name not in _OFFSCREEN_BACKENDS:
            errors.append(f"MUJOCO_GL={name!r} is not an offscreen backend")
            continue
        try:
            context = importlib.import_module(f"mujoco.{name}").GLContext(width, height)
            context.make_current()
            mjr = mujoco.MjrContext(model, font)
            mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, mjr)
            atexit.unregister(_close_open_renderers)
            atexit.register(_close_open_renderers)  # after the backend's hook
            return context, mjr
        except Exception as e:  # noqa: BLE001 - any backend failure is reported below
            errors.append(f"MUJOCO_GL={name}: {type(e).__name__}: {e}")
    raise RenderError(
        "offscreen rendering failed: " + "; ".join(errors) + ". Fix: install the backend's "
        "library (EGL: apt-get install libegl1; OSMesa: apt-get install libosmesa6) or set "
        "MUJOCO_GL to a working backend (egl, osmesa, glfw) before starting Python."
    )


def add_geom(scene, geom_type, size, pos, rgba, mat=None) -> bool:
    """Appends a decorative geom to `scene`; False (and nothing added) when it is full.

    geom_type: a mujoco.mjtGeom; size (3,), pos (3,), rgba (4,), mat (9,) rotation (default I).
    """
    if scene.ngeom >= scene.maxgeom:
        return False
    mat = np.eye(3).ravel() if mat is None else np.asarray(mat, dtype=np.float64).ravel()
    geom = scene.geoms[scene.ngeom]
    mujoco.mjv_initGeom(
        geom,
        geom_type,
        np.asarray(size, dtype=np.float64),
        np.asarray(pos, dtype=np.float64),
        mat,
        np.asarray(rgba, dtype=np.float32),
    )
    geom.category = mujoco.mjtCatBit.mjCAT_DECOR
    scene.ngeom += 1
    return True


def add_polyline(scene, points, rgba, width=0.05, z=0.05, line=False) -> int:
    """Draws consecutive points (n, 2) or (n, 3) as capsules; returns how many segments fit.

    2-D points are drawn at height z. Stops silently when scene.maxgeom is reached.
    line: draw GL lines `width` pixels wide instead of capsules `width` metres wide; many
    times cheaper to render, for dense overlays such as sampled rollouts.
    """
    points = np.asarray(points, dtype=np.float64)
    if points.shape[-1] == 2:
        points = np.column_stack([points, np.full(len(points), z)])
    kind = mujoco.mjtGeom.mjGEOM_LINE if line else mujoco.mjtGeom.mjGEOM_CAPSULE
    rgba = np.asarray(rgba, dtype=np.float32)
    zeros, eye = np.zeros(3), np.eye(3).ravel()
    drawn = 0
    for a, b in zip(points[:-1], points[1:], strict=True):
        if scene.ngeom >= scene.maxgeom:
            break
        geom = scene.geoms[scene.ngeom]
        mujoco.mjv_initGeom(geom, kind, zeros, zeros, eye, rgba)
        mujoco.mjv_connector(geom, kind, width, a, b)
        geom.category = mujoco.mjtCatBit.mjCAT_DECOR
        scene.ngeom += 1
        drawn += 1
    return drawn
