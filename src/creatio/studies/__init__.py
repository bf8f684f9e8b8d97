"""One module per study: a validated config in, an ``xarray.Dataset`` out."""

from __future__ import annotations

import xarray as xr

from creatio.config import KINEMATIC, Resolved
from creatio.io import provenance

__all__ = ["run_study"]


def run_study(resolved: Resolved, dt: float | None = None) -> xr.Dataset:
    """Run one study (a dynamic one at timestep dt) and attach provenance attributes."""
    study = resolved.study
    if study in KINEMATIC:
        if dt is not None:
            raise ValueError(f"study {study} is kinematic: it takes no timestep")
        from creatio.studies import ct02, en01

        ds = {"ct02": ct02.run, "en01": en01.run}[study](resolved.obj)
    else:
        from creatio.studies import en02

        ds = en02.run(resolved.obj, dt=resolved.obj.solver.dt if dt is None else dt)
    attrs = provenance(study, resolved.yaml, resolved.sha256, resolved.obj.study.title)
    ds.attrs = {**attrs, **ds.attrs}
    return ds
