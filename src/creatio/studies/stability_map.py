"""Stability map of the fixed-step explicit schemes against the friction's slip relaxation.

The regularised friction f = -mu N v_s / sqrt(v_s^2 + eps^2) makes the slip relax at
lambda = 3.5 mu N / (m eps) near zero slip (docs/model.md s.6), so a fixed-step explicit
scheme (RK4; dopri5 and dop853 with fixed_step) is stable only for lambda dt below its real
stability bound. This module measures where each scheme actually breaks on the EN-02
configuration, along the friction coefficient mu and along the regularisation speed eps, and
sets it against the a-priori estimate :func:`creatio.dynamics.stability_limit` and against
the config validation that refuses an unstable RK4 step.

For one configuration and one scheme, a run at dt = output_interval / n is *good* when it
ends with status ok and its centre stays within ``tolerance`` (1e-9 m) of a reference
solution on every output time (the reference: radau5 at rtol 1e-12, atol 1e-14, a different
method from every scheme mapped, cross-checked against adaptive dop853 at rtol 1e-13, atol
1e-15). The steps n are sampled from ``span`` x the estimate, then bisected between the last
good and the first broken n. A break is put down to *stability* when the first broken run
stopped, went non-finite or chattered (its largest slip speed more than ``chatter`` = twice
the reference's: the unstable mode is the slip relaxation), else to *accuracy* (the error
merely outgrew ``tolerance``).

The config (``conf/analysis/stability_map.yaml``) holds the grids and settings under
``study`` and the full EN-02 config under ``bases.en02``; every problem is a validated
variation of that base (:func:`creatio.studies.schema.vary`). One dataset per axis, plus the
duration check (the break at a few mu over the base's full duration, to show that the
shortened runs of the map break at the same dt).
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from creatio.dynamics import SimulationResult, SphereProblem, stability_limit
from creatio.dynamics.solvers import METHODS
from creatio.errors import ConfigError
from creatio.model.numerics import steps_in
from creatio.model.sphere import slip_relaxation_rate, stable_step
from creatio.studies.registry import Part
from creatio.studies.schema import MISSING, DynamicConfig, check_bases, require, require_runs, vary

if TYPE_CHECKING:
    import xarray as xr

__all__ = [
    "AXES",
    "BASE",
    "DURATION_AXIS",
    "DurationCheckConfig",
    "Probe",
    "ReferenceConfig",
    "StabilityMapConfig",
    "StabilityMapStudy",
    "base_problem",
    "duration_check",
    "linear_limit",
    "locate_break",
    "parts",
    "probe",
    "reference",
    "run",
    "scheme_problem",
    "stability_map",
]

log = logging.getLogger("creatio")

#: The base study every problem varies, and the key under ``bases`` that holds its config.
BASE = "en02"

#: The axes a map may run along: the base key each varies and its CF attributes.
AXES: dict[str, dict[str, str]] = {
    "mu": {"key": "sphere.mu", "long_name": "Coulomb friction coefficient mu", "units": "1"},
    "eps": {"key": "sphere.eps", "long_name": "friction regularisation speed eps",
            "units": "m s-1"},
}

#: The part argument of the duration check (the break over the base's full duration).
DURATION_AXIS = "duration"

#: How far below the smallest sampled dt the search refines before giving up (x 2 steps).
_MAX_REFINE = 64


# ---------------------------------------------------------------------------------- schema
@dataclass
class ReferenceConfig:
    """An error-controlled run: method and tolerances."""

    method: str = MISSING
    rtol: float = MISSING
    atol: float = MISSING

    def check(self, path: str) -> None:
        """A registered adaptive method; tolerances finite and > 0."""
        require(self.method in METHODS and METHODS[self.method].adaptive, f"{path}.method",
                self.method, "must be an adaptive method of creatio.dynamics.solvers.METHODS ("
                + ", ".join(m for m, v in METHODS.items() if v.adaptive) + ")")
        for name in ("rtol", "atol"):
            v = getattr(self, name)
            require(math.isfinite(v) and v > 0.0, f"{path}.{name}", v, "must be finite and > 0")

    def label(self) -> str:
        """``radau5 rtol=1e-12 atol=1e-14``."""
        return f"{self.method} rtol={self.rtol:g} atol={self.atol:g}"


@dataclass
class DurationCheckConfig:
    """Locate the break at these mu over this (full) duration too, next to the map's."""

    mu: list[float] = field(default_factory=list)
    duration: float = MISSING


@dataclass
class StabilityMapStudy:
    """The map's grids and settings (conf/analysis/stability_map.yaml)."""

    id: str = "stability_map"
    title: str = ""
    axes: dict[str, list[float]] = field(default_factory=dict)
    methods: list[str] = MISSING
    duration: float = MISSING
    tolerance: float = MISSING
    span: list[float] = MISSING
    samples: int = MISSING
    chatter: float = MISSING
    reference: ReferenceConfig = field(default_factory=ReferenceConfig)
    cross_check: ReferenceConfig = field(default_factory=ReferenceConfig)
    validation: bool = True
    duration_check: DurationCheckConfig = field(default_factory=DurationCheckConfig)

    def check(self, path: str, base: DynamicConfig) -> None:
        """Every grid value valid, and valid on the base (a varied base config checks)."""
        _check_duration(f"{path}.duration", self.duration, base)
        require(len(self.axes) >= 1, f"{path}.axes", dict(self.axes), "needs at least 1 axis")
        for axis, values in self.axes.items():
            require(axis in AXES, f"{path}.axes.{axis}", list(values),
                    f"unknown axis: one of {', '.join(AXES)}")
            require(len(values) >= 1, f"{path}.axes.{axis}", list(values),
                    "needs at least 1 value")
            require(len(set(values)) == len(values), f"{path}.axes.{axis}", list(values),
                    "values must be distinct")
            for i, v in enumerate(values):
                key = f"{path}.axes.{axis}[{i}]"
                require(math.isfinite(v) and v > 0.0, key, v,
                        "must be finite and > 0 (mu = 0 has no stability limit to map)")
                _on_base(key, v, base, {AXES[axis]["key"]: v})
        require(len(self.methods) >= 1, f"{path}.methods", list(self.methods),
                "needs at least 1 method")
        require(len(set(self.methods)) == len(self.methods), f"{path}.methods",
                list(self.methods), "methods must be distinct")
        explicit = [m for m, v in METHODS.items() if not v.l_stable]
        for i, m in enumerate(self.methods):
            require(m in explicit, f"{path}.methods[{i}]", m,
                    f"must be an explicit method with a stability limit ({', '.join(explicit)})")
        require(math.isfinite(self.tolerance) and self.tolerance > 0.0, f"{path}.tolerance",
                self.tolerance, "must be finite and > 0")
        require(len(self.span) == 2 and all(math.isfinite(s) and s > 0.0 for s in self.span)
                and self.span[0] < self.span[1], f"{path}.span", list(self.span),
                "must be [low, high] factors of the estimate with 0 < low < high")
        require(self.samples >= 2, f"{path}.samples", self.samples, "must be an integer >= 2")
        points = sum(len(values) for values in self.axes.values())
        require_runs(f"{path}.samples", self.samples, self.samples * len(self.methods) * points,
                     f"sampled runs ({path}.samples x {len(self.methods)} methods x {points} "
                     "axis values)")
        require(math.isfinite(self.chatter) and self.chatter > 1.0, f"{path}.chatter",
                self.chatter, "must be finite and > 1 (a multiple of the reference's slip)")
        self.reference.check(f"{path}.reference")
        require(self.reference.method not in self.methods, f"{path}.reference.method",
                self.reference.method, "must differ from every method mapped")
        self.cross_check.check(f"{path}.cross_check")
        check = self.duration_check
        _check_duration(f"{path}.duration_check.duration", check.duration, base)
        for i, mu in enumerate(check.mu):
            key = f"{path}.duration_check.mu[{i}]"
            require(math.isfinite(mu) and mu > 0.0, key, mu, "must be finite and > 0")
            _on_base(key, mu, base, {"sphere.mu": mu})


def _check_duration(key: str, value: float, base: DynamicConfig) -> None:
    interval = base.solver.output_interval
    require(math.isfinite(value) and value > 0.0, key, value, "must be finite and > 0")
    require(steps_in(value, interval) is not None, key, value,
            f"must be an integer multiple of bases.{BASE}.solver.output_interval = {interval}")
    _on_base(key, value, base, {"study.duration": value})


def _on_base(key: str, value: Any, base: DynamicConfig, changes: dict[str, Any]) -> None:
    """Refuse a grid value the base config refuses (as ConfigError naming the grid key)."""
    try:
        vary(base, {**changes, "solver.allow_unstable": True})
    except ConfigError as e:
        raise ConfigError(key, value, f"refused by bases.{BASE}: {e.key}: {e.rule}") from None


@dataclass
class StabilityMapConfig:
    """Root schema of the stability map: its settings and the base configs it varies."""

    study: StabilityMapStudy = field(default_factory=StabilityMapStudy)
    bases: dict[str, DynamicConfig] = field(default_factory=dict)

    def check(self) -> None:
        """The base valid (errors named under bases.en02), then every setting on it."""
        require(BASE in self.bases, "bases", sorted(self.bases), f"needs the base {BASE!r}")
        check_bases(self.bases)
        self.study.check("study", self.bases[BASE])

    @property
    def base(self) -> DynamicConfig:
        """The EN-02 config every problem varies."""
        return self.bases[BASE]


def parts(cfg: StabilityMapConfig) -> list[Part]:
    """One dataset per axis, then the duration check when it has mu values and its duration
    differs from the map's."""
    out = [Part(f"stability_map_{axis}", {"axis": axis}) for axis in cfg.study.axes]
    check = cfg.study.duration_check
    if check.mu and check.duration != cfg.study.duration:
        out.append(Part(f"stability_map_{DURATION_AXIS}", {"axis": DURATION_AXIS}))
    return out


def run(cfg: StabilityMapConfig, axis: str) -> xr.Dataset:
    """The dataset of one part: the map along an axis, or the duration check."""
    t0 = time.perf_counter()
    if axis == DURATION_AXIS:
        ds = duration_dataset(cfg)
    elif axis in cfg.study.axes:
        ds = stability_map(cfg, axis)
    else:
        raise ValueError(f"axis must be one of {', '.join([*cfg.study.axes, DURATION_AXIS])}, "
                         f"got {axis!r}")
    ds.attrs["compute_seconds"] = time.perf_counter() - t0
    return ds


# --------------------------------------------------------------------------------- probing
@dataclass(frozen=True)
class Probe:
    """One fixed-step run: its step, error against the reference, status and slip."""

    n: int
    dt: float
    error: float
    status: str
    max_slip: float
    good: bool
    chatter: bool


def base_problem(cfg: StabilityMapConfig, axis: str, value: float,
                 duration: float | None = None) -> SphereProblem:
    """The base problem at one axis value and duration, energy off, unstable steps allowed.

    Built from a validated variation of the base config, so the map runs exactly what a
    study would."""
    duration = cfg.study.duration if duration is None else duration
    varied = vary(cfg.base, {AXES[axis]["key"]: float(value), "study.duration": float(duration),
                             "solver.allow_unstable": True})
    return varied.sphere_problem().replace(energy=False, allow_unstable=True)


def reference(problem: SphereProblem, spec: ReferenceConfig) -> SimulationResult:
    """Reference run of the problem's configuration with an error-controlled method."""
    from creatio.dynamics import simulate

    ref = simulate(problem.replace(fixed_step=False, method=spec.method, rtol=spec.rtol,
                                   atol=spec.atol))
    if ref.counts.status != "ok":
        raise RuntimeError(f"reference {spec.label()} stopped with status {ref.counts.status}")
    return ref


def _distance(x: np.ndarray, x_ref: np.ndarray) -> float:
    """Largest Euclidean distance over the common output times (inf if non-finite or short)."""
    if x.shape != x_ref.shape:
        return math.inf
    d = np.linalg.norm(x - x_ref, axis=1)
    return float(d.max()) if np.all(np.isfinite(d)) else math.inf


def scheme_problem(problem: SphereProblem, method: str) -> SphereProblem:
    """The problem with a fixed-step explicit scheme (fixed_step for the adaptive pairs)."""
    if method not in METHODS or METHODS[method].l_stable:
        raise ValueError(f"method must be an explicit method of {', '.join(METHODS)}, "
                         f"got {method!r}")
    return problem.replace(method=method, fixed_step=METHODS[method].adaptive)


def probe(problem: SphereProblem, n: int, ref: SimulationResult, tol: float, chatter: float,
          ) -> Probe:
    """Run the problem's scheme at dt = output_interval / n and judge it against ref."""
    from creatio.dynamics import simulate

    dt = problem.output.interval / n
    res = simulate(problem.replace(dt=dt))
    error = _distance(res.histories.X, ref.histories.X)
    slip, status = res.extrema.max_slip_speed, res.counts.status
    chattered = not math.isfinite(slip) or slip > chatter * ref.extrema.max_slip_speed
    good = status == "ok" and error < tol
    return Probe(n, dt, error, status, float(slip), good, chattered)


def locate_break(
    problem: SphereProblem, ref: SimulationResult, tol: float, span: tuple[float, float],
    samples: int, chatter: float,
) -> tuple[list[Probe], int | None, int | None]:
    """Sample dt over span x the estimate, then bisect n to the break.

    Returns all probes (ascending dt), the n of the largest good dt below the first broken
    one, and the n of that first broken dt (None when no dt up to output_interval breaks;
    the good n is None when even the smallest dt tried breaks)."""
    est = stability_limit(problem)
    interval = problem.output.interval
    factors = np.geomspace(span[0], span[1], samples)
    ns = sorted({max(1, round(interval / (f * est))) for f in factors}, reverse=True)
    done: dict[int, Probe] = {}

    def run_n(n: int) -> Probe:
        if n not in done:
            done[n] = probe(problem, n, ref, tol, chatter)
        return done[n]

    good_n = bad_n = None
    for n in ns:
        if not run_n(n).good:
            bad_n = n
            break
        good_n = n
    if good_n is None:  # the smallest dt tried is broken already: refine until good
        n = ns[0]
        while good_n is None and n < _MAX_REFINE * ns[0]:
            n *= 2
            if run_n(n).good:
                good_n = n
            else:
                bad_n = n
    if bad_n is None:  # every dt tried is good: coarsen up to one step per output
        n = ns[-1]
        while bad_n is None and n > 1:
            n = max(1, n // 2)
            if run_n(n).good:
                good_n = n
            else:
                bad_n = n
    while good_n is not None and bad_n is not None and good_n - bad_n > 1:
        mid = (good_n + bad_n) // 2
        if run_n(mid).good:
            good_n = mid
        else:
            bad_n = mid
    return sorted(done.values(), key=lambda p: p.dt), good_n, bad_n


def linear_limit(problem: SphereProblem, n_max: float) -> float:
    """Linear stability limit of the slip mode at normal reaction n_max, without margin:
    the scheme's real stability bound over the slip relaxation rate at n_max."""
    sp = problem.model.sphere
    rate = slip_relaxation_rate(sp.mu, n_max, sp.m, sp.b, sp.eps)
    return stable_step(METHODS[problem.solver.method].stability_bound, rate)


def _locate(cfg: StabilityMapConfig, problem: SphereProblem, ref: SimulationResult,
            ) -> tuple[list[Probe], int | None, int | None]:
    s = cfg.study
    return locate_break(problem, ref, s.tolerance, (s.span[0], s.span[1]), s.samples, s.chatter)


def _validated_method(cfg: StabilityMapConfig) -> str | None:
    """The fixed-step scheme the base's validation guards, when it is mapped."""
    solver = cfg.base.solver
    method = str(solver.method)
    return method if not solver.adaptive and method in cfg.study.methods else None


def _refusal(cfg: StabilityMapConfig, axis: str, value: float, dt: float) -> bool:
    """Whether the config validation refuses solver.dt = dt for this configuration (the
    base's own scheme, allow_unstable off)."""
    try:
        vary(cfg.base, {AXES[axis]["key"]: float(value), "study.duration": cfg.study.duration,
                        "solver.allow_unstable": False, "solver.dt": float(dt)})
    except ConfigError as e:
        if e.key != "solver.dt":
            raise
        return True
    return False


def _step_limit(cfg: StabilityMapConfig, axis: str, value: float) -> float:
    varied = vary(cfg.base, {AXES[axis]["key"]: float(value),
                             "study.duration": cfg.study.duration,
                             "solver.allow_unstable": True})
    return float(varied.step_limit())


def _var(dims, data, long_name: str, units: str, **extra) -> xr.Variable:
    import xarray as xr

    return xr.Variable(dims, data, {"long_name": long_name, "units": units, **extra})


def _settings_attrs(cfg: StabilityMapConfig) -> dict[str, Any]:
    s = cfg.study
    return {
        "base": BASE,
        "tolerance_m": s.tolerance,
        "duration_s": s.duration,
        "output_interval_s": cfg.base.solver.output_interval,
        "dt_span_of_estimate": list(s.span),
        "samples": s.samples,
        "reference": s.reference.label(),
        "cross_check": s.cross_check.label(),
        "chatter_factor": s.chatter,
    }


# ------------------------------------------------------------------------------------ maps
def stability_map(cfg: StabilityMapConfig, axis: str) -> xr.Dataset:
    """Map the largest good fixed dt of each scheme along one axis (the base otherwise).

    dims: method, value (the axis value), sample (the dts tried, ascending, NaN-padded).
    With study.validation, also ask the config validation whether it refuses each dt tried
    of the base's own scheme (RK4), when that scheme is mapped.
    """
    import xarray as xr

    s = cfg.study
    values = tuple(float(v) for v in s.axes[axis])
    methods = tuple(s.methods)
    runs: dict[tuple[str, int], tuple[list[Probe], int | None, int | None]] = {}
    estimate = np.full((len(methods), len(values)), np.nan)
    ref_slip = np.empty(len(values))
    linear = np.full((len(methods), len(values)), np.nan)
    agreement = np.empty(len(values))
    interval = cfg.base.solver.output_interval
    for j, v in enumerate(values):
        base = base_problem(cfg, axis, v)
        ref = reference(base, s.reference)
        cross = reference(base, s.cross_check)
        agreement[j] = _distance(cross.histories.X, ref.histories.X)
        ref_slip[j] = ref.extrema.max_slip_speed
        for i, m in enumerate(methods):
            t0 = time.perf_counter()
            prob = scheme_problem(base, m)
            estimate[i, j] = stability_limit(prob)
            linear[i, j] = linear_limit(prob, ref.extrema.max_N)
            runs[m, j] = located = _locate(cfg, prob, ref)
            probes, good_n, bad_n = located
            good = base.output.interval / good_n if good_n else math.nan
            bad = base.output.interval / bad_n if bad_n else math.nan
            log.info("%s=%g %s: estimate %.4g s, good %.4g s, broken %.4g s (%d runs, %.2f s)",
                     axis, v, m, estimate[i, j], good, bad, len(probes),
                     time.perf_counter() - t0)
    width = max(len(r[0]) for r in runs.values())
    shape = (len(methods), len(values), width)
    dt = np.full(shape, np.nan)
    steps = np.zeros(shape, dtype=np.int64)
    error = np.full(shape, np.nan)
    slip = np.full(shape, np.nan)
    status = np.full(shape, "", dtype=object)
    good = np.zeros(shape, dtype=bool)
    chatter = np.zeros(shape, dtype=bool)
    largest = np.full(shape[:2], np.nan)
    broken = np.full(shape[:2], np.nan)
    limited = np.full(shape[:2], "", dtype=object)
    for (m, j), (probes, good_n, bad_n) in runs.items():
        i = methods.index(m)
        for k, p in enumerate(probes):
            dt[i, j, k], steps[i, j, k], error[i, j, k] = p.dt, p.n, p.error
            slip[i, j, k], status[i, j, k] = p.max_slip, p.status
            good[i, j, k], chatter[i, j, k] = p.good, p.chatter
        by_n = {p.n: p for p in probes}
        if good_n is not None:
            largest[i, j] = by_n[good_n].dt
        if bad_n is None:
            limited[i, j] = "none"
        else:
            first = by_n[bad_n]
            broken[i, j] = first.dt
            unstable = first.status != "ok" or first.chatter
            limited[i, j] = "stability" if unstable else "accuracy"
    dims3 = ("method", "value", "sample")
    mv = ("method", "value")
    data = {
        "dt": _var(dims3, dt, "fixed step tried", "s"),
        "steps_per_output": _var(dims3, steps, f"steps per output interval n (dt = "
                                 f"{interval:g} s / n; 0 = padding)", "1"),
        "error_m": _var(dims3, error, "max over the output grid of |X - X_ref| of the centre",
                        "m"),
        "status": _var(dims3, status.astype(str), "run status (ok or why it stopped)", "1"),
        "max_slip_speed": _var(dims3, slip, "largest slip speed over all steps", "m s-1"),
        "good": _var(dims3, good, f"status ok and error below {s.tolerance:g} m", "1"),
        "chatter": _var(dims3, chatter, f"largest slip speed above {s.chatter:g} x the "
                        "reference's (slip mode unstable)", "1"),
        "largest_stable_dt": _var(mv, largest, "largest good dt below the first broken one",
                                  "s"),
        "first_broken_dt": _var(mv, broken, "smallest broken dt tried above the largest good "
                                f"one (NaN: none up to {interval:g} s)", "s"),
        "estimate_dt": _var(mv, estimate, "a-priori stability limit "
                            "creatio.dynamics.stability_limit", "s"),
        "linear_limit_dt": _var(mv, linear, "bound / (3.5 mu N_max / (m eps)) at the "
                                "reference's largest N (no margin)", "s"),
        "ratio": _var(mv, largest / estimate, "largest good dt / estimate", "1"),
        "broken_ratio": _var(mv, broken / estimate, "first broken dt / estimate", "1"),
        "limited_by": _var(mv, limited.astype(str), "what breaks the first broken dt: "
                           "stability (stopped, non-finite or slip chatter), accuracy (error "
                           "above tolerance only) or none", "1"),
        "real_stability_bound": _var(("method",), [METHODS[m].stability_bound for m in methods],
                                     "length of the negative real axis in the stability "
                                     "region", "1"),
        "reference_max_slip_speed": _var(("value",), ref_slip, "largest slip speed of the "
                                         "reference run", "m s-1"),
        "reference_agreement_m": _var(("value",), agreement, f"max |X_{s.reference.method} - "
                                      f"X_{s.cross_check.method}| of the two reference "
                                      "solutions", "m"),
    }
    checked = _validated_method(cfg)
    attrs = {"axis": axis, **_settings_attrs(cfg)}
    if s.validation and checked is not None:
        i = methods.index(checked)
        name = checked.upper()
        limit = np.array([_step_limit(cfg, axis, v) for v in values])
        refuses = np.zeros(shape[1:], dtype=bool)
        for j, v in enumerate(values):
            for k in range(width):
                if np.isfinite(dt[i, j, k]):
                    refuses[j, k] = _refusal(cfg, axis, v, float(dt[i, j, k]))
        tried = np.isfinite(dt[i])
        expected = dt[i] > limit[:, None]
        agrees = np.all(~tried | (refuses == expected), axis=1)
        accepted_unstable = np.sum(tried & ~refuses & ~good[i] & chatter[i], axis=1)
        accepted_broken = np.sum(tried & ~refuses & ~good[i], axis=1)
        data |= {
            "validation_limit_dt": _var(("value",), limit, f"{name} step limit of the config "
                                        "validation (DynamicConfig.step_limit)", "s"),
            "validation_refuses": _var(("value", "sample"), refuses, "the config validation "
                                       f"refuses solver.dt = the {name} dt tried", "1"),
            "validation_agrees": _var(("value",), agrees, f"refused exactly the {name} dts "
                                      "above validation_limit_dt", "1"),
            "validation_break_ratio": _var(("value",), broken[i] / limit, f"first broken "
                                           f"{name} dt / validation_limit_dt", "1"),
            "validation_good_ratio": _var(("value",), largest[i] / limit, f"largest good "
                                          f"{name} dt / validation_limit_dt", "1"),
            "accepted_broken": _var(("value",), accepted_broken, f"{name} dts tried that "
                                    "validation accepts but are broken", "1"),
            "accepted_unstable": _var(("value",), accepted_unstable, f"{name} dts tried that "
                                      "validation accepts but are unstable (chatter)", "1"),
        }
        attrs["validation_method"] = checked
    coords = {
        "method": _var(("method",), list(methods), "fixed-step explicit scheme", "1"),
        "value": _var(("value",), np.array(values, dtype=float), AXES[axis]["long_name"],
                      AXES[axis]["units"]),
    }
    attrs["title"] = f"{s.title or 'Stability map'} along {axis}"
    return xr.Dataset(data, coords=coords, attrs=attrs)


def duration_check(
    cfg: StabilityMapConfig, mu: float, durations: tuple[float, ...],
) -> dict[str, dict[float, tuple[float, float]]]:
    """(largest good dt, first broken dt) per method and duration at one mu, to show that a
    shortened run breaks at the same dt as the full base duration."""
    out: dict[str, dict[float, tuple[float, float]]] = {m: {} for m in cfg.study.methods}
    for d in durations:
        base = base_problem(cfg, "mu", mu, d)
        ref = reference(base, cfg.study.reference)
        for m in cfg.study.methods:
            _, good_n, bad_n = _locate(cfg, scheme_problem(base, m), ref)
            out[m][float(d)] = (
                base.output.interval / good_n if good_n else math.nan,
                base.output.interval / bad_n if bad_n else math.nan,
            )
    return out


def duration_dataset(cfg: StabilityMapConfig) -> xr.Dataset:
    """The duration check as a dataset: dims method, mu, duration (the map's, the full)."""
    import xarray as xr

    s = cfg.study
    check = s.duration_check
    durations = (float(s.duration), float(check.duration))
    shape = (len(s.methods), len(check.mu), len(durations))
    good = np.full(shape, np.nan)
    broken = np.full(shape, np.nan)
    for j, mu in enumerate(check.mu):
        t0 = time.perf_counter()
        found = duration_check(cfg, float(mu), durations)
        for i, m in enumerate(s.methods):
            for k, d in enumerate(durations):
                good[i, j, k], broken[i, j, k] = found[m][d]
        log.info("duration check at mu=%g: %s (%.2f s)", mu, found, time.perf_counter() - t0)
    dims = ("method", "mu", "duration")
    data = {
        "largest_stable_dt": _var(dims, good, "largest good dt below the first broken one",
                                  "s"),
        "first_broken_dt": _var(dims, broken, "smallest broken dt tried above the largest "
                                "good one", "s"),
    }
    coords = {
        "method": _var(("method",), list(s.methods), "fixed-step explicit scheme", "1"),
        "mu": _var(("mu",), np.array(check.mu, dtype=float), AXES["mu"]["long_name"],
                   AXES["mu"]["units"]),
        "duration": _var(("duration",), np.array(durations), "simulated duration", "s"),
    }
    attrs = {"axis": DURATION_AXIS, **_settings_attrs(cfg),
             "title": f"{s.title or 'Stability map'}: break over the shortened and the full "
                      "duration"}
    return xr.Dataset(data, coords=coords, attrs=attrs)
