"""The answer a report opens with (issue 34): three to five plain-word lines, right under the
title, saying what was computed, the answer and what it rests on, before any table of keys.

Every figure in these lines comes from the report's own summary (its JSON), never from a
constant: :func:`answer_lines` only lays them out.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

__all__ = ["answer_lines", "num"]


def num(x: Any, unit: str = "", digits: int = 4) -> str:
    """A number in an answer line: `digits` significant digits and its unit; "not computed"
    for a missing or non-finite figure (a null in the JSON)."""
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "not computed"
    if isinstance(x, bool) or not isinstance(x, int | float):
        return f"{x}{' ' + unit if unit else ''}"
    text = f"{float(x):.{digits}g}"
    return f"{text} {unit}" if unit else text


def answer_lines(computed: str, answer: str | Sequence[str], rests_on: str) -> list[str]:
    """The opening lines of a report: what was computed, the answer (one line or a few),
    what it rests on; each a bullet, then a blank line."""
    answers = [answer] if isinstance(answer, str) else list(answer)
    if not 1 <= len(answers) <= 3:
        raise ValueError(f"an answer has one to three lines, not {len(answers)}")
    return ([f"- **Computed:** {computed}"]
            + [f"- **Answer:** {a}" for a in answers]
            + [f"- **Rests on:** {rests_on}", ""])
