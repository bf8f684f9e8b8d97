"""What every report shares: strict JSON, number formatting, markdown tables, matplotlib.

Reports are derived from datasets and never recompute a study. Numbers are formatted one
way everywhere (:func:`fmt`): four significant digits, scientific below 1e-3.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

__all__ = ["fmt", "h_key", "nested", "plt", "strict_json", "table"]


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


def table(header: Sequence[str], rows: Sequence[Sequence[Any]]) -> list[str]:
    """Markdown table lines (cells formatted by :func:`fmt`)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(fmt(c) for c in row) + " |" for row in rows]
    return lines
