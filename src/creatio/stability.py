"""Stability map of the fixed-step explicit schemes against the friction's slip relaxation.

The regularised friction f = -mu N v_s / sqrt(v_s^2 + eps^2) makes the slip relax at
lambda = 3.5 mu N / (m eps) near zero slip, so a fixed-step explicit scheme (RK4; dopri5 and
dop853 with fixed_step) is stable only for lambda dt below its real stability bound. This
module measures where each scheme actually breaks on the EN-02 configuration, along the
friction coefficient mu and along the regularisation speed eps, and sets it against the
a-priori estimate :func:`creatio.dynamics.stability_limit` and against the config validation
that refuses an unstable RK4 step.

For one configuration and one scheme, a run at dt = output_interval / n is *good* when it
ends with status ok and its centre stays within ``tol`` (1e-9 m) of a reference solution on
every output time (the reference: radau5 at rtol 1e-12, atol 1e-14, a different method from
every scheme mapped, cross-checked against adaptive dop853 at rtol 1e-13, atol 1e-15). The
steps n are sampled from ``span`` x the estimate, then bisected between the last good and
the first broken n. A break is put down to *stability* when the first broken run stopped, went
non-finite or chattered (its largest slip speed more than twice the reference's: the unstable
mode is the slip relaxation), else to *accuracy* (the error merely outgrew ``tol``).
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

import numpy as np
import xarray as xr

from creatio.config import ConfigError, resolve
from creatio.dynamics import SimulationResult, SphereProblem, simulate, stability_limit
from creatio.dynamics.integrators import real_stability_bound
from creatio.io import provenance, write_dataset

__all__ = [
    "AXES",
    "METHODS",
    "Probe",
    "base_problem",
    "duration_check",
    "figure",
    "linear_limit",
    "locate_break",
    "main",
    "probe",
    "reference",
    "scheme_problem",
    "stability_map",
    "write_stability",
]

#: The fixed-step explicit schemes mapped.
METHODS = ("rk4", "dopri5", "dop853")

#: Default values of each axis (eps is mapped at the EN-02 mu = 0.15, mu at eps = 0.01).
AXES: dict[str, tuple[float, ...]] = {
    "mu": (0.02, 0.05, 0.1, 0.15, 0.3, 0.6, 1.0),
    "eps": (0.0025, 0.005, 0.01, 0.02, 0.04),
}
_AXIS_ATTRS = {
    "mu": {"long_name": "Coulomb friction coefficient mu", "units": "1"},
    "eps": {"long_name": "friction regularisation speed eps", "units": "m s-1"},
}

TOLERANCE = 1e-9
DURATION = 30.0
SPAN = (0.3, 2.0)
SAMPLES = 9
#: A broken run whose largest slip speed exceeds this multiple of the reference's chatters.
CHATTER = 2.0
#: Reference solution and the independent one it is checked against.
REFERENCE = {"method": "radau5", "rtol": 1e-12, "atol": 1e-14}
CROSS_CHECK = {"method": "dop853", "rtol": 1e-13, "atol": 1e-15}

Progress = Callable[[str], None] | None


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


def _overrides(axis: str, value: float, duration: float) -> list[str]:
    if axis not in AXES:
        raise ValueError(f"axis must be one of {', '.join(AXES)}, got {axis!r}")
    return [f"sphere.{axis}={float(value)!r}", f"study.duration={float(duration)!r}"]


def base_problem(axis: str, value: float, duration: float = DURATION) -> SphereProblem:
    """The EN-02 problem at one axis value and duration, energy off, unstable steps allowed.

    Built through the config (resolve) so the map runs exactly what a study would."""
    cfg = resolve("en02", [*_overrides(axis, value, duration), "solver.allow_unstable=true"])
    return dataclasses.replace(cfg.obj.sphere_problem(), energy=False, allow_unstable=True)


def reference(problem: SphereProblem, spec: dict | None = None) -> SimulationResult:
    """Reference run of the problem's configuration with an error-controlled method."""
    spec = REFERENCE if spec is None else spec
    ref = simulate(dataclasses.replace(problem, fixed_step=False, **spec))
    if ref.status != "ok":
        raise RuntimeError(f"reference {spec} stopped with status {ref.status}")
    return ref


def _distance(x: np.ndarray, x_ref: np.ndarray) -> float:
    """Largest Euclidean distance over the common output times (inf if non-finite or short)."""
    if x.shape != x_ref.shape:
        return math.inf
    d = np.linalg.norm(x - x_ref, axis=1)
    return float(d.max()) if np.all(np.isfinite(d)) else math.inf


def scheme_problem(problem: SphereProblem, method: str) -> SphereProblem:
    """The problem with a fixed-step explicit scheme (fixed_step for the Dormand-Prince pairs)."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    return dataclasses.replace(problem, method=method, fixed_step=method != "rk4")


def probe(problem: SphereProblem, n: int, ref: SimulationResult, tol: float = TOLERANCE,
          ) -> Probe:
    """Run the problem's scheme at dt = output_interval / n and judge it against ref."""
    dt = problem.output_interval / n
    res = simulate(dataclasses.replace(problem, dt=dt))
    error = _distance(res.X, ref.X)
    chatter = not math.isfinite(res.max_slip_speed) or (
        res.max_slip_speed > CHATTER * ref.max_slip_speed
    )
    good = res.status == "ok" and error < tol
    return Probe(n, dt, error, res.status, float(res.max_slip_speed), good, chatter)


def locate_break(
    problem: SphereProblem, ref: SimulationResult, tol: float = TOLERANCE,
    span: tuple[float, float] = SPAN,
    samples: int = SAMPLES,
) -> tuple[list[Probe], int | None, int | None]:
    """Sample dt over span x the estimate, then bisect n to the break.

    Returns all probes (ascending dt), the n of the largest good dt below the first broken
    one, and the n of that first broken dt (None when no dt up to output_interval breaks;
    the good n is None when even the smallest dt tried breaks)."""
    est = stability_limit(problem)
    interval = problem.output_interval
    factors = np.geomspace(span[0], span[1], samples)
    ns = sorted({max(1, round(interval / (f * est))) for f in factors}, reverse=True)
    done: dict[int, Probe] = {}

    def run(n: int) -> Probe:
        if n not in done:
            done[n] = probe(problem, n, ref, tol)
        return done[n]

    good_n = bad_n = None
    for n in ns:
        if not run(n).good:
            bad_n = n
            break
        good_n = n
    if good_n is None:  # the smallest dt tried is broken already: refine until good
        n = ns[0]
        while good_n is None and n < 64 * ns[0]:
            n *= 2
            if run(n).good:
                good_n = n
            else:
                bad_n = n
    if bad_n is None:  # every dt tried is good: coarsen up to one step per output
        n = ns[-1]
        while bad_n is None and n > 1:
            n = max(1, n // 2)
            if run(n).good:
                good_n = n
            else:
                bad_n = n
    while good_n is not None and bad_n is not None and good_n - bad_n > 1:
        mid = (good_n + bad_n) // 2
        if run(mid).good:
            good_n = mid
        else:
            bad_n = mid
    return sorted(done.values(), key=lambda p: p.dt), good_n, bad_n


def linear_limit(problem: SphereProblem, n_max: float) -> float:
    """Linear stability limit of the slip mode at normal reaction n_max, without margin:
    real_stability_bound / (mu n_max (1/m + b^2/I) / eps), with I = 2 m b^2 / 5."""
    rate = problem.mu * n_max * (1.0 / problem.m + problem.b**2 / problem.inertia) / problem.eps
    return real_stability_bound(problem.method) / rate if rate > 0.0 else math.inf


def _refusal(axis: str, value: float, duration: float, dt: float) -> bool:
    """Whether resolve() refuses solver.dt = dt for this configuration (RK4, the default)."""
    try:
        resolve("en02", [*_overrides(axis, value, duration), f"solver.dt={dt!r}"])
    except ConfigError as e:
        if e.key != "solver.dt":
            raise
        return True
    return False


def _step_limit(axis: str, value: float, duration: float) -> float:
    cfg = resolve("en02", [*_overrides(axis, value, duration), "solver.allow_unstable=true"])
    return float(cfg.obj.step_limit())


def _var(dims, data, long_name: str, units: str, **extra) -> xr.Variable:
    return xr.Variable(dims, data, {"long_name": long_name, "units": units, **extra})


def stability_map(
    axis: str,
    methods: Sequence[str] = METHODS,
    values: Sequence[float] | None = None,
    duration: float = DURATION,
    tol: float = TOLERANCE,
    span: tuple[float, float] = SPAN,
    samples: int = SAMPLES,
    validation: bool = True,
    progress: Progress = None,
) -> xr.Dataset:
    """Map the largest good fixed dt of each scheme along mu or eps (EN-02 otherwise).

    dims: method, value (the axis value), sample (the dts tried, ascending, NaN-padded).
    validation: also ask resolve() whether it refuses each RK4 dt tried (needs "rk4").
    """
    values = tuple(AXES[axis] if values is None else values)
    methods = tuple(methods)
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise ValueError(f"methods must be among {', '.join(METHODS)}, got {unknown}")
    say = progress or (lambda _line: None)
    runs: dict[tuple[str, int], tuple[list[Probe], int | None, int | None]] = {}
    estimate = np.full((len(methods), len(values)), np.nan)
    ref_slip = np.empty(len(values))
    linear = np.full((len(methods), len(values)), np.nan)
    agreement = np.empty(len(values))
    for j, v in enumerate(values):
        base = base_problem(axis, v, duration)
        ref = reference(base)
        cross = reference(base, CROSS_CHECK)
        agreement[j] = _distance(cross.X, ref.X)
        ref_slip[j] = ref.max_slip_speed
        for i, m in enumerate(methods):
            t0 = time.perf_counter()
            prob = scheme_problem(base, m)
            estimate[i, j] = stability_limit(prob)
            linear[i, j] = linear_limit(prob, ref.max_N)
            runs[m, j] = located = locate_break(prob, ref, tol, span, samples)
            probes, good_n, bad_n = located
            good = base.output_interval / good_n if good_n else math.nan
            bad = base.output_interval / bad_n if bad_n else math.nan
            say(f"{axis}={v:g} {m}: estimate {estimate[i, j]:.4g} s, good {good:.4g} s, "
                f"broken {bad:.4g} s ({len(probes)} runs, {time.perf_counter() - t0:.2f} s)")
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
    axis_attrs = _AXIS_ATTRS[axis]
    dims3 = ("method", "value", "sample")
    data = {
        "dt": _var(dims3, dt, "fixed step tried", "s"),
        "steps_per_output": _var(dims3, steps, "steps per output interval n (dt = 0.1 s / n; "
                                 "0 = padding)", "1"),
        "error_m": _var(dims3, error, "max over the output grid of |X - X_ref| of the centre",
                        "m"),
        "status": _var(dims3, status.astype(str), "run status (ok or why it stopped)", "1"),
        "max_slip_speed": _var(dims3, slip, "largest slip speed over all steps", "m s-1"),
        "good": _var(dims3, good, f"status ok and error below {tol:g} m", "1"),
        "chatter": _var(dims3, chatter, f"largest slip speed above {CHATTER:g} x the "
                        "reference's (slip mode unstable)", "1"),
        "largest_stable_dt": _var(("method", "value"), largest, "largest good dt below the "
                                  "first broken one", "s"),
        "first_broken_dt": _var(("method", "value"), broken, "smallest broken dt tried above "
                                "the largest good one (NaN: none up to 0.1 s)", "s"),
        "estimate_dt": _var(("method", "value"), estimate, "a-priori stability limit "
                            "creatio.dynamics.stability_limit", "s"),
        "linear_limit_dt": _var(("method", "value"), linear, "bound / (3.5 mu N_max / (m "
                                "eps)) at the reference's largest N (no margin)", "s"),
        "ratio": _var(("method", "value"), largest / estimate, "largest good dt / estimate",
                      "1"),
        "broken_ratio": _var(("method", "value"), broken / estimate, "first broken dt / "
                             "estimate", "1"),
        "limited_by": _var(("method", "value"), limited.astype(str), "what breaks the first "
                           "broken dt: stability (stopped, non-finite or slip chatter), "
                           "accuracy (error above tolerance only) or none", "1"),
        "real_stability_bound": _var(("method",), [real_stability_bound(m) for m in methods],
                                     "length of the negative real axis in the stability "
                                     "region", "1"),
        "reference_max_slip_speed": _var(("value",), ref_slip, "largest slip speed of the "
                                         "reference run", "m s-1"),
        "reference_agreement_m": _var(("value",), agreement, "max |X_radau5 - X_dop853| of the "
                                      "two reference solutions", "m"),
    }
    if validation and "rk4" in methods:
        i = methods.index("rk4")
        limit = np.array([_step_limit(axis, v, duration) for v in values])
        refuses = np.zeros(shape[1:], dtype=bool)
        for j, v in enumerate(values):
            for k in range(width):
                if np.isfinite(dt[i, j, k]):
                    refuses[j, k] = _refusal(axis, v, duration, float(dt[i, j, k]))
        tried = np.isfinite(dt[i])
        expected = dt[i] > limit[:, None]
        agrees = np.all(~tried | (refuses == expected), axis=1)
        accepted_unstable = np.sum(tried & ~refuses & ~good[i] & chatter[i], axis=1)
        accepted_broken = np.sum(tried & ~refuses & ~good[i], axis=1)
        data |= {
            "validation_limit_dt": _var(("value",), limit, "RK4 step limit of the config "
                                        "validation (DynamicConfig.step_limit)", "s"),
            "validation_refuses": _var(("value", "sample"), refuses, "resolve() refuses "
                                       "solver.dt = the RK4 dt tried", "1"),
            "validation_agrees": _var(("value",), agrees, "refused exactly the RK4 dts above "
                                      "validation_limit_dt", "1"),
            "validation_break_ratio": _var(("value",), broken[i] / limit, "first broken RK4 "
                                           "dt / validation_limit_dt", "1"),
            "validation_good_ratio": _var(("value",), largest[i] / limit, "largest good RK4 "
                                          "dt / validation_limit_dt", "1"),
            "accepted_broken": _var(("value",), accepted_broken, "RK4 dts tried that "
                                    "validation accepts but are broken", "1"),
            "accepted_unstable": _var(("value",), accepted_unstable, "RK4 dts tried that "
                                      "validation accepts but are unstable (chatter)", "1"),
        }
    cfg = resolve("en02", [f"study.duration={float(duration)!r}"])
    attrs = provenance("en02", cfg.yaml, cfg.sha256, f"Stability map of the fixed-step "
                       f"explicit schemes along {axis} (EN-02)")
    attrs |= {
        "axis": axis,
        "tolerance_m": tol,
        "duration_s": duration,
        "dt_span_of_estimate": list(span),
        "reference": f"radau5 rtol={REFERENCE['rtol']:g} atol={REFERENCE['atol']:g}",
        "cross_check": f"dop853 rtol={CROSS_CHECK['rtol']:g} atol={CROSS_CHECK['atol']:g}",
        "chatter_factor": CHATTER,
    }
    coords = {
        "method": _var(("method",), list(methods), "fixed-step explicit scheme", "1"),
        "value": _var(("value",), np.array(values, dtype=float), axis_attrs["long_name"],
                      axis_attrs["units"]),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def duration_check(
    mu: float = 0.15, durations: Sequence[float] = (DURATION, 120.0),
    methods: Sequence[str] = METHODS, tol: float = TOLERANCE,
) -> dict[str, dict[float, tuple[float, float]]]:
    """(largest good dt, first broken dt) per method and duration at one mu, to show that a
    shortened run breaks at the same dt as the full EN-02 cycle."""
    out: dict[str, dict[float, tuple[float, float]]] = {m: {} for m in methods}
    for d in durations:
        base = base_problem("mu", mu, d)
        ref = reference(base)
        for m in methods:
            _, good_n, bad_n = locate_break(scheme_problem(base, m), ref, tol)
            out[m][float(d)] = (
                base.output_interval / good_n if good_n else math.nan,
                base.output_interval / bad_n if bad_n else math.nan,
            )
    return out


CheckResult = dict[float, dict[str, dict[float, tuple[float, float]]]]


def figure(ds: xr.Dataset | Sequence[xr.Dataset], path: str | Path) -> Path:
    """Largest good dt against the axis value (log-log) with the estimate, one column per
    dataset, and the error against dt / estimate underneath."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    sets = [ds] if isinstance(ds, xr.Dataset) else list(ds)
    fig, axes = plt.subplots(2, len(sets), figsize=(6.0 * len(sets), 9.0), squeeze=False)
    colors = dict(zip(METHODS, ("C0", "C1", "C2"), strict=True))
    for c, d in enumerate(sets):
        top, bottom = axes[0, c], axes[1, c]
        axis = d.attrs["axis"]
        x = d.value.values
        for m in d.method.values:
            m = str(m)
            color = colors.get(m, "k")
            sel = d.sel({"method": m})
            top.loglog(x, sel.estimate_dt, "--", color=color, label=f"{m} estimate")
            top.loglog(x, sel.largest_stable_dt, "o-", color=color, label=f"{m} largest good")
            top.loglog(x, sel.first_broken_dt, "x", color=color, ms=7)
            for j in range(x.size):
                ok = np.isfinite(sel.dt.values[j])
                ratio = sel.dt.values[j][ok] / float(sel.estimate_dt[j])
                err = np.clip(sel.error_m.values[j][ok], 1e-16, 1.0)
                bottom.loglog(ratio, err, ".-", color=color, alpha=0.5,
                              label=m if j == 0 else None)
        top.set_xlabel(f"{axis} ({d.value.attrs['units']})")
        top.set_ylabel("dt (s)")
        top.set_title(f"fixed-step break vs {axis} (x: first broken dt)")
        top.legend(fontsize=7)
        for ax in (top, bottom):
            ax.xaxis.set_minor_formatter(NullFormatter())
        top.grid(True, which="both", alpha=0.3)
        bottom.axhline(float(d.attrs["tolerance_m"]), color="k", lw=0.8)
        bottom.axvline(1.0, color="k", ls=":", lw=0.8)
        bottom.set_xlabel("dt / estimate")
        bottom.set_ylabel("max |X - X_ref| (m), clipped to [1e-16, 1]")
        bottom.set_title(f"error vs dt, every {axis} (line: tolerance)")
        bottom.legend(fontsize=7)
        bottom.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def _fmt(x: float) -> str:
    return "-" if not math.isfinite(x) else f"{x:.4g}"


def _markdown(sets: Sequence[xr.Dataset], check: CheckResult | None, seconds: float) -> str:
    first = sets[0]
    lines = [
        "# Stability map of the fixed-step explicit schemes (EN-02)",
        "",
        f"dt = 0.1 s / n; a run is good when its status is ok and its centre stays within "
        f"{first.attrs['tolerance_m']:g} m of the reference ({first.attrs['reference']}) on "
        f"every 0.1 s output, over {first.attrs['duration_s']:g} s. Estimate: "
        "creatio.dynamics.stability_limit (bound / (3.5 mu N_est / (m eps)), N_est = 1.25 "
        "max(N0, m g)). Ratio: largest good dt / estimate; the break lies between the "
        "largest good and the first broken dt. Linear limit: the same bound at the "
        "reference's largest N, without the 1.25 margin (the exact slip-mode limit).",
        "",
    ]
    for d in sets:
        axis = d.attrs["axis"]
        agree = float(np.nanmax(d.reference_agreement_m))
        lines += [
            f"## Along {axis}",
            "",
            f"Reference agreement ({d.attrs['cross_check']} vs radau5): max {agree:.2e} m "
            "over the values.",
            "",
            f"| method | {axis} | estimate (s) | linear limit (s) | largest good dt (s) | "
            "first broken dt (s) | ratio | broken / estimate | limited by |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for m in d.method.values:
            for j, v in enumerate(d.value.values):
                s = d.sel({"method": m}).isel(value=j)
                cells = [_fmt(float(s[k])) for k in ("estimate_dt", "linear_limit_dt",
                         "largest_stable_dt", "first_broken_dt", "ratio", "broken_ratio")]
                lines.append(f"| {m} | {v:g} | " + " | ".join(cells)
                             + f" | {s.limited_by.item()} |")
        if "validation_limit_dt" in d:
            lines += [
                "",
                f"RK4 config validation along {axis} (resolve with solver.dt, each RK4 dt "
                "tried):",
                "",
                f"| {axis} | step_limit (s) | refuses exactly dt > limit | largest good / "
                "limit | first broken / limit | accepted but broken |",
                "|---|---|---|---|---|---|",
            ]
            for j, v in enumerate(d.value.values):
                lines.append(
                    f"| {v:g} | {float(d.validation_limit_dt[j]):.4g} | "
                    f"{bool(d.validation_agrees[j])} | "
                    f"{_fmt(float(d.validation_good_ratio[j]))} | "
                    f"{_fmt(float(d.validation_break_ratio[j]))} | "
                    f"{int(d.accepted_broken[j])} |"
                )
        lines.append("")
    if check:
        lines += [
            "## Shortened duration",
            "",
            "(largest good dt, first broken dt) in s, per simulated duration:",
            "",
        ]
        for mu, by_method in check.items():
            durations = next(iter(by_method.values()))
            lines += [
                f"| mu = {mu:g} | " + " | ".join(f"{t:g} s" for t in durations) + " | same |",
                "|---|" + "---|" * (len(durations) + 1),
            ]
            for m, by_duration in by_method.items():
                cells = [f"{_fmt(g)}, {_fmt(b)}" for g, b in by_duration.values()]
                same = len(set(by_duration.values())) == 1
                lines.append(f"| {m} | " + " | ".join(cells) + f" | {same} |")
            lines.append("")
    lines.append(f"Computed in {seconds:.1f} s.")
    return "\n".join(lines) + "\n"


def write_stability(
    out_dir: Path, duration: float = DURATION, methods: Sequence[str] = METHODS,
    check_mu: Sequence[float] = (0.15, 1.0), progress: Progress = None,
) -> list[Path]:
    """Write stability_mu.nc, stability_eps.nc, stability.png and stability.md to out_dir.

    check_mu: also locate the break at these mu over the full 120 s cycle (() to skip)."""
    out_dir = Path(out_dir)
    t0 = time.perf_counter()
    sets = [stability_map(a, methods, duration=duration, progress=progress) for a in AXES]
    check: CheckResult = {}
    if duration != 120.0:
        for mu in check_mu:
            check[mu] = duration_check(mu, (duration, 120.0), methods)
            if progress:
                progress(f"duration check at mu={mu:g}: {check[mu]}")
    paths = [write_dataset(d, out_dir / f"stability_{d.attrs['axis']}.nc") for d in sets]
    paths.append(figure(sets, out_dir / "stability.png"))
    md = out_dir / "stability.md"
    md.write_text(_markdown(sets, check, time.perf_counter() - t0))
    paths.append(md)
    return paths


def main(argv: Sequence[str] | None = None) -> int:
    """Command line: write the stability map (datasets, figure, table) to OUT_DIR."""
    parser = argparse.ArgumentParser(
        prog="python -m creatio.stability",
        description="Map the largest fixed dt of RK4, dopri5 and dop853 (fixed_step) whose "
        "EN-02 trajectory stays within 1e-9 m of a radau5 reference, along mu and eps, and "
        "compare it with the analytic stability estimate and the config validation.",
    )
    parser.add_argument("out_dir", type=Path, nargs="?", default=Path("data/stability"),
                        help="directory for stability_{mu,eps}.nc, stability.png and "
                        "stability.md (default data/stability)")
    parser.add_argument("--duration", type=float, default=DURATION,
                        help=f"simulated time per run in s (default {DURATION:g})")
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS,
                        help="schemes to map (default all)")
    parser.add_argument("--no-check", action="store_true",
                        help="skip locating the break over the full 120 s at mu = 0.15 "
                        "and 1 (the check that --duration does not move it)")
    args = parser.parse_args(argv)

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    t0 = time.perf_counter()
    paths = write_stability(args.out_dir, args.duration, args.methods,
                            () if args.no_check else (0.15, 1.0), progress=say)
    say(f"wrote {len(paths)} files to {args.out_dir} in {time.perf_counter() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
