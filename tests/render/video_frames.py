"""Decoding the videos the render tests write."""

import imageio_ffmpeg
import numpy as np


def frames_of(path):
    """Decode a video file: (ffmpeg metadata, list of (height, width, 3) uint8 frames)."""
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    width, height = meta["size"]
    frames = [np.frombuffer(f, np.uint8).reshape(height, width, 3) for f in reader]
    return meta, frames
