"""EN-03M: microgravity with a confining force (docs/studies.md, docs/model.md s.10).

For each confinement (``normal``: a preload along -n; ``base``: a pull along -z) and each
structure inertia (free and fixed by default), the smallest confining force P that keeps
contact and keeps the sphere in its cavity's cell through the cycle:

1. a scan up the decades P = m g_ref 10^k (study.bisection.decades), then
   P = study.max_force_factor m g_ref, stopping at the first P that carries;
2. bisection between the last P that did not carry and the first that did, geometric (or
   halving from 0), until the bracket is narrower than study.bisection.rtol of its top; the
   smallest carrying force is the top of the bracket rounded up to 3 significant digits.

The search's runs ("probes") stop at the first step outside the cell (status left_cavity):
only their outcome counts. Then a full run at study.figure_factor times the smallest force
(or study.fallback_force when none carries) gives EN-03's figures plus the confinement work.
Each run's fixed step is refined to stay inside its own friction stability limit
(creatio.studies.en03m_schema.En03mConfig.force_problem).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import xarray as xr

from creatio.dynamics import simulate
from creatio.studies.en03m_schema import En03mConfig
from creatio.studies.run_datasets import output_grid, stack, structure_dataset
from creatio.studies.schema import Confinement
from creatio.studies.sphere import pattern

__all__ = ["FIGURE_HISTORIES", "Probe", "probe", "round_up", "run", "search"]

#: Histories kept of each figure run.
FIGURE_HISTORIES = ("centre", "centre_azimuth", "world_azimuth", "theta", "theta_rate", "hz",
                    "energy_residual", "confinement_work", "normal_reaction", "slip_speed",
                    "angular_lag", "cavity_cell_u", "cavity_cell_v", "surface_work",
                    "friction_dissipation")
#: Structure figures of each figure run (attributes of structure_dataset).
FIGURE_SCALARS = ("structure_rotation", "structure_rotation_point_mass",
                  "world_angular_displacement", "max_hz_drift", "hz_scale", "max_structure_rate",
                  "confinement_work_total", "confining_force", "dt")
#: Most runs one search may take (scan and bisection together).
MAX_PROBES = 80


@dataclass(frozen=True)
class Probe:
    """One run of the search: the force, its outcome, and how far the sphere was carried."""

    force: float
    dt: float
    status: str
    carried: bool
    stop_time: float
    left_cavity_time: float
    angle_deg: float
    lag_deg: float


def round_up(x: float, digits: int = 3) -> float:
    """x rounded up to `digits` significant digits (a carrying force stays carrying)."""
    if not (x > 0.0 and math.isfinite(x)):
        return x
    q = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return float(f"{math.ceil(x / q * (1.0 - 1e-12)) * q:.{digits}g}")


def probe(cfg: En03mConfig, kind: Confinement, inertia: float, force: float, dt: float) -> Probe:
    """Run one force to its outcome (stopping where the sphere leaves its cavity's cell):
    carried means completed ("ok") and never outside the cell. The angle is the centre's
    azimuth travelled relative to the structure up to the run's last step, the lag the
    centre's azimuth minus the pattern angle there."""
    prob = cfg.force_problem(kind, inertia, force, dt, stop_on_leaving=True)
    res = simulate(prob)
    angle = lag = math.nan
    h, c = res.histories, res.counts
    if h.t.size:
        angle = math.degrees(h.azimuth[-1] - h.azimuth[0])
        lag = math.degrees(h.azimuth[-1] - pattern(prob, h.t[-1:])[0])
    return Probe(float(force), prob.solver.dt, c.status, c.status == "ok" and res.carried,
                 c.stop_time, res.events.left_cavity_time, angle, lag)


def search(cfg: En03mConfig, kind: Confinement, inertia: float, dt: float
           ) -> tuple[list[Probe], float, float]:
    """The scan and bisection of the module docstring: (probes in run order, the largest
    force found not to carry (0 if the first scanned one carries), the smallest found to
    carry (NaN if none up to max_force_factor m g_ref does))."""
    st = cfg.study
    scale = cfg.sphere.m * st.reference_gravity
    top = st.max_force_factor * scale
    scan = sorted({scale * 10.0**k for k in st.bisection.decades if scale * 10.0**k < top}
                  | {top})
    probes: list[Probe] = []
    lo, hi = 0.0, math.nan
    for P in scan:
        pr = probe(cfg, kind, inertia, P, dt)
        probes.append(pr)
        if pr.carried:
            hi = P
            break
        lo = P
    if math.isnan(hi):
        return probes, lo, hi
    while hi - lo > st.bisection.rtol * hi and len(probes) < MAX_PROBES:
        mid = math.sqrt(lo * hi) if lo > 0.0 else 0.5 * hi
        pr = probe(cfg, kind, inertia, mid, dt)
        probes.append(pr)
        if pr.carried:
            hi = mid
        else:
            lo = mid
    return probes, lo, hi


def run(cfg: En03mConfig, dt: float) -> xr.Dataset:
    """Every search and figure run of EN-03M at timestep dt, in one dataset."""
    st = cfg.study
    kinds = [Confinement(c) for c in st.confinements]
    inertias = [float(v) for v in st.inertias]
    shape = (len(kinds), len(inertias))
    searches = {}
    figures = []
    for kind in kinds:
        for inertia in inertias:
            probes, lo, hi = search(cfg, kind, inertia, dt)
            P_min = round_up(hi) if math.isfinite(hi) else math.nan
            force = st.figure_factor * P_min if math.isfinite(P_min) else st.fallback_force
            prob = cfg.force_problem(kind, inertia, force, dt)
            ds = structure_dataset(prob, simulate(prob))
            ds.attrs["dt"] = prob.solver.dt
            figures.append(ds)
            searches[(kind, inertia)] = (probes, lo, hi, P_min, force)
    grid = output_grid(st.duration, cfg.solver.output_interval)
    flat = stack(figures, "run", list(range(len(figures))), {}, grid, FIGURE_HISTORIES,
                 FIGURE_SCALARS)
    # the flat run index is (confinement, structure_inertia) in row-major order
    dims2 = ("confinement", "structure_inertia")
    out = xr.Dataset(
        {name: (dims2 + var.dims[1:], var.values.reshape(shape + var.shape[1:]), var.attrs)
         for name, var in flat.data_vars.items()},
        coords={"time": flat.time, "component": flat.component,
                "confinement": ("confinement", [k.value for k in kinds]),
                "structure_inertia": ("structure_inertia", inertias,
                                      {"long_name": "structure moment of inertia about z "
                                       "(inf: fixed)", "units": "kg m2"})})
    n_probe = max(len(v[0]) for v in searches.values())
    fields = {"probe_force": ("force", "N"), "probe_dt": ("dt", "s"),
              "probe_stop_time": ("stop_time", "s"),
              "probe_left_cavity_time": ("left_cavity_time", "s"),
              "probe_angle": ("angle_deg", "degree"), "probe_lag": ("lag_deg", "degree")}
    arrays = {name: np.full((*shape, n_probe), np.nan) for name in fields}
    status = np.full((*shape, n_probe), "", dtype=object)
    carried = np.zeros((*shape, n_probe), dtype=np.int8)
    lo_a, hi_a, pmin_a, force_a = (np.full(shape, np.nan) for _ in range(4))
    for i, kind in enumerate(kinds):
        for j, inertia in enumerate(inertias):
            probes, lo, hi, P_min, force = searches[(kind, inertia)]
            for q, pr in enumerate(probes):
                for name, (attr, _) in fields.items():
                    arrays[name][i, j, q] = getattr(pr, attr)
                status[i, j, q] = pr.status
                carried[i, j, q] = int(pr.carried)
            lo_a[i, j], hi_a[i, j], pmin_a[i, j], force_a[i, j] = lo, hi, P_min, force
    dims3 = ("confinement", "structure_inertia", "probe")
    for name, (_, unit) in fields.items():
        out[name] = (dims3, arrays[name], {"units": unit})
    out["probe_status"] = (dims3, status.astype(str))
    out["probe_carried"] = (dims3, carried)
    out["bracket_low"] = (dims2, lo_a, {"units": "N", "long_name": "largest force found "
                                        "not to carry (0: the first scanned force carries)"})
    out["bracket_high"] = (dims2, hi_a, {"units": "N", "long_name": "smallest force found "
                                         "to carry (NaN: none up to the maximum)"})
    out["min_confining_force"] = (dims2, pmin_a, {"units": "N", "long_name": "bracket_high "
                                                  "rounded up to 3 significant digits"})
    out["figure_force"] = (dims2, force_a, {"units": "N"})
    out.attrs.update({
        "dt": dt,
        "method": str(cfg.solver.method),
        "reference_force": cfg.sphere.m * st.reference_gravity,
        "max_force": st.max_force_factor * cfg.sphere.m * st.reference_gravity,
        "bisection_rtol": st.bisection.rtol,
        "figure_factor": st.figure_factor,
        "fallback_force": st.fallback_force,
        "gravity": cfg.sphere.g,
        "comment": "probes stop where the sphere leaves its cavity's cell; figure runs "
                   "(dimension time) go through the cycle; extrema over every step",
    })
    if cfg.solver.adaptive:
        out.attrs["rtol"], out.attrs["atol"] = cfg.solver.tolerances(dt)
    return out

