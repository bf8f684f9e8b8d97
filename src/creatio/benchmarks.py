"""Work-precision benchmark of the sphere integrators (EN-02, EN-02R): run time against error.

For each study a reference solution is computed by two independent high-accuracy methods
(dop853 at rtol 1e-13, explicit; radau5 at rtol 1e-12, implicit) whose agreement is
recorded; the reference is the dop853 one. Every method is swept over its step or
tolerance; the error of a run is the maximum over the 0.1 s output grid of |X - X_ref|
(centre position, metres), plus the same at the final time, computed outside the timed
region. Timing follows the DiffEqBenchmarks practice: one warm-up run (which also yields
the error), then the minimum over repeats of the core call alone (the compiled loop, or
scipy's stepping loop), single-threaded; the first call's extra time (JIT compile or cache
load) is reported separately.

Methods: rk4 (fixed step, from far below to beyond the friction stability limit), dopri5 and
dop853 (adaptive explicit pairs), radau5 (adaptive, and fixed-step), and the scipy peers
DOP853, Radau and LSODA on a plain NumPy right-hand side. Two more rows measure what a
minimal-state run saves: rk4 and radau5 with full diagnostics (energy bookkeeping on).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import platform
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from creatio.dynamics import SphereProblem, core, integrators, simulate, stability_limit
from creatio.dynamics.peers import centre_grid, solve_peer
from creatio.dynamics.problem import MAX_STEPS

STUDIES = ("en02", "en02r")

#: Error levels (m) of the "fastest method" table.
LEVELS = (1e-6, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)

#: Native methods and their settings: rk4 by dt = 0.1 / n, the others by rtol (atol =
#: rtol / 100), radau5 fixed by dt.
NATIVE: dict[str, tuple[str, Sequence[float]]] = {
    "rk4": ("dt", [0.1 / n for n in (400, 200, 100, 50, 40, 30, 25, 24, 23, 22, 20)]),
    "dopri5": ("rtol", [1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]),
    "dop853": ("rtol", [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]),
    "radau5": ("rtol", [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11]),
    "radau5-fixed": ("dt", [0.1, 0.05, 0.1 / 3, 0.025, 0.02, 0.0125, 0.01]),
}

#: scipy peers and their rtol sweeps (atol = rtol / 100).
PEERS: dict[str, Sequence[float]] = {
    "scipy-DOP853": [1e-6, 1e-8, 1e-10, 1e-12],
    "scipy-Radau": [1e-5, 1e-7, 1e-9, 1e-11],
    "scipy-LSODA": [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12],
}

#: Minimal-state comparison: the same settings with the energy bookkeeping switched on.
FULL: dict[str, tuple[str, float]] = {
    "rk4-full": ("dt", 0.002),
    "radau5-full": ("rtol", 1e-8),
}

ENTRY_KEYS = ("study", "method", "setting", "error_m", "final_error_m", "time_s", "rhs_evals",
              "steps")


@dataclass
class Entry:
    """One benchmarked run: the contract's fields plus status and work counters."""

    study: str
    method: str
    setting: str
    error_m: float
    final_error_m: float
    time_s: float
    rhs_evals: int
    steps: int
    status: str
    first_call_s: float
    state_size: int
    rejected_steps: int = 0
    jacobians: int = 0
    lu_factorisations: int = 0

    def record(self) -> dict[str, Any]:
        """The JSON record (non-finite numbers as null)."""
        out = dataclasses.asdict(self)
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                for k, v in out.items()}


def problem(study: str) -> SphereProblem:
    """The study's default problem, trajectory only (energy off; rotation as friction needs)."""
    from creatio.config import resolve

    return dataclasses.replace(resolve(study).obj.sphere_problem(), energy=False)


def errors(X: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    """(max over the grid, final) Euclidean centre error; inf if the run stopped short."""
    if X.shape != ref.shape or not np.all(np.isfinite(X)):
        return math.inf, math.inf
    e = np.linalg.norm(X - ref, axis=1)
    return float(e.max()), float(e[-1])


def _native_call(prob: SphereProblem) -> Callable[[], tuple]:
    """A zero-argument call of the compiled loop with preallocated arguments (core time)."""
    args = prob.core_arguments()
    if prob.method == "rk4":
        return lambda: core.run(*args)
    p, lawc, y0, out, rot, en = args[0], args[1], args[2], args[6], args[7], args[8]
    return lambda: integrators.run(p, lawc, y0, prob.t_end, prob.output_interval, prob.dt,
                                   prob.rtol, prob.atol, prob.method, prob.fixed_step,
                                   MAX_STEPS, out, rot, en)


def native_problem(base: SphereProblem, method: str, value: float) -> SphereProblem:
    """The base problem set up for one native method and setting."""
    if method in ("rk4", "rk4-full"):
        return dataclasses.replace(base, method="rk4", dt=value, allow_unstable=True,
                                   energy=method == "rk4-full")
    if method == "radau5-fixed":
        return dataclasses.replace(base, method="radau5", dt=value, fixed_step=True)
    name = method.removesuffix("-full")
    return dataclasses.replace(base, method=name, rtol=value, atol=value / 100,
                               energy=method.endswith("-full"))


def time_call(call: Callable[[], Any], repeats: int, budget_s: float = 2.0) -> tuple[float, float]:
    """(first call s, min over repeats s) of call(); fewer repeats for slow calls."""
    t0 = time.perf_counter()
    call()
    first = time.perf_counter() - t0
    best = math.inf
    n = repeats if first < budget_s / repeats else max(1, int(budget_s / max(first, 1e-9)))
    for _ in range(max(n, 1)):
        t0 = time.perf_counter()
        call()
        best = min(best, time.perf_counter() - t0)
    return first, best


def run_native(study: str, base: SphereProblem, method: str, value: float, ref: np.ndarray,
               repeats: int) -> Entry:
    """Benchmark one native setting: the first core call (JIT compile or cache load
    included) comes first, then a simulate() run for the error, then the timed repeats."""
    prob = native_problem(base, method, value)
    call = _native_call(prob)
    t0 = time.perf_counter()
    call()
    first = time.perf_counter() - t0
    res = simulate(prob)
    err, fin = errors(res.X, ref) if res.status == "ok" else (math.inf, math.inf)
    _, best = time_call(call, repeats)
    kind = NATIVE.get(method, FULL.get(method, ("rtol",)))[0]
    return Entry(study, method, f"{kind}={value:.6g}", err, fin, best, res.rhs_evals, res.steps,
                 res.status, max(first - best, 0.0),
                 prob.initial_state(prob.rotation_integrated, prob.energy).size,
                 res.rejected_steps, res.jacobians, res.lu_factorisations)


def run_peer(study: str, base: SphereProblem, method: str, rtol: float, ref: np.ndarray,
             repeats: int) -> Entry:
    """Benchmark one scipy setting: a warm-up solve gives the error, then min of repeats."""
    name = method.removeprefix("scipy-")
    res = solve_peer(base, name, rtol, rtol / 100)
    first = res.time_s
    best = math.inf
    n = repeats if res.time_s < 2.0 / repeats else max(1, int(2.0 / res.time_s))
    for _ in range(n):
        best = min(best, solve_peer(base, name, rtol, rtol / 100).time_s)
    X = centre_grid(base, res.t, res.y, False)
    err, fin = errors(X, ref) if res.status == "ok" else (math.inf, math.inf)
    return Entry(study, method, f"rtol={rtol:.6g}", err, fin, best, res.rhs_evals, res.steps,
                 res.status, max(first - best, 0.0), res.y.shape[1], 0, res.jacobians,
                 res.lu_factorisations)


def minimal_state(base: SphereProblem, repeats: int) -> dict[str, float]:
    """RK4 core time without friction (mu = 0): trajectory alone (4 states: rotation and
    energy skipped) against full diagnostics (14 states), the largest saving outputs allow."""
    times = {}
    for name, rot, en in (("trajectory", False, False), ("full", True, True)):
        prob = dataclasses.replace(base, mu=0.0, rotation=rot, energy=en)
        times[f"{name}_time_s"] = time_call(_native_call(prob), repeats)[1]
        times[f"{name}_state"] = prob.initial_state(rot, en).size
    times["saved"] = 1 - times["trajectory_time_s"] / times["full_time_s"]
    return times


def reference(base: SphereProblem) -> tuple[np.ndarray, dict[str, float]]:
    """Reference centre positions (dop853, rtol 1e-13) and the evidence that they are one."""
    ref = simulate(dataclasses.replace(base, method="dop853", rtol=1e-13, atol=1e-15))
    alt = simulate(dataclasses.replace(base, method="radau5", rtol=1e-12, atol=1e-14))
    rk4 = simulate(dataclasses.replace(base, method="rk4", dt=0.1 / 400))
    evidence = {
        "reference_method": "dop853 rtol=1e-13 atol=1e-15",
        "reference_steps": ref.steps,
        "check_radau5_rtol1e-12_max_diff_m": errors(alt.X, ref.X)[0],
        "check_rk4_dt2.5e-4_max_diff_m": errors(rk4.X, ref.X)[0],
    }
    for r in (ref, alt, rk4):
        if r.status != "ok":
            raise RuntimeError(f"reference run stopped: {r.status} at {r.stop_time} s")
    return ref.X, evidence


COLD = """
import dataclasses, time
from creatio.benchmarks import problem
from creatio.dynamics import simulate
base = dataclasses.replace(problem("en02"), t_end=0.1)
for method in ("rk4", "radau5"):
    t0 = time.perf_counter()
    simulate(dataclasses.replace(base, method=method))
    print(method, time.perf_counter() - t0)
"""


def jit_times() -> dict[str, float]:
    """First-call seconds of the compiled loops: in a fresh process with an empty numba
    cache (cold compile) and in this process (cache load, or compile if none)."""
    import subprocess
    import tempfile

    out: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        run = subprocess.run([sys.executable, "-c", COLD], env=env, capture_output=True,
                             text=True, check=True)
    for line in run.stdout.split("\n"):
        if line.strip():
            name, value = line.split()
            out[f"cold_compile_{name}_s"] = float(value)
    base = dataclasses.replace(problem("en02"), t_end=0.1)
    for method in ("rk4", "radau5"):
        t0 = time.perf_counter()
        simulate(dataclasses.replace(base, method=method))
        out[f"this_process_first_{method}_s"] = time.perf_counter() - t0
    return out


def benchmark(studies: Sequence[str] = STUDIES, repeats: int = 5, quick: bool = False,
              log: Callable[[str], None] = print) -> tuple[list[Entry], dict[str, Any]]:
    """Run the whole work-precision sweep; returns the entries and per-study metadata."""
    entries: list[Entry] = []
    meta: dict[str, Any] = {"jit": jit_times()}
    log("JIT first calls: " + ", ".join(f"{k} {v:.2f} s" for k, v in meta["jit"].items()))
    for study in studies:
        base = problem(study)
        t0 = time.perf_counter()
        ref, evidence = reference(base)
        evidence["stability_limit_rk4_dt_s"] = stability_limit(base)
        meta[study] = evidence
        log(f"{study}: reference in {time.perf_counter() - t0:.1f} s; " + ", ".join(
            f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in evidence.items()))
        for method, (_, values) in NATIVE.items():
            for value in values[::3] if quick else values:
                e = run_native(study, base, method, value, ref, repeats)
                entries.append(e)
                log(f"{study} {method:13s} {e.setting:16s} error {e.error_m:.3e} m  "
                    f"time {e.time_s * 1e3:9.3f} ms  evals {e.rhs_evals}  {e.status}")
        for method, (_kind, value) in FULL.items():
            e = run_native(study, base, method, value, ref, repeats)
            entries.append(e)
            log(f"{study} {method:13s} {e.setting:16s} time {e.time_s * 1e3:9.3f} ms")
        evidence["minimal_state_mu0"] = minimal_state(base, repeats)
        log(f"{study} mu = 0 minimal vs full state: {evidence['minimal_state_mu0']}")
        for method, values in PEERS.items():
            for value in values[::3] if quick else values:
                e = run_peer(study, base, method, value, ref, repeats)
                entries.append(e)
                log(f"{study} {method:13s} {e.setting:16s} error {e.error_m:.3e} m  "
                    f"time {e.time_s * 1e3:9.3f} ms  evals {e.rhs_evals}  {e.status}")
    return entries, meta


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


def fastest(entries: Sequence[Entry], study: str, level: float,
            methods: Sequence[str] | None = None) -> Entry | None:
    """The quickest entry of a study whose error is <= level (optionally among methods)."""
    ok = [e for e in entries if e.study == study and e.error_m <= level
          and not e.method.endswith("-full") and (methods is None or e.method in methods)]
    return min(ok, key=lambda e: e.time_s) if ok else None


def to_dataset(entries: Sequence[Entry], meta: dict[str, Any]):
    """The entries as an xarray Dataset over dim `entry`, CF attributes on each variable."""
    import xarray as xr

    units = {"error_m": ("max centre-position error on the 0.1 s grid", "m"),
             "final_error_m": ("centre-position error at the final time", "m"),
             "time_s": ("core run time, min over repeats", "s"),
             "first_call_s": ("extra time of the first call (JIT compile or cache load)", "s"),
             "rhs_evals": ("right-hand-side evaluations", "1"),
             "steps": ("accepted steps", "1"),
             "rejected_steps": ("rejected steps", "1"),
             "jacobians": ("Jacobian evaluations", "1"),
             "lu_factorisations": ("LU factorisations", "1"),
             "state_size": ("integrated state components", "1")}
    data = {}
    for key in ("study", "method", "setting", "status"):
        data[key] = ("entry", np.array([getattr(e, key) for e in entries], dtype=object),
                     {"long_name": key})
    for key, (name, unit) in units.items():
        values = np.array([getattr(e, key) for e in entries], dtype=float)
        data[key] = ("entry", values, {"long_name": name, "units": unit})
    ds = xr.Dataset(data, coords={"entry": np.arange(len(entries))})
    ds.attrs["title"] = "work-precision benchmark of the sphere integrators"
    ds.attrs["machine"] = json.dumps(machine())
    ds.attrs["reference"] = json.dumps(meta)
    return ds


def markdown(entries: Sequence[Entry], meta: dict[str, Any]) -> str:
    """The report: fastest method per error level, targets, minimal-state savings, all rows."""
    lines = ["# Work-precision benchmark (EN-02, EN-02R)", "",
             "Error: max over the 0.1 s output grid of the centre-position error against the "
             "reference; time: core call, min over repeats after a warm-up, single thread, "
             "JIT excluded. Regenerate: `snakemake benchmarks -c 1`.", "",
             "Machine: " + "; ".join(f"{k} {v}" for k, v in machine().items()), ""]
    peers = list(PEERS)
    jit = meta.get("jit", {})
    if jit:
        lines += ["JIT, excluded from every timing (first call of a compiled loop): "
                  + ", ".join(f"{k.removesuffix('_s').replace('_', ' ')} {v:.2f} s"
                              for k, v in jit.items())
                  + ". The adaptive methods share one compiled driver (rk4 has its own).", ""]
    for study in sorted({e.study for e in entries}):
        m = meta.get(study, {})
        lines += [f"## {study}", "",
                  f"Reference {m.get('reference_method')}; agreement with radau5 rtol 1e-12: "
                  f"{m.get('check_radau5_rtol1e-12_max_diff_m', math.nan):.2e} m, with RK4 "
                  f"dt 2.5e-4: {m.get('check_rk4_dt2.5e-4_max_diff_m', math.nan):.2e} m. RK4 "
                  f"friction stability limit {m.get('stability_limit_rk4_dt_s', math.nan):.4g} s.",
                  "", "| error level (m) | fastest native method | setting | time (ms) | "
                  "error (m) | best scipy peer | peer time (ms) | speed-up |",
                  "|---|---|---|---|---|---|---|---|"]
        resolution = 10 * max(m.get("check_radau5_rtol1e-12_max_diff_m", 0.0),
                              m.get("check_rk4_dt2.5e-4_max_diff_m", 0.0))
        for level in LEVELS:
            if level < resolution:
                lines.append(f"| {level:.0e} | below 10 x the reference's own agreement "
                             f"({resolution / 10:.1e} m): not resolved | | | | | | |")
                continue
            best = fastest(entries, study, level, list(NATIVE))
            peer = fastest(entries, study, level, peers)
            if best is None:
                lines.append(f"| {level:.0e} | none | | | | | | |")
                continue
            ratio = f"{peer.time_s / best.time_s:.0f}x" if peer else ""
            lines.append(
                f"| {level:.0e} | {best.method} | {best.setting} | {best.time_s * 1e3:.3f} | "
                f"{best.error_m:.2e} | {peer.method + ' ' + peer.setting if peer else 'none'} | "
                f"{peer.time_s * 1e3:.1f} | {ratio} |" if peer else
                f"| {level:.0e} | {best.method} | {best.setting} | {best.time_s * 1e3:.3f} | "
                f"{best.error_m:.2e} | none reaches it | | |")
        lean = {e.method: e for e in entries if e.study == study}
        rows = []
        for full_name, (kind, value) in FULL.items():
            name = full_name.removesuffix("-full")
            full = lean.get(full_name)
            same = [e for e in entries if e.study == study and e.method == name
                    and e.setting == f"{kind}={value:.6g}"]
            if full and same:
                rows.append(f"| {name} {same[0].setting} | {same[0].state_size} | "
                            f"{same[0].time_s * 1e3:.3f} | {full.state_size} | "
                            f"{full.time_s * 1e3:.3f} | {1 - same[0].time_s / full.time_s:.0%} |")
        mu0 = m.get("minimal_state_mu0")
        if mu0:
            rows.append(f"| rk4 dt={FULL['rk4-full'][1]:g}, mu = 0 | {mu0['trajectory_state']} | "
                        f"{mu0['trajectory_time_s'] * 1e3:.3f} | {mu0['full_state']} | "
                        f"{mu0['full_time_s'] * 1e3:.3f} | {mu0['saved']:.0%} |")
        if rows:
            lines += ["", "Minimal state (`study.outputs=[trajectory]`) against full "
                      "diagnostics. With friction the spin drives the slip, so only the energy "
                      "bookkeeping can go; without friction rotation goes too:", "",
                      "| run | state | time (ms) | full state | full time (ms) | saved |",
                      "|---|---|---|---|---|---|", *rows]
        lines.append("")
    lines += ["## All runs", "", "| study | method | setting | error (m) | final error (m) | "
              "time (ms) | RHS evals | steps | status | first call extra (s) |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for e in entries:
        lines.append(f"| {e.study} | {e.method} | {e.setting} | {e.error_m:.2e} | "
                     f"{e.final_error_m:.2e} | {e.time_s * 1e3:.3f} | {e.rhs_evals} | "
                     f"{e.steps} | {e.status} | {e.first_call_s:.3f} |")
    return "\n".join(lines) + "\n"


def figure(entries: Sequence[Entry], path: Path) -> None:
    """Log-log work-precision figure: error vs time and error vs RHS evaluations, per study."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    studies = sorted({e.study for e in entries})
    fig, axes = plt.subplots(len(studies), 2, figsize=(12, 4.8 * len(studies)), squeeze=False)
    methods = [m for m in [*NATIVE, *PEERS] if any(e.method == m for e in entries)]
    styles = {m: ("-" if not m.startswith("scipy") else "--") for m in methods}
    for row, study in enumerate(studies):
        for col, (key, label) in enumerate((("time_s", "core time (s)"),
                                            ("rhs_evals", "right-hand-side evaluations"))):
            ax = axes[row, col]
            for m in methods:
                pts = sorted((getattr(e, key), e.error_m) for e in entries
                             if e.study == study and e.method == m and math.isfinite(e.error_m)
                             and e.error_m > 0)
                if pts:
                    x, y = zip(*pts, strict=True)
                    ax.loglog(x, y, styles[m], marker="o", ms=4, label=m)
            ax.axhline(1e-10, color="grey", lw=0.8, ls=":")
            ax.set_xlabel(label)
            ax.set_ylabel("max centre error (m)")
            ax.set_title(f"{study}: error against {label.split(' (')[0]}")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_benchmarks(out_dir: Path, studies: Sequence[str] = STUDIES, repeats: int = 5,
                     quick: bool = False, log: Callable[[str], None] = print) -> list[Path]:
    """Run the benchmark and write work_precision.{nc,json,png,md} into out_dir."""
    from creatio.io import write_dataset

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    entries, meta = benchmark(studies, repeats, quick, log)
    paths = [out_dir / f"work_precision.{ext}" for ext in ("nc", "json", "png", "md")]
    write_dataset(to_dataset(entries, meta), paths[0])
    paths[1].write_text(json.dumps([e.record() for e in entries], indent=1, allow_nan=False))
    figure(entries, paths[2])
    paths[3].write_text(markdown(entries, meta))
    return paths


def main(argv: Sequence[str] | None = None) -> int:
    """`creatio benchmark OUT_DIR`: the work-precision benchmark and its report."""
    parser = argparse.ArgumentParser(
        prog="creatio benchmark",
        description="Work-precision benchmark of the sphere integrators (EN-02, EN-02R): "
        "writes work_precision.{nc,json,png,md} into OUT_DIR. Set OMP_NUM_THREADS=1 etc. "
        "for single-thread timings (the Snakemake rule does).")
    parser.add_argument("out_dir", type=Path)
    parser.add_argument("--studies", default=",".join(STUDIES),
                        help="comma-separated studies (default: %(default)s)")
    parser.add_argument("--repeats", type=int, default=5,
                        help="timed repeats after the warm-up, min reported (default 5)")
    parser.add_argument("--quick", action="store_true",
                        help="every third setting only (a smoke run)")
    args = parser.parse_args(argv)
    studies = [s for s in args.studies.split(",") if s]
    bad = [s for s in studies if s not in STUDIES]
    if bad:
        parser.error(f"--studies: unknown {bad}; choose from {', '.join(STUDIES)}")
    if args.repeats < 1:
        parser.error(f"--repeats={args.repeats}: must be >= 1")
    paths = write_benchmarks(args.out_dir, studies, args.repeats, args.quick,
                             log=lambda s: print(s, file=sys.stderr, flush=True))
    for p in paths:
        print(p)
    return 0
