"""Run one sphere problem through the compiled driver and collect its result.

Importing this module loads the compiler (numba); creatio.dynamics exposes :func:`simulate`
lazily so that building and validating problems never does.
"""

from __future__ import annotations

import math

from creatio.dynamics import solvers
from creatio.dynamics import status as st
from creatio.dynamics.problem import (
    COL_ALPHA,
    COL_AZIMUTH,
    COL_CAVITY_R,
    COL_DISSIPATION,
    COL_ENERGY,
    COL_F,
    COL_KINETIC,
    COL_MARKER,
    COL_N,
    COL_OMEGA,
    COL_POTENTIAL,
    COL_Q,
    COL_R,
    COL_RESIDUAL,
    COL_SLIP,
    COL_SPEED,
    COL_SPIN,
    COL_SPIN_RATE,
    COL_T,
    COL_V,
    COL_WORK,
    COL_X,
    SimulationResult,
    SphereProblem,
    UnstableStepError,
    normal_estimate,
    slip_rate,
    stability_limit,
)
from creatio.dynamics.solvers.driver import run
from creatio.dynamics.sphere import E_E0
from creatio.model import sphere as contact

__all__ = ["simulate"]


def simulate(problem: SphereProblem) -> SimulationResult:
    """Integrate one sphere run with problem.method; return its histories and extrema.

    Raises UnstableStepError when dt exceeds stability_limit(problem) unless allow_unstable
    is set (then the run goes ahead and the result carries a warning).
    """
    warnings: list[str] = []
    limit = stability_limit(problem)
    name = problem.method.upper()
    bound = solvers.get(problem.method).stability_bound if math.isfinite(limit) else math.inf
    if problem.dt > limit:
        n_est = normal_estimate(problem)
        rate = slip_rate(problem, n_est)
        message = (
            f"dt = {problem.dt} s exceeds the {name} stability limit {limit:.6g} s of the "
            f"regularised friction (mu = {problem.mu}, eps = {problem.eps} m/s, m = {problem.m} "
            f"kg, b = {problem.b} m): the largest stable dt is {limit:.6g} s "
            f"(slip rate 3.5 mu N / (m eps) = {rate:.4g} 1/s at the a-priori N = {n_est:.4g} N; "
            f"lambda dt = {rate * problem.dt:.3g}, {name} needs <= {bound:.4g})"
        )
        if not problem.allow_unstable:
            raise UnstableStepError(message)
        warnings.append("allow_unstable override: " + message)
    rot = problem.rotation_integrated
    en = bool(problem.energy)
    args, kwargs = problem.driver_arguments()
    out = args[4]
    (status, steps, rows, evals, ext, rejected, jacobians, factorisations, stop_time) = run(
        *args, **kwargs)
    min_n, max_n, max_slip, max_res, max_track, min_clear, max_bk = (
        float(v) for v in ext[:E_E0]
    )
    if problem.mu > 0.0 and math.isfinite(max_n) and math.isfinite(bound):
        observed = contact.stable_step(bound, slip_rate(problem, max_n))
        if problem.dt > observed:
            warnings.append(
                f"max N = {max_n:.6g} N during the run puts the {name} stability limit at "
                f"{observed:.6g} s, below dt = {problem.dt} s (mu = {problem.mu}, "
                f"eps = {problem.eps} m/s): slip may chatter"
            )
    h = out[:rows]
    return SimulationResult(
        t=h[:, COL_T].copy(),
        X=h[:, COL_X : COL_X + 3].copy(),
        R=h[:, COL_R].copy(),
        alpha=h[:, COL_ALPHA].copy(),
        V=h[:, COL_V : COL_V + 3].copy(),
        speed=h[:, COL_SPEED].copy(),
        N=h[:, COL_N].copy(),
        f=h[:, COL_F : COL_F + 3].copy(),
        slip_speed=h[:, COL_SLIP].copy(),
        omega=h[:, COL_OMEGA : COL_OMEGA + 3].copy(),
        spin_rate=h[:, COL_SPIN_RATE].copy(),
        cumulative_spin=h[:, COL_SPIN].copy(),
        Q=h[:, COL_Q : COL_Q + 4].copy(),
        marker=h[:, COL_MARKER : COL_MARKER + 3].copy(),
        azimuth=h[:, COL_AZIMUTH].copy(),
        kinetic=h[:, COL_KINETIC].copy(),
        potential=h[:, COL_POTENTIAL].copy(),
        energy=h[:, COL_ENERGY].copy(),
        surface_work=h[:, COL_WORK].copy(),
        friction_dissipation=h[:, COL_DISSIPATION].copy(),
        energy_residual=h[:, COL_RESIDUAL].copy(),
        cavity_R=h[:, COL_CAVITY_R].copy(),
        min_N=float(min_n),
        max_N=float(max_n),
        max_slip_speed=float(max_slip),
        max_energy_residual=float(max_res),
        max_cavity_tracking_error=float(max_track),
        min_edge_clearance=float(min_clear),
        max_b_kappa=float(max_bk),
        status=st.NAMES[status],
        stop_time=float(stop_time),
        steps=int(steps),
        rhs_evals=int(evals),
        rotation_integrated=rot,
        energy_integrated=en,
        dt=problem.dt,
        stability_limit=limit,
        warnings=warnings,
        method=problem.method,
        rejected_steps=int(rejected),
        jacobians=int(jacobians),
        lu_factorisations=int(factorisations),
    )
