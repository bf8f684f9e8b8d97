"""Run one sphere problem through the compiled driver and collect its result.

Importing this module loads the compiler (numba); creatio.dynamics exposes :func:`simulate`
lazily so that building and validating problems never does.
"""

from __future__ import annotations

import math
import sys

import numpy as np

from creatio.dynamics import solvers
from creatio.dynamics import status as st
from creatio.dynamics.layout import (
    COL_ALPHA,
    COL_ALPHADOT,
    COL_AZIMUTH,
    COL_CAVITY_R,
    COL_CELL_U,
    COL_CELL_V,
    COL_CONFINE,
    COL_DISSIPATION,
    COL_ENERGY,
    COL_F,
    COL_HZ_ORBITAL,
    COL_HZ_SPIN,
    COL_HZ_STRUCTURE,
    COL_KINETIC,
    COL_MARKER,
    COL_N,
    COL_OMEGA,
    COL_PHI_A,
    COL_PHI_A_RATE,
    COL_POTENTIAL,
    COL_Q,
    COL_R,
    COL_RESIDUAL,
    COL_SLIP,
    COL_SPEED,
    COL_SPIN,
    COL_SPIN_RATE,
    COL_T,
    COL_THETA,
    COL_THETA_RATE,
    COL_V,
    COL_WORK,
    COL_WORLD_AZIMUTH,
    COL_X,
    E_E0,
    E_LEFT,
    E_MAX_HZ_DRIFT,
    E_MAX_IS_THETA,
    E_MAX_RHO,
    E_MAX_THETA_RATE,
    FL_IMPACT_CAP,
    FL_RESTITUTION,
    FL_RESUME_SPEED,
    FL_START_HEIGHT,
    NCOL,
    NEV,
    NFL,
    X_MAX_GAP,
)
from creatio.dynamics.problem import (
    Counts,
    EventLog,
    Extrema,
    Histories,
    SimulationResult,
    SphereProblem,
    check_stable,
    normal_estimate,
    slip_rate,
    stability_limit,
)
from creatio.dynamics.progress import budget_message
from creatio.dynamics.solvers.driver import run
from creatio.dynamics.solvers.flight import FLIGHT, run_flight
from creatio.model import sphere as contact
from creatio.model.numerics import steps_in

__all__ = ["collapse_cause", "compiled_call", "simulate"]

#: Where each of :class:`Histories` sits in the driver's history table: its first column and
#: its width (creatio.dynamics.layout COL_*).
_COLUMNS: dict[str, tuple[int, int]] = {
    "t": (COL_T, 1),
    "X": (COL_X, 3),
    "R": (COL_R, 1),
    "alpha": (COL_ALPHA, 1),
    "alphadot": (COL_ALPHADOT, 1),
    "V": (COL_V, 3),
    "speed": (COL_SPEED, 1),
    "N": (COL_N, 1),
    "f": (COL_F, 3),
    "slip_speed": (COL_SLIP, 1),
    "omega": (COL_OMEGA, 3),
    "spin_rate": (COL_SPIN_RATE, 1),
    "cumulative_spin": (COL_SPIN, 1),
    "Q": (COL_Q, 4),
    "marker": (COL_MARKER, 3),
    "azimuth": (COL_AZIMUTH, 1),
    "kinetic": (COL_KINETIC, 1),
    "potential": (COL_POTENTIAL, 1),
    "energy": (COL_ENERGY, 1),
    "surface_work": (COL_WORK, 1),
    "friction_dissipation": (COL_DISSIPATION, 1),
    "energy_residual": (COL_RESIDUAL, 1),
    "cavity_R": (COL_CAVITY_R, 1),
    "cell_u": (COL_CELL_U, 1),
    "cell_v": (COL_CELL_V, 1),
    "theta": (COL_THETA, 1),
    "theta_rate": (COL_THETA_RATE, 1),
    "hz_structure": (COL_HZ_STRUCTURE, 1),
    "hz_orbital": (COL_HZ_ORBITAL, 1),
    "hz_spin": (COL_HZ_SPIN, 1),
    "confinement_work": (COL_CONFINE, 1),
    "world_azimuth": (COL_WORLD_AZIMUTH, 1),
    "phi_a": (COL_PHI_A, 1),
    "phi_a_rate": (COL_PHI_A_RATE, 1),
}
#: The histories recorded on the structure path only (NaN off it).
_STRUCTURE = ("theta", "theta_rate", "hz_structure", "hz_orbital", "hz_spin",
              "confinement_work")


def _run_arguments(problem: SphereProblem) -> tuple[tuple, dict]:
    """(positional, keyword) arguments of creatio.dynamics.solvers.driver.run: the method,
    parameters, laws, initial state, a preallocated history table, and the step plan.

    Fixed-step runs take n_steps = t_end / dt steps with a history row every
    interval / dt; adaptive ones start with the solver's first_step (h0, else dt) and, like
    dense output, write a row per output time.
    """
    sv, out = problem.solver, problem.output
    rot, en = problem.rotation_integrated, bool(out.energy)
    if problem.adaptive or sv.dense_output:
        n_steps, stride = math.ceil(out.t_end / out.interval * (1 - 1e-12)), 1
    else:
        n_steps = steps_in(out.t_end, sv.dt)
        stride = steps_in(out.interval, sv.dt)
    table = np.empty((n_steps // stride + 3, NCOL))
    args = (solvers.get(sv.method), problem.run_parameters(), problem.law_matrix(),
            problem.initial_state(rot, en), table)
    kwargs = {
        "t_end": out.t_end, "interval": out.interval, "h0": sv.first_step,
        "n_steps": 0 if problem.adaptive else n_steps, "stride": stride,
        "rtol": sv.rtol, "atol": sv.atol, "fixed": not problem.adaptive,
        "max_evals": sv.max_rhs_evals, "progress": sv.progress_interval,
        "rotation": rot, "energy": en,
        "free": problem.structure_free, "dense": sv.dense_output,
        "control": problem.controlled,
    }
    return args, kwargs


def _flight_arguments(problem: SphereProblem) -> tuple[np.ndarray, np.ndarray]:
    """The hybrid loop's extra arguments: an empty event table sized for the impact cap over
    the run, and the flight settings (creatio.dynamics.layout FL_*)."""
    ev = problem.events
    rows = int(3 * ev.impact_cap * problem.output.t_end) + 64
    fl = np.empty(NFL)
    fl[FL_RESTITUTION] = ev.restitution
    fl[FL_RESUME_SPEED] = ev.resume_speed
    fl[FL_IMPACT_CAP] = ev.impact_cap
    fl[FL_START_HEIGHT] = problem.start.height
    return np.full((rows, NEV), math.nan), fl


def compiled_call(problem: SphereProblem):
    """A zero-argument call of the compiled run with every argument prepared, for timing the
    core alone; returns the driver's result tuple."""
    args, kwargs = _run_arguments(problem)
    return lambda: run(*args, **kwargs)


def simulate(problem: SphereProblem) -> SimulationResult:
    """Integrate one sphere run with its solver; return its histories and extrema.

    Raises UnstableStepError when dt exceeds the friction stability limit unless the solver
    allows it (check_stable: then the run goes ahead and the result carries the warning). A
    problem with an equilibrium start and no acceptable equilibrium is not run: its result
    has status no_equilibrium, no steps and empty histories.
    """
    eq = problem.equilibrium
    if eq is not None and not eq.acceptable:
        return _no_equilibrium(problem, eq.reason)
    warnings: list[str] = []
    unstable = check_stable(problem)
    if unstable:
        warnings.append("allow_unstable override: " + unstable)
    limit = stability_limit(problem)
    sv, sp = problem.solver, problem.model.sphere
    name = sv.method.upper()
    bound = solvers.get(sv.method).stability_bound if math.isfinite(limit) else math.inf
    rot = problem.rotation_integrated
    en = bool(problem.output.energy)
    args, kwargs = _run_arguments(problem)
    out = args[4]
    events = np.empty((0, NEV))
    max_height = math.nan
    in_flight = False
    if problem.events.flight:
        ev, fl = _flight_arguments(problem)
        for key in ("rotation", "energy", "free", "dense"):
            kwargs.pop(key)
        (status, steps, rows, evals, ext, rejected, jacobians, factorisations, stop_time,
         n_events, fx, phase) = run_flight(*args, ev, fl, **kwargs)
        if n_events > ev.shape[0]:
            warnings.append(f"{n_events} events, only the first {ev.shape[0]} are in the "
                            "event table")
        events = ev[: min(int(n_events), ev.shape[0])].copy()
        max_height = float(fx[X_MAX_GAP])
        in_flight = int(phase) == FLIGHT
        newton = 0  # the flight loop runs explicit methods only
    else:
        (status, steps, rows, evals, ext, rejected, jacobians, factorisations, stop_time,
         newton) = run(*args, **kwargs)
    if status == st.BUDGET_EXCEEDED:
        message = budget_message(float(stop_time), problem.output.t_end, int(steps),
                                 sv.max_rhs_evals)
        print(f"creatio: {message}", file=sys.stderr, flush=True)
        warnings.append(message)
    elif status == st.STEP_SIZE_COLLAPSE:
        message = st.collapse_message(float(stop_time), problem.output.t_end, int(steps),
                                      sv.max_rhs_evals, collapse_cause(problem))
        print(f"creatio: {message}", file=sys.stderr, flush=True)
        warnings.append(message)
    min_n, max_n, max_slip, max_res, max_track, min_clear, max_bk = (
        float(v) for v in ext[:E_E0]
    )
    free = problem.structure_free
    max_rho = float(ext[E_MAX_RHO]) if free else math.nan
    if sp.mu > 0.0 and math.isfinite(max_n) and math.isfinite(bound):
        # on a free structure, with the largest horizontal radius the contact reached
        # (bounded by the centre's plus b)
        observed = contact.stable_step(
            bound, slip_rate(problem, max_n, max_rho if math.isfinite(max_rho) else None))
        if sv.dt > observed:
            warnings.append(
                f"max N = {max_n:.6g} N during the run puts the {name} stability limit at "
                f"{observed:.6g} s, below dt = {sv.dt} s (mu = {sp.mu}, "
                f"eps = {sp.eps} m/s): slip may chatter"
            )
    h = out[:rows]
    nan = np.full(rows, math.nan)
    histories = {name: _column(h, col, width) for name, (col, width) in _COLUMNS.items()}
    if not free:  # the structure's histories are NaN off its path, the world frame its own
        histories.update({name: nan.copy() for name in _STRUCTURE})
        histories["world_azimuth"] = h[:, COL_AZIMUTH].copy()
    fixed = math.isinf(problem.model.structure.inertia)
    start_R, start_alpha = problem.start_point
    return SimulationResult(
        histories=Histories(**histories),
        extrema=Extrema(
            min_N=float(min_n),
            max_N=float(max_n),
            max_slip_speed=float(max_slip),
            max_energy_residual=float(max_res),
            max_cavity_tracking_error=float(max_track),
            min_edge_clearance=float(min_clear),
            max_b_kappa=float(max_bk),
            max_hz_drift=float(ext[E_MAX_HZ_DRIFT]) if free and not fixed else math.nan,
            max_structure_momentum=(float(ext[E_MAX_IS_THETA]) if free and not fixed
                                    else math.nan),
            max_structure_rate=float(ext[E_MAX_THETA_RATE]) if free else math.nan,
            max_contact_radius=max_rho,
        ),
        counts=Counts(
            method=sv.method,
            dt=sv.dt,
            stability_limit=limit,
            rotation_integrated=rot,
            energy_integrated=en,
            structure_free=free,
            status=st.NAMES[status],
            stop_time=float(stop_time),
            steps=int(steps),
            rhs_evals=int(evals),
            rejected_steps=int(rejected),
            jacobians=int(jacobians),
            lu_factorisations=int(factorisations),
            newton_iterations=int(newton),
            warnings=warnings,
            start_R=float(start_R),
            start_alpha=float(start_alpha),
        ),
        events=EventLog(
            left_cavity_time=float(ext[E_LEFT]),
            flight=problem.events.flight,
            table=events,
            max_flight_height=max_height,
            ends_in_flight=in_flight,
        ),
    )


def _column(h: np.ndarray, col: int, width: int) -> np.ndarray:
    """A copy of one history of the driver's table: column col, or width columns from it."""
    return h[:, col].copy() if width == 1 else h[:, col : col + width].copy()


def collapse_cause(problem: SphereProblem) -> str:
    """The likely cause of a step-size collapse, naming the key to change: the friction's
    regularisation when its slip relaxation time m eps / (3.5 mu N), the model's smallest time
    scale, is below the sustained floor (t_end / max_rhs_evals: steps that resolve it cannot
    cover the run), else a right-hand side that is not smooth where the run stopped."""
    sp = problem.model.sphere
    floor = problem.output.t_end / problem.solver.max_rhs_evals
    if sp.mu > 0.0:
        relax = 1.0 / slip_rate(problem, normal_estimate(problem))
        if relax < floor:
            return (f"sphere.eps = {sp.eps:g} m/s: the friction's slip relaxation time "
                    f"m eps / (3.5 mu N) = {relax:.2g} s is below that floor (raise "
                    "sphere.eps)")
        return (f"a right-hand side that is not smooth where the run stopped (not sphere.eps: "
                f"the slip relaxation time m eps / (3.5 mu N) = {relax:.2g} s is above the "
                "floor)")
    return "a right-hand side that is not smooth where the run stopped (mu = 0: no friction)"


def _no_equilibrium(problem: SphereProblem, reason: str) -> SimulationResult:
    """The result of a run that was not run: no acceptable equilibrium start (s.8.1)."""
    return SimulationResult(
        histories=Histories(**{name: np.empty((0,) if width == 1 else (0, width))
                               for name, (_, width) in _COLUMNS.items()}),
        extrema=Extrema(),
        counts=Counts(
            method=problem.solver.method,
            dt=problem.solver.dt,
            stability_limit=stability_limit(problem),
            rotation_integrated=problem.rotation_integrated,
            energy_integrated=bool(problem.output.energy),
            structure_free=problem.structure_free,
            status=st.NAMES[st.NO_EQUILIBRIUM],
            stop_time=0.0,
            steps=0,
            rhs_evals=0,
            equilibrium_message=reason,
        ),
        events=EventLog(),
    )
