"""Self-contained HTML pages: the report's (dcmppi.bench.reports.html) and the episode viewer's
(dcmppi.render.viewer). A page opens from disk with no server and no network: its style, its
scripts (ours, in web/) and its pictures are inline.

    Table(head, align, rows)   a table: its Markdown text (it is a str), and .html()
    inline(text)               Markdown's inline marks (code, bold, links, images) as HTML
    blocks(items, image)       a Markdown document's lines and Tables as HTML
    page(title, body, script)  the whole page
"""

from __future__ import annotations

import base64
import html
import json
import re
from pathlib import Path

WEB = Path(__file__).with_name("web")
_INTERVAL = re.compile(r"\[([-+]?(?:[\d.]+|inf|nan)), ([-+]?(?:[\d.]+|inf|nan))\]")
_IMAGE = re.compile(r"!\[([^\]]*)\]\(([^()\s]+)\)")
_LINK = re.compile(r"\[([^\[\]]*)\]\(([^()\s]+)\)")


class Table(str):
    """A table's Markdown text, which it is, with its cells for other formats.

    head: the headings; align: "l" or "r" per column; rows: the cells of each row (text with
    Markdown's inline marks), as many as head; name: what the table is (the HTML table's
    data-table).
    """

    def __new__(cls, head, align, rows, name: str = ""):
        rule = "|" + "".join("---:|" if a == "r" else "---|" for a in align)
        lines = [_line(head), rule, *map(_line, rows)]
        self = super().__new__(cls, "\n".join(lines))
        self.head, self.align, self.rows, self.name = list(head), list(align), rows, name
        return self

    def html(self) -> str:
        """The table as HTML, sortable by a click on a heading (web/table.js), intervals
        "[lo, hi]" in small print."""
        head = "".join(f"<th>{inline(h)}</th>" for h in self.head)
        body = "".join(
            "<tr>"
            + "".join(
                f"<td{' class=num' if a == 'r' else ''}>{_cell(c)}</td>"
                for a, c in zip(self.align, row, strict=True)
            )
            + "</tr>\n"
            for row in self.rows
        )
        return (
            f'<table class=sortable data-table="{html.escape(self.name)}">'
            f"<thead><tr>{head}</tr></thead><tbody>\n{body}</tbody></table>"
        )


def _line(cells) -> str:
    return "| " + " | ".join(cells) + " |"


def _cell(text: str) -> str:
    return _INTERVAL.sub(r"<span class=ci>[\1, \2]</span>", inline(text))


def inline(text: str) -> str:
    """`text` escaped, with Markdown's `code`, **bold**, [links](url) and ![images](url) as
    HTML (an image inside a link included)."""
    out = html.escape(str(text), quote=True)
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    out = re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", out)
    out = _IMAGE.sub(r'<img src="\2" alt="\1" title="\1">', out)
    return _LINK.sub(r'<a href="\2">\1</a>', out)


def blocks(items, image=lambda src: src) -> str:
    """HTML of `items`: Tables, and strings of Markdown lines (a string may hold several) of
    the kinds the report writes: headings ("# ", "## "), paragraphs (one that begins with a
    bold "**Notice**:" set apart), lists ("- "), fenced code, and images alone in their
    paragraph, whose source `image(src)` gives."""
    out, lines = [], []
    for item in items:
        if isinstance(item, Table):
            out += [_prose(lines, image), f"<div class=scroll>{item.html()}</div>"]
            lines = []
        else:
            lines += str(item).split("\n")
    out.append(_prose(lines, image))
    return "\n".join(o for o in out if o)


def _prose(lines: list[str], image) -> str:
    """HTML of Markdown lines: blocks apart at blank lines, fenced code kept as it is."""
    out, block, code = [], [], None
    for line in [*lines, ""]:
        if code is not None:
            if line.startswith("```"):
                out.append(f"<pre>{html.escape(chr(10).join(code))}</pre>")
                code = None
            else:
                code.append(line)
        elif line.strip() and not line.startswith("```"):
            block.append(line)
        else:
            out.append(_block(block, image))
            block, code = [], ([] if line.startswith("```") else None)
    return "\n".join(o for o in out if o)


def _block(lines: list[str], image) -> str:
    """One block of Markdown lines: a heading, an image, or a paragraph and then a list."""
    if not lines:
        return ""
    heading = re.fullmatch(r"(#{1,3}) (.*)", lines[0])
    picture = re.fullmatch(r"!\[([^\]]*)\]\(([^()\s]+)\)", lines[0])
    if heading and len(lines) == 1:
        level = len(heading[1])
        return f"<h{level}>{inline(heading[2])}</h{level}>"
    if picture and len(lines) == 1:
        alt = html.escape(picture[1], quote=True)
        return f'<figure><img src="{image(picture[2])}" alt="{alt}"></figure>'
    first = next((i for i, line in enumerate(lines) if line.startswith("- ")), len(lines))
    out = []
    if first:
        text = inline(" ".join(lines[:first]))
        notice = re.match(r"<b>[^<]+</b>:", text)
        out.append(f"<p class=notice>{text}</p>" if notice else f"<p>{text}</p>")
    items = []
    for line in lines[first:]:
        if line.startswith("- "):
            items.append(line[2:])
        else:
            items[-1] += " " + line
    if items:
        out.append("<ul>" + "".join(f"<li>{inline(i)}</li>" for i in items) + "</ul>")
    return "".join(out)


def data_uri(path, kind: str = "image/png") -> str:
    """The file `path` as a data: URI."""
    return f"data:{kind};base64,{base64.b64encode(Path(path).read_bytes()).decode()}"


def script_data(value) -> str:
    """`value` as JSON inside a <script type="application/json"> (no "</" to end it early)."""
    return json.dumps(value, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")


def page(title: str, body: str, scripts=("table.js",)) -> str:
    """A whole HTML page: `body` (HTML) under the shared style, with the scripts of web/ named
    in `scripts` inline."""
    style = (WEB / "page.css").read_text()
    code = "\n".join((WEB / name).read_text() for name in scripts)
    return (
        "<!DOCTYPE html>\n<html lang=en>\n<head>\n<meta charset=utf-8>\n"
        '<meta name=viewport content="width=device-width, initial-scale=1">\n'
        f"<title>{html.escape(title)}</title>\n<style>\n{style}</style>\n</head>\n<body>\n"
        f"{body}\n<script>\n{code}</script>\n</body>\n</html>\n"
    )
