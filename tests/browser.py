"""Headless Chromium for the tests of the HTML pages (test_browser.py) and their screenshots in
docs/images: the system's Chromium (Debian's `chromium`) driven by Playwright for Python.

    python tests/browser.py report/report.html docs/images/report.png
    python tests/browser.py episode.html docs/images/viewer.png --seek 120
"""

import argparse
import contextlib
import importlib.util
import os
import pathlib
import shutil

NAMES = ("chromium", "chromium-browser", "google-chrome")
HOW = (
    "no headless browser: apt-get install chromium (or set DCMPPI_CHROMIUM to a Chromium) and "
    "pip install '.[browser]' (Playwright; no `playwright install` needed)"
)


def executable() -> str | None:
    """The Chromium to drive ($DCMPPI_CHROMIUM, else the first of NAMES on PATH), or None where
    it or Playwright is missing."""
    if importlib.util.find_spec("playwright") is None:
        return None
    found = os.environ.get("DCMPPI_CHROMIUM") or next(filter(None, map(shutil.which, NAMES)), None)
    return found if found and os.access(found, os.X_OK) else None


@contextlib.contextmanager
def chromium():
    """A headless Chromium (Playwright's Browser)."""
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path=executable())
        try:
            yield browser
        finally:
            browser.close()


def open_page(browser, path, errors: list, width=1400, height=900):
    """A new page of `browser` showing the file `path`; console errors and uncaught exceptions
    are appended to `errors`."""
    page = browser.new_page(viewport={"width": width, "height": height})
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(pathlib.Path(path).resolve().as_uri())
    return page


def main() -> None:
    parser = argparse.ArgumentParser(description="a screenshot of an HTML page of dcmppi")
    parser.add_argument("page")
    parser.add_argument("png")
    parser.add_argument("--seek", type=int, help="the viewer's control instant to show")
    parser.add_argument("--width", type=int, default=1280)
    parser.add_argument("--height", type=int, default=800)
    args = parser.parse_args()
    if executable() is None:
        raise SystemExit(HOW)
    errors = []
    with chromium() as browser:
        page = open_page(browser, args.page, errors, args.width, args.height)
        if args.seek is not None:
            page.evaluate(f"viewer.seek({args.seek})")
        page.screenshot(path=args.png)
    if errors:
        raise SystemExit(f"the page logged errors: {errors}")


if __name__ == "__main__":
    main()
