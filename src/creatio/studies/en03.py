"""EN-03: the sphere on a structure free to yaw about z (docs/studies.md, docs/model.md s.9).

Two kinds of dataset per timestep. The single run (``sweep=False``) at structure.inertia is
EN-02's dataset plus the structure: yaw, H_z and its parts, the world-frame centre, the
point-mass estimate. The inertia sweep (``sweep=True``) runs every study.inertia_sweep value,
then the I_s -> infinity check (study.limit_inertia and the fixed structure, inf), along the
``structure_inertia`` dimension.
"""

from __future__ import annotations

import xarray as xr

from creatio.dynamics import simulate
from creatio.studies.en03_schema import En03Config
from creatio.studies.run_datasets import output_grid, stack, structure_dataset

__all__ = ["SWEEP_HISTORIES", "SWEEP_SCALARS", "run"]

#: Histories kept per run of the inertia sweep.
SWEEP_HISTORIES = ("centre", "centre_azimuth", "world_azimuth", "theta", "theta_rate", "hz",
                   "hz_structure", "hz_orbital", "hz_spin", "energy_residual", "normal_reaction",
                   "angular_lag", "cavity_cell_u", "cavity_cell_v")
#: Structure figures of each run of the sweep (dataset attributes of structure_dataset).
SWEEP_SCALARS = ("structure_rotation", "structure_rotation_point_mass",
                 "world_angular_displacement", "max_hz_drift", "hz_scale", "max_structure_rate",
                 "max_contact_radius")


def run(cfg: En03Config, dt: float, sweep: bool = False) -> xr.Dataset:
    """The single run at structure.inertia, or the inertia sweep, at timestep dt."""
    if not sweep:
        prob = cfg.sphere_problem(dt)
        ds = structure_dataset(prob, simulate(prob))
        ds.attrs["part"] = "single"
        return ds
    runs = cfg.sweep_problems(dt)
    datasets = [structure_dataset(prob, simulate(prob)) for _, prob in runs]
    grid = output_grid(cfg.study.duration, cfg.solver.output_interval)
    out = stack(datasets, "structure_inertia", [v for v, _ in runs],
                {"long_name": "structure moment of inertia about z (inf: fixed)",
                 "units": "kg m2"}, grid, SWEEP_HISTORIES, SWEEP_SCALARS)
    out.attrs.update({
        "part": "inertia_sweep",
        "dt": dt,
        "method": str(cfg.solver.method),
        "sweep_runs": len(cfg.study.inertia_sweep),
        "limit_inertia": float(cfg.study.limit_inertia),
        "comment": "the last two runs are the I_s -> infinity check: limit_inertia and the "
                   "fixed structure (inf, where H_z is not conserved and reported NaN)",
    })
    if cfg.solver.adaptive:
        out.attrs["rtol"], out.attrs["atol"] = cfg.solver.tolerances(dt)
    return out
