"""Offscreen videos of episodes: MP4 (H.264) or GIF, top-down or chase camera.

    from dcmppi import tasks, video
    env = tasks.load("forest", task_kwargs={"random": 0})
    info = video.render_episode(env, lambda ts: [0.0], "forest.mp4", camera="top")

One GL context and one MuJoCo scene serve all frames, and each frame goes straight to an
ffmpeg pipe, so memory does not grow with the episode. The backend comes from MUJOCO_GL; if it
is unset, the first of egl, osmesa whose library is installed (set before MuJoCo is imported).
This is the only dcmppi module that imports MuJoCo; `import dcmppi` does not import it.
"""

import importlib
import os
import pathlib

from dcmppi.tasks import _gl

_gl.choose_backend()

import imageio_ffmpeg  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402

CAMERAS = ("top", "chase")
_CAMERA_IN_MODEL = {"top": "top", "chase": "robot/chase"}  # the chase camera rides the robot
_OFFSCREEN_BACKENDS = ("egl", "osmesa", "glfw")


class RenderError(RuntimeError):
    """No working OpenGL backend for offscreen rendering."""


def render_episode(
    env, policy, path, camera="top", width=1280, height=720, fps=None, decorate=None, max_steps=None
) -> dict:
    """Runs one episode of `env` under `policy` and writes every frame to `path`.

    Args:
      env: a dcmppi task Environment (see `dcmppi.tasks.load`); it is reset first.
      policy: callable(time_step) -> action.
      path: output file; ".mp4" (H.264) or ".gif".
      camera: "top" (whole map) or "chase" (behind the robot).
      width, height: frame size in pixels (even numbers, at most the model's offscreen buffer,
        1920 x 1080).
      fps: frames per second; default real time (1 / control timestep).
      decorate: optional callable(scene, physics) run after the scene is built and before it
        is drawn, to add geoms to the mujoco.MjvScene (see `add_geom`, `add_polyline`; both
        respect scene.maxgeom).
      max_steps: stop after this many steps even if the episode has not ended.

    Returns:
      dict with path, frames (steps + 1, the reset frame included), steps, width, height, fps,
      camera, outcome and min_clearance of the task.
    """
    if camera not in CAMERAS:
        raise ValueError(f"camera must be one of {CAMERAS}, got {camera!r}")
    physics = env.physics
    fps = 1.0 / env.control_timestep() if fps is None else float(fps)
    frames = steps = 0
    with VideoWriter(path, width, height, fps) as writer:
        renderer = Renderer(physics.model.ptr, width, height)
        try:
            time_step = env.reset()
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
        steps=steps,
        width=width,
        height=height,
        fps=fps,
        camera=camera,
        outcome=getattr(task, "outcome", None),
        min_clearance=getattr(task, "min_clearance", None),
    )


class VideoWriter:
    """Frames (height, width, 3) uint8 piped straight into ffmpeg: MP4 (H.264) or GIF.

    Use as a context manager; nothing is buffered, so memory does not grow with the video.
    """

    def __init__(self, path, width, height, fps):
        path = pathlib.Path(path)
        suffix = path.suffix.lower()
        if suffix not in (".mp4", ".gif"):
            raise ValueError(f"path must end in .mp4 or .gif, got {path.name!r}")
        if width <= 0 or height <= 0 or width % 2 or height % 2:
            raise ValueError(
                f"width and height must be positive even numbers, got {width}x{height}"
            )
        if fps <= 0:
            raise ValueError(f"fps must be > 0, got {fps}")
        path.parent.mkdir(parents=True, exist_ok=True)
        if suffix == ".gif":
            codec = dict(codec="gif", pix_fmt_out="rgb8", quality=None)
        else:
            codec = dict(codec="libx264", pix_fmt_out="yuv420p", quality=7,
                         output_params=["-preset", "veryfast"])  # fmt: skip
        self.path, self.frames = path, 0
        self._writer = imageio_ffmpeg.write_frames(
            str(path), (width, height), fps=fps, macro_block_size=1, ffmpeg_log_level="error",
            **codec,
        )  # fmt: skip
        self._writer.send(None)

    def write(self, frame: np.ndarray) -> None:
        self._writer.send(frame)
        self.frames += 1

    def close(self) -> None:
        self._writer.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class Renderer:
    """Offscreen renderer: one GL context, one MjrContext and one MjvScene for many frames."""

    def __init__(self, model, width, height, max_geom=20000):
        buffer = model.vis.global_.offwidth, model.vis.global_.offheight
        if width > buffer[0] or height > buffer[1]:
            raise ValueError(
                f"frame {width}x{height} exceeds the model's offscreen buffer "
                f"{buffer[0]}x{buffer[1]}"
            )
        self._model = model
        self._context, self._mjr = _make_context(model, width, height)
        self.scene = mujoco.MjvScene(model, maxgeom=max_geom)
        self._option = mujoco.MjvOption()
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FIXED
        self._rect = mujoco.MjrRect(0, 0, width, height)
        self._pixels = np.empty((height, width, 3), dtype=np.uint8)

    def render(self, physics, camera="top", decorate=None, text=None) -> np.ndarray:
        """The current frame (height, width, 3) uint8 from the named camera.

        text: optional (left column, right column) strings drawn at the top left, with
        lines separated by newlines.
        """
        self._context.make_current()
        self._camera.fixedcamid = self._model.camera(_CAMERA_IN_MODEL.get(camera, camera)).id
        mujoco.mjv_updateScene(
            self._model,
            physics.data.ptr,
            self._option,
            None,
            self._camera,
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
        mujoco.mjr_readPixels(self._pixels, None, self._rect, self._mjr)
        return np.ascontiguousarray(self._pixels[::-1])

    def close(self):
        if self._mjr is not None:
            self._mjr.free()
            self._context.free()
            self._mjr = None


def _make_context(model, width, height):
    """A current GL context and MjrContext, from MUJOCO_GL or a headless fallback."""
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
            mjr = mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_150)
            mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, mjr)
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
