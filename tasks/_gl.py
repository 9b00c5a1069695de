"""Picks MuJoCo's OpenGL backend before MuJoCo is imported (it reads MUJOCO_GL on import)."""

import ctypes.util
import os

# Headless backends in order of preference, with the library each one loads.
HEADLESS = (("egl", "EGL"), ("osmesa", "OSMesa"))

user_choice = os.environ.get("MUJOCO_GL") or None


def choose_backend() -> str:
    """Sets MUJOCO_GL, unless the user set it, to the first headless backend installed.

    Without any, MUJOCO_GL=disable: simulation works, rendering fails with a clear error.
    """
    if os.environ.get("MUJOCO_GL"):
        return os.environ["MUJOCO_GL"]
    backend = next((name for name, lib in HEADLESS if ctypes.util.find_library(lib)), "disable")
    os.environ["MUJOCO_GL"] = backend
    return backend
