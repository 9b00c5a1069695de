"""Test configuration: offscreen rendering through EGL unless the caller chose a backend, and
tests/ on sys.path for the helper modules the test files in its subfolders import by name."""

import os
import pathlib
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

# user_controllers.py, a user's module named in strings ("user_controllers:Straight"): spawned
# workers inherit this sys.path, Ray's get the folder from dcmppi.bench.plugins.import_roots.
TESTS = str(pathlib.Path(__file__).resolve().parent)
if TESTS not in sys.path:
    sys.path.insert(0, TESTS)
