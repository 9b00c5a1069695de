"""Test configuration: offscreen rendering through EGL unless the caller chose a backend."""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
