"""report.html: the report as one page that opens from disk, no server and no network
(dcmppi.render.html): report.md's tables, sortable, with their intervals, its notes and
provenance, the plots inline, each row's failures linked to their episode viewers, and the
gallery's GIFs beside their rows (files in gallery/ beside the page).
"""

from __future__ import annotations

from pathlib import Path

from dcmppi.render.html import Table, blocks, data_uri, page

FAILURES_NOTE = (
    "Each row's failed episodes by environment index and outcome; those the gallery replayed "
    "(`dcmppi report --gallery N`) link to their episode viewer. The viewer of any episode: "
    "`dcmppi replay --db {db} --noise NOISE --label ROW --env INDEX --html episode.html`."
)


def replay_cells(clips: dict) -> dict:
    """{(noise, label): cell}: the gallery's GIFs of a row, each linked to its episode viewer.
    clips: dcmppi.bench.runs.replay.gallery's."""
    return {
        key: " ".join(
            f"[![env {index}: {outcome}]({gif})]({viewer})"
            for index, outcome, gif, viewer in entries
        )
        for key, entries in clips.items()
    }


def failures_table(rows: list[dict], order: list[tuple[str, str]], clips: dict | None) -> Table:
    """The failures (finished, not at the goal) of each (noise, label) of `order`, in the order
    of their environments, each linked to its episode viewer where `clips` (the gallery's, or
    None) holds one."""
    viewers = {
        (*key, index): viewer
        for key, entries in (clips or {}).items()
        for index, _, _, viewer in entries
    }
    failed = {}
    for r in sorted(rows, key=lambda r: r["env_index"]):
        if r["status"] == "ok" and r["outcome"] != "goal":
            failed.setdefault((r["noise"], r["label"]), []).append(r)
    lines = []
    for key in order:
        cells = []
        for r in failed.get(key, []):
            text = f"{r['env_index']} ({r['outcome']})"
            viewer = viewers.get((*key, r["env_index"]))
            cells.append(f"[{text}]({viewer})" if viewer else text)
        lines.append([*key, str(len(cells)), ", ".join(cells)])
    head = ["Noise", "Row", "Failures", "Environments (outcome)"]
    return Table(head, "llrl", lines, "failures")


def write(path: Path, items: list, title: str) -> None:
    """Write the page of report.md's `items` (lines and Tables) to `path`; its images (files
    beside it) inline."""
    folder = Path(path).parent
    body = blocks(items, image=lambda src: data_uri(folder / src))
    Path(path).write_text(page(title, body))
