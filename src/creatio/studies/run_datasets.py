"""What the studies beyond the notebook share (EN-02G, EN-03, EN-03M; docs/studies.md).

* :func:`run_dataset`: one run's EN-02 dataset (creatio.studies.sphere.result_dataset) with
  its start (the equilibrium of docs/model.md s.8.1 when asked for) and the cell offsets;
* :func:`structure_dataset`: the same plus the structure of docs/model.md s.9-10: yaw, H_z
  and its parts, the world-frame centre and azimuth, the confinement work, and the
  point-mass estimate of s.9.5;
* :func:`stack`: many runs of one study on one output grid, along a named dimension, their
  all-step extrema and statuses as variables of that dimension (a run that stops early, or
  never starts, is NaN where it has no sample).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import xarray as xr

from creatio.dynamics import SimulationResult, SphereProblem
from creatio.model.structure import point_mass_rotation
from creatio.studies.sphere import result_dataset

__all__ = ["SCALARS", "output_grid", "run_dataset", "run_scalars", "stack",
           "structure_dataset"]

#: Per-run scalar figures of a stacked dataset: (variable, dataset attribute, attributes).
SCALARS = (
    ("stop_time", "stop_time", {"units": "s"}),
    ("steps", "steps", {"long_name": "integration steps", "units": "1"}),
    ("min_normal_reaction", "min_normal_reaction", {"units": "N"}),
    ("max_normal_reaction", "max_normal_reaction", {"units": "N"}),
    ("max_slip_speed", "max_slip_speed", {"units": "m s-1"}),
    ("max_energy_residual", "max_energy_residual", {"units": "J"}),
    ("max_cavity_tracking_error", "max_cavity_tracking_error", {"units": "m"}),
    ("min_edge_clearance", "min_edge_clearance", {"units": "m"}),
    ("max_b_kappa", "max_b_kappa",
     {"long_name": "largest sphere radius times surface curvature", "units": "1"}),
    ("stability_limit_dt", "stability_limit_dt", {"units": "s"}),
    ("left_cavity_time", "left_cavity_time",
     {"units": "s", "long_name": "first step outside the starting cavity's cell (NaN: never)"}),
    ("start_R", "start_R", {"units": "m", "long_name": "contact R at the start"}),
    ("start_alpha", "start_alpha", {"units": "degree",
                                    "long_name": "contact alpha at the start"}),
)


#: Units and names of the per-run scalars the studies beyond the notebook add to stack().
EXTRA_ATTRS: dict[str, dict[str, str]] = {
    "structure_rotation": {"units": "degree", "long_name": "structure yaw over the run"},
    "structure_rotation_point_mass": {"units": "degree",
                                      "long_name": "structure yaw of the point-mass estimate"},
    "world_angular_displacement": {"units": "degree",
                                   "long_name": "sphere azimuth change in the world frame"},
    "max_hz_drift": {"units": "kg m2 s-1", "long_name": "largest |H_z(t) - H_z(0)| (NaN: "
                     "fixed structure)"},
    "hz_scale": {"units": "kg m2 s-1", "long_name": "largest |I_s Theta|"},
    "max_structure_rate": {"units": "rad s-1", "long_name": "largest structure yaw rate"},
    "max_contact_radius": {"units": "m", "long_name": "largest horizontal contact radius"},
    "confinement_work_total": {"units": "J", "long_name": "work of the confining force"},
    "confining_force": {"units": "N", "long_name": "confining force P"},
    "dt": {"units": "s", "long_name": "timestep of the run"},
    "flights": {"units": "1", "long_name": "number of flights"},
    "impacts": {"units": "1", "long_name": "number of impacts"},
    "flight_time": {"units": "s", "long_name": "total time in flight"},
    "max_flight_height": {"units": "m", "long_name": "largest gap to the surface in flight"},
    "impact_loss": {"units": "J", "long_name": "mechanical energy lost at impacts and "
                    "resumptions of contact"},
    "ends_in_cavity": {"units": "1", "long_name": "1 if the run ends in contact in its "
                       "starting cavity's cell"},
}


def output_grid(duration: float, interval: float) -> np.ndarray:
    """The histories' common time grid: every output interval from 0, and the duration."""
    n = int(math.floor(duration / interval * (1.0 + 1e-12)))
    t = np.arange(n + 1) * interval
    if duration - t[-1] > 1e-9 * max(1.0, duration):
        t = np.append(t, duration)
    return t


def run_dataset(prob: SphereProblem, res: SimulationResult) -> xr.Dataset:
    """One run's EN-02 dataset with its start point, the equilibrium's verdict (empty when
    accepted or not asked for) and the cavity-cell offsets (docs/model.md s.8)."""
    ds = result_dataset(prob, res)
    c = res.counts
    ds.attrs.update({"start_R": c.start_R, "start_alpha": math.degrees(c.start_alpha),
                     "equilibrium_message": c.equilibrium_message})
    ds["cavity_cell_u"] = ("time", np.degrees(res.histories.cell_u),
                           {"long_name": "radial phase offset from the cavity bottom "
                            "(cell: |du| < 90 deg)", "units": "degree"})
    ds["cavity_cell_v"] = ("time", np.degrees(res.histories.cell_v),
                           {"long_name": "angular phase offset from the cavity bottom "
                            "(cell: |dv| < 90 deg)", "units": "degree"})
    return ds


def run_scalars(ds: xr.Dataset) -> dict[str, float]:
    """Derived per-run figures of one run's dataset: angular displacement (deg, relative to
    the structure), initial and final centre radius, cumulative spin (deg); NaN if empty."""
    def ends(name: str) -> tuple[float, float]:
        v = ds[name].values
        return (float(v[0]), float(v[-1])) if v.size else (math.nan, math.nan)

    az0, az1 = ends("centre_azimuth")
    r0, r1 = ends("centre_radius")
    _, spin = ends("cumulative_spin")
    return {"angular_displacement": az1 - az0, "initial_radius": r0, "final_radius": r1,
            "cumulative_spin": spin}


def structure_dataset(prob: SphereProblem, res: SimulationResult) -> xr.Dataset:
    """One run's dataset with the structure of docs/model.md s.9-10 (for runs on the
    structure path; on a fixed structure theta is 0 and H_z NaN)."""
    ds = run_dataset(prob, res)
    h = res.histories
    # a fixed structure (the run took the EN-02 path) does not turn: theta = 0
    th = h.theta if res.counts.structure_free else 0.0 * h.t
    c, s = np.cos(th), np.sin(th)
    X = h.X
    world = np.stack([c * X[:, 0] - s * X[:, 1], s * X[:, 0] + c * X[:, 1], X[:, 2]], axis=-1)
    hz = h.hz_structure + h.hz_orbital + h.hz_spin
    vec = ("time", "component")
    ds["centre"].attrs["long_name"] = "sphere centre X = c + b n (structure frame)"
    ds["velocity"].attrs["long_name"] = "centre velocity relative to the structure"
    ds["centre_azimuth"].attrs["long_name"] = "unwrapped azimuth of the centre (structure frame)"
    ds["world_centre"] = (vec, world, {"long_name": "sphere centre in the world frame",
                                       "units": "m"})
    ds["world_azimuth"] = ("time", np.degrees(h.world_azimuth),
                           {"long_name": "unwrapped azimuth of the centre (world frame)",
                            "units": "degree"})
    ds["theta"] = ("time", np.degrees(th), {"long_name": "structure yaw theta",
                                            "units": "degree"})
    ds["theta_rate"] = ("time", h.theta_rate if res.counts.structure_free else 0.0 * h.t,
                        {"long_name": "structure yaw rate Theta", "units": "rad s-1"})
    ds["hz_structure"] = ("time", h.hz_structure, {"long_name": "H_z part I_s Theta",
                                                     "units": "kg m2 s-1"})
    ds["hz_orbital"] = ("time", h.hz_orbital,
                        {"long_name": "H_z part m [X x V_abs] . z", "units": "kg m2 s-1"})
    ds["hz_spin"] = ("time", h.hz_spin, {"long_name": "H_z part I omega_z",
                                           "units": "kg m2 s-1"})
    ds["hz"] = ("time", hz, {"long_name": "angular momentum about z, H_z",
                             "units": "kg m2 s-1"})
    ds["confinement_work"] = ("time", h.confinement_work,
                              {"long_name": "work of the normal preload, W_confine",
                               "units": "J"})
    figures = run_scalars(ds)
    rho0 = figures["initial_radius"]
    rotation = float(np.degrees(th[-1] - th[0])) if th.size else math.nan
    structure = prob.model.structure
    ds.attrs.update({
        "structure_inertia": structure.inertia,
        "confinement": structure.confinement,
        "confining_force": structure.force,
        "structure_rotation": rotation,
        "structure_rotation_point_mass": point_mass_rotation(
            prob.model.sphere.m, rho0, structure.inertia, figures["angular_displacement"]),
        "angular_displacement": figures["angular_displacement"],
        "world_angular_displacement": (float(ds.world_azimuth.values[-1]
                                             - ds.world_azimuth.values[0])
                                       if th.size else math.nan),
        "max_hz_drift": res.extrema.max_hz_drift,
        "hz_scale": res.extrema.max_structure_momentum,
        "max_structure_rate": res.extrema.max_structure_rate,
        "max_contact_radius": res.extrema.max_contact_radius,
        "confinement_work_total": (float(h.confinement_work[-1])
                                   if h.confinement_work.size else math.nan),
    })
    return ds


def stack(datasets: Sequence[xr.Dataset], dim: str, coord: Sequence[float], coord_attrs: dict,
          grid: np.ndarray, histories: Sequence[str], extra_scalars: Sequence[str] = ()
          ) -> xr.Dataset:
    """Runs along dimension dim (coordinate values coord): the named histories on the time
    grid (NaN where a run has no sample; a stop row off the grid is left out, its values
    are in the extrema) and the per-run scalars of SCALARS, run_scalars and extra_scalars
    (dataset attributes)."""
    on_grid = [ds[list(histories)].reindex(time=grid, method="nearest", tolerance=1e-9)
               for ds in datasets]
    out = xr.concat(on_grid, dim=dim, coords="minimal", compat="override",
                    combine_attrs="drop")
    out = out.assign_coords({dim: (dim, np.asarray(coord, float), coord_attrs)})
    for name in histories:
        out[name].attrs = dict(datasets[0][name].attrs)
    out["status"] = (dim, np.array([str(ds.attrs["status"]) for ds in datasets], dtype=str))
    out["carried"] = (dim, np.array([int(ds.attrs["carried"]) for ds in datasets], np.int8),
                      {"long_name": "1 if the contact point never left its cavity's cell"})
    out["equilibrium_message"] = (dim, np.array(
        [str(ds.attrs.get("equilibrium_message", "")) for ds in datasets], dtype=str))
    for var, key, attrs in SCALARS:
        out[var] = (dim, np.array([float(ds.attrs.get(key, math.nan)) for ds in datasets]),
                    attrs)
    derived = [run_scalars(ds) for ds in datasets]
    units = {"angular_displacement": "degree", "initial_radius": "m", "final_radius": "m",
             "cumulative_spin": "degree"}
    for key, unit in units.items():
        out[key] = (dim, np.array([d[key] for d in derived]), {"units": unit})
    for key in extra_scalars:
        out[key] = (dim, np.array([float(ds.attrs.get(key, math.nan)) for ds in datasets]),
                    EXTRA_ATTRS.get(key, {}))
    return out
