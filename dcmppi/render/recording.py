"""Videos of benchmark episodes with the controller's reasoning drawn in.

        record_episode(Episode(EpisodeSpec("crossing", "dc")), "dc.mp4")              # one episode
    compare([Episode(EpisodeSpec("crossing", c)) for c in ("mppi", "dc")], "cmp.mp4")  # tiled

An episode is any object with `spec`, `env`, `controller`, `time_step`, `done`, `ctrl_s`,
`step()` and `result()` (dcmppi.bench.runner.Episode): this package drives it, never builds it.
Frames go straight to the encoder (memory does not grow with the episode); one renderer per
episode and camera serves all of its frames.
"""

from __future__ import annotations

import sys
import time

import numpy as np

from dcmppi.render import video
from dcmppi.render.overlay import Overlay


class _Tile:
    """One episode, its renderer and its overlay."""

    def __init__(self, episode, width: int, height: int, camera: str, overlay: bool):
        self.episode = episode
        self.camera = camera
        self.renderer = video.Renderer(self.episode.env.physics.model.ptr, width, height)
        self.overlay = Overlay(self.episode.controller) if overlay else None
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
        frame = self.renderer.render(ep.env.physics, self.camera, self.overlay, text)
        if ep.done:
            self.last_frame = frame.copy()
        return frame

    def close(self) -> None:
        self.renderer.close()


def compare(
    episodes: list,
    path,
    camera: str = "top",
    width: int | None = None,
    height: int = 720,
    overlay: bool = True,
    progress: bool = True,
) -> list[dict]:
    """Run `episodes` in lockstep and write their frames side by side into one video.

    Args:
      episodes: episodes just started (dcmppi.bench.runner.Episode), left to right (usually
        one environment, several controllers).
      path: .mp4 or .gif.
      camera: "top" or "chase".
      width, height: size of one tile (default width: 1280 for one tile, else 640).
      overlay: draw rollouts, clusters, plan, trail and obstacle futures.
    Returns:
      the metrics of each episode (as `dcmppi.bench.runner.run_episode`).
    """
    if not episodes:
        raise ValueError("compare needs at least one episode")
    if camera not in video.CAMERAS:
        raise ValueError(f"camera must be one of {video.CAMERAS}, got {camera!r}")
    width = width or (1280 if len(episodes) == 1 else 640)
    tiles = []
    start = time.monotonic()
    try:
        for episode in episodes:
            tiles.append(_Tile(episode, width, height, camera, overlay))
        fps = 1.0 / tiles[0].episode.env.control_timestep()
        with video.VideoWriter(path, width * len(tiles), height, fps) as writer:
            while True:
                writer.write(np.hstack([tile.frame() for tile in tiles]))
                if progress and writer.frames % 50 == 0:
                    _progress(writer.frames, tiles, start)
                if all(tile.episode.done for tile in tiles):
                    break
                for tile in tiles:
                    if not tile.episode.done:
                        tile.episode.step()
        if progress:
            _progress(writer.frames, tiles, start, end="\n")
    finally:
        for tile in tiles:
            tile.close()
    return [tile.episode.result() for tile in tiles]


def record_episode(episode, path, camera: str = "top", **kwargs) -> dict:
    """Run one episode and write its video with the controller overlay; returns its metrics."""
    return compare([episode], path, camera, **kwargs)[0]


def _progress(frames: int, tiles, start: float, end: str = "") -> None:
    sim = max(tile.episode.env.physics.data.time for tile in tiles)
    sys.stderr.write(
        f"\rrendered {frames} frames ({sim:.1f} s simulated) in {time.monotonic() - start:.1f} s"
        + end
    )
    sys.stderr.flush()
