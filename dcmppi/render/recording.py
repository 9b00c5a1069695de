"""Videos of benchmark episodes with the controller's reasoning drawn in.

        record_episode(Episode(EpisodeSpec("crossing", "dc")), "dc.mp4")              # one episode
    compare([Episode(EpisodeSpec("crossing", c)) for c in ("mppi", "dc")], "cmp.mp4")  # tiled

Each tile shows the controller, step, time, noise and outcome at the top left and, with the
overlay, a colour legend of the overlay's lines at the bottom left.

An episode is any object with `spec`, `env`, `controller`, `time_step`, `done`, `ctrl_s`,
`step()` and `result()` (dcmppi.bench.episodes.runner.Episode): this package drives it, never
builds it. Frames go straight to the encoder (memory does not grow with the episode); one renderer
per episode and camera serves all of its frames.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from dcmppi.render import video
from dcmppi.render.overlay import Overlay


class _Tile:
    """One episode, its renderer and its overlay."""

    def __init__(self, episode, width, height, camera: str, overlay: bool, legend: bool):
        self.episode = episode
        self.camera = camera
        self.renderer = video.Renderer(self.episode.env.physics.model.ptr, width, height)
        if camera == "scene":
            self.renderer.look_at(video.scene_region(episode.time_step.observation))
        self.overlay = Overlay(self.episode.controller) if overlay else None
        self.legend = legend and overlay
        self.last_frame = None

    def frame(self) -> np.ndarray:
        """The current frame; after the episode ended, its last frame."""
        ep = self.episode
        if self.last_frame is not None:
            return self.last_frame
        if self.overlay is not None:
            self.overlay.record(ep.time_step.observation["robot_pose"])
        t = ep.env.physics.data.time
        outcome = ep.env.task.outcome or "running"
        text = (
            f"{ep.spec.controller}\nstep\ntime\nnoise\noutcome",
            f"\n{len(ep.ctrl_s)}\n{t:.1f} s\n{ep.spec.noise}\n{outcome}",
        )
        legend = self.overlay.legend() if self.legend else None
        frame = self.renderer.render(ep.env.physics, self.camera, self.overlay, text, legend)
        if ep.done:
            self.last_frame = frame.copy()
        return frame

    def close(self) -> None:
        self.renderer.close()


def compare(
    episodes: list,
    path,
    camera: str = "scene",
    width: int | None = None,
    height: int | None = None,
    overlay: bool = True,
    legend: bool = True,
    progress: bool = True,
) -> list[dict]:
    """Run `episodes` in lockstep and write their frames side by side into one video.

    Args:
      episodes: episodes just started (dcmppi.bench.episodes.runner.Episode), left to right (usually
        one environment, several controllers).
      path: .mp4 (every frame) or .gif (at most video.GIF_MAX_FRAMES frames, see
        video.VideoWriter).
      camera: "scene" (start, goal and the obstacles between), "top" (whole map) or "chase".
      width, height: size of one tile; defaults (`tile_size`) 1280 x 720 for one MP4 tile,
        640 x 480 for several; a GIF's are smaller: 480 x 270, or 320 x 240.
      overlay: draw rollouts, clusters, plan, trail and obstacle futures.
      legend: with the overlay, a colour legend at the bottom left of each tile.
    Returns:
      the metrics of each episode (as `dcmppi.bench.episodes.runner.run_episode`).
    Raises:
      KeyboardInterrupt: on Ctrl-C, after finishing the video of the frames so far; its
        message says what the file holds.
    """
    if not episodes:
        raise ValueError("compare needs at least one episode")
    video.check_camera(camera)
    path = video.check_path(path)
    default_w, default_h = tile_size(len(episodes), path.suffix.lower() == ".gif")
    width, height = width or default_w, height or default_h
    tiles, writer = [], None
    start = time.monotonic()
    try:
        for episode in episodes:
            tiles.append(_Tile(episode, width, height, camera, overlay, legend))
        fps = 1.0 / tiles[0].episode.env.control_timestep()
        with video.VideoWriter(path, width * len(tiles), height, fps) as writer:
            _lockstep(tiles, writer, progress, start)
        if progress:
            _progress(writer.frames, tiles, start, end="\n")
    except KeyboardInterrupt:
        raise _interrupted(writer, path, progress) from None
    finally:
        for tile in tiles:
            tile.close()
    return [tile.episode.result() for tile in tiles]


def _lockstep(tiles, writer, progress: bool, start: float) -> None:
    """Writes the tiles' frames side by side, then steps each episode not done, until all are
    done; with progress, a progress line every 50 frames (start: time.monotonic() at the
    start)."""
    while True:
        writer.write(np.hstack([tile.frame() for tile in tiles]))
        if progress and writer.frames % 50 == 0:
            _progress(writer.frames, tiles, start)
        if all(tile.episode.done for tile in tiles):
            return
        for tile in tiles:
            if not tile.episode.done:
                tile.episode.step()


def _interrupted(writer, path, progress: bool) -> KeyboardInterrupt:
    """The KeyboardInterrupt for Ctrl-C during `compare`: its message says what `path` holds
    (writer: the video.VideoWriter, None before it opened); ends the progress line."""
    if progress and writer is not None and writer.frames >= 50:
        sys.stderr.write("\n")
    kept = writer is not None and writer.frames and path.exists()
    return KeyboardInterrupt(
        f"the video so far ({writer.frames} frames) is in {path}"
        if kept
        else f"no video written to {path}"
    )


def tile_size(tiles: int, gif: bool) -> tuple[int, int]:
    """Default (width, height) of one tile of a video of `tiles` tiles."""
    if gif:
        return (480, 270) if tiles == 1 else (320, 240)
    return (1280, 720) if tiles == 1 else (640, 480)


def record_episode(episode, path, camera: str = "scene", **kwargs) -> dict:
    """Run one episode and write its video with the controller overlay; returns its metrics."""
    return compare([episode], path, camera, **kwargs)[0]


def _progress(frames: int, tiles, start: float, end: str = "") -> None:
    sim = max(tile.episode.env.physics.data.time for tile in tiles)
    sys.stderr.write(
        f"\rrendered {frames} frames ({sim:.1f} s simulated) in {time.monotonic() - start:.1f} s"
        + end
    )
    sys.stderr.flush()
