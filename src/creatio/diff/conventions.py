"""The documented changes of how datasets write a quantity, mapped before comparing.

A release written before a convention changed (0.1.0 stored ``contact_alpha`` in rad, today's
datasets store every angle in degree: docs/datasets.md) is still compared value for value:
the old side is converted to the new convention with the same function the studies use
(``numpy.degrees``), so an unchanged computation compares bit for bit at atol = rtol = 0.
Each mapping that applied is reported as provenance (what changed, and why), never as a
numeric difference; a variable whose units match neither side's convention is compared as
it stands and its units change is counted, as before.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr

__all__ = ["CONVENTIONS", "Convention", "apply_conventions", "encoding_notes"]


@dataclass(frozen=True)
class Convention:
    """One change of encoding: a variable renamed, its units converted, an attribute dropped.

    ``names`` are the variables it applies to (new names); ``old_name`` the name before a
    rename; ``old_units`` -> ``new_units`` with ``convert`` (old values to new units) for a
    change of units; ``dropped`` the attributes (name, value) the old side stated and the new
    one no longer does.
    """

    since: str
    names: tuple[str, ...]
    why: str
    old_name: str | None = None
    old_units: str | None = None
    new_units: str | None = None
    convert: Callable[[np.ndarray], np.ndarray] | None = None
    dropped: tuple[tuple[str, str], ...] = ()


_ANGLE = "one angle convention: angles in degree, angular rates in rad s-1"

#: Every convention change since the first release (docs/datasets.md, "Conventions and
#: releases"). The studies of release 0.1.0 meet the first two; the others concern datasets
#: no release holds yet (EN-02G/EN-02F, scenes) and keep older local data comparable.
CONVENTIONS: tuple[Convention, ...] = (
    Convention("0.2.0", ("contact_alpha", "pattern_angle"), _ANGLE, old_units="rad",
               new_units="degree", convert=np.degrees),
    Convention("0.2.0", ("time",), "simulated time is an elapsed time, not a CF calendar "
               "instant: no standard_name time", dropped=(("standard_name", "time"),)),
    Convention("0.2.0", ("start_alpha", "cavity_cell_u", "cavity_cell_v", "event_alpha",
                         "stroke_alpha", "worst_alpha", "phase_r", "phase_a", "inclination"),
               _ANGLE, old_units="rad",
               new_units="degree", convert=np.degrees),
    Convention("0.2.0", ("friction_magnitude",), "one meaning per name: friction is the "
               "force vector, its magnitude is friction_magnitude", old_name="friction"),
)


def _note(name: str, old: Any, new: Any, why: str, kind: str = "convention") -> dict[str, Any]:
    """A provenance entry of the diff: reported, counted only with --strict-provenance."""
    return {"variable": None, "name": name, "old": old, "new": new, "beyond": False,
            "category": "provenance", "kind": kind, "why": why}


def _replace(ds: xr.Dataset, name: str, var: xr.Variable) -> xr.Dataset:
    if name in ds.coords:
        return ds.assign_coords({name: var})
    return ds.assign({name: var})


def apply_conventions(a: xr.Dataset, b: xr.Dataset) -> tuple[xr.Dataset, list[dict[str, Any]]]:
    """A (old) mapped onto B's conventions where a documented change explains the
    difference, and one provenance entry per mapping applied."""
    notes: list[dict[str, Any]] = []
    for c in CONVENTIONS:
        for name in c.names:
            if (c.old_name and c.old_name in a.variables and name in b.variables
                    and name not in a.variables and c.old_name not in b.variables):
                a = a.rename({c.old_name: name})
                notes.append(_note(f"{name} (was {c.old_name})", c.old_name, name, c.why))
            if name not in a.variables or name not in b.variables:
                continue
            va, vb = a[name].variable, b[name].variable
            if (c.convert is not None and va.attrs.get("units") == c.old_units
                    and vb.attrs.get("units") == c.new_units and va.dtype.kind == "f"):
                converted = va.copy(data=c.convert(va.values))
                converted.attrs["units"] = c.new_units
                a = _replace(a, name, converted)
                notes.append(_note(f"{name} units (converted before comparing)", c.old_units,
                                   c.new_units, c.why))
            for key, value in c.dropped:
                va = a[name].variable
                if va.attrs.get(key) == value and key not in vb.attrs:
                    kept = va.copy()
                    del kept.attrs[key]
                    a = _replace(a, name, kept)
                    notes.append(_note(f"{name}:{key}", value, None, c.why))
    return a, notes


def encoding_notes(a: xr.Dataset, b: xr.Dataset) -> list[dict[str, Any]]:
    """Variables whose units read back the same but were stored otherwise (the time of
    datasets before 0.2, ``seconds since 1970-01-01``, against ``s``): provenance."""
    from creatio.store.cf import STORED_UNITS

    notes = []
    for name in sorted(set(a.variables) & set(b.variables), key=str):
        sa, sb = a[name].encoding.get(STORED_UNITS), b[name].encoding.get(STORED_UNITS)
        if (sa != sb and None not in (sa, sb)
                and a[name].attrs.get("units") == b[name].attrs.get("units")):
            notes.append(_note(f"{name} stored units (read back as "
                               f"{a[name].attrs.get('units')!r})", sa, sb,
                               "an encoding change: the values read back are compared",
                               "encoding"))
    return notes
