"""EN-02 family: one sphere carried by the moving membrane, at one timestep.

The numeric work is one compiled run (creatio.dynamics.simulate); this module maps the
validated config to a SphereProblem and the result to a dataset with named dimensions,
CF-style units, and every all-step extremum as an attribute. :func:`result_dataset` is the
mapping itself, shared by the studies beyond the notebook (EN-02G, EN-03, EN-03M).
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr

from creatio.dynamics import Histories, SimulationResult, SphereProblem, simulate
from creatio.model.cavity import pattern_angle
from creatio.studies.en04_control import measure
from creatio.studies.schema import ControlGroup, DynamicConfig

__all__ = ["COMPONENTS", "angular_lag", "pattern", "result_dataset", "result_pattern", "run"]

COMPONENTS = ["x", "y", "z"]


def pattern(prob: SphereProblem, t: np.ndarray) -> np.ndarray:
    """Pattern angle (rad) of a problem's phases at times t, measured from the initial
    contact angle alpha_init (docs/model.md s.3.1)."""
    return pattern_angle(prob.model.surface, prob.model.motion, t, prob.start.alpha)[0]


def result_pattern(prob: SphereProblem, h: Histories) -> np.ndarray:
    """Pattern angle (rad) at a run's history times: it starts at the initial contact angle
    and turns at -phi_a' / Ka (on the controlled path phi_a is the state's, recorded with
    the run)."""
    if prob.controlled:
        return prob.start.alpha - (h.phi_a - h.phi_a[:1]) / prob.model.surface.Ka
    return pattern(prob, h.t)


def angular_lag(h: Histories, pattern_t: np.ndarray) -> np.ndarray:
    """Centre azimuth minus pattern angle (degree) at the history's times."""
    return np.degrees(h.azimuth) - np.degrees(pattern_t)


def run(cfg: DynamicConfig, dt: float) -> xr.Dataset:
    """Simulate at timestep dt and return the time-history dataset."""
    prob = cfg.sphere_problem(dt)
    return result_dataset(prob, simulate(prob), cfg.control)


def result_dataset(prob: SphereProblem, res: SimulationResult,
                   control: ControlGroup | None = None) -> xr.Dataset:
    """The EN-02 time-history dataset of one run: histories, extrema as attributes, and the
    cavity-cell check (docs/model.md s.8.2) as ``left_cavity_time`` (NaN: never left) and
    ``carried``; on the controlled path (s.12.2) the phase, its rate, the servo's u, the lead
    and the arrival readouts too (control: the group, for its arrival tolerance)."""
    h = res.histories
    t = h.t
    dt = prob.solver.dt
    pattern_t = result_pattern(prob, h)
    rho = np.hypot(h.X[:, 0], h.X[:, 1])
    vec = ("time", "component")
    coords = {
        "time": ("time", t, {"units": "s"}),
        "component": ("component", COMPONENTS),
        "quaternion_component": ("quaternion_component", ["w", "x", "y", "z"]),
    }
    data = {
        "centre": (vec, h.X, {"long_name": "sphere centre X = c + b n", "units": "m"}),
        "centre_radius": ("time", rho, {"long_name": "horizontal radius of the centre",
                                        "units": "m"}),
        "centre_azimuth": ("time", np.degrees(h.azimuth),
                           {"long_name": "unwrapped azimuth of the centre", "units": "degree"}),
        "contact_R": ("time", h.R, {"long_name": "contact radial coordinate R", "units": "m"}),
        "contact_alpha": ("time", np.degrees(h.alpha), {"long_name": "contact angle alpha",
                                                          "units": "degree"}),
        "velocity": (vec, h.V, {"long_name": "centre velocity", "units": "m s-1"}),
        "speed": ("time", h.speed, {"long_name": "centre speed", "units": "m s-1"}),
        "normal_reaction": ("time", h.N, {"long_name": "normal reaction N", "units": "N"}),
        "friction": (vec, h.f, {"long_name": "friction force", "units": "N"}),
        "slip_speed": ("time", h.slip_speed, {"long_name": "slip speed |v_s|",
                                                "units": "m s-1"}),
        "omega": (vec, h.omega, {"long_name": "angular velocity (world frame)",
                                   "units": "rad s-1"}),
        "spin_rate": ("time", h.spin_rate, {"long_name": "|omega|", "units": "rad s-1"}),
        "cumulative_spin": ("time", np.degrees(h.cumulative_spin),
                            {"long_name": "integral of |omega| dt", "units": "degree"}),
        "quaternion": (("time", "quaternion_component"), h.Q,
                       {"long_name": "orientation, unit quaternion, scalar first"}),
        "marker": (vec, h.marker, {"long_name": "body marker, starts at (0, 0, 1)"}),
        "pattern_angle": ("time", np.degrees(pattern_t),
                          {"long_name": "pattern angle from the initial contact angle",
                           "units": "degree"}),
        "angular_lag": ("time", angular_lag(h, pattern_t),
                        {"long_name": "centre azimuth minus pattern angle", "units": "degree"}),
        "cavity_R": ("time", h.cavity_R, {"long_name": "radial coordinate of the cavity",
                                            "units": "m"}),
        "kinetic_energy": ("time", h.kinetic, {"units": "J"}),
        "potential_energy": ("time", h.potential, {"units": "J"}),
        "energy": ("time", h.energy, {"long_name": "mechanical energy E", "units": "J"}),
        "surface_work": ("time", h.surface_work, {"long_name": "work of the membrane",
                                                    "units": "J"}),
        "friction_dissipation": ("time", h.friction_dissipation,
                                 {"long_name": "energy dissipated by friction", "units": "J"}),
        "energy_residual": ("time", h.energy_residual,
                            {"long_name": "E - E0 - W_surface + D_friction", "units": "J"}),
    }
    ds = xr.Dataset(data, coords=coords)
    if prob.controlled:
        _control_variables(ds, prob, res, control or ControlGroup())
    if prob.adaptive:
        ds.attrs.update({"rtol": prob.solver.rtol, "atol": prob.solver.atol})
    sp = prob.model.sphere
    if sp.tilted:  # a mounting tilt (docs/model.md s.4); a level run's attributes are as before
        gx, gy, gz = sp.gravity
        ds.attrs.update({"tilt_beta_deg": math.degrees(sp.beta),
                         "tilt_psi_deg": math.degrees(sp.psi), "gravity_x": gx,
                         "gravity_y": gy, "gravity_z": gz})
    ds.attrs.update({
        "dt": dt,
        "method": res.counts.method,
        "status": res.counts.status,
        "stop_time": res.counts.stop_time,
        "steps": res.counts.steps,
        "rhs_evals": res.counts.rhs_evals,
        "rotation_integrated": int(res.counts.rotation_integrated),
        "energy_integrated": int(res.counts.energy_integrated),
        "stability_limit_dt": res.counts.stability_limit,
        "min_normal_reaction": res.extrema.min_N,
        "max_normal_reaction": res.extrema.max_N,
        "max_slip_speed": res.extrema.max_slip_speed,
        "max_energy_residual": res.extrema.max_energy_residual,
        "max_cavity_tracking_error": res.extrema.max_cavity_tracking_error,
        "min_edge_clearance": res.extrema.min_edge_clearance,
        "max_b_kappa": res.extrema.max_b_kappa,
        "rejected_steps": res.counts.rejected_steps,
        "jacobians": res.counts.jacobians,
        "lu_factorisations": res.counts.lu_factorisations,
        "newton_iterations": res.counts.newton_iterations,
        "warnings": "\n".join(res.counts.warnings),
        "comment": "extrema (min_*, max_*) are taken over every integration step",
        "left_cavity_time": res.events.left_cavity_time,
        "carried": int(res.carried),
    })
    return ds


def _control_variables(ds: xr.Dataset, prob: SphereProblem, res: SimulationResult,
                       control: ControlGroup) -> None:
    """Add the controlled run's histories and readouts (docs/model.md s.12.2) to ds: phi_a,
    its rate, u, the lead and the commanded lead (u and the leads recomputed from the
    recorded state by the controller's own formula), the travel theta, and arrival, settling,
    overshoot and final error against the group's arrival tolerance."""
    ctl = prob.model.control
    Ka = float(prob.model.surface.Ka)
    h = res.histories
    u, delta, delta_cmd = ctl.acceleration(Ka, h.alpha, h.alphadot, h.phi_a, h.phi_a_rate)
    m = measure(res, ctl.goal, math.radians(control.arrival_tol_deg), Ka, ctl)
    ds["phase_a"] = ("time", np.degrees(h.phi_a),
                     {"long_name": "angular phase phi_a (controlled state)", "units": "degree"})
    ds["phase_a_rate"] = ("time", h.phi_a_rate.copy(),
                          {"long_name": "rate of the angular phase", "units": "rad s-1"})
    ds["phase_a_acceleration"] = ("time", u, {"long_name": "servo output u = phi_a''",
                                              "units": "rad s-2"})
    ds["lead"] = ("time", np.degrees(delta), {"long_name": "lead of the carrying cavity "
                                              "over the contact", "units": "degree"})
    ds["lead_command"] = ("time", np.degrees(delta_cmd), {"long_name": "lead commanded by "
                                                          "the outer loop", "units": "degree"})
    ds["travel"] = ("time", np.degrees(h.alpha - ctl.alpha0),
                    {"long_name": "travel theta = alpha - alpha(0)", "units": "degree"})
    ds.attrs.update({
        "control": 1,
        "control_goal_deg": math.degrees(ctl.goal),
        "control_arrival_tol_deg": control.arrival_tol_deg,
        "control_k_theta": ctl.k_theta,
        "control_k_omega": ctl.k_omega,
        "control_omega_max": ctl.omega_max,
        "control_delta_max_deg": math.degrees(ctl.delta_max),
        "control_omega_n": ctl.omega_n,
        "control_zeta": ctl.zeta,
        "control_u_max": ctl.u_max,
        "arrival_time": m.arrival,
        "settling_time": m.settling,
        "overshoot_deg": m.overshoot,
        "final_error_deg": m.final_error,
        "max_lead_deg": m.max_delta,
        "max_phase_a_rate": m.max_phidot,
        "max_phase_a_acceleration": m.max_u,
    })
