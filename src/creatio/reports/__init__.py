"""Reports derived from datasets (never recomputing a study): one module per study, one per
kind where studies share a report (kinematic, sphere), and what they share (common).

:func:`summary` gives the JSON summary of any study's dataset (what sweeps aggregate).
"""

from __future__ import annotations

from typing import Any

__all__ = ["summary"]


def summary(ds: Any) -> dict[str, Any]:
    """The JSON summary figures of one dataset, by its study's kind."""
    from creatio.studies import registry

    kind = registry.get(str(ds.attrs["study"])).kind
    if kind is registry.SPHERE:
        from creatio.reports.sphere import dynamic_summary

        return dynamic_summary([ds])
    from creatio.reports.kinematic import kinematic_summary

    return kinematic_summary(ds)
