"""Physics boundaries of EN-02: push one parameter at a time until the model stops applying.

Each axis starts at the EN-02 default and moves outward over a coarse grid; a bisection
between the last ``ok`` value and the first failing one locates the boundary to about three
significant digits. Every point goes through the config layer (``resolve("en02", ...)``),
so a value the config refuses is recorded as ``refused`` (or ``refused_unstable`` for a dt
beyond the friction stability limit) with its message, and every run that stops early
keeps the model's own status (``contact_lost``, ``edge_crossed``, ``offset_singular``, ...).
Each boundary is set beside an independent analytic expectation where one exists.

Run ``python -m creatio.boundaries OUT_DIR`` for every axis (about half a minute).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from creatio.config import ConfigError, DynamicConfig, resolve
from creatio.dynamics import SimulationResult, UnstableStepError, simulate
from creatio.dynamics.core import STATUS_NAMES

__all__ = [
    "AXES",
    "Axis",
    "STATUSES",
    "analytic",
    "bottom_b_kappa",
    "evaluate",
    "explore",
    "figure",
    "main",
    "stable_dt",
    "write_boundaries",
]

STUDY = "en02"
#: Every status a point can get: the model's stop statuses, then the two refusals.
STATUSES = (*STATUS_NAMES, "refused", "refused_unstable")
#: Status of the run whose physics a point records ("not_run" when nothing could run).
RUN_STATUSES = (*STATUS_NAMES, "not_run")
#: Relative width of the final bisection bracket (about three significant digits).
RTOL = 1e-3
#: Fraction of the config's step_limit() a stable rerun may use.
STABLE_FRACTION = 0.8
#: Mantissas of the "nice" steps tried for a stable rerun (times powers of ten).
NICE_MANTISSAS = (5.0, 4.0, 2.5, 2.0, 1.0)
#: Sampled histories that must stay finite up to a run's stop (energy columns are NaN when
#: the energy bookkeeping is off, by design, so they are not checked).
HISTORIES = ("t", "X", "R", "alpha", "V", "speed", "N", "f", "slip_speed", "omega",
             "spin_rate", "cumulative_spin", "Q", "marker", "azimuth", "cavity_R")
_COLOURS = {
    "ok": "tab:green",
    "contact_lost": "tab:red",
    "left_annulus": "tab:purple",
    "edge_crossed": "tab:orange",
    "offset_singular": "tab:blue",
    "non_finite": "black",
    "refused": "tab:gray",
    "refused_unstable": "tab:brown",
}


@dataclass(frozen=True)
class Axis:
    """One boundary axis: the config key it moves, its outward grid, units and meaning."""

    name: str
    key: str
    long_name: str
    units: str
    grid: tuple[float, ...]
    description: str
    log: bool = False
    quantum_is_dt: bool = False
    stable_rerun: bool = False

    def overrides(self, value: float) -> list[str]:
        """Hydra overrides that put this axis at value."""
        text = repr(float(value))
        if self.name == "gamma":
            return [f"phases.gamma.phi0={text}", "phases.gamma.unit=deg"]
        return [f"{self.key}={text}"]


AXES: dict[str, Axis] = {
    "T": Axis(
        "T", "phases.T", "cycle duration of the pattern", "s",
        (120.0, 90.0, 60.0, 45.0, 30.0, 24.0, 20.0, 16.0, 12.0, 10.0, 9.0, 8.0, 7.5, 7.0,
         6.5, 6.0, 5.0, 4.0, 3.0, 2.0),
        "faster pattern (study.duration follows T): the cavity must carry the sphere round "
        "against the centrifugal pull",
        log=True, quantum_is_dt=True,
    ),
    "A": Axis(
        "A", "geometry.A", "corrugation amplitude", "m",
        (0.18, 0.2, 0.22, 0.24, 0.26, 0.28, 0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65, 0.67,
         0.68, 0.7),
        "deeper corrugation: the cavity bottom curves more (b kappa -> 1); A >= R0 is refused",
    ),
    "b": Axis(
        "b", "sphere.b", "sphere radius", "m",
        (0.12, 0.14, 0.16, 0.18, 0.2, 0.22, 0.25, 0.3, 0.35, 0.4, 0.43, 0.45, 0.5, 0.6, 0.8,
         1.0),
        "bigger sphere: offset surface singular (b kappa -> 1), then the envelope crosses an edge",
    ),
    "gamma": Axis(
        "gamma", "phases.gamma.phi0", "inclination of the generator", "degree",
        tuple(float(g) for g in range(0, 91, 5)),
        "steeper cone (phases.gamma.unit=deg): gravity pulls the sphere out of the cavity "
        "towards the inner edge",
    ),
    "mu": Axis(
        "mu", "sphere.mu", "friction coefficient", "1",
        (0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0, 20.0),
        "stiffer friction: the default dt leaves the RK4 stability region (refused_unstable); "
        "each value is also run at a stable dt",
        log=True, stable_rerun=True,
    ),
}


# ------------------------------------------------------------------------------ points
@dataclass
class Point:
    """The outcome of one parameter value (status, the recorded run's figures, notes)."""

    value: float
    kind: str
    status: str
    run_status: str = "not_run"
    message: str = ""
    dt: float = math.nan
    step_limit: float = math.nan
    duration: float = math.nan
    stop_time: float = math.nan
    min_N: float = math.nan
    max_N: float = math.nan
    max_b_kappa: float = math.nan
    min_edge_clearance: float = math.nan
    max_cavity_tracking_error: float = math.nan
    max_slip_speed: float = math.nan
    final_R: float = math.nan
    steps: float = math.nan
    n_warnings: int = 0
    histories_finite: int = -1
    half_dt_status: str = ""
    half_dt_stop_time: float = math.nan
    anomalies: list[str] = dataclasses.field(default_factory=list)
    result: SimulationResult | None = dataclasses.field(default=None, repr=False)


def stable_dt(limit: float, nominal: float, output_interval: float, duration: float) -> float:
    """Largest "nice" step (m 10^e, m in 5, 4, 2.5, 2, 1) <= min(nominal, 0.8 limit) that
    divides both the output interval and the duration (what the config accepts)."""
    cap = min(nominal, STABLE_FRACTION * limit)
    for e in range(0, -12, -1):
        for m in NICE_MANTISSAS:
            dt = float(f"{m}e{e}")
            if dt <= cap and _divides(dt, output_interval) and _divides(dt, duration):
                return dt
    raise ValueError(f"no nice dt below {cap} s divides {output_interval} s and {duration} s")


def _divides(dt: float, span: float) -> bool:
    ratio = span / dt
    return round(ratio) >= 1 and abs(ratio - round(ratio)) <= 1e-9 * ratio


def _quantize(value: float, quantum: float | None) -> float:
    if quantum is None:
        return float(value)
    return round(round(value / quantum) * quantum, 12)


def _resolve_point(overrides: list[str]) -> tuple[DynamicConfig | None, str, str, float]:
    """(config, status, message, step_limit) of one override set, refusals classified."""
    try:
        cfg = resolve(STUDY, overrides).obj
        return cfg, "ok", "", cfg.step_limit()
    except ConfigError as error:
        message = str(error)
    try:
        relaxed = resolve(STUDY, [*overrides, "solver.allow_unstable=true"]).obj
    except ConfigError:
        return None, "refused", message, math.nan
    limit = relaxed.step_limit()
    status = "refused_unstable" if relaxed.solver.dt > limit else "refused"
    return None, status, message, limit


def _run(cfg: DynamicConfig, dt: float) -> tuple[SimulationResult | None, str]:
    """simulate() at dt with the energy bookkeeping off; (None, message) if dt is unstable."""
    problem = dataclasses.replace(cfg.sphere_problem(dt), energy=False)
    try:
        return simulate(problem), ""
    except UnstableStepError as error:
        return None, str(error)


def _finite_check(res: SimulationResult) -> tuple[int, list[str]]:
    """1 if every checked history is finite before the stop row (and at it, unless the
    status is non_finite), else 0 with a note naming the history and the time."""
    notes = []
    for name in HISTORIES:
        h = np.asarray(getattr(res, name))
        rows = h.reshape(h.shape[0], -1)
        body = rows if res.status != "non_finite" else rows[:-1]
        bad = ~np.isfinite(body).all(axis=1)
        if bad.any():
            notes.append(f"{name} non-finite at t = {res.t[np.argmax(bad)]:.6g} s before the "
                         f"stop (status {res.status})")
    return int(not notes), notes


def _consistency(res: SimulationResult, duration: float) -> list[str]:
    """Notes where a result contradicts its own status (these would be model bugs)."""
    notes = []
    if res.status == "ok" and not math.isclose(res.stop_time, duration, rel_tol=1e-9):
        notes.append(f"status ok but stop_time {res.stop_time} != duration {duration}")
    if res.status == "contact_lost" and not (res.N[-1] <= 0.0 and res.min_N <= 0.0):
        notes.append(f"contact_lost with N = {res.N[-1]:.6g} at the stop")
    if res.status not in ("contact_lost", "non_finite") and res.min_N <= 0.0:
        notes.append(f"min N = {res.min_N:.6g} <= 0 but status {res.status}")
    if res.status == "offset_singular" and not res.max_b_kappa >= 1.0:
        notes.append(f"offset_singular with max b kappa = {res.max_b_kappa:.6g} < 1")
    if res.status == "edge_crossed" and not res.min_edge_clearance < 0.0:
        notes.append(f"edge_crossed with min clearance = {res.min_edge_clearance:.6g} >= 0")
    return notes


def _record(point: Point, res: SimulationResult, duration: float) -> None:
    """Copy a run's figures into a point and check its histories and self-consistency."""
    point.run_status = res.status
    point.dt = res.dt
    point.duration = duration
    point.stop_time = res.stop_time
    point.min_N = res.min_N
    point.max_N = res.max_N
    point.max_b_kappa = res.max_b_kappa
    point.min_edge_clearance = res.min_edge_clearance
    point.max_cavity_tracking_error = res.max_cavity_tracking_error
    point.max_slip_speed = res.max_slip_speed
    point.final_R = float(res.R[-1])
    point.steps = float(res.steps)
    point.n_warnings = len(res.warnings)
    point.histories_finite, notes = _finite_check(res)
    point.anomalies += notes + _consistency(res, duration)
    if res.warnings:
        point.message = "; ".join(filter(None, [point.message, *res.warnings]))
    point.result = res


def _half_dt(point: Point, cfg: DynamicConfig) -> None:
    """Rerun a point at dt / 2: its status must not be an artefact of the step."""
    res, message = _run(cfg, 0.5 * point.dt)
    point.half_dt_status = res.status if res is not None else "refused_unstable"
    point.half_dt_stop_time = res.stop_time if res is not None else math.nan
    if res is not None and res.status != point.run_status:
        point.anomalies.append(
            f"dt / 2 gives {res.status} at t = {res.stop_time:.6g} s instead of "
            f"{point.run_status} at {point.stop_time:.6g} s"
        )


def evaluate(axis: Axis, value: float, dt: float | None = None, kind: str = "grid") -> Point:
    """Resolve, validate and (if accepted, or at a stable dt on a stable_rerun axis) run one
    value of an axis; never raises for a refused value, records it instead."""
    extra = [f"solver.dt={dt!r}"] if dt is not None else []
    overrides = [*axis.overrides(value), *extra]
    cfg, status, message, limit = _resolve_point(overrides)
    point = Point(value=float(value), kind=kind, status=status, message=message,
                  step_limit=limit)
    if cfg is not None:
        res, unstable = _run(cfg, cfg.solver.dt)
        if res is None:
            point.status, point.message = "refused_unstable", unstable
            point.anomalies.append("config accepted a dt that simulate() refuses: " + unstable)
        else:
            point.status = res.status
            _record(point, res, cfg.study.duration)
            if res.warnings:
                _half_dt(point, cfg)
    if point.run_status == "not_run" and axis.stable_rerun and status == "refused_unstable":
        relaxed = resolve(STUDY, [*overrides, "solver.allow_unstable=true"]).obj
        step = stable_dt(limit, relaxed.solver.dt, relaxed.solver.output_interval,
                         relaxed.study.duration)
        stable_cfg, stable_status, stable_message, _ = _resolve_point(
            [*axis.overrides(value), f"solver.dt={step!r}"]
        )
        if stable_cfg is None:
            point.anomalies.append(f"stable dt {step} refused: {stable_message}")
        else:
            res, unstable = _run(stable_cfg, step)
            if res is None:
                point.anomalies.append(f"stable dt {step} refused by simulate(): {unstable}")
            else:
                _record(point, res, stable_cfg.study.duration)
                if res.warnings:
                    _half_dt(point, stable_cfg)
    return point


# ------------------------------------------------------------------------------ analytics
def _cavity_start(cfg: DynamicConfig) -> tuple[float, float, float, float]:
    """(k, u0, cos v0, R_init) at the start: u = k R + phi_r, v = Ka alpha + phi_a."""
    g, ph = cfg.geometry, cfg.phases
    k = 2.0 * math.pi * g.Kr / g.dR
    law_r, law_a, _ = ph.laws()
    R = cfg.study.initial.R
    u0 = k * R + law_r.coefficients()[0]
    v0 = g.Ka * math.radians(cfg.study.initial.alpha_deg) + law_a.coefficients()[0]
    return k, u0, math.cos(v0), R


def bottom_b_kappa(cfg: DynamicConfig) -> float:
    """b times the larger principal curvature at the start, for a start at a cavity bottom
    (sin u = 1, cos v = -1): principal curvatures A k^2 and (A Ka^2 + rho sin gamma) / rho^2."""
    g, sp = cfg.geometry, cfg.sphere
    k, _, _, R = _cavity_start(cfg)
    gamma = cfg.phases.gamma.to_law().coefficients()[0]
    rho = g.R0 + R * math.cos(gamma) + g.A * math.sin(gamma)
    return sp.b * max(g.A * k * k, (g.A * g.Ka**2 + rho * math.sin(gamma)) / rho**2)


def _at_bottom(cfg: DynamicConfig) -> bool:
    _, u0, cv0, _ = _cavity_start(cfg)
    return math.isclose(math.sin(u0), 1.0, abs_tol=1e-9) and math.isclose(cv0, -1.0,
                                                                          abs_tol=1e-9)


def _rk4_real_limit() -> float:
    """The negative real root of |R(z)| = 1 for RK4: z^3 + 4 z^2 + 12 z + 24 = 0."""
    roots = np.roots([1.0, 4.0, 12.0, 24.0])
    return float(-roots[np.abs(roots.imag) < 1e-12].real[0])


def _section(cfg: DynamicConfig, gamma: float, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre height and generator coordinate of a sphere touching the meridian section
    through the start (cos v fixed) at contact coordinate R, inclination gamma (rad)."""
    g, b = cfg.geometry, cfg.sphere.b
    k, u0, cv0, R_init = _cavity_start(cfg)
    u = u0 + k * (R - R_init)
    W = g.A * np.sin(u) * cv0
    WR = g.A * k * np.cos(u) * cv0
    sg, cg = math.sin(gamma), math.cos(gamma)
    tr, tz = cg - WR * sg, sg + WR * cg  # c_R in (e_rho, e_z)
    J = np.hypot(tr, tz)
    Xr = g.R0 + R * cg - W * sg - b * tz / J
    Xz = R * sg + W * cg + b * tr / J
    return Xz, (Xr - g.R0) * cg + Xz * sg


def _escapes_inward(cfg: DynamicConfig, gamma: float) -> bool:
    """Whether a sphere released at rest at the start rolls (energy conserved) over the
    inner edge: its centre height stays below the start height until the clearance is 0."""
    R_init, b = cfg.study.initial.R, cfg.sphere.b
    R = np.linspace(R_init, R_init - cfg.geometry.dR, 200001)
    H, sx = _section(cfg, gamma, R)
    edge = np.flatnonzero(sx < b)
    if edge.size == 0:
        return False
    return bool(np.all(H[1 : edge[0]] < H[0]))


def _gamma_energy_limit(cfg: DynamicConfig) -> float:
    """Smallest inclination (deg) at which the released sphere escapes over the inner edge."""
    lo, hi = 0.0, 90.0
    if _escapes_inward(cfg, 0.0) or not _escapes_inward(cfg, math.radians(hi)):
        return math.nan
    while hi - lo > 1e-9:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if _escapes_inward(cfg, math.radians(mid)) else (mid, hi)
    return 0.5 * (lo + hi)


def _gamma_singular_limit(cfg: DynamicConfig) -> float:
    """Inclination (deg) where b kappa at the start reaches 1 (offset singular from t = 0)."""
    g, b = cfg.geometry, cfg.sphere.b
    k, _, _, R = _cavity_start(cfg)

    def excess(deg: float) -> float:
        s, c = math.sin(math.radians(deg)), math.cos(math.radians(deg))
        rho = g.R0 + R * c + g.A * s
        return b * max(g.A * k * k, (g.A * g.Ka**2 + rho * s) / rho**2) - 1.0

    if excess(0.0) >= 0.0 or excess(90.0) < 0.0:
        return math.nan
    lo, hi = 0.0, 90.0
    while hi - lo > 1e-9:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if excess(mid) >= 0.0 else (mid, hi)
    return 0.5 * (lo + hi)


def _peak_pattern_rate(cfg: DynamicConfig, T: float) -> float:
    """Peak |d phi_a / dt| (rad/s) of a quintic angular law of cycle T: |delta| 15 / (8 T)."""
    return abs(cfg.phases.a.to_law(T).coefficients()[2]) * 15.0 / (8.0 * T)


def _T_hold_limit(cfg: DynamicConfig) -> float:
    """Cycle T below which no quasi-static hold exists at peak pattern speed: a rolling
    sphere needs a radial push (7/5) Omega^2 rho_centre that the cavity's outer wall
    (slope W_R along the meridian) must supply, g W_R >= (7/5) Omega^2 rho_centre."""
    g, b, grav = cfg.geometry, cfg.sphere.b, cfg.sphere.g
    k, u0, cv0, R_init = _cavity_start(cfg)
    R = np.linspace(R_init, R_init + 0.5 * g.dR / g.Kr, 200001)
    WR = g.A * k * np.cos(u0 + k * (R - R_init)) * cv0
    rho_c = g.R0 + R - b * WR / np.sqrt(1.0 + WR**2)
    omega2 = float(np.max(grav * WR / (1.4 * rho_c)))
    if omega2 <= 0.0:
        return math.nan
    # Omega = phi_a' / Ka and phi_a' peaks at |delta| 15 / (8 T): solve for T.
    return _peak_pattern_rate(cfg, 1.0) / (g.Ka * math.sqrt(omega2))


def analytic(axis: str, dt: float | None = None) -> tuple[float, str, dict[str, float]]:
    """Independent expectation of an axis's first failure: (value, explanation, extras)."""
    cfg = resolve(STUDY, [f"solver.dt={dt!r}"] if dt is not None else []).obj
    g, sp = cfg.geometry, cfg.sphere
    k, _, _, R = _cavity_start(cfg)
    rho = g.R0 + R
    curv = max(k * k, g.Ka**2 / rho**2)  # per unit A, at the bottom, gamma = 0
    bottom = _at_bottom(cfg) and cfg.phases.gamma.to_law().coefficients()[0] == 0.0
    if axis == "A":
        if not bottom:
            return math.nan, "start not at a flat cavity bottom: no closed form", {}
        return 1.0 / (sp.b * curv), (
            "offset_singular where b A max(k^2, Ka^2 / rho^2) = 1 at the cavity bottom "
            f"(k^2 = {k * k:.4g}, Ka^2 / rho^2 = {g.Ka**2 / rho**2:.4g} 1/m^2, rho = {rho:.4g} m)"
        ), {"refused_at": g.R0}
    if axis == "b":
        if not bottom:
            return math.nan, "start not at a flat cavity bottom: no closed form", {}
        return 1.0 / (g.A * curv), (
            "offset_singular where b A max(k^2, Ka^2 / rho^2) = 1 at the cavity bottom "
            f"(rho = {rho:.4g} m); edge_crossed from b = R_init = {R:.4g} m"
        ), {"edge_crossed_from": R}
    if axis == "gamma":
        value = _gamma_energy_limit(cfg)
        extras = {
            "no_equilibrium_from_deg": math.degrees(math.atan(g.A * k)),
            "offset_singular_from_deg": _gamma_singular_limit(cfg),
        }
        return value, (
            "energy barrier: released at rest at the cavity bottom, the rolling sphere "
            "(no dissipation, pattern still) clears the inner edge; quasi-static equilibrium "
            f"is lost only at atan(A k) = {extras['no_equilibrium_from_deg']:.4g} deg; "
            f"offset singular from {extras['offset_singular_from_deg']:.4g} deg"
        ), extras
    if axis == "T":
        if cfg.phases.a.kind.value != "quintic":
            return math.nan, "the angular law is not quintic: no closed form", {}
        crest = _peak_pattern_rate(cfg, 1.0) * math.sqrt(g.A / sp.g)
        return _T_hold_limit(cfg), (
            "quasi-static hold at peak pattern speed of a rolling sphere, g W_R = (7/5) "
            f"Omega^2 rho; a crest sweeping under a sphere at rest outruns g below "
            f"T = {crest:.4g} s"
        ), {"crest_outruns_g_T": crest}
    if axis == "mu":
        # at rest at the flat bottom N = m g; limit = z* m eps / (3.5 mu 1.25 m g)
        n0 = sp.m * sp.g
        value = _rk4_real_limit() * sp.m * sp.eps / (3.5 * cfg.solver.dt * 1.25 * n0)
        return value, (
            "refused_unstable where 3.5 mu (1.25 m g) dt / (m eps) = 2.785 (RK4 real "
            f"stability root) at dt = {cfg.solver.dt} s"
        ), {}
    raise KeyError(f"unknown axis {axis!r}; choose from {', '.join(AXES)}")


# ------------------------------------------------------------------------------ explore
def _bisect(
    axis: Axis, ok: Point, bad: Point, fails: Callable[[Point], bool], dt: float | None,
    quantum: float | None, points: dict[float, Point], rtol: float,
    progress: Callable[[str], None] | None,
) -> tuple[Point, Point]:
    """Narrow [last ok, first failing] until its width is below rtol of the value."""
    while abs(bad.value - ok.value) > rtol * max(abs(ok.value), abs(bad.value)):
        mid = _quantize(0.5 * (ok.value + bad.value), quantum)
        if mid in (ok.value, bad.value):
            break
        if mid not in points:
            points[mid] = evaluate(axis, mid, dt, kind="bisection")
            if progress:
                progress(f"  {axis.name} = {mid:.6g}: {_label(points[mid])}")
        if fails(points[mid]):
            bad = points[mid]
        else:
            ok = points[mid]
    return ok, bad


def _label(p: Point) -> str:
    run = f" (run at dt = {p.dt:g}: {p.run_status})" if p.run_status != p.status else ""
    stop = f" at t = {p.stop_time:.4g} s" if p.status in STATUS_NAMES[1:] else ""
    return p.status + stop + run


def _first_failure(
    axis: Axis, ordered: list[Point], fails: Callable[[Point], bool], dt: float | None,
    quantum: float | None, points: dict[float, Point], bisect: bool, rtol: float,
    progress: Callable[[str], None] | None,
) -> tuple[Point, Point] | None:
    """(last ok, first failing) along the outward grid, bisected; None if nothing fails."""
    for i, p in enumerate(ordered):
        if fails(p):
            if i == 0:
                raise ValueError(f"axis {axis.name}: the EN-02 default already fails ({p.status})")
            ok = ordered[i - 1]
            if bisect:
                return _bisect(axis, ok, p, fails, dt, quantum, points, rtol, progress)
            return ok, p
    return None


def explore(
    axis: str,
    dt: float | None = None,
    bisect: bool = True,
    values: Sequence[float] | None = None,
    progress: Callable[[str], None] | None = None,
    rtol: float = RTOL,
) -> xr.Dataset:
    """Sweep one axis outward from the EN-02 default (grid, then bisection of the first
    failure) and return every point, the located boundary and the analytic expectation.

    dt overrides solver.dt (default: the config's); values replaces the axis's grid (its
    first value must be the model-valid start); progress receives one line per point;
    the bisection stops once the bracket is narrower than rtol times the value.
    """
    ax = AXES[axis]
    base = resolve(STUDY, [f"solver.dt={dt!r}"] if dt is not None else [])
    nominal = base.obj.solver.dt
    quantum = nominal if ax.quantum_is_dt else None
    grid = [_quantize(v, quantum) for v in (ax.grid if values is None else values)]
    points: dict[float, Point] = {}
    for v in grid:
        if v not in points:
            points[v] = evaluate(ax, v, dt)
            if progress:
                progress(f"  {ax.name} = {v:.6g}: {_label(points[v])}")
    ordered = [points[v] for v in dict.fromkeys(grid)]
    t0 = time.perf_counter()

    def fails(p: Point) -> bool:
        return p.status != "ok"

    def physics_fails(p: Point) -> bool:
        return p.run_status not in ("ok", "not_run")

    found = _first_failure(ax, ordered, fails, dt, quantum, points, bisect, rtol, progress)
    physics = found
    if ax.stable_rerun:
        physics = _first_failure(ax, ordered, physics_fails, dt, quantum, points, bisect,
                                 rtol, progress)
    checks = []
    bracket = {id(p): p for pair in (found, physics) if pair is not None for p in pair}
    for p in bracket.values():
        if p.run_status != "not_run" and not p.half_dt_status:
            _half_dt(p, resolve(STUDY, [*ax.overrides(p.value), f"solver.dt={p.dt!r}"]).obj)
        if p.half_dt_status:
            checks.append(f"{ax.name} = {p.value:.6g}: {p.run_status} at dt = {p.dt:g}, "
                          f"{p.half_dt_status} at dt / 2")
    value, explanation, extras = analytic(axis, dt)
    ds = _dataset(ax, points, found, physics, value, explanation, extras, base.obj,
                  ordered[-1].value)
    ds.attrs["boundary_dt_check"] = "; ".join(checks)
    ds.attrs["bisection_seconds"] = round(time.perf_counter() - t0, 3)
    return ds


def _transitions(points: list[Point]) -> str:
    """Where the status changes along the sorted values (e.g. offset_singular -> edge_crossed)."""
    out = []
    for a, b in zip(points, points[1:], strict=False):
        if a.status != b.status:
            out.append(f"{a.status} -> {b.status} between {a.value:.6g} and {b.value:.6g}")
    return "; ".join(out)


def _what_failed(p: Point | None, ax: Axis, last: float) -> str:
    """One sentence on why the failing point of a boundary failed."""
    if p is None:
        return f"nothing fails up to {ax.name} = {last:g}"
    at = f"at t = {p.stop_time:.4g} s" if math.isfinite(p.stop_time) else ""
    if p.status == "refused":
        return p.message
    if p.status == "refused_unstable":
        return (f"dt beyond the friction RK4 limit: the largest stable dt is "
                f"{p.step_limit:.4g} s")
    if p.status == "contact_lost":
        return f"normal reaction reached 0 (N = {p.min_N:.3g} N) {at}: the sphere takes off"
    if p.status == "edge_crossed":
        return (f"sphere envelope crossed an annulus edge {at} (clearance "
                f"{p.min_edge_clearance:.3g} m, final R = {p.final_R:.3g} m)")
    if p.status == "offset_singular":
        return (f"b kappa reached {p.max_b_kappa:.6g} >= 1 {at}: the sphere no longer fits "
                "the cavity bottom at one contact point")
    if p.status == "left_annulus":
        return f"contact point left 0 <= R <= dR {at} (final R = {p.final_R:.3g} m)"
    return f"non-finite state {at}"


_VARIABLES: dict[str, tuple[str, str]] = {
    "dt": ("time step of the recorded run", "s"),
    "step_limit": ("largest stable RK4 step of the config (friction slip relaxation)", "s"),
    "duration": ("simulated duration asked for", "s"),
    "stop_time": ("time at which the recorded run stopped", "s"),
    "min_N": ("minimum normal reaction over every step", "N"),
    "max_N": ("maximum normal reaction over every step", "N"),
    "max_b_kappa": ("maximum of b times the larger principal curvature", "1"),
    "min_edge_clearance": ("minimum clearance of the sphere envelope to the edges", "m"),
    "max_cavity_tracking_error": ("maximum |R - R_cavity|", "m"),
    "max_slip_speed": ("maximum slip speed of the contact point", "m s-1"),
    "final_R": ("contact coordinate R at the stop", "m"),
    "steps": ("RK4 steps taken by the recorded run", "1"),
    "n_warnings": ("warnings of the recorded run (e.g. max N beyond the stability limit)", "1"),
    "half_dt_stop_time": ("stop time of the rerun at dt / 2 (NaN if not rerun)", "s"),
}


def _dataset(
    ax: Axis, points: dict[float, Point], found: tuple[Point, Point] | None,
    physics: tuple[Point, Point] | None, value: float, explanation: str,
    extras: dict[str, float], cfg: DynamicConfig, last: float,
) -> xr.Dataset:
    """Assemble the points (sorted by value) and the located boundaries into a Dataset."""
    ps = [points[v] for v in sorted(points)]
    coords = {"value": ("value", np.array([p.value for p in ps]),
                        {"long_name": ax.long_name, "units": ax.units, "config_key": ax.key})}
    data: dict[str, Any] = {}
    for name, (long_name, units) in _VARIABLES.items():
        data[name] = ("value", np.array([float(getattr(p, name)) for p in ps]),
                      {"long_name": long_name, "units": units})
    data["status"] = ("value", np.array([p.status for p in ps], dtype=str),
                      {"long_name": "outcome at the nominal dt", "units": "",
                       "allowed_values": " ".join(STATUSES)})
    data["run_status"] = ("value", np.array([p.run_status for p in ps], dtype=str),
                          {"long_name": "status of the recorded run (at a stable dt when the "
                                        "nominal one is refused)", "units": "",
                           "allowed_values": " ".join(RUN_STATUSES)})
    data["half_dt_status"] = ("value", np.array([p.half_dt_status for p in ps], dtype=str),
                              {"long_name": "status of the rerun at dt / 2 (empty if none)",
                               "units": ""})
    data["kind"] = ("value", np.array([p.kind for p in ps], dtype=str),
                    {"long_name": "grid point or bisection point", "units": ""})
    data["message"] = ("value", np.array([p.message for p in ps], dtype=str),
                       {"long_name": "refusal message or run warnings", "units": ""})
    half_wave = 0.5 * cfg.geometry.dR / cfg.geometry.Kr
    track = np.array([p.max_cavity_tracking_error for p in ps])
    left = np.where(np.isfinite(track), (track > half_wave).astype(np.int8), -1).astype(np.int8)
    data["left_cavity"] = (
        "value", left,
        {"long_name": "radial excursion past the cavity's crest line, |R - R_c| > dR / (2 Kr) "
                      f"= {half_wave:g} m (the model has no stop status for it)", "units": "1",
         "flag_values": np.array([-1, 0, 1], dtype=np.int8),
         "flag_meanings": "not_run stayed left"},
    )
    data["histories_finite"] = (
        "value", np.array([p.histories_finite for p in ps], dtype=np.int8),
        {"long_name": "sampled histories finite up to the stop", "units": "1",
         "flag_values": np.array([-1, 0, 1], dtype=np.int8),
         "flag_meanings": "not_run non_finite finite"},
    )
    for prefix, pair, label in (("boundary", found, "first failure"),
                                ("physics_boundary", physics, "first failure of a run")):
        ok, bad = pair if pair is not None else (None, None)
        mid = 0.5 * (ok.value + bad.value) if pair is not None else math.nan
        data[prefix] = ((), mid, {"long_name": f"{label} along the axis (bracket midpoint)",
                                  "units": ax.units})
        data[f"{prefix}_ok"] = ((), ok.value if ok else math.nan,
                                {"long_name": f"last ok value before the {label}",
                                 "units": ax.units})
        data[f"{prefix}_fail"] = ((), bad.value if bad else math.nan,
                                  {"long_name": f"first value of the {label}",
                                   "units": ax.units})
        status = (bad.status if prefix == "boundary" else bad.run_status) if bad else "none"
        data[f"{prefix}_status"] = ((), status, {"long_name": f"status at the {label}",
                                                 "units": ""})
    data["analytic_boundary"] = ((), value, {"long_name": "analytic expectation of the first "
                                             "failure", "units": ax.units,
                                             "comment": explanation})
    anomalies = [f"{ax.name} = {p.value:.6g}: {a}" for p in ps for a in p.anomalies]
    ds = xr.Dataset(data, coords=coords)
    ds.attrs.update({
        "title": f"EN-02 physics boundary along {ax.key}",
        "axis": ax.name,
        "config_key": ax.key,
        "description": ax.description,
        "nominal_dt": cfg.solver.dt,
        "analytic": explanation,
        **{f"analytic_{k}": v for k, v in extras.items()},
        "what_failed": _what_failed(found[1] if found else None, ax, last),
        "physics_what_failed": _what_failed(physics[1] if physics else None, ax, last),
        "transitions": _transitions(ps),
        "anomalies": "; ".join(anomalies),
        "statuses": " ".join(STATUSES),
    })
    return ds


# ------------------------------------------------------------------------------ outputs
def figure(ds: xr.Dataset, path: str | Path) -> Path:
    """Six diagnostics against the axis value (dots: the recorded run, coloured by its
    status; bottom ticks: the status at the nominal dt), boundary and analytic lines."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    x = ds["value"].values
    status = ds["status"].values.astype(str)
    run_status = ds["run_status"].values.astype(str)
    with np.errstate(invalid="ignore", divide="ignore"):
        completed = ds["stop_time"].values / ds["duration"].values
    panels = (
        ("min_N", ds["min_N"].values, 0.0),
        ("max_b_kappa", ds["max_b_kappa"].values, 1.0),
        ("min_edge_clearance", ds["min_edge_clearance"].values, 0.0),
        ("stop_time / duration", completed, 1.0),
        ("max_slip_speed", ds["max_slip_speed"].values, None),
        ("max_cavity_tracking_error", ds["max_cavity_tracking_error"].values, None),
    )
    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5), sharex=True)
    ax_meta = AXES.get(str(ds.attrs.get("axis")))
    for axp, (name, y, ref) in zip(axes.flat, panels, strict=True):
        for st in dict.fromkeys(run_status):
            sel = (run_status == st) & np.isfinite(y)
            if sel.any():
                axp.scatter(x[sel], y[sel], s=22, color=_COLOURS.get(st, "k"), label=st,
                            zorder=3)
        for st in dict.fromkeys(status):
            sel = status == st
            axp.scatter(x[sel], np.full(sel.sum(), 0.0), marker="|", s=150,
                        color=_COLOURS.get(st, "k"), transform=axp.get_xaxis_transform(),
                        clip_on=False, label=st)
        if ref is not None:
            axp.axhline(ref, color="0.5", lw=0.8, ls=":")
        for var, style in (("boundary", "-"), ("physics_boundary", "--")):
            if np.isfinite(ds[var].values):
                axp.axvline(float(ds[var]), color="k", lw=1.0, ls=style)
        if np.isfinite(ds["analytic_boundary"].values):
            axp.axvline(float(ds["analytic_boundary"]), color="tab:red", lw=0.8, ls="-.")
        if name in ds:
            a = ds[name].attrs
            axp.set_ylabel(f"{name} [{a.get('units', '')}]")
            axp.set_title(a.get("long_name", name), fontsize=8.5)
        else:
            axp.set_ylabel(name)
            axp.set_title("fraction of the run completed", fontsize=8.5)
        positive = y[np.isfinite(y)]
        if name == "max_slip_speed" and positive.size and (positive > 0).all():
            axp.set_yscale("log")
        if ax_meta is not None and ax_meta.log:
            axp.set_xscale("log")
    units = ds["value"].attrs["units"]
    for axp in axes[1]:
        axp.set_xlabel(f"{ds['value'].attrs['long_name']} [{units}]")
    handles: dict[str, Any] = {}
    for axp in axes.flat:
        for h, lab in zip(*axp.get_legend_handles_labels(), strict=True):
            handles.setdefault(lab, h)
    handles["located boundary"] = plt.Line2D([], [], color="k")
    if not np.array_equal(ds["physics_boundary"].values, ds["boundary"].values, equal_nan=True):
        handles["physics boundary (stable dt)"] = plt.Line2D([], [], color="k", ls="--")
    handles["analytic expectation"] = plt.Line2D([], [], color="tab:red", ls="-.")
    fig.legend(handles.values(), handles.keys(), loc="lower center", ncol=6, fontsize=8,
               title="dots: status of the recorded run; bottom ticks: status at the nominal dt",
               title_fontsize=8)
    shown = "" if units == "1" else f" {units}"
    fig.suptitle(f"{ds.attrs.get('title', '')}: boundary {float(ds['boundary']):.5g}{shown} "
                 f"({ds['boundary_status'].item()}), analytic "
                 f"{float(ds['analytic_boundary']):.5g}{shown}")
    fig.tight_layout(rect=(0, 0.09, 1, 0.97))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def _fmt(x: float, digits: int = 5) -> str:
    return "-" if not math.isfinite(x) else f"{x:.{digits}g}"


def _markdown(datasets: Sequence[xr.Dataset]) -> str:
    """One table of the located boundaries, then per-axis transitions, checks, anomalies."""
    lines = [
        "# EN-02 physics boundaries",
        "",
        "Each axis moves one EN-02 parameter outward from its default; the boundary is the "
        "midpoint of the bisected bracket [last ok, first failure].",
        "",
        "| axis | key | boundary | bracket (ok -> fail) | failure status | analytic expectation "
        "| what failed |",
        "|---|---|---|---|---|---|---|",
    ]
    for ds in datasets:
        u = "" if ds["value"].attrs["units"] == "1" else " " + ds["value"].attrs["units"]
        lines.append(
            f"| {ds.attrs['axis']} | `{ds.attrs['config_key']}` | "
            f"{_fmt(float(ds['boundary']))}{u} | "
            f"{_fmt(float(ds['boundary_ok']), 6)} -> {_fmt(float(ds['boundary_fail']), 6)} | "
            f"{ds['boundary_status'].item()} | {_fmt(float(ds['analytic_boundary']))}{u} | "
            f"{ds.attrs['what_failed']} |"
        )
    for ds in datasets:
        lines += ["", f"## {ds.attrs['axis']} (`{ds.attrs['config_key']}`)", "",
                  ds.attrs["description"] + ".", "",
                  f"* analytic: {ds.attrs['analytic']}",
                  f"* status changes: {ds.attrs['transitions'] or 'none'}"]
        if ds["physics_boundary_status"].item() != ds["boundary_status"].item():
            lines.append(f"* physics at a stable dt: {ds.attrs['physics_what_failed']}")
        if ds.attrs.get("boundary_dt_check"):
            lines.append(f"* dt / 2 check of the bracket: {ds.attrs['boundary_dt_check']}")
        escaped = ds["value"].values[(ds["left_cavity"].values == 1)
                                     & (ds["run_status"].values.astype(str) == "ok")]
        if escaped.size:
            lines.append("* ok runs whose sphere left its cavity (|R - R_c| past the crest "
                         "line) yet finished the cycle: "
                         + ", ".join(f"{v:.6g}" for v in escaped))
        warned = ds["value"].values[ds["n_warnings"].values > 0]
        if warned.size:
            lines.append("* run warnings (max N beyond the stability limit) at: "
                         + ", ".join(f"{v:.4g}" for v in warned))
        lines.append(f"* anomalies: {ds.attrs['anomalies'] or 'none'}")
    return "\n".join(lines) + "\n"


def write_boundaries(
    out_dir: Path, axes: Sequence[str] | None = None,
    progress: Callable[[str], None] | None = None,
) -> list[Path]:
    """Explore each axis and write boundary_<axis>.nc (with provenance), boundary_<axis>.png
    and one boundaries.md table; returns the written paths."""
    from creatio.io import provenance, write_dataset

    out_dir = Path(out_dir)
    names = list(AXES) if axes is None else list(axes)
    unknown = [a for a in names if a not in AXES]
    if unknown:
        raise KeyError(f"unknown axes {unknown}; choose from {', '.join(AXES)}")
    base = resolve(STUDY)
    paths, datasets = [], []
    for name in names:
        t0 = time.perf_counter()
        if progress:
            progress(f"axis {name} ({AXES[name].key}):")
        ds = explore(name, progress=progress)
        attrs = provenance(STUDY, base.yaml, base.sha256, ds.attrs["title"])
        ds.attrs = {**attrs, **ds.attrs}
        paths.append(write_dataset(ds, out_dir / f"boundary_{name}.nc"))
        paths.append(figure(ds, out_dir / f"boundary_{name}.png"))
        datasets.append(ds)
        if progress:
            progress(f"axis {name}: boundary {float(ds['boundary']):.4g} "
                     f"({ds['boundary_status'].item()}), analytic "
                     f"{float(ds['analytic_boundary']):.4g}, "
                     f"{time.perf_counter() - t0:.1f} s")
    md = out_dir / "boundaries.md"
    md.write_text(_markdown(datasets))
    paths.append(md)
    return paths


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: write the boundary datasets, figures and table to OUT_DIR."""
    parser = argparse.ArgumentParser(
        prog="python -m creatio.boundaries",
        description="Push the EN-02 configuration along one parameter at a time until the "
        "model's assumptions fail (contact lost, edge crossed, offset singular, refused), "
        "locate each boundary by bisection and compare it with its analytic expectation.",
        epilog="axes: " + "; ".join(f"{a.name} = {a.key} ({a.units})" for a in AXES.values()),
    )
    parser.add_argument("out_dir", type=Path,
                        help="directory for boundary_<axis>.nc/.png and boundaries.md")
    parser.add_argument("--axes", nargs="+", default=None, metavar="AXIS",
                        help=f"axes to explore (space or comma separated; default all: "
                        f"{','.join(AXES)})")
    args = parser.parse_args(argv)
    axes = None
    if args.axes:
        axes = [a for item in args.axes for a in item.split(",") if a]
        bad = [a for a in axes if a not in AXES]
        if bad:
            parser.error(f"unknown axes {bad}; choose from {', '.join(AXES)}")

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    t0 = time.perf_counter()
    paths = write_boundaries(args.out_dir, axes, progress=say)
    say(f"wrote {len(paths)} files to {args.out_dir} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
