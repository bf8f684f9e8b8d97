"""EN-02G: the sphere across the inclination family (docs/studies.md, docs/model.md s.8).

EN-02's sphere, friction and phases at each constant inclination, and under the notebook's
oscillating inclination gamma(t) = gamma0 + G sin(Omega t) at a few gamma0; every run starts
at rest at the static equilibrium nearest its cavity's bottom (status no_equilibrium and no
run when there is none) and records whether the sphere stays in its cavity's cell. One
dataset per timestep: the constant runs along ``inclination``, the oscillating ones along
``gamma0`` (variables prefixed ``oscillating_``), both on EN-02's output grid, and the
largest inclination at which an equilibrium exists (creatio.model.equilibrium).
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from creatio.dynamics import simulate
from creatio.model.equilibrium import equilibrium_limit
from creatio.studies.en02g_schema import En02gConfig
from creatio.studies.run_datasets import output_grid, run_dataset, stack

__all__ = ["HISTORIES", "run"]

#: The EN-02 histories kept per run.
HISTORIES = ("centre", "centre_radius", "centre_azimuth", "contact_R", "contact_alpha", "speed",
             "normal_reaction", "slip_speed", "spin_rate", "cumulative_spin", "angular_lag",
             "cavity_R", "energy_residual", "cavity_cell_u", "cavity_cell_v")


def run(cfg: En02gConfig, dt: float) -> xr.Dataset:
    """Every run of EN-02G at timestep dt, in one dataset (docs/studies.md)."""
    grid = output_grid(cfg.study.duration, cfg.solver.output_interval)
    constant, oscillating = [], []
    for kind, _, prob in cfg.run_problems(dt):
        ds = run_dataset(prob, simulate(prob))
        gamma = prob.model.motion.gamma
        g = np.array([gamma.scalar(float(t))[0] for t in ds.time.values])
        ds["inclination_t"] = ("time", np.degrees(g), {"long_name": "inclination gamma(t)",
                                                       "units": "degree"})
        (constant if kind == "constant" else oscillating).append(ds)
    names = (*HISTORIES, "inclination_t")
    out = stack(constant, "inclination", cfg.study.inclinations_deg,
                {"long_name": "constant inclination gamma", "units": "degree"}, grid, names)
    osc = cfg.study.oscillation
    if oscillating:
        o = stack(oscillating, "gamma0", osc.gamma0_deg,
                  {"long_name": "mean inclination gamma0 of gamma0 + G sin(Omega t)",
                   "units": "degree"}, grid, names)
        out = out.merge(o.rename({v: f"oscillating_{v}" for v in o.data_vars}))
    first = cfg.run_problems(dt)[0][2]
    n, m = first.cavity_cell()
    model = first.model
    surface, motion = model.surface, model.motion
    limit = equilibrium_limit(surface.R0, model.k, surface.A, float(surface.Ka), model.sphere.b,
                              motion.phi_r.scalar(0.0)[0], motion.phi_a.scalar(0.0)[0],
                              n, m)
    out.attrs.update({
        "dt": dt,
        "method": str(cfg.solver.method),
        "oscillation_amplitude_deg": osc.amplitude_deg,
        "oscillation_omega": osc.omega,
        "equilibrium_limit_deg": math.degrees(limit),
        "comment": "extrema (min_*, max_*) are taken over every integration step; "
                   "histories are NaN after a run stops and for runs with no_equilibrium",
    })
    if cfg.solver.adaptive:
        rtol, atol = cfg.solver.tolerances(dt)
        out.attrs.update({"rtol": rtol, "atol": atol})
    return out
