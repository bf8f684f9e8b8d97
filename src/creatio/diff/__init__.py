"""Dataset, directory and release diffs (``creatio diff``): tolerances, structure, attributes,
configs key by key, report figures; nccmp-style exit codes."""

from creatio.diff.core import DiffError, Tolerance, diff, main, render_text

__all__ = ["DiffError", "Tolerance", "diff", "main", "render_text"]
