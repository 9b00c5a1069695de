"""Test configuration: offscreen rendering through EGL unless the caller chose a backend,
tests/ on sys.path for the helper modules the test files in its subfolders import by name, and
Ctrl-C (SIGINT) handled as at a terminal."""

import os
import pathlib
import signal
import sys

os.environ.setdefault("MUJOCO_GL", "egl")

# The Ctrl-C tests send SIGINT to `dcmppi bench` subprocesses. A test run started in the
# background by a script (`pytest &`) inherits SIGINT ignored, and so would those children:
# they would run on, untested (or, waiting on a sleeping worker, hang).
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

# user_controllers.py, a user's module named in strings ("user_controllers:Straight"): spawned
# workers inherit this sys.path, Ray's get the folder from
# dcmppi.bench.episodes.plugins.import_roots.
TESTS = str(pathlib.Path(__file__).resolve().parent)
if TESTS not in sys.path:
    sys.path.insert(0, TESTS)
