"""The report's and the episode viewer's pages in a real browser, headless Chromium (browser.py):
each opens from disk without a console error, the report's tables hold the database's rows,
and the viewer's slider shows the robot where the database's trace puts it."""

import sqlite3
import time

import numpy as np
import pytest
from browser import HOW, chromium, executable, open_page

from dcmppi.bench.episodes.runner import decode_trace
from dcmppi.bench.experiments import Experiment
from dcmppi.bench.reports.report import write_report
from dcmppi.bench.results.database import ResultsDB
from dcmppi.bench.runs.execution import run_experiment
from dcmppi.bench.runs.replay import replay

if executable() is None:
    pytest.skip(HOW, allow_module_level=True)

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def pages(tmp_path_factory):
    """A report (plots inline) and an episode viewer of a small crowd database, and the
    database."""
    folder = tmp_path_factory.mktemp("pages")
    exp = Experiment.from_dict(
        {
            "task": "crowd",
            "noises": ["none", "control"],
            "episodes": 2,
            "base_seed": 1,
            "reference": "mppi",
            "task_params": {"time_limit": 2.0, "n_obstacles": 12},
            "controller_params": {"K": 64, "N": 12},
            "rows": [{"label": c, "controller": c} for c in ("mppi", "dc")],
        },
        "test",
    )
    db = ResultsDB(folder / "r.db", exp.config())
    run_experiment(exp, db, progress=False)
    db.close()
    write_report(folder / "r.db", folder / "report", plots=True)
    assert replay(folder / "r.db", "dc", 1, noise="control", page=folder / "dc.html").reproduced
    return folder


@pytest.fixture(scope="module")
def browser():
    with chromium() as browser:
        yield browser


def test_the_report_opens_quickly_and_its_tables_hold_the_databases_rows(pages, browser):
    errors = []
    start = time.perf_counter()
    page = open_page(browser, pages / "report" / "report.html", errors)  # to its load event
    assert time.perf_counter() - start < 2.0
    with sqlite3.connect(pages / "r.db") as con:
        groups = con.execute("SELECT COUNT(DISTINCT noise || '/' || label) FROM episodes")
        groups = groups.fetchone()[0]
        labels = con.execute("SELECT COUNT(DISTINCT label) FROM episodes").fetchone()[0]
    con.close()
    per_row = ("outcomes", "failures", "metrics", "smoothness", "diagnostics")
    expected = {**dict.fromkeys(per_row, groups), "time": labels}
    rows = page.evaluate(
        "Object.fromEntries([...document.querySelectorAll('table[data-table]')]"
        ".map(t => [t.dataset.table, t.tBodies[0].rows.length]))"
    )
    assert groups == 4 and {k: rows[k] for k in expected} == expected
    assert page.evaluate("[...document.images].every(i => i.complete && i.naturalWidth > 0)")
    assert page.locator("figure img").count() == 3  # the plots, inline
    # a click on a heading sorts by it, a second reverses
    heading = page.locator("table[data-table=outcomes] th", has_text="Goal %")
    column = "[...document.querySelectorAll('table[data-table=outcomes] tbody tr')]"
    column += ".map(r => parseFloat(r.cells[3].textContent))"
    for order in (1, -1):
        heading.click()
        goal = page.evaluate(column)
        assert goal == sorted(goal, key=lambda g: order * g)
    assert not errors


def test_the_viewer_plays_and_its_slider_shows_the_robot_at_the_stored_state(pages, browser):
    errors = []
    page = open_page(browser, pages / "dc.html", errors)
    db = ResultsDB(pages / "r.db")
    trace = decode_trace(db.row("control", "dc", 1)["trace"])
    db.close()
    assert page.evaluate("viewer.frames") == len(trace)
    slider = page.locator("#slider")
    robot = page.evaluate("viewer.robotColour")
    for i in (0, len(trace) // 2, len(trace) - 1):
        slider.fill(str(i))
        assert page.evaluate("viewer.frame()") == i
        assert np.array_equal(np.float32(page.evaluate(f"viewer.pose({i})")), trace[i])
        x, y = page.evaluate(f"viewer.pixel({float(trace[i, 0])}, {float(trace[i, 1])})")
        pixel = page.evaluate(
            f"[...document.getElementById('stage').getContext('2d')"
            f".getImageData({round(x)}, {round(y)}, 1, 1).data].slice(0, 3)"
        )
        assert f"rgb({','.join(map(str, pixel))})" == robot, i  # the robot is drawn there
        assert f"step {i} of {len(trace) - 1}" in page.locator("#clock").inner_text()
    slider.fill("0")
    page.locator("#speed").select_option("1")
    page.locator("#play").click()
    page.wait_for_function("viewer.frame() > 2", timeout=3000)  # it plays
    page.locator("#play").click()
    shown = page.evaluate("viewer.frame()")
    page.wait_for_timeout(300)
    assert page.evaluate("viewer.frame()") == shown < len(trace) - 1  # and pauses
    assert not errors
