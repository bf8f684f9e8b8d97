"""Physics boundaries of EN-02: push one parameter at a time until the model stops applying.

Each axis starts at the EN-02 default and moves outward over a coarse grid; a bisection
between the last ``ok`` value and the first failing one locates the boundary to about three
significant digits (``study.rtol``). Every point is a validated variation of the EN-02 base
config (:func:`creatio.studies.schema.vary`), so a value the config refuses is recorded as
``refused`` (or ``refused_unstable`` for a dt beyond the friction stability limit,
docs/model.md s.6.3) with its message, and every run that stops early keeps the model's own
status (``contact_lost``, ``edge_crossed``, ``offset_singular``, ..., docs/model.md s.4.5).
Each boundary is set beside an independent analytic expectation where one exists: the
offset surface's singularity at the cavity bottom (docs/model.md s.6.4) for A and b, the
friction stability limit for mu, a quasi-static hold at peak pattern speed for T and an
energy barrier for the inclination gamma.

The config (``conf/analysis/boundaries.yaml``) holds the grids and settings under ``study``
and the full EN-02 config under ``bases.en02``; one dataset per explored axis
(``creatio run analysis=boundaries``, a few minutes for every axis).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from creatio.dynamics import SimulationResult, UnstableStepError
from creatio.dynamics.solvers import METHODS
from creatio.dynamics.status import NAMES as STATUS_NAMES
from creatio.errors import ConfigError
from creatio.model.cavity import bottom_curvatures, pattern_angle
from creatio.model.laws import Law
from creatio.model.numerics import steps_in
from creatio.model.sphere import (
    STABILITY_MARGIN,
    inertia,
    normal_estimate,
    slip_relaxation_rate,
    stable_step,
)
from creatio.model.surface import Frame, Motion, Surface, wavenumber
from creatio.studies.registry import Part
from creatio.studies.schema import (
    MISSING,
    DynamicConfig,
    check_bases,
    require,
    require_samples,
    vary,
)

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "AXES",
    "BASE",
    "Axis",
    "AxisConfig",
    "BoundariesConfig",
    "BoundariesStudy",
    "BoundaryAxes",
    "Point",
    "RUN_STATUSES",
    "STATUSES",
    "analytic",
    "bottom_b_kappa",
    "evaluate",
    "explore",
    "parts",
    "run",
    "stable_dt",
]

log = logging.getLogger("creatio")

#: The base study every point varies, and the key under ``bases`` that holds its config.
BASE = "en02"
#: Every status a point can get: the model's stop statuses, then the two refusals.
STATUSES = (*STATUS_NAMES, "refused", "refused_unstable")
#: Status of the run whose physics a point records ("not_run" when nothing could run).
RUN_STATUSES = (*STATUS_NAMES, "not_run")
#: Sampled histories that must stay finite up to a run's stop (energy columns are NaN when
#: the energy bookkeeping is off, by design, so they are not checked).
HISTORIES = ("t", "X", "R", "alpha", "V", "speed", "N", "f", "slip_speed", "omega",
             "spin_rate", "cumulative_spin", "Q", "marker", "azimuth", "cavity_R")
#: Decades of the "nice" steps tried for a stable rerun: m 10^e for e = 0, -1, ..., -11.
_NICE_EXPONENTS = range(0, -12, -1)


@dataclass(frozen=True)
class Axis:
    """What one boundary axis is: the config key it moves, its units and meaning (its grid
    and sampling settings are config, :class:`AxisConfig`)."""

    name: str
    key: str
    long_name: str
    units: str
    description: str

    def changes(self, value: float) -> dict[str, Any]:
        """The base-config changes that put this axis at value (for :func:`vary`)."""
        v = float(value)
        if self.name == "gamma":
            return {"phases.gamma.phi0": v, "phases.gamma.unit": "deg"}
        if self.name == "T":
            return {"phases.T": v, "study.duration": v}
        return {self.key: v}


AXES: dict[str, Axis] = {
    "T": Axis(
        "T", "phases.T", "cycle duration of the pattern", "s",
        "faster pattern (study.duration follows T): the cavity must carry the sphere round "
        "against the centrifugal pull",
    ),
    "A": Axis(
        "A", "geometry.A", "corrugation amplitude", "m",
        "deeper corrugation: the cavity bottom curves more (b kappa -> 1); A >= R0 is refused",
    ),
    "b": Axis(
        "b", "sphere.b", "sphere radius", "m",
        "bigger sphere: offset surface singular (b kappa -> 1), then the envelope crosses an edge",
    ),
    "gamma": Axis(
        "gamma", "phases.gamma.phi0", "inclination of the generator", "degree",
        "steeper cone (phases.gamma.unit=deg): gravity pulls the sphere out of the cavity "
        "towards the inner edge",
    ),
    "mu": Axis(
        "mu", "sphere.mu", "friction coefficient", "1",
        "stiffer friction: the default dt leaves the RK4 stability region (refused_unstable); "
        "each value is also run at a stable dt",
    ),
}


# ------------------------------------------------------------------------------ config
@dataclass
class AxisConfig:
    """Sampling of one axis: its outward grid (the first value the EN-02 start), whether the
    figure shows it on a log scale, whether values are rounded to multiples of the base's dt
    (the cycle T, which the duration follows) and whether a value whose dt the config
    refuses is also run at a stable dt."""

    grid: list[float] = MISSING
    log: bool = False
    quantize_to_dt: bool = False
    stable_rerun: bool = False

    def check(self, path: str, axis: Axis, base: DynamicConfig) -> None:
        """At least two finite values, strictly monotonic (outward), the first one a value
        the base config accepts (the model-valid start of the axis)."""
        grid = list(self.grid)
        require(len(grid) >= 2, f"{path}.grid", grid,
                "needs at least 2 values (the start and one step outward)")
        for i, v in enumerate(grid):
            require(isinstance(v, int | float) and not isinstance(v, bool)
                    and math.isfinite(v), f"{path}.grid[{i}]", v, "must be a finite number")
        sign = math.copysign(1.0, grid[1] - grid[0])
        for i in range(1, len(grid)):
            require((grid[i] - grid[i - 1]) * sign > 0.0, f"{path}.grid[{i}]", grid[i],
                    f"must move outward: strictly {'in' if sign > 0 else 'de'}creasing from "
                    f"grid[0] = {grid[0]}")
        start = _quantize(grid[0], base.solver.dt if self.quantize_to_dt else None)
        try:
            vary(base, axis.changes(start))
        except ConfigError as e:
            require(False, f"{path}.grid[0]", grid[0],
                    f"must be a value the {BASE} base accepts (the start of the axis): "
                    f"{e.key}: {e.rule}")


@dataclass
class BoundaryAxes:
    """The sampling of every axis, by name (the names of :data:`AXES`)."""

    T: AxisConfig = field(default_factory=AxisConfig)
    A: AxisConfig = field(default_factory=AxisConfig)
    b: AxisConfig = field(default_factory=AxisConfig)
    gamma: AxisConfig = field(default_factory=AxisConfig)
    mu: AxisConfig = field(default_factory=AxisConfig)


@dataclass
class BoundariesStudy:
    """The axes explored, their grids, the bisection tolerance, the stable-rerun step rule
    and the sampling of the analytic expectations."""

    id: str = "boundaries"
    title: str = ""
    explore: list[str] = MISSING
    rtol: float = MISSING
    stable_fraction: float = MISSING
    nice_mantissas: list[float] = MISSING
    analytic_samples: int = MISSING
    analytic_tol_deg: float = MISSING
    axes: BoundaryAxes = field(default_factory=BoundaryAxes)

    def axis(self, name: str) -> AxisConfig:
        """The sampling of the axis called name."""
        if name not in AXES:
            raise KeyError(f"unknown axis {name!r}; choose from {', '.join(AXES)}")
        return getattr(self.axes, name)

    def check(self, path: str, base: DynamicConfig) -> None:
        """Known axes without repeats, 0 < rtol < 1, 0 < stable_fraction <= 1, mantissas in
        [1, 10) and decreasing, sane analytic sampling, every axis grid valid."""
        require(len(self.explore) >= 1, f"{path}.explore", list(self.explore),
                "needs at least 1 axis")
        for i, name in enumerate(self.explore):
            require(name in AXES, f"{path}.explore[{i}]", name,
                    f"must be one of {', '.join(AXES)}")
            require(name not in self.explore[:i], f"{path}.explore[{i}]", name,
                    "is listed twice")
        require(math.isfinite(self.rtol) and 0.0 < self.rtol < 1.0, f"{path}.rtol", self.rtol,
                "must lie in (0, 1)")
        require(math.isfinite(self.stable_fraction) and 0.0 < self.stable_fraction <= 1.0,
                f"{path}.stable_fraction", self.stable_fraction, "must lie in (0, 1]")
        require(len(self.nice_mantissas) >= 1, f"{path}.nice_mantissas",
                list(self.nice_mantissas), "needs at least 1 value")
        for i, m in enumerate(self.nice_mantissas):
            require(1.0 <= m < 10.0, f"{path}.nice_mantissas[{i}]", m, "must lie in [1, 10)")
            if i:
                require(m < self.nice_mantissas[i - 1], f"{path}.nice_mantissas[{i}]", m,
                        "must be below the one before it (largest first)")
        require(self.analytic_samples >= 101, f"{path}.analytic_samples",
                self.analytic_samples, "must be >= 101")
        require_samples(f"{path}.analytic_samples", self.analytic_samples,
                        self.analytic_samples, "R samples of each analytic section")
        require(math.isfinite(self.analytic_tol_deg) and 0.0 < self.analytic_tol_deg < 1.0,
                f"{path}.analytic_tol_deg", self.analytic_tol_deg, "must lie in (0, 1) degree")
        for name, axis in AXES.items():
            self.axis(name).check(f"{path}.axes.{name}", axis, base)


@dataclass
class BoundariesConfig:
    """Root schema of the boundaries analysis: its settings and the base config it varies."""

    study: BoundariesStudy = field(default_factory=BoundariesStudy)
    bases: dict[str, DynamicConfig] = field(default_factory=dict)

    def check(self) -> None:
        """The base valid (errors named under bases.en02), then every setting on it."""
        require(BASE in self.bases, "bases", sorted(self.bases), f"needs the base {BASE!r}")
        check_bases(self.bases)
        self.study.check("study", self.bases[BASE])

    @property
    def base(self) -> DynamicConfig:
        """The EN-02 config every point varies."""
        return self.bases[BASE]


def parts(cfg: BoundariesConfig) -> list[Part]:
    """One dataset per explored axis, in the configured order."""
    return [Part(f"boundaries_{axis}", {"axis": axis}) for axis in cfg.study.explore]


def run(cfg: BoundariesConfig, axis: str) -> xr.Dataset:
    """The dataset of one axis: every point, the located boundary and its expectation."""
    if axis not in cfg.study.explore:
        raise ValueError(f"axis must be one of {', '.join(cfg.study.explore)}, got {axis!r}")
    t0 = time.perf_counter()
    log.info("axis %s (%s):", axis, AXES[axis].key)
    ds = explore(cfg, axis, progress=log.info)
    log.info("axis %s: boundary %.4g (%s), analytic %.4g, %.1f s", axis, float(ds["boundary"]),
             ds["boundary_status"].item(), float(ds["analytic_boundary"]),
             time.perf_counter() - t0)
    return ds


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


def stable_dt(limit: float, nominal: float, output_interval: float, duration: float,
              fraction: float, mantissas: Sequence[float]) -> float:
    """Largest "nice" step (m 10^e, m in mantissas, largest first) <= min(nominal, fraction
    limit) that divides both the output interval and the duration (what the config accepts)."""
    cap = min(nominal, fraction * limit)
    for e in _NICE_EXPONENTS:
        for m in mantissas:
            dt = float(f"{float(m)}e{e}")
            if dt <= cap and steps_in(output_interval, dt) and steps_in(duration, dt):
                return dt
    raise ValueError(f"no nice dt below {cap} s divides {output_interval} s and {duration} s")


def _quantize(value: float, quantum: float | None) -> float:
    if quantum is None:
        return float(value)
    return round(round(value / quantum) * quantum, 12)


def _resolve_point(base: DynamicConfig, changes: dict[str, Any]
                   ) -> tuple[DynamicConfig | None, str, str, float]:
    """(config, status, message, step_limit) of one variation, refusals classified from the
    ConfigError: a refused solver.dt that the relaxed config (allow_unstable) accepts beyond
    its stability limit is ``refused_unstable``, anything else ``refused``."""
    try:
        cfg = vary(base, changes)
        return cfg, "ok", "", cfg.step_limit()
    except ConfigError as error:
        message, key = str(error), error.key
    if key != "solver.dt":
        return None, "refused", message, math.nan
    try:
        relaxed = vary(base, {**changes, "solver.allow_unstable": True})
    except ConfigError:
        return None, "refused", message, math.nan
    limit = relaxed.step_limit()
    status = "refused_unstable" if relaxed.solver.dt > limit else "refused"
    return None, status, message, limit


def _run(cfg: DynamicConfig, dt: float) -> tuple[SimulationResult | None, str]:
    """simulate() at dt with the energy bookkeeping off; (None, message) if dt is unstable."""
    from creatio.dynamics import simulate

    problem = cfg.sphere_problem(dt).replace(energy=False)
    try:
        return simulate(problem), ""
    except UnstableStepError as error:
        return None, str(error)


def _finite_check(res: SimulationResult) -> tuple[int, list[str]]:
    """1 if every checked history is finite before the stop row (and at it, unless the
    status is non_finite), else 0 with a note naming the history and the time."""
    notes = []
    status = res.counts.status
    for name in HISTORIES:
        h = np.asarray(getattr(res.histories, name))
        rows = h.reshape(h.shape[0], -1)
        body = rows if status != "non_finite" else rows[:-1]
        bad = ~np.isfinite(body).all(axis=1)
        if bad.any():
            notes.append(f"{name} non-finite at t = {res.histories.t[np.argmax(bad)]:.6g} s "
                         f"before the stop (status {status})")
    return int(not notes), notes


def _consistency(res: SimulationResult, duration: float) -> list[str]:
    """Notes where a result contradicts its own status (these would be model bugs)."""
    notes = []
    c, x, N = res.counts, res.extrema, res.histories.N
    if c.status == "ok" and not math.isclose(c.stop_time, duration, rel_tol=1e-9):
        notes.append(f"status ok but stop_time {c.stop_time} != duration {duration}")
    if c.status == "contact_lost" and not (N[-1] <= 0.0 and x.min_N <= 0.0):
        notes.append(f"contact_lost with N = {N[-1]:.6g} at the stop")
    if c.status not in ("contact_lost", "non_finite") and x.min_N <= 0.0:
        notes.append(f"min N = {x.min_N:.6g} <= 0 but status {c.status}")
    if c.status == "offset_singular" and not x.max_b_kappa >= 1.0:
        notes.append(f"offset_singular with max b kappa = {x.max_b_kappa:.6g} < 1")
    if c.status == "edge_crossed" and not x.min_edge_clearance < 0.0:
        notes.append(f"edge_crossed with min clearance = {x.min_edge_clearance:.6g} >= 0")
    return notes


def _record(point: Point, res: SimulationResult, duration: float) -> None:
    """Copy a run's figures into a point and check its histories and self-consistency."""
    c, x = res.counts, res.extrema
    point.run_status = c.status
    point.dt = c.dt
    point.duration = duration
    point.stop_time = c.stop_time
    point.min_N = x.min_N
    point.max_N = x.max_N
    point.max_b_kappa = x.max_b_kappa
    point.min_edge_clearance = x.min_edge_clearance
    point.max_cavity_tracking_error = x.max_cavity_tracking_error
    point.max_slip_speed = x.max_slip_speed
    point.final_R = float(res.histories.R[-1])
    point.steps = float(c.steps)
    point.n_warnings = len(c.warnings)
    point.histories_finite, notes = _finite_check(res)
    point.anomalies += notes + _consistency(res, duration)
    if c.warnings:
        point.message = "; ".join(filter(None, [point.message, *c.warnings]))
    point.result = res


def _half_dt(point: Point, cfg: DynamicConfig) -> None:
    """Rerun a point at dt / 2: its status must not be an artefact of the step."""
    res, message = _run(cfg, 0.5 * point.dt)
    point.half_dt_status = res.counts.status if res is not None else "refused_unstable"
    point.half_dt_stop_time = res.counts.stop_time if res is not None else math.nan
    if res is not None and res.counts.status != point.run_status:
        point.anomalies.append(
            f"dt / 2 gives {res.counts.status} at t = {res.counts.stop_time:.6g} s instead of "
            f"{point.run_status} at {point.stop_time:.6g} s"
        )


def evaluate(cfg: BoundariesConfig, axis: str, value: float, kind: str = "grid") -> Point:
    """Validate and (if accepted, or at a stable dt on a stable_rerun axis) run one value of
    an axis on the base config; never raises for a refused value, records it instead."""
    ax, settings, base = AXES[axis], cfg.study.axis(axis), cfg.base
    changes = ax.changes(value)
    dyn, status, message, limit = _resolve_point(base, changes)
    point = Point(value=float(value), kind=kind, status=status, message=message,
                  step_limit=limit)
    if dyn is not None:
        res, unstable = _run(dyn, dyn.solver.dt)
        if res is None:
            point.status, point.message = "refused_unstable", unstable
            point.anomalies.append("config accepted a dt that simulate() refuses: " + unstable)
        else:
            point.status = res.counts.status
            _record(point, res, dyn.study.duration)
            if res.counts.warnings:
                _half_dt(point, dyn)
    if point.run_status == "not_run" and settings.stable_rerun and status == "refused_unstable":
        relaxed = vary(base, {**changes, "solver.allow_unstable": True})
        step = stable_dt(limit, relaxed.solver.dt, relaxed.solver.output_interval,
                         relaxed.study.duration, cfg.study.stable_fraction,
                         cfg.study.nice_mantissas)
        stable_cfg, _, stable_message, _ = _resolve_point(base, {**changes, "solver.dt": step})
        if stable_cfg is None:
            point.anomalies.append(f"stable dt {step} refused: {stable_message}")
        else:
            res, unstable = _run(stable_cfg, step)
            if res is None:
                point.anomalies.append(f"stable dt {step} refused by simulate(): {unstable}")
            else:
                _record(point, res, stable_cfg.study.duration)
                if res.counts.warnings:
                    _half_dt(point, stable_cfg)
    return point


# ------------------------------------------------------------------------------ analytics
def _surface_motion(base: DynamicConfig, gamma: float | None = None,
                    T: float | None = None) -> tuple[Surface, Motion]:
    """The base's surface and motion (its inclination replaced by the constant gamma in rad,
    its quintic cycle by T, when given)."""
    ph = base.phases
    T = ph.T if T is None else T
    law_g = ph.gamma.to_law(T) if gamma is None else Law.constant(gamma)
    return base.geometry.surface(), Motion(ph.r.to_law(T), ph.a.to_law(T), law_g)


def _start_frame(base: DynamicConfig, R: Any = None, gamma: float | None = None,
                 T: float | None = None) -> Frame:
    """The surface frame at t = 0 on the meridian through the start (alpha_init), at R
    (default R_init)."""
    surface, motion = _surface_motion(base, gamma, T)
    ini = base.study.initial
    return Frame(surface, motion, math.radians(ini.alpha_deg), ini.R if R is None else R, 0.0)


def _centre(frame: Frame, b: float) -> tuple[np.ndarray, np.ndarray]:
    """(radial, vertical) coordinates of the centre X = c + b n of a sphere touching at the
    frame's points (docs/model.md s.4.2)."""
    X = frame.position + b * frame.normal
    return np.einsum("...i,...i->...", X, frame.e_rho), X[..., 2]


def bottom_b_kappa(cfg: DynamicConfig) -> float:
    """b times the larger principal curvature at the start, for a start at a cavity bottom
    (:func:`creatio.model.cavity.bottom_curvatures`, rho_c the start's distance from the axis)."""
    g = cfg.geometry
    frame = _start_frame(cfg)
    gamma = float(frame.w.g)
    return cfg.sphere.b * max(bottom_curvatures(
        g.A, wavenumber(g.Kr, g.dR), g.Ka, float(frame.rho), gamma))


def _at_bottom(cfg: DynamicConfig) -> bool:
    """Whether the start is a cavity bottom: W = -A there (sin u = 1 and cos v = -1, or the
    reverse signs), to 1e-9 A."""
    w = _start_frame(cfg).w
    return math.isclose(float(w.W), -cfg.geometry.A, rel_tol=0.0,
                        abs_tol=1e-9 * cfg.geometry.A)


def _section(cfg: DynamicConfig, gamma: float, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Centre height and generator coordinate of a sphere touching the meridian section
    through the start at contact coordinates R, inclination gamma (rad), t = 0."""
    Xr, Xz = _centre(_start_frame(cfg, R, gamma), cfg.sphere.b)
    return Xz, (Xr - cfg.geometry.R0) * math.cos(gamma) + Xz * math.sin(gamma)


def _escapes_inward(cfg: DynamicConfig, gamma: float, samples: int) -> bool:
    """Whether a sphere released at rest at the start rolls (energy conserved) over the
    inner edge: its centre height stays below the start height until the clearance is 0."""
    R_init, b = cfg.study.initial.R, cfg.sphere.b
    R = np.linspace(R_init, R_init - cfg.geometry.dR, samples)
    H, sx = _section(cfg, gamma, R)
    edge = np.flatnonzero(sx < b)
    if edge.size == 0:
        return False
    return bool(np.all(H[1 : edge[0]] < H[0]))


def _bisect_deg(inside: Callable[[float], bool], tol: float) -> float:
    """Midpoint of the final [lo, hi] bracket (deg) of the first inclination in [0, 90]
    where inside() holds (inside(0) false, inside(90) true)."""
    lo, hi = 0.0, 90.0
    while hi - lo > tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if inside(mid) else (mid, hi)
    return 0.5 * (lo + hi)


def _gamma_energy_limit(cfg: DynamicConfig, samples: int, tol: float) -> float:
    """Smallest inclination (deg) at which the released sphere escapes over the inner edge."""
    def escapes(deg: float) -> bool:
        return _escapes_inward(cfg, math.radians(deg), samples)

    if escapes(0.0) or not escapes(90.0):
        return math.nan
    return _bisect_deg(escapes, tol)


def _gamma_singular_limit(cfg: DynamicConfig, tol: float) -> float:
    """Inclination (deg) where b kappa at the start reaches 1 (offset singular from t = 0)."""
    g, b = cfg.geometry, cfg.sphere.b
    k = wavenumber(g.Kr, g.dR)

    def singular(deg: float) -> bool:
        gamma = math.radians(deg)
        rho = float(_start_frame(cfg, gamma=gamma).rho)
        return b * max(bottom_curvatures(g.A, k, g.Ka, rho, gamma)) >= 1.0

    if singular(0.0) or not singular(90.0):
        return math.nan
    return _bisect_deg(singular, tol)


def _peak_phase_rate(cfg: DynamicConfig, T: float) -> float:
    """Peak |d phi_a / dt| (rad/s) of the quintic angular law of cycle T (at t = T / 2)."""
    return abs(float(cfg.phases.a.to_law(T)(0.5 * T).d1))


def _T_hold_limit(cfg: DynamicConfig, samples: int) -> float:
    """Cycle T below which no quasi-static hold exists at peak pattern speed: a rolling
    sphere needs a radial push (1 + I / (m b^2)) Omega^2 rho_centre = (7/5) Omega^2
    rho_centre that the cavity's outer wall (slope W_R along the flat meridian) must supply,
    g W_R >= (7/5) Omega^2 rho_centre."""
    g, sp = cfg.geometry, cfg.sphere
    R_init = cfg.study.initial.R
    k = wavenumber(g.Kr, g.dR)
    R = np.linspace(R_init, R_init + math.pi / k, samples)  # half a radial wavelength
    frame = _start_frame(cfg, R, gamma=0.0)
    rho_c, _ = _centre(frame, sp.b)
    rolling = 1.0 + inertia(sp.m, sp.b) / (sp.m * sp.b * sp.b)
    omega2 = float(np.max(sp.g * frame.w.W_R / (rolling * rho_c)))
    if omega2 <= 0.0:
        return math.nan
    # Omega = |alpha_p'| = |phi_a'| / Ka peaks at T / 2 and scales as 1 / T: solve for T.
    surface, motion = _surface_motion(cfg, 0.0, T=1.0)
    return abs(float(pattern_angle(surface, motion, 0.5)[1])) / math.sqrt(omega2)


def analytic(cfg: BoundariesConfig, axis: str) -> tuple[float, str, dict[str, float]]:
    """Independent expectation of an axis's first failure: (value, explanation, extras)."""
    base, study = cfg.base, cfg.study
    g, sp = base.geometry, base.sphere
    k = wavenumber(g.Kr, g.dR)
    R = base.study.initial.R
    rho = float(_start_frame(base, gamma=0.0).rho)  # R0 + R_init on the flat annulus
    curv = max(bottom_curvatures(1.0, k, g.Ka, rho, 0.0))  # per unit A, gamma = 0
    bottom = _at_bottom(base) and base.phases.gamma.to_law().bounds() == (0.0, 0.0)
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
        value = _gamma_energy_limit(base, study.analytic_samples, study.analytic_tol_deg)
        extras = {
            "no_equilibrium_from_deg": math.degrees(math.atan(g.A * k)),
            "offset_singular_from_deg": _gamma_singular_limit(base, study.analytic_tol_deg),
        }
        return value, (
            "energy barrier: released at rest at the cavity bottom, the rolling sphere "
            "(no dissipation, pattern still) clears the inner edge; quasi-static equilibrium "
            f"is lost only at atan(A k) = {extras['no_equilibrium_from_deg']:.4g} deg; "
            f"offset singular from {extras['offset_singular_from_deg']:.4g} deg"
        ), extras
    if axis == "T":
        if base.phases.a.kind.value != "quintic":
            return math.nan, "the angular law is not quintic: no closed form", {}
        crest = _peak_phase_rate(base, 1.0) * math.sqrt(g.A / sp.g)
        return _T_hold_limit(base, study.analytic_samples), (
            "quasi-static hold at peak pattern speed of a rolling sphere, g W_R = (7/5) "
            f"Omega^2 rho; a crest sweeping under a sphere at rest outruns g below "
            f"T = {crest:.4g} s"
        ), {"crest_outruns_g_T": crest}
    if axis == "mu":
        method, dt = str(base.solver.method), base.solver.dt
        bound = METHODS[method].stability_bound
        if base.solver.adaptive or math.isinf(bound):
            return math.nan, f"{method} has no friction step limit: no closed form", {}
        # at rest at the flat bottom N = m g: limit(mu) = z* / (mu rate(mu = 1)) = dt
        n_est = normal_estimate(sp.m * sp.g, sp.m, sp.g)
        value = stable_step(bound, slip_relaxation_rate(1.0, n_est, sp.m, sp.b, sp.eps)) / dt
        return value, (
            f"refused_unstable where 3.5 mu ({STABILITY_MARGIN:g} m g) dt / (m eps) = "
            f"{bound:.4g} ({method.upper()} real stability root) at dt = {dt} s"
        ), {}
    raise KeyError(f"unknown axis {axis!r}; choose from {', '.join(AXES)}")


# ------------------------------------------------------------------------------ explore
def _bisect(
    cfg: BoundariesConfig, axis: str, ok: Point, bad: Point, fails: Callable[[Point], bool],
    quantum: float | None, points: dict[float, Point],
    progress: Callable[[str], None] | None,
) -> tuple[Point, Point]:
    """Narrow [last ok, first failing] until its width is below rtol of the value."""
    rtol = cfg.study.rtol
    while abs(bad.value - ok.value) > rtol * max(abs(ok.value), abs(bad.value)):
        mid = _quantize(0.5 * (ok.value + bad.value), quantum)
        if mid in (ok.value, bad.value):
            break
        if mid not in points:
            points[mid] = evaluate(cfg, axis, mid, kind="bisection")
            if progress:
                progress(f"  {axis} = {mid:.6g}: {_label(points[mid])}")
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
    cfg: BoundariesConfig, axis: str, ordered: list[Point], fails: Callable[[Point], bool],
    quantum: float | None, points: dict[float, Point],
    progress: Callable[[str], None] | None,
) -> tuple[Point, Point] | None:
    """(last ok, first failing) along the outward grid, bisected; None if nothing fails."""
    for i, p in enumerate(ordered):
        if fails(p):
            if i == 0:
                raise ValueError(f"axis {axis}: the EN-02 default already fails ({p.status})")
            return _bisect(cfg, axis, ordered[i - 1], p, fails, quantum, points, progress)
    return None


def explore(
    cfg: BoundariesConfig, axis: str, progress: Callable[[str], None] | None = None,
) -> xr.Dataset:
    """Sweep one axis outward from the EN-02 base (its grid, then bisection of the first
    failure) and return every point, the located boundary and the analytic expectation;
    progress receives one line per point."""
    ax, settings, base = AXES[axis], cfg.study.axis(axis), cfg.base
    quantum = base.solver.dt if settings.quantize_to_dt else None
    grid = [_quantize(v, quantum) for v in settings.grid]
    points: dict[float, Point] = {}
    for v in grid:
        if v not in points:
            points[v] = evaluate(cfg, axis, v)
            if progress:
                progress(f"  {axis} = {v:.6g}: {_label(points[v])}")
    ordered = [points[v] for v in dict.fromkeys(grid)]
    t0 = time.perf_counter()

    def fails(p: Point) -> bool:
        return p.status != "ok"

    def physics_fails(p: Point) -> bool:
        return p.run_status not in ("ok", "not_run")

    found = _first_failure(cfg, axis, ordered, fails, quantum, points, progress)
    physics = found
    if settings.stable_rerun:
        physics = _first_failure(cfg, axis, ordered, physics_fails, quantum, points, progress)
    checks = []
    bracket = {id(p): p for pair in (found, physics) if pair is not None for p in pair}
    for p in bracket.values():
        if p.run_status != "not_run" and not p.half_dt_status:
            _half_dt(p, vary(base, {**ax.changes(p.value), "solver.dt": p.dt}))
        if p.half_dt_status:
            checks.append(f"{axis} = {p.value:.6g}: {p.run_status} at dt = {p.dt:g}, "
                          f"{p.half_dt_status} at dt / 2")
    value, explanation, extras = analytic(cfg, axis)
    ds = _dataset(ax, settings, points, found, physics, value, explanation, extras, base,
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
    ax: Axis, settings: AxisConfig, points: dict[float, Point],
    found: tuple[Point, Point] | None, physics: tuple[Point, Point] | None, value: float,
    explanation: str, extras: dict[str, float], cfg: DynamicConfig, last: float,
) -> xr.Dataset:
    """Assemble the points (sorted by value) and the located boundaries into a Dataset."""
    import xarray as xr

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
    half_wave = math.pi / wavenumber(cfg.geometry.Kr, cfg.geometry.dR)  # dR / (2 Kr)
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
        "log_scale": int(settings.log),
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
