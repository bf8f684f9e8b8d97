"""Work-precision benchmark of the sphere integrators (EN-02, EN-02R): run time against error.

For each base study a reference solution is computed by a high-accuracy implicit method
(radau13 at rtol 1e-14) and checked by an independent explicit one (dop853 at rtol 1e-13) and
a fine fixed-step RK4 run, whose agreement is recorded: a level is resolved only above ten
times the checks' disagreement. Every
method of the registry (creatio.dynamics.solvers.METHODS) is swept over its settings
(adaptive ones by tolerance, fixed-step ones by step; an adaptive method may also be run at
fixed steps), so a newly registered method is benchmarked without editing this module. The
error of a run is the maximum over the 0.1 s output grid of |X - X_ref| (centre position,
metres), plus the same at the final time, computed outside the timed region. Timing follows
the DiffEqBenchmarks practice: one warm-up run (which also yields the error), then repeats
of the core call alone (the compiled loop, or the peer's solve), single-threaded; the
repeats are interleaved round-robin across all settings of a base (each round starting one
setting later, so no setting always follows the same neighbour), so a slow spell of the
machine spreads over every setting instead of spoiling one. Every repeat is recorded; the
minimum is the headline number, the median and the spread are kept beside it. The first
call's extra time (JIT compile or cache load) is reported separately.

Peers: scipy's DOP853, Radau and LSODA on a plain NumPy right-hand side, and SUNDIALS
CVODE's BDF through scikit-sundae on the same one (creatio.dynamics.peer_solvers). CVODE is a
benchmark-only dependency (the ``bench`` extra): without it its rows are left out and the
dataset says so (attribute peers_unavailable). Two more rows measure what a minimal-state
run saves: rk4 and radau5 with full diagnostics (energy bookkeeping on); and, without
friction, the base's own solver with the trajectory alone against full diagnostics.

Config: conf/analysis/work_precision.yaml (grids, peers, reference, timing) over the base
studies under ``bases``. One dataset per base study; the first also carries the JIT
first-call times.
"""

from __future__ import annotations

import json
import math
import os
import pickle
import platform
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from creatio.dynamics import METHODS, SphereProblem, stability_limit
from creatio.dynamics.solvers import IMPLICIT
from creatio.model.numerics import steps_in
from creatio.studies.registry import Part
from creatio.studies.schema import (
    MISSING,
    DynamicConfig,
    check_bases,
    count,
    require,
    require_runs,
    require_samples,
)

__all__ = [
    "PEER_METHODS",
    "SUNDIALS_PEERS",
    "JitConfig",
    "MethodGrid",
    "ReferenceConfig",
    "Setting",
    "WorkPrecisionConfig",
    "WorkPrecisionStudy",
    "errors",
    "peer_label",
    "parts",
    "run",
    "settings",
]

#: Names of the peers: scipy's (creatio.dynamics.peer_solvers.PEERS, which imports scipy: the names
#: are repeated here so that validating a config does not) and SUNDIALS' (peers.SUNDIALS).
SUNDIALS_PEERS = ("CVODE",)
PEER_METHODS = ("RK45", "DOP853", "Radau", "LSODA", *SUNDIALS_PEERS)


def peer_label(name: str) -> str:
    """A peer's method label in the report: ``scipy-LSODA``, ``sundials-CVODE-BDF``."""
    return f"sundials-{name}-BDF" if name in SUNDIALS_PEERS else f"scipy-{name}"


# --------------------------------------------------------------------------------- schema
@dataclass
class MethodGrid:
    """The settings one method runs at: tolerances (adaptive), steps (fixed step).

    A fixed step is dt = solver.output_interval / n for n in steps_per_output, so that it
    divides the output grid. An implicit method's fixed steps run at the base's tolerances,
    which its Newton iteration converges to, and again at each of newton_rtol (atol = rtol x
    atol_ratio): at a fixed step the Newton tolerance, not the step, can set the error.
    With dense output (rows from each step's interpolant, steps free of the grid) it runs
    again at each of dense_rtol ("<name>-dense") and at the fixed steps dense_dt, in
    seconds, which need not divide the grid ("<name>-fixed-dense", or "rk4-dense").
    """

    rtol: list[float] = field(default_factory=list)
    steps_per_output: list[int] = field(default_factory=list)
    newton_rtol: list[float] = field(default_factory=list)
    dense_rtol: list[float] = field(default_factory=list)
    dense_dt: list[float] = field(default_factory=list)

    def check(self, path: str) -> None:
        """Tolerances in (0, 1), step counts >= 1, dense steps > 0."""
        for key in ("rtol", "newton_rtol", "dense_rtol"):
            for i, v in enumerate(getattr(self, key)):
                require(math.isfinite(v) and 0.0 < v < 1.0, f"{path}.{key}[{i}]", v,
                        "must lie in (0, 1)")
        for i, n in enumerate(self.steps_per_output):
            require(n >= 1, f"{path}.steps_per_output[{i}]", n, "must be an integer >= 1")
        for i, v in enumerate(self.dense_dt):
            require(math.isfinite(v) and v > 0.0, f"{path}.dense_dt[{i}]", v, "must be > 0 s")


@dataclass
class ReferenceConfig:
    """The reference run (an adaptive method at a tight tolerance) and its two checks."""

    method: str = "radau13"
    rtol: float = 1e-14
    atol: float = 1e-16
    check_method: str = "dop853"
    check_rtol: float = 1e-13
    check_atol: float = 1e-15
    fixed_method: str = "rk4"
    fixed_steps_per_output: int = 400

    def check(self, path: str) -> None:
        """Methods registered (the first two adaptive), tolerances positive, steps >= 1."""
        for key in ("method", "check_method", "fixed_method"):
            name = getattr(self, key)
            require(name in METHODS, f"{path}.{key}", name,
                    f"must be a registered method: one of {', '.join(METHODS)}")
        for key in ("method", "check_method"):
            name = getattr(self, key)
            require(METHODS[name].adaptive, f"{path}.{key}", name,
                    "must be an adaptive method (the reference is error-controlled)")
        for key in ("rtol", "atol", "check_rtol", "check_atol"):
            v = getattr(self, key)
            require(math.isfinite(v) and 0.0 < v < 1.0, f"{path}.{key}", v, "must lie in (0, 1)")
        require(self.fixed_steps_per_output >= 1, f"{path}.fixed_steps_per_output",
                self.fixed_steps_per_output, "must be an integer >= 1")


@dataclass
class JitConfig:
    """First-call measurement: which methods, over how long a run, and whether cold."""

    methods: list[str] = field(default_factory=lambda: ["rk4", "radau5"])
    t_end: float = 0.1
    cold: bool = True

    def check(self, path: str) -> None:
        """Methods registered, t_end > 0."""
        for i, name in enumerate(self.methods):
            require(name in METHODS, f"{path}.methods[{i}]", name,
                    f"must be a registered method: one of {', '.join(METHODS)}")
        require(math.isfinite(self.t_end) and self.t_end > 0.0, f"{path}.t_end", self.t_end,
                "must be > 0")


@dataclass
class WorkPrecisionStudy:
    """The benchmark's settings (conf/analysis/work_precision.yaml documents each)."""

    id: str = "work_precision"
    title: str = ""
    levels: list[float] = MISSING
    resolution_factor: float = 10.0
    atol_ratio: float = 0.01
    methods: dict[str, MethodGrid] = field(default_factory=dict)
    unlisted: MethodGrid = field(default_factory=MethodGrid)
    full_state: dict[str, MethodGrid] = field(default_factory=dict)
    minimal_state: bool = True
    peers: dict[str, list[float]] = field(default_factory=dict)
    reference: ReferenceConfig = field(default_factory=ReferenceConfig)
    repeats: int = 5
    budget_s: float = 2.0
    quick: bool = False
    jit: JitConfig = field(default_factory=JitConfig)

    def grid(self, name: str) -> MethodGrid:
        """The settings of a registered method: its own entry, else the unlisted grid
        (tolerances for an adaptive method, steps for a fixed-step one)."""
        if name in self.methods:
            return self.methods[name]
        if METHODS[name].adaptive:
            return MethodGrid(rtol=list(self.unlisted.rtol))
        return MethodGrid(steps_per_output=list(self.unlisted.steps_per_output))

    def check(self, path: str) -> None:
        """Every grid value valid; every method and peer known; every registered method
        swept (adaptive ones by rtol); full-state settings among the swept ones."""
        require(len(self.levels) >= 1, f"{path}.levels", list(self.levels),
                "needs at least 1 value")
        for i, v in enumerate(self.levels):
            require(math.isfinite(v) and v > 0.0, f"{path}.levels[{i}]", v, "must be > 0")
        require(math.isfinite(self.resolution_factor) and self.resolution_factor >= 1.0,
                f"{path}.resolution_factor", self.resolution_factor, "must be >= 1")
        require(math.isfinite(self.atol_ratio) and 0.0 < self.atol_ratio <= 1.0,
                f"{path}.atol_ratio", self.atol_ratio, "must lie in (0, 1]")
        known = f"must be a registered method: one of {', '.join(METHODS)}"
        for name, g in self.methods.items():
            key = f"{path}.methods.{name}"
            require(name in METHODS, key, name, known)
            g.check(key)
            if g.newton_rtol:
                require(METHODS[name].stepper in IMPLICIT, f"{key}.newton_rtol",
                        list(g.newton_rtol),
                        f"{name} has no Newton iteration (explicit or linearly implicit)")
                require(len(g.steps_per_output) >= 1, f"{key}.newton_rtol",
                        list(g.newton_rtol), "applies to fixed steps: give steps_per_output")
            if METHODS[name].adaptive:
                require(len(g.rtol) >= 1, f"{key}.rtol", list(g.rtol),
                        "an adaptive method needs at least 1 tolerance")
            else:
                require(not g.rtol, f"{key}.rtol", list(g.rtol),
                        f"{name} takes a fixed step: give steps_per_output")
                require(not g.dense_rtol, f"{key}.dense_rtol", list(g.dense_rtol),
                        f"{name} takes a fixed step: give dense_dt")
                require(len(g.steps_per_output) >= 1, f"{key}.steps_per_output",
                        list(g.steps_per_output), "needs at least 1 value")
        self.unlisted.check(f"{path}.unlisted")
        for name in METHODS:
            if name not in self.methods:
                kind = "rtol" if METHODS[name].adaptive else "steps_per_output"
                require(len(getattr(self.unlisted, kind)) >= 1, f"{path}.unlisted.{kind}",
                        list(getattr(self.unlisted, kind)),
                        f"needs at least 1 value: {name} is registered but not under methods")
        for name, g in self.full_state.items():
            key = f"{path}.full_state.{name}"
            require(name in METHODS, key, name, known)
            g.check(key)
            require(not g.newton_rtol, f"{key}.newton_rtol", list(g.newton_rtol),
                    "full-state rows run at the base's tolerances: give it under methods")
            swept = self.grid(name)
            for i, v in enumerate(g.rtol):
                require(v in swept.rtol, f"{key}.rtol[{i}]", v,
                        f"must be one of the tolerances {name} is swept over (its partner)")
            for i, n in enumerate(g.steps_per_output):
                require(n in swept.steps_per_output, f"{key}.steps_per_output[{i}]", n,
                        f"must be one of the steps {name} is swept over (its partner)")
        for name, rtols in self.peers.items():
            key = f"{path}.peers.{name}"
            require(name in PEER_METHODS, key, name,
                    f"must be a peer: one of {', '.join(PEER_METHODS)}")
            require(len(rtols) >= 1, key, list(rtols), "needs at least 1 tolerance")
            for i, v in enumerate(rtols):
                require(math.isfinite(v) and 0.0 < v < 1.0, f"{key}[{i}]", v,
                        "must lie in (0, 1)")
        self.reference.check(f"{path}.reference")
        require(self.repeats >= 1, f"{path}.repeats", self.repeats, "must be an integer >= 1")
        require(math.isfinite(self.budget_s) and self.budget_s > 0.0, f"{path}.budget_s",
                self.budget_s, "must be > 0")
        self.jit.check(f"{path}.jit")


@dataclass
class WorkPrecisionConfig:
    """Root schema of the work-precision benchmark: its settings and the base studies."""

    study: WorkPrecisionStudy = field(default_factory=WorkPrecisionStudy)
    bases: dict[str, DynamicConfig] = field(default_factory=dict)

    def check(self) -> None:
        """Validate the settings and every base (its keys prefixed ``bases.<id>.``), that
        each base's duration and JIT run fit the fixed-step grids, and the sizes: every
        fixed step within each base's budget of evaluations, the timed calls within
        MAX_RUNS."""
        self.study.check("study")
        require(len(self.bases) >= 1, "bases", list(self.bases), "needs at least 1 base study")
        for name, base in self.bases.items():
            check_bases({name: base})
            interval = base.solver.output_interval
            require(steps_in(base.study.duration, interval) is not None,
                    f"bases.{name}.study.duration", base.study.duration,
                    f"must be an integer multiple of solver.output_interval = {interval} "
                    "(every fixed step of the sweep divides the output grid)")
        first = next(iter(self.bases.values()))
        if self.study.jit.methods:
            require(steps_in(self.study.jit.t_end, first.solver.output_interval) is not None,
                    "study.jit.t_end", self.study.jit.t_end,
                    f"must be an integer multiple of the first base's solver.output_interval "
                    f"= {first.solver.output_interval}")
            _check_jit_size(self.study.jit, first)
        for name, base in self.bases.items():
            _check_steps(self.study, name, base)
        require_runs("study.repeats", self.study.repeats,
                     _setting_count(self.study) * len(self.bases) * self.study.repeats,
                     f"timed calls (settings x {len(self.bases)} bases x study.repeats)")


def _check_steps(study: WorkPrecisionStudy, name: str, base: DynamicConfig) -> None:
    """Refuse a fixed step whose run over the base's duration would take more steps than
    the base's budget of evaluations (solver.max_rhs_evals; each step takes at least one)."""
    duration, budget = base.study.duration, base.solver.max_rhs_evals
    rows = duration / base.solver.output_interval

    def bound(key: str, value: Any, steps: float, how: str) -> None:
        require(steps <= budget, key, value,
                f"asks for {count(steps)} steps per run ({how} over bases.{name}.study."
                f"duration = {duration:g} s), more than bases.{name}.solver.max_rhs_evals = "
                f"{budget:,} (each step takes at least one evaluation)")

    grids = [*((f"study.methods.{m}", g) for m, g in study.methods.items()),
             ("study.unlisted", study.unlisted),
             *((f"study.full_state.{m}", g) for m, g in study.full_state.items())]
    for path, g in grids:
        for i, n in enumerate(g.steps_per_output):
            bound(f"{path}.steps_per_output[{i}]", n, rows * n, f"{n} per output interval")
        for i, dt in enumerate(g.dense_dt):
            bound(f"{path}.dense_dt[{i}]", dt, duration / dt, f"dt = {dt:g} s")
    n = study.reference.fixed_steps_per_output
    bound("study.reference.fixed_steps_per_output", n, rows * n, f"{n} per output interval")


def _check_jit_size(jit: JitConfig, base: DynamicConfig) -> None:
    """Refuse a first-call run (on the first base) longer than its history rows or its fixed
    step's budget of evaluations allow."""
    sv = base.solver
    require_samples("study.jit.t_end", jit.t_end, jit.t_end / sv.output_interval,
                    "history rows (study.jit.t_end / solver.output_interval)")
    steps = jit.t_end / sv.dt
    require(steps <= sv.max_rhs_evals, "study.jit.t_end", jit.t_end,
            f"asks for {count(steps)} steps at the first base's solver.dt = {sv.dt:g} s, more "
            f"than solver.max_rhs_evals = {sv.max_rhs_evals:,} (each step takes at least one "
            "evaluation)")


def _setting_count(study: WorkPrecisionStudy) -> int:
    """How many settings one base runs at most (every grid value, none thinned)."""
    n = 2 + sum(len(v) for v in study.peers.values())
    for name in METHODS:
        g = study.grid(name)
        n += (len(g.rtol) + len(g.steps_per_output) * (1 + len(g.newton_rtol))
              + len(g.dense_rtol) + len(g.dense_dt))
    return n + sum(len(g.rtol) + len(g.steps_per_output) for g in study.full_state.values())


def parts(cfg: WorkPrecisionConfig) -> list[Part]:
    """One dataset per base study; the first also measures the JIT first calls."""
    return [Part(f"work_precision_{name}", {"base": name, "jit": i == 0})
            for i, name in enumerate(cfg.bases)]


# ------------------------------------------------------------------------------- settings
@dataclass(frozen=True)
class Setting:
    """One benchmarked run: group (native, full, mu0, peer), entry label, the registered
    method or peer it runs, its setting (rtol, or a fixed dt) and, for an implicit method's
    fixed step, the rtol of its Newton iteration (None: the base's), and whether its rows
    are dense output."""

    group: str
    method: str
    solver: str
    kind: str
    value: float
    newton_rtol: float | None = None
    dense: bool = False

    @property
    def label(self) -> str:
        """The setting as the report prints it: ``rtol=1e-08``, ``dt=0.05 newton_rtol=1e-09``."""
        newton = f" newton_rtol={self.newton_rtol:.6g}" if self.newton_rtol is not None else ""
        return f"{self.kind}={self.value:.6g}{newton}"


def _thin(values: Sequence[Any], quick: bool, keep: Iterable[Any] = ()) -> list[Any]:
    """Every value, or in a quick run every third one plus those in keep."""
    if not quick:
        return list(values)
    keep = set(keep)
    return [v for i, v in enumerate(values) if i % 3 == 0 or v in keep]


def settings(study: WorkPrecisionStudy, base: SphereProblem) -> list[Setting]:
    """Every run on one base problem, in report order: each registered method over its grid
    (an adaptive one by rtol, then at its fixed steps if it has any; a fixed-step one by
    dt = output_interval / n), the full-state rows, the mu = 0 pair at the base's own
    solver, the peers (scipy, SUNDIALS)."""
    output_interval = base.output.interval
    out: list[Setting] = []
    full = study.full_state
    for name, method in METHODS.items():
        grid = study.grid(name)
        keep = full[name] if name in full else MethodGrid()
        fixed = f"{name}-fixed" if method.adaptive else name
        if method.adaptive:
            out += [Setting("native", name, name, "rtol", float(v))
                    for v in _thin(grid.rtol, study.quick, keep.rtol)]
        for n in _thin(grid.steps_per_output, study.quick, keep.steps_per_output):
            out += [Setting("native", fixed, name, "dt", output_interval / n)]
            out += [Setting("native", fixed, name, "dt", output_interval / n, float(v))
                    for v in grid.newton_rtol]
        out += [Setting("native", f"{name}-dense", name, "rtol", float(v), dense=True)
                for v in _thin(grid.dense_rtol, study.quick)]
        out += [Setting("native", f"{fixed}-dense", name, "dt", float(v), dense=True)
                for v in _thin(grid.dense_dt, study.quick)]
    for name, grid in full.items():
        fixed = f"{name}-fixed" if METHODS[name].adaptive else name
        out += [Setting("full", f"{name}-full", name, "rtol", float(v)) for v in grid.rtol]
        out += [Setting("full", f"{fixed}-full", name, "dt", output_interval / n)
                for n in grid.steps_per_output]
    if study.minimal_state:
        sv = base.solver
        kind, value = ("rtol", sv.rtol) if base.adaptive else ("dt", sv.dt)
        name = sv.method if base.adaptive or not METHODS[sv.method].adaptive \
            else f"{sv.method}-fixed"
        out += [Setting("mu0", f"{name}-mu0", sv.method, kind, value),
                Setting("mu0", f"{name}-mu0-full", sv.method, kind, value)]
    for name, rtols in study.peers.items():
        out += [Setting("peer", peer_label(name), name, "rtol", float(v))
                for v in _thin(rtols, study.quick)]
    return out


def native_problem(base: SphereProblem, s: Setting, atol_ratio: float) -> SphereProblem:
    """The base problem set up for one native setting (full: energy bookkeeping on; mu0:
    no friction, trajectory alone or full diagnostics, at the base's own solver)."""
    if s.group == "mu0":
        full = s.method.endswith("-full")
        return base.replace(mu=0.0, rotation=full, energy=full)
    energy = s.group == "full"
    if s.kind == "dt":
        prob = base.replace(method=s.solver, dt=s.value, allow_unstable=True,
                            fixed_step=METHODS[s.solver].adaptive, energy=energy,
                            dense_output=s.dense)
        if s.newton_rtol is None:
            return prob
        return prob.replace(rtol=s.newton_rtol, atol=s.newton_rtol * atol_ratio)
    return base.replace(method=s.solver, rtol=s.value, atol=s.value * atol_ratio,
                        fixed_step=False, energy=energy, dense_output=s.dense)


# -------------------------------------------------------------------------------- running
def errors(X: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    """(max over the grid, final) Euclidean centre error; inf if the run stopped short."""
    if X.shape != ref.shape or not np.all(np.isfinite(X)):
        return math.inf, math.inf
    e = np.linalg.norm(X - ref, axis=1)
    return float(e.max()), float(e[-1])


def base_problem(cfg: WorkPrecisionConfig, base: str) -> SphereProblem:
    """A base study's problem, trajectory only (energy off; rotation as friction needs)."""
    return cfg.bases[base].sphere_problem().replace(energy=False)


def reference(base: SphereProblem, ref: ReferenceConfig) -> tuple[np.ndarray, dict[str, Any]]:
    """Reference centre positions and the evidence that they are one: the agreement of an
    independent adaptive method and of a fine fixed step with them."""
    from creatio.dynamics import simulate

    dt = base.output.interval / ref.fixed_steps_per_output
    runs = {
        "reference": base.replace(method=ref.method, rtol=ref.rtol, atol=ref.atol,
                                  fixed_step=False),
        "check_adaptive": base.replace(method=ref.check_method, rtol=ref.check_rtol,
                                       atol=ref.check_atol, fixed_step=False),
        "check_fixed": base.replace(method=ref.fixed_method, dt=dt,
                                    fixed_step=METHODS[ref.fixed_method].adaptive),
    }
    res = {k: simulate(p) for k, p in runs.items()}
    for k, r in res.items():
        if r.counts.status != "ok":
            raise RuntimeError(f"{k} run stopped: {r.counts.status} at {r.counts.stop_time} s")
    X = res["reference"].histories.X
    return X, {
        "reference": f"{ref.method} rtol={ref.rtol:g} atol={ref.atol:g}",
        "reference_steps": int(res["reference"].counts.steps),
        "check_adaptive": f"{ref.check_method} rtol={ref.check_rtol:g} atol={ref.check_atol:g}",
        "check_adaptive_max_diff_m": errors(res["check_adaptive"].histories.X, X)[0],
        "check_fixed": f"{ref.fixed_method} dt={dt:.6g}",
        "check_fixed_max_diff_m": errors(res["check_fixed"].histories.X, X)[0],
    }


def stability_limits(base: SphereProblem) -> dict[str, float | None]:
    """Largest stable fixed step (s) of every registered method on this problem's friction
    (None: no limit, L-stable or frictionless)."""
    out: dict[str, float | None] = {}
    for name, method in METHODS.items():
        # the limit does not depend on dt
        fixed = base.replace(method=name, fixed_step=method.adaptive, dt=base.output.interval)
        lim = stability_limit(fixed)
        out[name] = lim if math.isfinite(lim) else None
    return out


@dataclass
class Run:
    """A setting after its warm-up: what is timed, how often, and what it measured."""

    setting: Setting
    call: Callable[[], float]
    first_s: float
    count: int
    record: dict[str, Any]


def _repeat_count(warm_s: float, repeats: int, budget_s: float) -> int:
    """repeats, or fewer for slow calls (budget_s / warm-up time, at least 1)."""
    if warm_s < budget_s / repeats:
        return repeats
    return max(1, int(budget_s / max(warm_s, 1e-9)))


def _timed(call: Callable[[], Any]) -> Callable[[], float]:
    def timed() -> float:
        t0 = time.perf_counter()
        call()
        return time.perf_counter() - t0

    return timed


def prepare_native(base: SphereProblem, s: Setting, ref: np.ndarray, study: WorkPrecisionStudy
                   ) -> Run:
    """The first core call (JIT compile or cache load included), then a simulate() run for
    the error and the work counters (its wall time sets the repeat count)."""
    from creatio.dynamics import compiled_call, simulate

    prob = native_problem(base, s, study.atol_ratio)
    call = _timed(compiled_call(prob))
    first = call()
    t0 = time.perf_counter()
    res = simulate(prob)
    warm = time.perf_counter() - t0
    c = res.counts
    if s.group == "mu0":
        err = fin = math.nan  # no reference without friction: a timing row only
    else:
        err, fin = errors(res.histories.X, ref) if c.status == "ok" else (math.inf, math.inf)
    record = {"error_m": err, "final_error_m": fin, "rhs_evals": c.rhs_evals,
              "steps": c.steps, "status": c.status,
              "state_size": prob.initial_state(prob.rotation_integrated,
                                               prob.output.energy).size,
              "rejected_steps": c.rejected_steps, "jacobians": c.jacobians,
              "lu_factorisations": c.lu_factorisations,
              "newton_iterations": c.newton_iterations}
    return Run(s, call, first, _repeat_count(warm, study.repeats, study.budget_s), record)


def prepare_peer(base: SphereProblem, s: Setting, ref: np.ndarray, study: WorkPrecisionStudy
                 ) -> Run:
    """A warm-up peer solve gives the error; a timed call is its construction and stepping
    loop (scipy) or construction and solve (CVODE), as solve_peer times them."""
    from creatio.dynamics.peer_solvers import centre_grid, solve_peer

    rtol, atol = s.value, s.value * study.atol_ratio
    res = solve_peer(base, s.solver, rtol, atol)
    X = centre_grid(base, res.t, res.y, False)
    err, fin = errors(X, ref) if res.status == "ok" else (math.inf, math.inf)
    record = {"error_m": err, "final_error_m": fin, "rhs_evals": res.rhs_evals,
              "steps": res.steps, "status": res.status, "state_size": res.y.shape[1],
              "rejected_steps": 0, "jacobians": res.jacobians,
              "lu_factorisations": res.lu_factorisations, "newton_iterations": -1}
    return Run(s, lambda: solve_peer(base, s.solver, rtol, atol).time_s, res.time_s,
               _repeat_count(res.time_s, study.repeats, study.budget_s), record)


def round_robin(runs: Sequence[Run]) -> np.ndarray:
    """Time every run's core call, repeats interleaved: round k calls each run that still
    has repeats left, in order from run k mod n on (wrapping), so that a run is preceded by
    a different one each round. Returns seconds (run, repeat), NaN where none was taken."""
    n = len(runs)
    times = np.full((n, max((r.count for r in runs), default=0)), np.nan)
    for k in range(times.shape[1]):
        for j in range(n):
            i = (k + j) % n
            if k < runs[i].count:
                times[i, k] = runs[i].call()
    return times


COLD = """
import pickle, sys, time
from creatio.dynamics import simulate
base, methods = pickle.loads(sys.stdin.buffer.read())
for method in methods:
    t0 = time.perf_counter()
    simulate(base.replace(method=method))
    print(method, time.perf_counter() - t0)
"""


def jit_times(base: SphereProblem, jit: JitConfig) -> dict[str, float]:
    """First-call seconds of the compiled loop over a short run: in a fresh process with an
    empty numba cache (cold compile, when jit.cold) and in this process (cache load, or
    compile if there is no cache)."""
    import subprocess
    import tempfile

    from creatio.dynamics import simulate

    short = base.replace(t_end=jit.t_end)
    out: dict[str, float] = {}
    if jit.cold:
        spec = pickle.dumps((short, list(jit.methods)))
        with tempfile.TemporaryDirectory() as cache:
            # an empty cache, whichever variable names it (creatio.dynamics.jit reads both)
            env = dict(os.environ, NUMBA_CACHE_DIR=cache, CREATIO_NUMBA_CACHE=cache)
            proc = subprocess.run([sys.executable, "-c", COLD], input=spec, env=env,
                                  capture_output=True, check=True)
        for line in proc.stdout.decode().splitlines():
            if line.strip():
                name, value = line.split()
                out[f"cold_compile_{name}_s"] = float(value)
    for name in jit.methods:
        t0 = time.perf_counter()
        simulate(short.replace(method=name))
        out[f"this_process_first_{name}_s"] = time.perf_counter() - t0
    return out


def _load() -> str:
    """The machine's load average over 1, 5 and 15 minutes (how busy it was while timed)."""
    return ", ".join(f"{x:.2f}" for x in os.getloadavg())


def machine() -> dict[str, str]:
    """Facts about the machine and the numeric stack the timings belong to."""
    import numba
    import scipy

    return {
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": str(os.cpu_count()),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "threads": ", ".join(f"{k}={os.environ.get(k, 'unset')}" for k in
                             ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS")),
    }


_COUNTERS = {
    "rhs_evals": "right-hand-side evaluations",
    "steps": "accepted steps (-1: not reported by the peer)",
    "rejected_steps": "rejected steps",
    "jacobians": "Jacobian evaluations",
    "lu_factorisations": "LU factorisations (-1: not reported by the peer)",
    "newton_iterations": "Newton iterations (0: none, explicit or linearly implicit; -1: not "
                         "reported by the peer)",
    "state_size": "integrated state components",
}


def to_dataset(base: str, runs: Sequence[Run], times: np.ndarray, attrs: dict[str, Any]):
    """The runs as an xarray Dataset over dims (entry, repeat), CF attributes on each."""
    import xarray as xr

    n = len(runs)
    with np.errstate(all="ignore"):
        tmin = np.nanmin(times, axis=1) if n else np.zeros(0)
        tmed = np.nanmedian(times, axis=1) if n else np.zeros(0)
    first = np.array([max(r.first_s - t, 0.0) for r, t in zip(runs, tmin, strict=True)])
    text = {
        "study": [base] * n,
        "group": [r.setting.group for r in runs],
        "method": [r.setting.method for r in runs],
        "solver": [r.setting.solver for r in runs],
        "setting": [r.setting.label for r in runs],
        "setting_kind": [r.setting.kind for r in runs],
        "status": [str(r.record["status"]) for r in runs],
    }
    data: dict[str, Any] = {k: ("entry", np.array(v, dtype=object), {"long_name": k})
                            for k, v in text.items()}
    data["setting_value"] = ("entry", np.array([r.setting.value for r in runs], dtype=float),
                             {"long_name": "rtol, or the fixed step dt (s)"})
    data["error_m"] = ("entry", np.array([r.record["error_m"] for r in runs], dtype=float),
                       {"long_name": "max centre-position error on the output grid",
                        "units": "m"})
    data["final_error_m"] = ("entry",
                             np.array([r.record["final_error_m"] for r in runs], dtype=float),
                             {"long_name": "centre-position error at the final time",
                              "units": "m"})
    data["time_s"] = ("entry", tmin, {"long_name": "core run time, min over repeats",
                                      "units": "s"})
    data["time_median_s"] = ("entry", tmed, {"long_name": "core run time, median over repeats",
                                             "units": "s"})
    data["times_s"] = (("entry", "repeat"), times,
                       {"long_name": "core run time of each repeat (round-robin order; NaN: "
                        "not taken)", "units": "s"})
    data["repeats"] = ("entry", np.array([r.count for r in runs], dtype=np.int64),
                       {"long_name": "timed repeats", "units": "1"})
    data["first_call_s"] = ("entry", first,
                            {"long_name": "extra time of the first call (JIT compile or cache "
                             "load)", "units": "s"})
    for key, name in _COUNTERS.items():
        data[key] = ("entry", np.array([r.record[key] for r in runs], dtype=np.int64),
                     {"long_name": name, "units": "1"})
    ds = xr.Dataset(data, coords={"entry": np.arange(n), "repeat": np.arange(times.shape[1])})
    ds.attrs.update(attrs)
    return ds


def run(cfg: WorkPrecisionConfig, base: str, jit: bool = False):
    """Benchmark every setting on one base study; returns the dataset (attrs: machine,
    reference evidence, stability limits, JIT first calls when jit)."""
    study = cfg.study
    prob = base_problem(cfg, base)
    attrs: dict[str, Any] = {"title": "work-precision benchmark of the sphere integrators",
                             "base": base, "machine": json.dumps(machine())}
    if jit and study.jit.methods:
        attrs["jit"] = json.dumps(jit_times(prob, study.jit))
    ref, evidence = reference(prob, study.reference)
    evidence["stability_limit_dt_s"] = stability_limits(prob)
    attrs["reference"] = json.dumps(evidence)
    attrs["timing"] = ("warm-up run, then repeats of the core call interleaved round-robin "
                       "across all settings (each round starting one setting later); "
                       "time_s = min, time_median_s = median, times_s = every repeat")
    from creatio.dynamics.peer_solvers import available

    plan = settings(study, prob)
    missing = sorted({s.solver for s in plan if s.group == "peer" and not available(s.solver)})
    attrs["peers_unavailable"] = json.dumps(missing)
    runs = [(prepare_peer if s.group == "peer" else prepare_native)(prob, s, ref, study)
            for s in plan if s.group != "peer" or s.solver not in missing]
    attrs["load_before_timing"] = _load()
    times = round_robin(runs)
    attrs["load_after_timing"] = _load()
    return to_dataset(base, runs, times, attrs)
