"""EN-04's closed loop (docs/studies.md "EN-04", docs/model.md s.12.2): the controller grid,
the open-loop boundaries it is measured against, and the robustness runs.

One dataset, ``en04_control``, from the sphere of ``bases.<control.base>`` (EN-02's):

* the grid Omega_max x delta_max x omega_c x omega_n (zeta_c = zeta = 1), each case run for
  ``duration`` seconds at dt and at dt / refine with every step recorded: status, whether
  the sphere stayed in its cavity, arrival, settling, final error, overshoot, max |delta|,
  max |R - R_cavity|, max |phidot_a|, max |u|, min N, max slip, peak and mean load power,
  energy residual, the dt - dt/2 difference of the centre;
* the open-loop quintic cycle's shortest carried T (bisection on T) and the trapezoidal law's
  grid Omega_max x a_max (its switch times rounded onto the step grid), each run as long
  and judged by the same arrival rule;
* robustness: the default controller and the quintic law at a fixed T, at each mu and mass
  factor (the controller's gains stay the nominal sphere's);
* the paths of the fastest carried closed loop, the quintic boundary case and the best
  trapezoid on a common time grid, for the figures;
* what the actuators delivered along each controlled run (every grid case, the robustness
  runs' controller) and along the three paths: the figures of docs/model.md s.12.1 from the
  run's recorded histories (creatio.model.actuation with the controlled phase as samples),
  the membrane quadrature converged once, on the fastest case (:func:`demand_figures`);
* the accuracy budgets of the answers computed at the base's fixed step: the
  quintic boundary within 1e-2 of its bisection's resolution, checked on its final bracket,
  and the grid's arrivals within 1e-2 of the step, checked on a seeded subsample of 16
  cases, each rerun at dt / 4 (:class:`StepCheck`, attributes ``quintic_accuracy_*`` and
  ``arrival_accuracy_*``); a broken bisection budget halves the step and redoes it.

The costly part is not the integrations (about a tenth of the CPU) but the actuation
figures along each run; the controller's u and lead along a run are computed once
(:func:`servo_along`), and the paths other than the reference case get only their histories.

The gains come from the design rule of docs/model.md s.12.2: k_alpha is the square of the
rolling sphere's small-oscillation frequency along alpha in the base's still cavity
(creatio.studies.en04.closed_forms).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from creatio.dynamics import (
    SimulationResult,
    SphereProblem,
    UnstableStepError,
    check_stable,
    solvers,
)
from creatio.model import actuation as act
from creatio.model.control import Controller, lead, outer_gains
from creatio.model.laws import Law, trapezoid_on_grid
from creatio.model.surface import Motion, Surface
from creatio.studies.schema import DynamicConfig, require

if TYPE_CHECKING:
    import xarray as xr

__all__ = ["DEMAND_FIGURES", "ControlConfig", "ControllerPoint", "DemandSettings",
           "ExtremaGridConfig", "StepCheck", "budgeted_bisection", "check_arrivals",
           "check_bracket", "controller", "crossing", "demand_figures", "run_control",
           "servo_along"]


@dataclass
class ControllerPoint:
    """One controller: speed limit (rad/s of the sphere's alpha), lead limit (deg), outer
    loop frequency omega_c and servo frequency omega_n (rad/s)."""

    omega_max: float = 2.0
    delta_max_deg: float = 10.0
    omega_c: float = 3.0
    omega_n: float = 20.0


@dataclass
class BisectionConfig:
    """The bracket [lo, hi] (s) of the quintic cycle's carried boundary and its width at
    which the bisection stops."""

    lo: float = 4.0
    hi: float = 14.0
    tol: float = 0.01


@dataclass
class TrapezoidGridConfig:
    """The trapezoidal laws: pattern speed limits (rad/s) x accelerations (rad/s^2)."""

    omega_max: list[float] = field(default_factory=lambda: [1.0, 1.5, 2.0, 2.5, 3.0])
    a_max: list[float] = field(default_factory=lambda: [0.5, 1.0, 1.5, 2.0, 3.0])


@dataclass
class RobustnessConfig:
    """The default controller and the quintic law of cycle quintic_T (s) at each friction
    coefficient and mass factor."""

    mus: list[float] = field(default_factory=lambda: [0.05, 0.15, 0.3])
    mass_factors: list[float] = field(default_factory=lambda: [0.5, 1.0, 2.0])
    quintic_T: float = 7.0


@dataclass
class ExtremaGridConfig:
    """The (alpha, R) grid the numeric extrema of W start from (then polished locally):
    study.actuation.extrema for the prescribed cycles, study.control.extrema along the
    closed loop (a coarser default, 16 x 9: every controlled run is searched)."""

    n_alpha: int = 48
    n_R: int = 33

    def check(self, path: str) -> None:
        """At least 4 angles and 3 radii."""
        require(self.n_alpha >= 4, f"{path}.n_alpha", self.n_alpha, "must be >= 4")
        require(self.n_R >= 3, f"{path}.n_R", self.n_R, "must be >= 3")


@dataclass
class ControlConfig:
    """The closed loop of docs/model.md s.12.2 on the sphere of ``base``."""

    base: str = "en02"
    duration: float = 15.0
    theta_goal_deg: float = -360.0
    arrival_tol_deg: float = 2.0
    zeta_c: float = 1.0
    zeta: float = 1.0
    u_max: float | None = None
    path_interval: float = 0.02
    extrema: ExtremaGridConfig = field(default_factory=lambda: ExtremaGridConfig(16, 9))
    omega_max: list[float] = field(default_factory=lambda: [1.0, 1.5, 2.0, 2.5, 3.0])
    delta_max_deg: list[float] = field(default_factory=lambda: [5.0, 10.0, 20.0])
    omega_c: list[float] = field(default_factory=lambda: [2.0, 3.0, 4.0])
    omega_n: list[float] = field(default_factory=lambda: [10.0, 20.0, 40.0])
    default: ControllerPoint = field(default_factory=ControllerPoint)
    quintic: BisectionConfig = field(default_factory=BisectionConfig)
    trapezoid: TrapezoidGridConfig = field(default_factory=TrapezoidGridConfig)
    robustness: RobustnessConfig = field(default_factory=RobustnessConfig)

    def check(self, path: str, bases: dict[str, DynamicConfig]) -> None:
        """A fixed-step explicit base, positive gains and limits, delta_max below half a
        cavity, u_max > 0 (null: none), a duration and sampling on the base's steps."""
        require(self.base in bases, f"{path}.base", self.base,
                f"must be a key of bases ({', '.join(sorted(bases))})")
        base = bases[self.base]
        sv = base.solver
        require(solvers.get(str(sv.method)).stepper == solvers.EXPLICIT and not sv.adaptive
                and not sv.dense_output, f"bases.{self.base}.solver.method", str(sv.method),
                "the closed loop runs a fixed-step explicit method (rk4, or dopri5 / dop853 "
                "with fixed_step) without dense output")
        half = 180.0 / base.geometry.Ka
        require(self.duration > 0.0, f"{path}.duration", self.duration, "must be > 0 s")
        for step in sv.timesteps():
            for key, v in (("duration", self.duration), ("path_interval", self.path_interval)):
                require(abs(v / step - round(v / step)) < 1e-9 and v > 0.0, f"{path}.{key}", v,
                        f"must be a positive multiple of bases.{self.base}.solver.dt and of "
                        f"dt / refine ({step:g} s)")
        self.extrema.check(f"{path}.extrema")
        require(self.theta_goal_deg != 0.0 and math.isfinite(self.theta_goal_deg),
                f"{path}.theta_goal_deg", self.theta_goal_deg, "must be a nonzero travel")
        require(self.arrival_tol_deg > 0.0, f"{path}.arrival_tol_deg", self.arrival_tol_deg,
                "must be > 0 deg")
        require(self.zeta_c > 0.0, f"{path}.zeta_c", self.zeta_c, "must be > 0 (a gain)")
        require(self.zeta >= 0.0, f"{path}.zeta", self.zeta, "must be >= 0 (a gain)")
        require(self.u_max is None or self.u_max > 0.0, f"{path}.u_max", self.u_max,
                "must be > 0 rad/s^2 (null: no limit)")
        points = [(f"{path}.omega_max", self.omega_max), (f"{path}.omega_c", self.omega_c),
                  (f"{path}.omega_n", self.omega_n)]
        for key, values in points:
            require(len(values) >= 1, key, list(values), "needs at least 1 value")
            for i, v in enumerate(values):
                require(v > 0.0, f"{key}[{i}]", v, "must be > 0 (a gain or a limit)")
        require(len(self.delta_max_deg) >= 1, f"{path}.delta_max_deg", list(self.delta_max_deg),
                "needs at least 1 value")
        for i, v in enumerate(self.delta_max_deg):
            require(0.0 <= v < half, f"{path}.delta_max_deg[{i}]", v,
                    f"must lie in [0, 180 / Ka = {half:g}) deg: at half a cavity the lead "
                    "reaches the next cavity")
        d = self.default
        for key in ("omega_max", "omega_c", "omega_n"):
            require(getattr(d, key) > 0.0, f"{path}.default.{key}", getattr(d, key),
                    "must be > 0 (a gain or a limit)")
        require(0.0 <= d.delta_max_deg < half, f"{path}.default.delta_max_deg",
                d.delta_max_deg, f"must lie in [0, 180 / Ka = {half:g}) deg")
        q = self.quintic
        require(0.0 < q.lo < q.hi, f"{path}.quintic.lo", q.lo,
                f"must satisfy 0 < lo < hi = {q.hi} s")
        require(0.0 < q.tol < q.hi - q.lo, f"{path}.quintic.tol", q.tol,
                "must be > 0 and below the bracket's width")
        require(q.hi <= self.duration, f"{path}.quintic.hi", q.hi,
                f"must be <= duration = {self.duration} s (a cycle ends within the run)")
        for key in ("omega_max", "a_max"):
            values = getattr(self.trapezoid, key)
            require(len(values) >= 1, f"{path}.trapezoid.{key}", list(values),
                    "needs at least 1 value")
            for i, v in enumerate(values):
                require(v > 0.0, f"{path}.trapezoid.{key}[{i}]", v, "must be > 0")
        r = self.robustness
        for i, mu in enumerate(r.mus):
            require(mu >= 0.0, f"{path}.robustness.mus[{i}]", mu, "must be >= 0")
        for i, f in enumerate(r.mass_factors):
            require(f > 0.0, f"{path}.robustness.mass_factors[{i}]", f, "must be > 0")
        require(0.0 < r.quintic_T <= self.duration, f"{path}.robustness.quintic_T",
                r.quintic_T, f"must lie in (0, duration = {self.duration}] s")


# ------------------------------------------------------------------------------- runs
def _carried(res: SimulationResult) -> bool:
    """Whether res carried the sphere through its whole run without a numerical failure."""
    return bool(res.carried and res.counts.status == "ok")


#: A bisection's outcome: the cycles tried (and whether each carried), the final bracket's
#: lo and hi, the run at hi, whether the bracket held a boundary.
Bisection = tuple[list[tuple[float, bool]], float, float, SimulationResult, bool]


def _bisect(q: BisectionConfig, run: Callable[[float, float], SimulationResult], dt: float
            ) -> Bisection:
    """The quintic cycle's carried boundary by bisection of [q.lo, q.hi] to q.tol with runs
    at step dt: (the cycles tried and whether each carried, the final bracket lo and hi, the
    run at hi, whether the bracket held a boundary at all)."""
    lo, hi = q.lo, q.hi
    tried: list[tuple[float, bool]] = []
    hi_res = run(hi, dt)
    tried.append((hi, _carried(hi_res)))
    tried.append((lo, _carried(run(lo, dt))))
    found = tried[0][1] and not tried[1][1]
    best = hi_res
    while found and hi - lo > q.tol:
        mid = 0.5 * (lo + hi)
        r = run(mid, dt)
        ok = _carried(r)
        tried.append((mid, ok))
        if ok:
            hi, best = mid, r
        else:
            lo = mid
    return tried, lo, hi, best, found


#: The verification's step refinement of a fixed-step search: RK4's error shrinks as dt^4,
#: so dt / 4 is 256 times tighter (the budget asks for at least 100 times).
CHECK_REFINE = 4


@dataclass(frozen=True)
class StepCheck:
    """The accuracy budget of an answer computed at a fixed step (docs/studies.md "EN-04"): its
    resolution and budget (1e-2 of it), the largest error observed on ``points`` reruns at the
    reference step, the step it ran at; ``found`` False when there was nothing to check."""

    resolution: float
    budget: float
    observed: float
    points: int
    dt: float
    reference_dt: float
    found: bool
    tightened: int = 0

    @property
    def ok(self) -> bool:
        """The observed error is within the budget (nothing to check: ok)."""
        return not self.found or self.observed <= self.budget

    def line(self) -> str:
        """"numerical error <= X (budget Y, checked on N points)"."""
        if not self.found:
            return "nothing to check"
        text = (f"numerical error <= {self.observed:.2g} s (budget {self.budget:.2g} s, "
                f"checked on {self.points} points)")
        if self.tightened:
            text += (f"; broken at first, the bisection redone {self.tightened} time(s) at "
                     "half the step")
        return text

    def attrs(self, prefix: str) -> dict[str, float | int | str]:
        """Flat netCDF attributes of the check."""
        return {f"{prefix}resolution": self.resolution, f"{prefix}budget": self.budget,
                f"{prefix}observed": self.observed,
                f"{prefix}points": self.points, f"{prefix}dt": self.dt,
                f"{prefix}reference_dt": self.reference_dt, f"{prefix}ok": int(self.ok),
                f"{prefix}tightened": self.tightened, f"{prefix}line": self.line()}


def check_bracket(q: BisectionConfig, run: Callable[[float, float], SimulationResult],
                  dt: float, bisection: Bisection) -> StepCheck:
    """The bisection's budget (1e-2 of q.tol, creatio.studies.budget.resolution_budget)
    checked on its final bracket: both ends rerun at dt / CHECK_REFINE. When both keep
    their outcome, the boundary at the tighter step lies in the same bracket, and (the
    carried set being an interval above the boundary, as bisection assumes) every earlier
    decision holds too: the reported boundary is the same, error 0. An end that flips moves
    it by at least a bracket: the error is recorded as the bracket's width, over budget."""
    from creatio.studies.budget import resolution_budget

    _, lo, hi, _, found = bisection
    fine = dt / CHECK_REFINE
    if not found:
        return StepCheck(q.tol, resolution_budget(q.tol), math.nan, 0, dt, fine, False)
    flipped = [_carried(run(T, fine)) != ok for T, ok in ((lo, False), (hi, True))]
    observed = (hi - lo) if any(flipped) else 0.0
    return StepCheck(q.tol, resolution_budget(q.tol), observed, 2, dt, fine, True)


#: The seed and size of the grid's verification subsample (creatio.studies.budget.subsample).
CHECK_SEED = 0
CHECK_POINTS = 16


def crossing(res: SimulationResult, goal: float, tol: float) -> float:
    """The arrival of :func:`measure` between recorded steps: the time at which |theta - goal|
    first falls to tol, linear between the step before and the step of the arrival (NaN
    when it never does); a continuous measure of the arrival, to compare runs at two steps."""
    h = res.histories
    if h.t.size == 0:
        return math.nan
    e = np.abs(h.alpha - h.alpha[0] - goal) - tol
    within = np.flatnonzero(e <= 0.0)
    if within.size == 0:
        return math.nan
    j = int(within[0])
    if j == 0:
        return float(h.t[0])
    return float(h.t[j - 1] + (h.t[j] - h.t[j - 1]) * e[j - 1] / (e[j - 1] - e[j]))


def check_arrivals(runs: Sequence[SimulationResult],
                   rerun: Callable[[int, float], SimulationResult], goal: float, tol: float,
                   dt: float) -> StepCheck:
    """The grid's budget: its arrivals, known to the step dt, within 1e-2 of it. A seeded
    subsample of CHECK_POINTS cases is rerun at dt / CHECK_REFINE (``rerun(i, step)``) and
    the largest difference of :func:`crossing` recorded (inf when a case's carried flips)."""
    from creatio.studies.budget import resolution_budget, subsample

    fine = dt / CHECK_REFINE
    idx = subsample(len(runs), CHECK_POINTS, CHECK_SEED)
    observed = 0.0
    for i in idx:
        a, b = runs[i], rerun(int(i), fine)
        if _carried(a) != _carried(b):
            observed = math.inf
        elif _carried(a):
            observed = max(observed, abs(crossing(a, goal, tol) - crossing(b, goal, tol)))
    return StepCheck(dt, resolution_budget(dt), observed, int(idx.size), dt, fine,
                     bool(idx.size))


def budgeted_bisection(q: BisectionConfig, run: Callable[[float, float], SimulationResult],
                       dt: float, max_tighten: int = 2) -> tuple[Bisection, StepCheck]:
    """The bisection at step dt and its check (:func:`check_bracket`); a broken budget
    halves the step and redoes the bisection, at most max_tighten times (then ``ok`` is
    False), and the check says so (``tightened``)."""
    tightened = 0
    while True:
        bisection = _bisect(q, run, dt)
        check = check_bracket(q, run, dt, bisection)
        if check.ok or tightened >= max_tighten:
            return bisection, replace(check, tightened=tightened)
        dt, tightened = dt / 2.0, tightened + 1


def controller(cfg: ControlConfig, problem: SphereProblem, k_alpha: float, point: ControllerPoint
               ) -> Controller:
    """The controller of one grid point on problem's start, gains by the design rule."""
    k_theta, k_omega = outer_gains(point.omega_c, cfg.zeta_c, k_alpha)
    return Controller(goal=math.radians(cfg.theta_goal_deg), alpha0=problem.start_point[1],
                      k_theta=k_theta, k_omega=k_omega, omega_max=point.omega_max,
                      delta_max=math.radians(point.delta_max_deg), omega_n=point.omega_n,
                      zeta=cfg.zeta, u_max=math.inf if cfg.u_max is None else cfg.u_max)


def _stable(problem: SphereProblem) -> SphereProblem:
    """problem at its dt, or at dt halved until the friction stability limit allows it (a
    robustness run at a larger mu; the step used is recorded)."""
    while True:
        try:
            check_stable(problem)
            return problem
        except UnstableStepError:
            problem = problem.replace(dt=problem.solver.dt / 2.0,
                                      interval=problem.output.interval / 2.0)


def _simulate(problem: SphereProblem) -> SimulationResult:
    from creatio.dynamics import simulate

    return simulate(_stable(problem))


# ------------------------------------------------------------------ actuation demand
@dataclass(frozen=True)
class DemandSettings:
    """The settings of the actuation figures along each run (EN-04): study.actuation's
    areal density and damping, quadrature (first grid, growth, tolerance, most grids) and
    energy fraction of the bandwidth; study.control.extrema's start grid of the stroke."""

    sigma: float = 0.5
    c_d: float = 0.0
    n_alpha: int = 9
    n_R: int = 5
    growth: float = 1.5
    rtol: float = 1e-10
    max_levels: int = 12
    extrema_n_alpha: int = 16
    extrema_n_R: int = 9
    energy_fraction: float = 0.99


#: The actuation figures of each controlled run (docs/model.md s.12.1): dataset variable,
#: unit and long name.
DEMAND_FIGURES = (
    ("P_actuator_peak", "W", "largest |P_actuator|, P_surface + P_inertia + P_gravity + "
                             "P_damping along the run"),
    ("E_actuator", "J", "int P_actuator dt over the run (int P_inertia dt as K_m(end) - "
                        "K_m(0))"),
    ("P_inertia_peak", "W", "largest |P_inertia| = |dK_m/dt| along the run"),
    ("K_m_max", "J", "largest membrane kinetic energy along the run"),
    ("stroke", "m", "largest max_t W - min_t W over the membrane's points"),
    ("max_W_t", "m s-1", "largest |W_t| over the membrane and the run"),
    ("max_W_tt", "m s-2", "largest |W_tt| over the membrane and the run"),
    ("bandwidth", "Hz", "largest local frequency (|phi_r'| + |phi_a'|) / (2 pi)"),
    ("bandwidth99", "Hz", "frequency below which 99 % of the energy of W_t at the worst "
                          "point lies (NaN: the run does not end at rest)"),
    ("K_m_closed_form_rel_error", "1", "largest |K_m - flat-annulus closed form| over the "
                                       "largest K_m (NaN off the flat annulus)"),
)


@dataclass
class DemandAlong:
    """The actuation figures of one run (keys of DEMAND_FIGURES) and the powers and K_m at
    its demand samples t."""

    figures: dict[str, float]
    t: np.ndarray
    histories: dict[str, np.ndarray]


def _rows(res: SimulationResult, interval: float) -> np.ndarray:
    """Every row of res at the interval (rounded to its step), and its last row."""
    h = res.histories
    every = max(1, round(interval / res.counts.dt))
    rows = np.arange(0, h.t.size, every)
    if rows.size and rows[-1] != h.t.size - 1:
        rows = np.append(rows, h.t.size - 1)
    return rows


def servo_along(res: SimulationResult, ctl: Controller, Ka: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """(u, delta) at every recorded step of res by the controller's own formula, compiled
    (creatio.dynamics.control_loop): computed once per run and handed to :func:`measure` and
    :func:`demand_figures`, which need both."""
    from creatio.dynamics.control_loop import servo_histories  # the compiler, when run

    h = res.histories
    u, delta, _ = servo_histories(ctl, Ka, h.alpha, h.alphadot, h.phi_a, h.phi_a_rate)
    return u, delta


def _motion_along(res: SimulationResult, motion: Motion, ctl: Controller | None, Ka: float,
                  rows: np.ndarray, u: np.ndarray | None = None) -> Motion:
    """The surface's motion along res at its rows: the laws of an open-loop run, or the
    controlled phase as samples (phi_a, its rate, and u recomputed by the controller, or
    taken from ``u`` at every recorded step when given)."""
    if ctl is None:
        return motion
    h = res.histories
    if u is None:
        from creatio.dynamics.control_loop import servo_histories

        u, _, _ = servo_histories(ctl, Ka, h.alpha[rows], h.alphadot[rows], h.phi_a[rows],
                                  h.phi_a_rate[rows])
    else:
        u = u[rows]
    return act.sampled_motion(motion, h.t[rows], h.phi_a[rows], h.phi_a_rate[rows],
                              np.asarray(u, float))


#: The maxima of W whose local search the figures use: the stroke and the worst point of
#: |W_t| (its spectrum is the bandwidth); max |W_tt| is the closed form's, so its search,
#: independent of the others, is skipped.
DEMAND_POLISHED = ("stroke", "max_W_t")

#: The golden-section tolerance (s) of K_m's largest value between recorded steps: a sampled
#: phase is known to far less than refine_maximum's default (creatio.model.actuation).
REFINE_XTOL = 1e-9


def _around_peaks(rows: np.ndarray, samples: list[np.ndarray], fraction: float = 0.5,
                  most: int = 8) -> np.ndarray:
    """The recorded rows between the neighbours of each sample's largest local maxima of
    |y| (those within ``fraction`` of its largest, at most ``most`` per history)."""
    out: list[np.ndarray] = []
    for y in samples:
        a = np.abs(y)
        if a.size < 3 or not np.isfinite(a).all():
            continue
        left = np.r_[-np.inf, a[:-1]]
        right = np.r_[a[1:], -np.inf]
        tops = np.flatnonzero((a >= left) & (a >= right) & (a >= fraction * a.max()))
        for j in tops[np.argsort(a[tops])[::-1][:most]]:
            out.append(np.arange(rows[max(j - 1, 0)], rows[min(j + 1, rows.size - 1)] + 1))
    return np.unique(np.concatenate(out)) if out else np.empty(0, dtype=int)


def demand_figures(res: SimulationResult, surface: Surface, motion: Motion,
                   ctl: Controller | None, rule: act.Quadrature, settings: DemandSettings,
                   g: float, interval: float, u: np.ndarray | None = None) -> DemandAlong:
    """What the actuators delivered along res (docs/model.md s.12.1). ``motion`` is the
    run's (its angular law replaced by the controlled phase, sampled at every recorded step,
    when ``ctl`` is given; ``u`` the controller's u at every step when the caller has it,
    :func:`servo_along`).

    The load power at every recorded step; the membrane integrals by ``rule`` at the rows
    every ``interval``, and again at every recorded step around the largest samples of
    |P_actuator| and |P_inertia| (a servo's transients are shorter than a path interval:
    the peaks are those of the recorded steps); E_actuator = int P_surface dt over every
    step + K_m(end) - K_m(0) (P_inertia is dK_m/dt) + int (P_gravity + P_damping) dt over
    the rows (rate-level integrands, smooth). The stroke and the worst point from the
    (alpha, R) grid at the rows, each polished by the local search (on a partial sweep the
    grid alone is 2 % short), the closed-form maxima of |W_t|, |W_tt| and the local
    frequency over the run, the energy frequency of W_t at the worst point at the rows (NaN
    unless the run ends with its local frequency below 1 % of the largest: the record must
    end at rest)."""
    h = res.histories
    n = h.t.size
    if n < 3:
        return DemandAlong({k: math.nan for k, *_ in DEMAND_FIGURES}, h.t, {})
    s = settings
    t_all = h.t
    m = _motion_along(res, motion, ctl, float(surface.Ka), np.arange(n), u)
    P_all = act.load_power(surface, m, t_all, h.R, h.alpha, h.N, h.f)
    rows = _rows(res, interval)
    t = t_all[rows]
    d = act.actuation_demand(surface, m, t, P_all[rows], rule, s.sigma, s.c_d, g,
                             span=(float(t[0]), float(t[-1])),
                             extrema=(s.extrema_n_alpha, s.extrema_n_R),
                             energy_fraction=s.energy_fraction, xtol=REFINE_XTOL,
                             polish=DEMAND_POLISHED)
    coarse = d.powers()
    near = np.setdiff1d(_around_peaks(rows, [coarse["P_actuator"], coarse["P_inertia"]]),
                        rows)
    mi = act.membrane_integrals(surface, m, t_all[near], rule, s.sigma, s.c_d, g)
    fine = {"P_surface": P_all[near], "P_inertia": mi.inertia, "P_gravity": mi.gravity,
            "P_damping": mi.damping,
            "P_actuator": P_all[near] + mi.inertia + mi.gravity + mi.damping,
            "K_m": mi.kinetic}
    order = np.argsort(np.concatenate([rows, near]), kind="stable")
    histories = {key: np.concatenate([y, fine[key]])[order]
                 for key, y in {**coarse, "K_m": d.integrals.kinetic}.items()}
    K = d.integrals.kinetic
    membrane = d.integrals.gravity + d.integrals.damping
    energy = (act.time_integral(P_all, t_all) + float(K[-1] - K[0])
              + act.time_integral(membrane, t))
    try:
        K_cf, _ = act.annulus_kinetic_energy(surface, m, t, s.sigma)
        K_rel = float(np.max(np.abs(K - K_cf)) / np.max(np.abs(K_cf)))
    except ValueError:  # an inclined membrane: no closed form
        K_rel = math.nan
    figures = {
        "P_actuator_peak": float(np.max(np.abs(histories["P_actuator"]))),
        "E_actuator": energy,
        "P_inertia_peak": float(np.max(np.abs(histories["P_inertia"]))),
        "K_m_max": d.K_m_max, "stroke": d.extrema.stroke,
        "max_W_t": d.max_W_t_closed_form, "max_W_tt": d.max_W_tt_closed_form,
        "bandwidth": d.bandwidth,
        # the spectrum takes W_t as zero after the record: a run that stops with the pattern
        # still moving (lost, or not settled) would have its truncation counted as signal
        "bandwidth99": (d.bandwidth99 if act.local_frequency(m, t[-1:])[0]
                        <= 0.01 * d.bandwidth else math.nan),
        "K_m_closed_form_rel_error": K_rel,
    }
    return DemandAlong(figures, t_all[np.concatenate([rows, near])[order]], histories)


def _histories_along(res: SimulationResult, surface: Surface, motion: Motion,
                     ctl: Controller | None, rule: act.Quadrature, settings: DemandSettings,
                     g: float, u: np.ndarray | None = None) -> DemandAlong:
    """The powers and K_m of :func:`demand_figures` at every recorded step of res, without its
    figures (a path's histories: the same numbers, none of the searches)."""
    h = res.histories
    if h.t.size < 3:
        return DemandAlong({}, h.t, {})
    m = _motion_along(res, motion, ctl, float(surface.Ka), np.arange(h.t.size), u)
    P = act.load_power(surface, m, h.t, h.R, h.alpha, h.N, h.f)
    mi = act.membrane_integrals(surface, m, h.t, rule, settings.sigma, settings.c_d, g)
    return DemandAlong({}, h.t, {
        "P_surface": P, "P_inertia": mi.inertia, "P_gravity": mi.gravity,
        "P_damping": mi.damping, "P_actuator": P + mi.inertia + mi.gravity + mi.damping,
        "K_m": mi.kinetic})


def _maxima_every_step(res: SimulationResult, surface: Surface, motion: Motion,
                       ctl: Controller | None, rule: act.Quadrature, settings: DemandSettings,
                       g: float, u: np.ndarray | None, every: DemandAlong) -> dict[str, float]:
    """K_m_max and max |W_tt| as :func:`demand_figures` refines them (the same searches and
    tolerances), from every recorded step of res (``every``: its histories there)."""
    h = res.histories
    if h.t.size < 3:
        return {"K_m_max": math.nan, "max_W_tt": math.nan}
    m = _motion_along(res, motion, ctl, float(surface.Ka), np.arange(h.t.size), u)

    def K_quad(x: np.ndarray) -> np.ndarray:
        return act.membrane_integrals(surface, m, x, rule, settings.sigma, 0.0, g).kinetic

    _, K_max = act.refine_maximum(K_quad, every.t, every.histories["K_m"], REFINE_XTOL)
    _, wtt = act.time_maximum(lambda x: act.normal_rate_bounds(surface, m, x)[1],
                              float(h.t[0]), float(h.t[-1]))
    return {"K_m_max": K_max, "max_W_tt": wtt}


@dataclass
class Measured:
    """What one run's histories say against the arrival rule (angles in deg, times in s)."""

    status: str
    carried: bool
    arrival: float
    settling: float
    final_error: float
    overshoot: float
    max_delta: float
    max_phidot: float
    max_u: float
    min_N: float
    max_slip: float
    max_track: float
    P_peak: float
    P_mean: float
    residual: float
    end_time: float


def measure(res: SimulationResult, goal: float, tol: float, Ka: float,
            ctl: Controller | None, servo: tuple[np.ndarray, np.ndarray] | None = None
            ) -> Measured:
    """The arrival rule of docs/model.md s.12.2 on theta = alpha - alpha(0): arrival the first
    time |theta - goal| <= tol, settling the time from which it stays so to the end (NaN if
    it does not end so, or the run stopped early), overshoot past the goal; u recomputed from
    the histories by the controller's own formula (``servo``: its (u, delta) at every step,
    :func:`servo_along`, when the caller has them)."""
    h = res.histories
    t = h.t
    if t.size == 0:
        nan = math.nan
        return Measured(res.counts.status, False, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan,
                        nan, nan, nan, 0.0)
    theta = h.alpha - h.alpha[0]
    err = theta - goal
    within = np.abs(err) <= tol
    arrival = float(t[np.argmax(within)]) if within.any() else math.nan
    settling = math.nan
    ran = res.counts.status == "ok"
    if ran and within[-1]:
        outside = np.nonzero(~within)[0]
        settling = float(t[outside[-1] + 1]) if outside.size else float(t[0])
    sign = math.copysign(1.0, goal)
    overshoot = max(0.0, float(np.max(sign * err)))
    if ctl is not None:
        u, delta = servo if servo is not None else servo_along(res, ctl, Ka)
        phidot = h.phi_a_rate
        max_u = float(np.max(np.abs(u)))
    else:
        delta = np.array([lead(a, p, Ka) for a, p in zip(h.alpha, h.phi_a, strict=True)])
        phidot = np.gradient(h.phi_a, t) if t.size > 1 else np.zeros(1)
        max_u = math.nan
    P = np.gradient(h.surface_work, t) if t.size > 1 else np.zeros(1)
    span = float(t[-1] - t[0])
    return Measured(
        status=res.counts.status, carried=bool(res.carried and ran), arrival=arrival,
        settling=settling, final_error=math.degrees(float(err[-1])),
        overshoot=math.degrees(overshoot), max_delta=math.degrees(float(np.max(np.abs(delta)))),
        max_phidot=float(np.max(np.abs(phidot))), max_u=max_u, min_N=res.extrema.min_N,
        max_slip=res.extrema.max_slip_speed, max_track=res.extrema.max_cavity_tracking_error,
        P_peak=float(np.max(np.abs(P))),
        P_mean=float(h.surface_work[-1] - h.surface_work[0]) / span if span > 0 else 0.0,
        residual=res.extrema.max_energy_residual, end_time=float(t[-1]))


def _difference(a: SimulationResult, b: SimulationResult) -> float:
    """Largest distance between the centres of two runs at their common times."""
    ha, hb = a.histories, b.histories
    common, ia, ib = np.intersect1d(np.round(ha.t, 9), np.round(hb.t, 9), return_indices=True)
    if common.size == 0:
        return math.nan
    return float(np.max(np.linalg.norm(ha.X[ia] - hb.X[ib], axis=1)))


@dataclass
class Path:
    """A run's path on the common time grid: travel (deg), pattern speed (rad/s), lead (deg),
    load power (W), and what a scene draws: the sphere centre (m, world frame), the angular
    phase phi_a (deg) and the orientation (unit quaternion, scalar first; NaN where the run
    did not integrate it)."""

    name: str
    label: str
    t: np.ndarray
    theta: np.ndarray
    pattern_speed: np.ndarray
    lead: np.ndarray
    power: np.ndarray
    centre: np.ndarray
    phase_a: np.ndarray
    quaternion: np.ndarray


def _path(name: str, label: str, res: SimulationResult, Ka: float, grid: np.ndarray) -> Path:
    """res's histories on grid (NaN after its last row). The grid's times are steps of the
    run (path_interval is a multiple of dt), so the centre and phase are the run's own rows."""
    h = res.histories
    theta = np.degrees(h.alpha - h.alpha[0])
    rate = h.phi_a_rate if np.isfinite(h.phi_a_rate).all() else np.gradient(h.phi_a, h.t)
    delta = np.degrees([lead(a, p, Ka) for a, p in zip(h.alpha, h.phi_a, strict=True)])
    power = np.gradient(h.surface_work, h.t)

    def on(y: np.ndarray) -> np.ndarray:
        if y.ndim == 2:
            return np.stack([on(col) for col in y.T], axis=-1)
        return np.interp(grid, h.t, y, right=math.nan)

    Q = h.Q if len(h.Q) == len(h.t) else np.full((len(h.t), 4), math.nan)
    return Path(name, label, grid, on(theta), on(-rate / Ka), on(delta), on(power),
                on(h.X), on(np.degrees(h.phi_a)), on(Q))


def run_control(cfg: ControlConfig, base: DynamicConfig, k_alpha: float,
                demand: DemandSettings | None = None) -> xr.Dataset:
    """The ``en04_control`` dataset (see the module docstring); ``demand`` holds the settings
    of the actuation figures (default DemandSettings())."""
    import xarray as xr

    Ka = float(base.geometry.Ka)
    goal = math.radians(cfg.theta_goal_deg)
    tol = math.radians(cfg.arrival_tol_deg)
    dts = base.solver.timesteps()
    nominal = base.sphere_problem().replace(t_end=cfg.duration)

    def at(dt: float, **changes: Any) -> SphereProblem:
        return nominal.replace(dt=dt, interval=dt, **changes)

    # ---- the controller grid
    keys = ("omega_max", "delta_max_deg", "omega_c", "omega_n")
    grid = [ControllerPoint(om, dm, wc, wn) for om in cfg.omega_max for dm in cfg.delta_max_deg
            for wc in cfg.omega_c for wn in cfg.omega_n]
    cases: list[Measured] = []
    diffs: list[float] = []
    results: list[SimulationResult] = []
    servos: list[tuple[np.ndarray, np.ndarray]] = []
    for point in grid:
        ctl = controller(cfg, nominal, k_alpha, point)
        coarse = _simulate(at(dts[0], control=ctl))
        fine = _simulate(at(dts[1], control=ctl))
        servos.append(servo_along(coarse, ctl, Ka))
        cases.append(measure(coarse, goal, tol, Ka, ctl, servos[-1]))
        diffs.append(_difference(coarse, fine))
        results.append(coarse)
    arrivals = np.array([c.arrival if c.carried else math.nan for c in cases])
    fastest = int(np.nanargmin(arrivals)) if np.isfinite(arrivals).any() else -1
    arrival_check = check_arrivals(
        results, lambda i, dt: _simulate(at(dt, control=controller(cfg, nominal, k_alpha,
                                                                    grid[i]))),
        goal, tol, dts[0])

    # ---- open loop: the quintic cycle's carried boundary
    phase_travel = -Ka * goal
    pa0 = float(nominal.model.motion.phi_a.scalar(0.0)[0])
    motion = nominal.model.motion

    def quintic(T: float, problem: SphereProblem | None = None) -> SimulationResult:
        law = Law.quintic(pa0, phase_travel, T)
        p = problem or at(dts[0])
        return _simulate(p.replace(motion=Motion(motion.phi_r, law, motion.gamma)))

    q = cfg.quintic
    bisection, boundary_check = budgeted_bisection(q, lambda T, dt: quintic(T, at(dt)), dts[0])
    tried, lo, hi, best_quintic, boundary_found = bisection
    if boundary_check.tightened and boundary_found:  # the boundary case at the base's step
        best_quintic = quintic(hi)
    boundary_T = hi if boundary_found else math.nan
    quintic_measure = measure(best_quintic, goal, tol, Ka, None)

    # ---- open loop: the trapezoidal laws, switch times on the step grid
    trap_rows: list[tuple[float, float, float, float, float, float, Measured]] = []
    trap_results: list[SimulationResult] = []
    trap_laws: list[Law] = []
    for om in cfg.trapezoid.omega_max:
        for am in cfg.trapezoid.a_max:
            T, ramp, W, a = trapezoid_on_grid(phase_travel, Ka * om, Ka * am, dts[0])
            law = Law.trapezoid(pa0, phase_travel, T, ramp)
            r = _simulate(at(dts[0]).replace(motion=Motion(motion.phi_r, law, motion.gamma)))
            trap_rows.append((om, am, W / Ka, a / Ka, T, ramp * T,
                              measure(r, goal, tol, Ka, None)))
            trap_results.append(r)
            trap_laws.append(law)
    trap_arrival = np.array([m.arrival if m.carried else math.nan for *_, m in trap_rows])
    best_trap = int(np.nanargmin(trap_arrival)) if np.isfinite(trap_arrival).any() else -1

    # ---- robustness: default controller and quintic at a fixed T, mu x mass
    rb = cfg.robustness
    closed = np.zeros((len(rb.mus), len(rb.mass_factors)), dtype=bool)
    opened = np.zeros_like(closed)
    closed_arrival = np.full(closed.shape, math.nan)
    open_arrival = np.full(closed.shape, math.nan)
    closed_status = np.full(closed.shape, "", dtype=object)
    open_status = np.full(closed.shape, "", dtype=object)
    robust_dt = np.full(closed.shape, math.nan)
    default_ctl = controller(cfg, nominal, k_alpha, cfg.default)
    robust_runs: list[tuple[SimulationResult, tuple[np.ndarray, np.ndarray]]] = []
    for i, mu in enumerate(rb.mus):
        for j, f in enumerate(rb.mass_factors):
            p = at(dts[0], mu=float(mu), m=nominal.model.sphere.m * f)
            rc = _simulate(p.replace(control=default_ctl))
            robust_runs.append((rc, servo_along(rc, default_ctl, Ka)))
            ro = quintic(rb.quintic_T, p)
            mc = measure(rc, goal, tol, Ka, default_ctl, robust_runs[-1][1])
            mo = measure(ro, goal, tol, Ka, None)
            closed[i, j], opened[i, j] = mc.carried, mo.carried
            closed_arrival[i, j], open_arrival[i, j] = mc.arrival, mo.arrival
            closed_status[i, j], open_status[i, j] = rc.counts.status, ro.counts.status
            robust_dt[i, j] = rc.counts.dt

    # ---- paths for the figures
    tgrid = np.arange(0.0, cfg.duration + 0.5 * cfg.path_interval, cfg.path_interval)
    paths = []
    if fastest >= 0:
        paths.append(_path("closed_loop", "fastest closed loop", results[fastest], Ka, tgrid))
    paths.append(_path("quintic", f"quintic T = {boundary_T:.3f} s", best_quintic, Ka, tgrid))
    if best_trap >= 0:
        paths.append(_path("trapezoid", "best trapezoid", trap_results[best_trap], Ka, tgrid))

    def col(name: str) -> np.ndarray:
        return np.array([getattr(c, name) for c in cases], dtype=float)

    ds = xr.Dataset(
        {
            "status": ("case", np.array([c.status for c in cases], dtype=str)),
            "carried": ("case", np.array([c.carried for c in cases])),
            "arrival": ("case", col("arrival"), {"units": "s"}),
            "settling": ("case", col("settling"), {"units": "s"}),
            "final_error": ("case", col("final_error"), {"units": "degree"}),
            "overshoot": ("case", col("overshoot"), {"units": "degree"}),
            "max_delta": ("case", col("max_delta"), {"units": "degree"}),
            "max_phidot_a": ("case", col("max_phidot"), {"units": "rad s-1"}),
            "max_u": ("case", col("max_u"), {"units": "rad s-2"}),
            "min_normal_reaction": ("case", col("min_N"), {"units": "N"}),
            "max_slip": ("case", col("max_slip"), {"units": "m s-1"}),
            "max_cavity_tracking": ("case", col("max_track"), {"units": "m"}),
            "P_surface_peak": ("case", col("P_peak"), {"units": "W"}),
            "P_surface_mean": ("case", col("P_mean"), {"units": "W"}),
            "energy_residual": ("case", col("residual"), {"units": "J"}),
            "timestep_difference": ("case", np.array(diffs), {"units": "m"}),
            "quintic_T": ("bisection", np.array([T for T, _ in tried]), {"units": "s"}),
            "quintic_carried": ("bisection", np.array([ok for _, ok in tried])),
            "trap_omega_max_asked": ("trap", np.array([r[0] for r in trap_rows]),
                                     {"units": "rad s-1"}),
            "trap_a_max_asked": ("trap", np.array([r[1] for r in trap_rows]),
                                 {"units": "rad s-2"}),
            "trap_omega_max": ("trap", np.array([r[2] for r in trap_rows]),
                               {"units": "rad s-1", "long_name": "pattern speed limit used "
                                "(switch times rounded to the step grid)"}),
            "trap_a_max": ("trap", np.array([r[3] for r in trap_rows]), {"units": "rad s-2"}),
            "trap_T": ("trap", np.array([r[4] for r in trap_rows]), {"units": "s"}),
            "trap_ramp_time": ("trap", np.array([r[5] for r in trap_rows]), {"units": "s"}),
            "trap_carried": ("trap", np.array([r[6].carried for r in trap_rows])),
            "trap_status": ("trap", np.array([r[6].status for r in trap_rows], dtype=str)),
            "trap_arrival": ("trap", np.array([r[6].arrival for r in trap_rows]),
                             {"units": "s"}),
            "robust_closed_carried": (("mu", "mass_factor"), closed),
            "robust_open_carried": (("mu", "mass_factor"), opened),
            "robust_closed_arrival": (("mu", "mass_factor"), closed_arrival, {"units": "s"}),
            "robust_open_arrival": (("mu", "mass_factor"), open_arrival, {"units": "s"}),
            "robust_closed_status": (("mu", "mass_factor"), closed_status.astype(str)),
            "robust_open_status": (("mu", "mass_factor"), open_status.astype(str)),
            "robust_dt": (("mu", "mass_factor"), robust_dt, {"units": "s"}),
            "path_theta": (("path", "time"), np.array([p.theta for p in paths]),
                           {"units": "degree"}),
            "path_pattern_speed": (("path", "time"), np.array([p.pattern_speed for p in paths]),
                                   {"units": "rad s-1"}),
            "path_lead": (("path", "time"), np.array([p.lead for p in paths]),
                          {"units": "degree"}),
            "path_power": (("path", "time"), np.array([p.power for p in paths]),
                           {"units": "W"}),
            "path_centre": (("path", "time", "component"), np.array([p.centre for p in paths]),
                            {"long_name": "sphere centre X = c + b n", "units": "m"}),
            "path_phase_a": (("path", "time"), np.array([p.phase_a for p in paths]),
                             {"long_name": "angular phase phi_a", "units": "degree"}),
            "path_quaternion": (("path", "time", "quaternion_component"),
                                np.array([p.quaternion for p in paths]),
                                {"long_name": "orientation, unit quaternion, scalar first"}),
        },
        coords={
            **{k: ("case", np.array([getattr(p, k) for p in grid], dtype=float))
               for k in keys},
            "mu": np.array(rb.mus, dtype=float),
            "mass_factor": np.array(rb.mass_factors, dtype=float),
            "path": [p.name for p in paths],
            "path_label": ("path", [p.label for p in paths]),
            "time": ("time", tgrid, {"units": "s"}),
            "component": ("component", ["x", "y", "z"]),
            "quaternion_component": ("quaternion_component", ["w", "x", "y", "z"]),
        },
    )
    ds.attrs.update({
        "part": "control", "k_alpha": k_alpha, "theta_goal_deg": cfg.theta_goal_deg,
        "arrival_tol_deg": cfg.arrival_tol_deg, "duration": cfg.duration, "dt": dts[0],
        "fine_dt": dts[1], "zeta_c": cfg.zeta_c, "zeta": cfg.zeta,
        "u_max": math.inf if cfg.u_max is None else cfg.u_max,
        "fastest_case": fastest,
        "fastest_arrival": float(arrivals[fastest]) if fastest >= 0 else math.nan,
        "open_loop_boundary_T": boundary_T,
        "open_loop_boundary_found": int(boundary_found),
        **boundary_check.attrs("quintic_accuracy_"),
        **arrival_check.attrs("arrival_accuracy_"),
        "quintic_boundary_arrival": quintic_measure.arrival,
        "trapezoid_best": best_trap,
        "robust_quintic_T": rb.quintic_T,
        "default_omega_max": cfg.default.omega_max,
        "default_delta_max_deg": cfg.default.delta_max_deg,
        "default_omega_c": cfg.default.omega_c, "default_omega_n": cfg.default.omega_n,
    })
    # ---- what the actuators delivered along each controlled run and along the paths
    along: list[Along] = [
        (results[fastest], motion, controller(cfg, nominal, k_alpha, grid[fastest]),
         servos[fastest][0])] if fastest >= 0 else []
    along.append((best_quintic, Motion(motion.phi_r, Law.quintic(pa0, phase_travel, hi),
                                       motion.gamma), None, None))
    if best_trap >= 0:
        along.append((trap_results[best_trap],
                      Motion(motion.phi_r, trap_laws[best_trap], motion.gamma), None, None))
    cases_along: list[Along] = [
        (r, motion, controller(cfg, nominal, k_alpha, point), sv[0])
        for r, point, sv in zip(results, grid, servos, strict=True)]
    robust_along: list[Along] = [(r, motion, default_ctl, sv[0]) for r, sv in robust_runs]
    return _with_demand(ds, cfg, base, demand or DemandSettings(), cases_along,
                        max(fastest, 0), robust_along, along)


#: A run whose actuation figures are computed: its result, surface motion, controller (None
#: on an open loop) and the controller's u at every recorded step (servo_along; None: open).
Along = tuple[SimulationResult, Motion, Controller | None, np.ndarray | None]


def _with_demand(ds: xr.Dataset, cfg: ControlConfig, base: DynamicConfig,
                 settings: DemandSettings, cases: list[Along], reference: int,
                 robust: list[Along], paths: list[Along]) -> xr.Dataset:
    """ds with the actuation figures of docs/model.md s.12.1 along every grid case (``case``),
    every robustness run's controller (``mu`` x ``mass_factor``) and the paths (their powers
    and K_m on ``demand_time``).

    The membrane quadrature is converged once, on the reference case (the fastest, else the
    first) at its path samples, and the grid before the last refinement is used for every run
    (the last refinement changed no integral by more than the tolerance, so that grid is
    within it). Each run's figures come from its rows every path interval, refined at its
    recorded steps around the peaks (:func:`demand_figures`); that sampling is checked
    once, on the same case, against every recorded step (P_actuator's integral there by
    Simpson's rule, the definition), and the relative changes recorded as attributes."""
    surface = base.geometry.surface()
    g = base.sphere.g
    s = settings
    ref_res, ref_motion, ref_ctl, ref_u = cases[reference]
    check_rows = _rows(ref_res, cfg.path_interval)
    conv = act.converge_quadrature(surface, _motion_along(ref_res, ref_motion, ref_ctl,
                                                          float(surface.Ka), check_rows, ref_u),
                                   ref_res.histories.t[check_rows], s.sigma, s.c_d, g,
                                   s.n_alpha, s.n_R, s.rtol, s.growth, s.max_levels)
    levels = conv.levels[-2] if conv.converged else conv.levels[-1]
    rule = act.quadrature(surface, *levels)

    def along(res: SimulationResult, motion: Motion, ctl: Controller | None,
              u: np.ndarray | None, interval: float = cfg.path_interval) -> DemandAlong:
        return demand_figures(res, surface, motion, ctl, rule, s, g, interval, u)

    case_demand = [along(*c) for c in cases]
    # the reference case at every recorded step: the check of the sampling above, and the
    # fastest path's histories; the other paths need only their histories there
    every = _histories_along(ref_res, surface, ref_motion, ref_ctl, rule, s, g, ref_u)
    path_demand = [every if p[0] is ref_res else
                   _histories_along(p[0], surface, p[1], p[2], rule, s, g, p[3])
                   for p in paths]
    ref = case_demand[reference].figures
    direct = {"P_actuator_peak": float(np.max(np.abs(every.histories["P_actuator"]))),
              "E_actuator": act.time_integral(every.histories["P_actuator"], every.t),
              "P_inertia_peak": float(np.max(np.abs(every.histories["P_inertia"]))),
              **_maxima_every_step(ref_res, surface, ref_motion, ref_ctl, rule, s, g, ref_u,
                                   every)}
    sampling = {k: _rel(ref[k], v) for k, v in direct.items()}
    robust_demand = [along(*r) for r in robust]
    shape = (ds.sizes["mu"], ds.sizes["mass_factor"])
    data: dict[str, Any] = {}
    for key, unit, long_name in DEMAND_FIGURES:
        attrs = {"units": unit, "long_name": long_name}
        data[key] = ("case", np.array([d.figures[key] for d in case_demand]), attrs)
        data[f"robust_closed_{key}"] = (("mu", "mass_factor"), np.array(
            [d.figures[key] for d in robust_demand]).reshape(shape), attrs)
    dt = base.solver.dt
    n = max((d.t.size for d in path_demand), default=0)
    tgrid = np.arange(n) * dt
    for key in (*act.POWERS, "K_m"):
        rows = np.full((len(path_demand), n), math.nan)
        for i, d in enumerate(path_demand):
            if key in d.histories:
                rows[i] = np.interp(tgrid, d.t, d.histories[key], right=math.nan)
        data[f"demand_{key}"] = (("path", "demand_time"), rows, {
            "units": "J" if key == "K_m" else "W",
            "long_name": f"{key} along the path at every recorded step"})
    out = ds.assign(data).assign_coords(demand_time=("demand_time", tgrid, {
        "units": "s", "long_name": "simulated time since the start of the run, every "
                                  "recorded step of the paths' actuation histories"}))
    out.attrs.update({
        "demand_sigma": s.sigma, "demand_c_d": s.c_d,
        "demand_sample_interval": cfg.path_interval,
        "demand_quadrature_n_alpha": levels[0], "demand_quadrature_n_R": levels[1],
        "demand_quadrature_levels": np.array(conv.levels, dtype=np.int32).ravel(),
        "demand_quadrature_rel_change": conv.final_rel_change,
        "demand_quadrature_converged": int(conv.converged),
        "demand_reference_case": reference,
        **{f"demand_sampling_rel_change_{k}": v for k, v in sampling.items()},
    })
    return out


def _rel(a: float, b: float) -> float:
    """|a - b| / |b| (NaN where b is 0 or not finite)."""
    return abs(a - b) / abs(b) if math.isfinite(b) and b != 0.0 else math.nan
