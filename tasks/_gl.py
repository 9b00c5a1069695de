"""Picks MuJoCo's OpenGL backend before MuJoCo is imported (it reads MUJOCO_GL on import)."""

import ctypes
import ctypes.util
import os

# Headless backends in order of preference, with the library each one loads and the Debian /
# Ubuntu package that installs it.
HEADLESS = (("egl", "EGL"), ("osmesa", "OSMesa"))
PACKAGES = {"egl": "libegl1", "osmesa": "libosmesa6"}
# the values dm_control accepts (dm_control/_render/__init__.py), lower case
BACKENDS = ("egl", "osmesa", "glfw", "disable", "disabled", "off", "false", "0", "enable",
            "enabled", "on", "true", "1")  # fmt: skip

user_choice = os.environ.get("MUJOCO_GL") or None
# Why the user's MUJOCO_GL cannot render (one line naming the package), or None.
problem = None


def choose_backend() -> str:
    """Sets MUJOCO_GL, unless the user set it, to the first headless backend installed.

    Without any, MUJOCO_GL=disable: simulation works, rendering fails with a clear error. A
    user's egl or osmesa whose library cannot be loaded is also replaced by disable (MuJoCo
    imports the backend's bindings on import, so it would fail every import of MuJoCo, the
    simulation's included) and recorded in `problem` for the renderer's error, as is a value
    that names no backend; the user's value is taken in lower case (EGL: egl).
    """
    global problem
    chosen = os.environ.get("MUJOCO_GL")
    if chosen:
        name = chosen.strip().lower()
        os.environ["MUJOCO_GL"] = name  # dm_control takes lower case only
        library = dict(HEADLESS).get(name)
        if name not in BACKENDS:
            problem = f"MUJOCO_GL={chosen} is no backend: set egl, osmesa, glfw or disable"
            os.environ["MUJOCO_GL"] = "disable"
        elif library is not None and not _loadable(library):
            problem = (
                f"MUJOCO_GL={chosen} needs the {library} library (lib{library}.so), which is "
                f"not installed: apt-get install {PACKAGES[name]} (Debian, Ubuntu), or set "
                "MUJOCO_GL to another backend"
            )
            os.environ["MUJOCO_GL"] = "disable"
        return os.environ["MUJOCO_GL"]
    backend = next((name for name, lib in HEADLESS if ctypes.util.find_library(lib)), "disable")
    os.environ["MUJOCO_GL"] = backend
    return backend


def _loadable(library: str) -> bool:
    """Whether lib<library>.so (or .so.0 ... .so.9) loads, as PyOpenGL looks for it."""
    for suffix in ("", *(f".{i}" for i in range(10))):
        try:
            ctypes.CDLL(f"lib{library}.so{suffix}", mode=ctypes.RTLD_GLOBAL)
        except OSError:
            continue
        return True
    return False
