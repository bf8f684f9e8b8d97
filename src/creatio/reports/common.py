"""What every report shares: strict JSON, number formatting, markdown tables, matplotlib.

Reports are derived from datasets and never recompute a study. Numbers are formatted one
way everywhere (:func:`fmt`): four significant digits, scientific below 1e-3.
"""

from __future__ import annotations

import html
import json
import math
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from creatio.store.atomic import atomic_save, atomic_write  # noqa: E402
from creatio.studies.published import Published  # noqa: E402

__all__ = ["PUBLISHED_HEADER", "cell", "fmt", "h_key", "markdown_html", "nested", "plt",
           "published_row", "readable_y", "strict_json", "table", "write_markdown"]


def strict_json(data: Any) -> str:
    """Strict JSON: NaN and infinities (a figure not computed) become null."""
    def clean(x: Any) -> Any:
        if isinstance(x, float) and not math.isfinite(x):
            return None
        if isinstance(x, dict):
            return {k: clean(v) for k, v in x.items()}
        if isinstance(x, list | tuple):
            return [clean(v) for v in x]
        return x

    return json.dumps(clean(data), indent=2, allow_nan=False) + "\n"


def h_key(h: float) -> str:
    """The h label of the report contract: Python's shortest float repr (0.01, 1e-05)."""
    return repr(float(h))


def nested(names: Sequence[str], keys: Sequence[str], values: np.ndarray) -> dict:
    """{name: {key: value}} from rows of values."""
    return {n: {k: float(v) for k, v in zip(keys, row, strict=True)}
            for n, row in zip(names, values, strict=True)}


def fmt(x: Any) -> str:
    """A number as reports print it: 4 significant digits, scientific below 1e-3; a
    published figure with the digits the notebook prints (1.110, not 1.11)."""
    if isinstance(x, Published):
        return x.text
    if isinstance(x, float | np.floating):
        return "nan" if math.isnan(x) else f"{x:.4g}" if abs(x) >= 1e-3 or x == 0 else f"{x:.3e}"
    return str(x)


#: Columns of a computed-vs-published table (reports of the notebook's studies).
PUBLISHED_HEADER = ["figure", "computed", "published", "computed - published", "agreement"]


def published_row(label: str, computed: float, published: Published) -> list[str]:
    """One row of a computed-vs-published table: the computed value to three more decimals
    than the notebook prints (or four significant digits beside a bound or a magnitude), the
    published digits, the difference and the verdict (Published.verdict)."""
    if not math.isfinite(computed):
        return [label, "not computed", published.text, "", published.verdict(computed)]
    if published.kind == "value":
        shown = f"{computed:.{published.decimals + 3}f}"
    else:
        shown = fmt(float(computed))
    d = float(computed) - float(published)
    diff = "0" if d == 0 else f"{d:+.3e}" if abs(d) < 1e-3 or abs(d) >= 1e5 else f"{d:+.4g}"
    return [label, shown, published.text, diff, published.verdict(float(computed))]


def cell(x: Any) -> str:
    """A table cell: the number formatted by :func:`fmt`, with ``|`` escaped so that a
    label such as ``max |C' - C'_fd|`` stays inside its cell when rendered."""
    return fmt(x).replace("|", "\\|")


def table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    """Markdown table lines (cells formatted by :func:`fmt`, ``|`` escaped); every row must
    have one cell per header (a column without a header is a bug, not a blank)."""
    for row in rows:
        if len(row) != len(header):
            raise ValueError(f"table row {list(row)} has {len(row)} cells for {len(header)} "
                             f"columns {list(header)}")
    lines = ["| " + " | ".join(cell(h) for h in header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(c) for c in row) + " |" for row in rows]
    return lines


def readable_y(ax: Any, y: Any) -> None:
    """No offset notation on the y axis (it hides the values); a series constant to
    rounding is drawn flat in the middle of a readable range around its value."""
    ax.ticklabel_format(axis="y", useOffset=False)
    y = np.asarray(y, float)
    y = y[np.isfinite(y)]
    if y.size == 0:
        return
    lo, hi = float(y.min()), float(y.max())
    scale = max(abs(lo), abs(hi))
    if scale > 0 and hi - lo <= 1e-6 * scale:
        pad = 1e-3 * scale
        ax.set_ylim(lo - pad, hi + pad)


def write_text(path: Path, text: str) -> Path:
    """Write a report file through a temporary sibling and a rename: a killed report job
    leaves the previous file or none, never a partial one."""
    with atomic_write(path) as fh:
        fh.write(text)
    return Path(path)


def save_figure(fig: Any, path: Path, **kwargs: Any) -> Path:
    """Save a matplotlib figure the same way (format from the suffix)."""
    return atomic_save(path, lambda tmp: fig.savefig(tmp, **kwargs))


#: Style of a report's HTML page (Snakemake's report shows it inline; a browser offline).
_CSS = ("body{font:14px/1.45 system-ui,sans-serif;margin:1.2em;color:#222;max-width:70em}"
        "table{border-collapse:collapse;margin:.6em 0}th,td{border:1px solid #ccc;"
        "padding:.2em .55em;text-align:right}th{background:#f3f3f3}td:first-child,"
        "th:first-child{text-align:left}code{background:#f3f3f3;padding:0 .2em}"
        "p.figures{color:#666;font-size:12px}")
_CELL = re.compile(r"(?<!\\)\|")


def _inline(text: str) -> str:
    """Markdown inline code and bold as HTML, the rest escaped."""
    out = html.escape(text.replace("\\|", "|"))
    out = re.sub(r"`([^`]+)`", r"<code>\1</code>", out)
    return re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", out)


def _cells(line: str) -> list[str]:
    return [c.strip() for c in _CELL.split(line.strip().strip("|"))]


def markdown_html(text: str) -> str:
    """A report's markdown (headings, paragraphs, bullet lists, the tables of :func:`table`)
    as a standalone HTML page, so that Snakemake's report shows the tables instead of
    offering the markdown as a download. Images are named, not embedded (they are shown
    beside it)."""
    body: list[str] = []
    figures: list[str] = []
    lines = text.splitlines()
    i = 0
    title = "report"
    while i < len(lines):
        line = lines[i]
        if line.startswith("|") and i + 1 < len(lines) and set(lines[i + 1]) <= set("|-: "):
            head = _cells(line)
            body.append("<table><tr>" + "".join(f"<th>{_inline(c)}</th>" for c in head)
                        + "</tr>")
            i += 2
            while i < len(lines) and lines[i].startswith("|"):
                body.append("<tr>" + "".join(f"<td>{_inline(c)}</td>"
                                             for c in _cells(lines[i])) + "</tr>")
                i += 1
            body.append("</table>")
            continue
        m = re.match(r"^(#{1,4}) (.*)", line)
        if m:
            level = len(m.group(1))
            if level == 1:
                title = m.group(2)
            body.append(f"<h{level}>{_inline(m.group(2))}</h{level}>")
        elif (img := re.match(r"^!\[[^]]*\]\(([^)]+)\)", line)):
            figures.append(img.group(1))
        elif line.startswith(("* ", "- ")):
            body.append(f"<ul><li>{_inline(line[2:])}</li></ul>")
        elif line.strip():
            body.append(f"<p>{_inline(line.strip())}</p>")
        i += 1
    if figures:
        body.append(f"<p class=figures>Figures of this report: {html.escape(', '.join(figures))}"
                    "</p>")
    return ("<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
            f"<title>{html.escape(title)}</title><style>{_CSS}</style></head><body>"
            + "\n".join(body).replace("</ul>\n<ul>", "\n") + "</body></html>\n")


def write_markdown(path: Path, text: str) -> Path:
    """Write a report's markdown and, beside it (same stem, .html), its HTML page."""
    write_text(path.with_suffix(".html"), markdown_html(text))
    return write_text(path, text)
