"""CT-02: spatial kinematics over inclinations 0 ... 90 deg.

Derivative check of c_R, c_alpha, c_t against central differences at every inclination and
for a time-varying inclination; regularity (J identity, normal-tangent orthogonality, seam
closure, the analytic bound J >= R0 - A); cavity velocity and acceleration against
differences of C(t); helical pitch against the displacement of C over one turn of alpha_c.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from creatio.model.cavity import cavity, classify_inclination, helical_pitch
from creatio.model.laws import Law, LawKind
from creatio.model.surface import Motion
from creatio.studies.ct02_schema import Ct02Config
from creatio.studies.verification import DERIVATIVES, fd_errors, regularity, sample_grid

REGULARITY_KEYS = ("j_identity_error", "normal_tangent_dot", "normal_length_error",
                   "seam_closure", "j_min_sampled")


def run(cfg: Ct02Config) -> xr.Dataset:
    """Compute the CT-02 dataset from a validated config."""
    st = cfg.study
    surface = cfg.geometry.surface()
    phi_r, phi_a = cfg.phases.r.to_law(), cfg.phases.a.to_law()
    incl = np.asarray(st.inclinations_deg, float)
    hs = list(st.h)
    alpha, R, t = sample_grid(surface, st.n_radii, st.n_angles, st.times)

    motions = [Motion(phi_r, phi_a, Law.constant(np.deg2rad(g))) for g in incl]
    varying = Motion(phi_r, phi_a, st.varying_gamma.to_law())

    fd = np.stack([fd_errors(surface, m, alpha, R, t, hs) for m in motions], axis=-1)
    fd_var = fd_errors(surface, varying, alpha, R, t, hs)
    reg = [regularity(surface, m, alpha, R, t) for m in motions]
    reg_var = regularity(surface, varying, alpha, R, t)

    # Cavity (n = m = 0) at each inclination and feature time, against differences of C(t).
    tf = np.asarray(st.feature_times, float)
    hf = st.feature_h
    vel_err = np.empty((incl.size, tf.size))
    acc_err = np.empty_like(vel_err)
    pitch_formula = np.empty((incl.size, 3))
    pitch_measured = np.empty_like(pitch_formula)
    vel_err[:] = acc_err[:] = pitch_formula[:] = pitch_measured[:] = np.nan
    for i, m in enumerate(motions):
        if surface.A == 0.0:  # a flat surface has no cavities: features stay NaN
            break
        c0 = cavity(surface, m, tf)
        cp, cm = cavity(surface, m, tf + hf), cavity(surface, m, tf - hf)
        v_fd = (cp.position - cm.position) / (2 * hf)
        a_fd = (cp.position + cm.position - 2 * c0.position) / hf**2
        vel_err[i] = np.linalg.norm(v_fd - c0.velocity, axis=-1)
        acc_err[i] = np.linalg.norm(a_fd - c0.acceleration, axis=-1)
        if _linear_rate(m.phi_a) != 0.0:  # Wa = 0: motion along a meridian, no pitch
            pitch_formula[i], pitch_measured[i] = _pitch(surface, m, np.deg2rad(incl[i]))

    h_coord = xr.DataArray(hs, dims="h", attrs={"long_name": "finite-difference step",
                                                "units": "model units (u, rad, s)"})
    coords = {
        "derivative": ("derivative", list(DERIVATIVES)),
        "h": h_coord,
        "inclination": ("inclination", incl, {"long_name": "inclination gamma",
                                              "units": "degree"}),
        "feature_time": ("feature_time", tf, {"units": "s"}),
        "pitch_component": ("pitch_component", ["p_R", "p_z", "p_rho"]),
    }
    err_attrs = {"long_name": "max Euclidean error, analytic vs central difference",
                 "units": "u (per coordinate unit)"}
    data = {
        "fd_error": (("derivative", "h", "inclination"), fd, err_attrs),
        "fd_error_varying": (("derivative", "h"), fd_var,
                             {**err_attrs, "comment": "time-varying inclination case"}),
        "surface_class": (("inclination",),
                          [classify_inclination(np.deg2rad(g)) for g in incl]),
        "feature_velocity_error": (("inclination", "feature_time"), vel_err,
                                   {"long_name": "|C' - central difference|", "units": "u/s"}),
        "feature_acceleration_error": (("inclination", "feature_time"), acc_err,
                                       {"long_name": "|C'' - second difference|",
                                        "units": "u/s2"}),
        "pitch_formula": (("inclination", "pitch_component"), pitch_formula, {"units": "u"}),
        "pitch_measured": (("inclination", "pitch_component"), pitch_measured,
                           {"units": "u", "comment": "displacement of C over one turn"}),
    }
    for key in REGULARITY_KEYS:
        data[key] = (("inclination",), [r[key] for r in reg])
        data[f"{key}_varying"] = ((), reg_var[key])
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "j_lower_bound": surface.j_lower_bound,
        "n_samples": int(alpha.size * (incl.size + 1)),
    })
    return ds


def _pitch(surface, motion: Motion, gamma: float) -> tuple[np.ndarray, np.ndarray]:
    """Pitch from the formula and from C over the time alpha_c takes to advance +2 pi.

    With the CT-02 phases one turn moves R_c by p_R = 6.8 u, far beyond [0, dR]: this is a
    check of the kinematic formula on the smoothly extended surface, not a followed branch.
    """
    Wr, Wa = _linear_rate(motion.phi_r), _linear_rate(motion.phi_a)
    formula = np.array(helical_pitch(surface, Wr, Wa, gamma))
    turn = -2.0 * np.pi * surface.Ka / Wa
    c = cavity(surface, motion, np.array([0.0, turn]))
    d = c.position[1] - c.position[0]
    rho = np.hypot(c.position[:, 0], c.position[:, 1])
    measured = np.array([c.R[1] - c.R[0], d[2], rho[1] - rho[0]])
    return formula, measured


def _linear_rate(law: Law) -> float:
    if law.kind not in (LawKind.linear, LawKind.constant):
        raise ValueError(f"pitch needs linear phases, got kind={law.kind.value}")
    return law.rate
