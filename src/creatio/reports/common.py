"""What every report shares: strict JSON, number formatting, markdown tables, matplotlib.

Reports are derived from datasets and never recompute a study. Numbers are formatted one
way everywhere (:func:`fmt`): four significant digits, scientific below 1e-3.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from creatio.pipeline.io import atomic_save, atomic_write  # noqa: E402

__all__ = ["cell", "fmt", "h_key", "nested", "plt", "readable_y", "strict_json", "table"]


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
    """A number as reports print it: 4 significant digits, scientific below 1e-3."""
    if isinstance(x, float | np.floating):
        return "nan" if math.isnan(x) else f"{x:.4g}" if abs(x) >= 1e-3 or x == 0 else f"{x:.3e}"
    return str(x)


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
