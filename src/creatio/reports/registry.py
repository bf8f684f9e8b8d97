"""Which report writer serves which study: the reports' own registry, beside them.

Each entry names a writer ``(dataset paths, output directory) -> {name: path}`` by import
path within this package, loaded on first use: asking for EN-02's writer imports the sphere
report alone, and the studies' registry below this layer names no report at all. A study
of the kinematic or sphere kind is served by its kind's writer (BY_KIND) with no line here;
a study with a report of its own adds its line to WRITERS.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

__all__ = ["BY_KIND", "WRITERS", "writer"]

#: study kind -> "module:function" of the writer of its studies that list none of their own.
BY_KIND: dict[str, str] = {
    "kinematic": "kinematic:write_report",
    "sphere": "sphere:write_report",
}

#: study id -> "module:function" of its own report writer (modules of creatio.reports).
WRITERS: dict[str, str] = {
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
    """The report writer of a registered study (its module imported on first use): its own,
    else its kind's."""
    from creatio.studies import registry

    entry = WRITERS.get(study_id)
    if entry is None:
        kind = registry.get(study_id).kind.name
        if kind not in BY_KIND:
            raise KeyError(f"no report writer for study {study_id!r} (kind {kind}): one of "
                           f"{', '.join(WRITERS)}, or a study of the kinds "
                           f"{', '.join(BY_KIND)}")
        entry = BY_KIND[kind]
    module, _, name = entry.partition(":")
    return getattr(importlib.import_module(f"{__package__}.{module}"), name)
