"""Which report writer serves which study: the reports' own registry, beside them.

Each entry names a writer ``(dataset paths, output directory) -> {name: path}`` by import
path within this package, loaded on first use: asking for EN-02's writer imports the sphere
report alone, and the studies' registry below this layer names no report at all. A new
study adds its line here (its kind already says which files the writer makes).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

__all__ = ["WRITERS", "writer"]

#: study id -> "module:function" of its report writer (modules of creatio.reports).
WRITERS: dict[str, str] = {
    "ct02": "kinematic:write_report",
    "en01": "kinematic:write_report",
    "en02": "sphere:write_report",
    "en02r": "sphere:write_report",
    "en02v": "sphere:write_report",
    "en02g": "en02g:write_en02g",
    "en02f": "en02f:write_en02f",
    "en03": "en03:write_en03",
    "en03m": "en03m:write_en03m",
    "en04": "en04:write_report",
    "en05": "en05:write_report",
    "en06": "en06:write_report",
    "en07": "en07:write_report",
    "work_precision": "work_precision:write_report",
    "stability_map": "stability_map:write_report",
    "boundaries": "boundaries:write_report",
}


def writer(study_id: str) -> Callable[..., Any]:
    """The report writer of a registered study (its module imported on first use)."""
    try:
        module, _, name = WRITERS[study_id].partition(":")
    except KeyError:
        raise KeyError(f"no report writer for study {study_id!r}: one of "
                       f"{', '.join(WRITERS)}") from None
    return getattr(importlib.import_module(f"{__package__}.{module}"), name)
