"""EN-01: kinematic verification in SI units.

Derivative check over three time laws (17 radii x 36 angles x 9 times each), regularity
over inclinations on a 168 x 168 grid, and the pattern velocity alpha_p' = -phi_a' / Ka over
the EN-02 quintic cycle with its central-difference check.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from creatio.model.cavity import pattern_angle
from creatio.model.laws import Law
from creatio.model.surface import Motion
from creatio.studies.en01_schema import En01Config
from creatio.studies.verification import DERIVATIVES, fd_errors, regularity, sample_grid

REGULARITY_KEYS = ("normal_length_error", "normal_tangent_dot", "j_identity_error",
                   "j_min_sampled")


def run(cfg: En01Config) -> xr.Dataset:
    """Compute the EN-01 dataset from a validated config."""
    st = cfg.study
    surface = cfg.geometry.surface()
    hs = list(st.h)
    alpha, R, t = sample_grid(surface, st.n_radii, st.n_angles, st.times)
    names = list(st.laws)
    fd = np.stack(
        [fd_errors(surface, _motion(st.laws[k]), alpha, R, t, hs) for k in names], axis=-1
    )

    # Regularity: the law (a) phases at t = 0 (first case), inclination swept.
    rg = st.regularity
    first = _motion(st.laws[names[0]])
    ra, rR, rt = sample_grid(surface, rg.n_radii, rg.n_angles, [0.0])
    incl = np.asarray(rg.inclinations_deg, float)
    reg = [
        regularity(surface, Motion(first.phi_r, first.phi_a, Law.constant(np.deg2rad(g))),
                   ra, rR, rt)
        for g in incl
    ]

    # Pattern velocity over the quintic cycle, checked by central differences.
    pc = st.pattern
    pmotion = Motion(Law.constant(0.0), pc.a.to_law(pc.T), Law.constant(0.0))
    n = int(round(pc.T / pc.sample_interval))
    tp = np.linspace(0.0, n * pc.sample_interval, n + 1)
    ap, rate, _ = pattern_angle(surface, pmotion, tp)
    hp = pc.fd_step
    fd_rate = (pattern_angle(surface, pmotion, tp + hp)[0]
               - pattern_angle(surface, pmotion, tp - hp)[0]) / (2 * hp)

    coords = {
        "derivative": ("derivative", list(DERIVATIVES)),
        "h": ("h", hs, {"long_name": "finite-difference step", "units": "m, rad, s"}),
        "law": ("law", names, {"long_name": "time-law case"}),
        "inclination": ("inclination", incl, {"long_name": "inclination gamma",
                                              "units": "degree"}),
        "time": ("time", tp, {"units": "s"}),
    }
    data = {
        "fd_error": (("derivative", "h", "law"), fd,
                     {"long_name": "max Euclidean error, analytic vs central difference",
                      "units": "m (c_R: dimensionless)"}),
        "pattern_angle": (("time",), np.degrees(ap), {"long_name": "pattern angle alpha_p",
                                                      "units": "degree"}),
        "pattern_rate": (("time",), rate, {"long_name": "pattern rate alpha_p'",
                                           "units": "rad s-1"}),
        "pattern_rate_fd": (("time",), fd_rate,
                            {"long_name": "central difference of alpha_p",
                             "units": "rad s-1", "fd_step_s": hp}),
    }
    for key in REGULARITY_KEYS:
        data[key] = (("inclination",), [r[key] for r in reg])
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "j_lower_bound": surface.j_lower_bound,
        "n_samples": int(alpha.size * len(names)),
        "regularity_points_per_inclination": int(ra.size),
    })
    return ds


def _motion(case) -> Motion:
    return Motion(case.r.to_law(), case.a.to_law(), case.gamma.to_law())
