"""Test configuration: offscreen rendering through EGL unless the caller chose a backend,
tests/ on sys.path for the helper modules the test files in its subfolders import by name,
Ctrl-C (SIGINT) handled as at a terminal, and `--slow-audit` (SlowAudit)."""

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


def pytest_addoption(parser):
    parser.addoption(
        "--slow-audit",
        type=float,
        nargs="?",
        const=1.0,
        default=None,
        metavar="SECONDS",
        help="list the tests not marked slow that took over SECONDS (1 s) with setup and "
        "teardown: candidates for @pytest.mark.slow, which keeps `pytest -m 'not slow'` quick",
    )


def pytest_configure(config):
    budget = config.getoption("--slow-audit")
    if budget is not None:
        config.pluginmanager.register(SlowAudit(budget), "slow-audit")


class SlowAudit:
    """`--slow-audit`: the seconds of every test not marked slow, and those over the budget."""

    def __init__(self, budget):
        self.budget, self.quick, self.seconds = budget, set(), {}

    def pytest_collection_modifyitems(self, items):
        self.quick = {item.nodeid for item in items if item.get_closest_marker("slow") is None}

    def pytest_runtest_logreport(self, report):
        if report.nodeid in self.quick:
            self.seconds[report.nodeid] = self.seconds.get(report.nodeid, 0.0) + report.duration

    def pytest_terminal_summary(self, terminalreporter):
        over = sorted(((s, n) for n, s in self.seconds.items() if s > self.budget), reverse=True)
        total = sum(self.seconds.values())
        terminalreporter.write_sep(
            "=", f"{len(over)} of {len(self.seconds)} tests not marked slow over {self.budget:g} s"
        )
        for seconds, nodeid in over:
            terminalreporter.write_line(f"{seconds:6.2f}s {nodeid}")
        terminalreporter.write_line(f"the tests not marked slow took {total:.1f} s in all")
