"""Benchmark one EN-02 run (120 s, RK4 dt = 0.002 s, 60,000 steps) of the compiled sphere core.

Reports the JIT compile time (a cold compile in a fresh process with an empty numba cache,
and the first call of this process with its cache state), then the median and min of
repeated runs for full diagnostics and for trajectory-only specialisations. Target: one
EN-02 run <= 0.1 s of core time, JIT excluded.

Usage: .venv/bin/python scripts/bench_en02.py [--repeats 9] [--no-cold] [--quick]
(--quick: 1 s runs, one repeat, no cold compile: checks the script runs, measures nothing)
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

import numba
import numpy as np

from creatio.dynamics import SphereProblem, compiled_call, simulate
from creatio.dynamics.solvers import EXPLICIT
from creatio.dynamics.solvers.driver import SPECIALISATIONS
from creatio.pipeline.config import resolve

# The default EN-02 configuration, exactly as `snakemake all` runs it (conf/study/en02.yaml).
EN02 = resolve("en02").obj.sphere_problem()

VARIANTS = {
    "EN-02 full (rotation + energy)": EN02,
    "EN-02 trajectory-only (energy off; mu > 0 needs rotation)": EN02.replace(energy=False),
    "EN-02 mu=0 full (rotation forced + energy)": EN02.replace(mu=0.0, rotation=True),
    "EN-02 mu=0 trajectory-only (rotation + energy off)": EN02.replace(mu=0.0, rotation=False,
                                                                        energy=False),
}

COLD_SNIPPET = """
import time
t0 = time.perf_counter()
from creatio.dynamics import simulate
from creatio.pipeline.config import resolve
t1 = time.perf_counter()
p = resolve("en02").obj.sphere_problem().replace(t_end=0.1)
simulate(p)
print(t1 - t0, time.perf_counter() - t1)
"""


def machine_info() -> str:
    """One line per fact about the machine and the numeric stack."""
    return "\n".join(
        [
            f"platform: {platform.platform()}",
            f"processor: {platform.processor() or platform.machine()}",
            f"cpu count: {os.cpu_count()}",
            f"python: {platform.python_version()}, numpy {np.__version__}, "
            f"numba {numba.__version__}",
        ]
    )


def cold_compile() -> tuple[float, float]:
    """Import time and first EN-02 call time (JIT of the rotation + energy loop), no cache."""
    with tempfile.TemporaryDirectory() as cache:
        # an empty cache, whichever variable names it (creatio.dynamics.jit reads both)
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, CREATIO_NUMBA_CACHE=cache)
        cmd = [sys.executable, "-c", COLD_SNIPPET]
        out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True)
    imp, first = (float(x) for x in out.stdout.split())
    return imp, first


def core_call(problem: SphereProblem) -> tuple[float, int]:
    """Time one call of the compiled loop alone (arrays prepared beforehand)."""
    call = compiled_call(problem)
    t0 = time.perf_counter()
    result = call()
    elapsed = time.perf_counter() - t0
    return elapsed, int(result[3])


def main() -> None:
    """Run the benchmark and print machine info, compile times and per-variant timings."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=9, help="timed runs per variant (>= 7)")
    parser.add_argument("--no-cold", action="store_true", help="skip the cold-compile probe")
    parser.add_argument("--quick", action="store_true",
                        help="1 s runs, one repeat, no cold compile (a smoke test)")
    args = parser.parse_args()
    repeats = 1 if args.quick else max(7, args.repeats)
    variants = {name: p.replace(t_end=1.0) if args.quick else p for name, p in VARIANTS.items()}
    print(machine_info())
    if not (args.no_cold or args.quick):
        imp, first = cold_compile()
        print(f"cold JIT (fresh process, empty numba cache): import {imp:.2f} s, "
              f"first EN-02 simulate (compiles its specialisation) {first:.2f} s")  # fmt: skip
    t0 = time.perf_counter()
    simulate(EN02.replace(t_end=0.1))
    first = time.perf_counter() - t0
    stats = SPECIALISATIONS[(EXPLICIT, True, True, False)].stats
    hits = sum(stats.cache_hits.values())
    misses = sum(stats.cache_misses.values())
    print(f"this process: first simulate {first:.3f} s (numba cache hits {hits}, misses {misses})")
    steps = round(EN02.output.t_end / EN02.solver.dt) if not args.quick else 500
    print(f"timed: {repeats} repeats, {steps:,} RK4 steps each; core = compiled loop alone, "
          f"simulate = whole call")  # fmt: skip
    for name, problem in variants.items():
        core_times = []
        evals = 0
        for _ in range(repeats):
            elapsed, evals = core_call(problem)
            core_times.append(elapsed)
        sim_times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            res = simulate(problem)
            sim_times.append(time.perf_counter() - t0)
        med = statistics.median(core_times)
        print(
            f"{name}:\n    core median {med * 1e3:.1f} ms, min {min(core_times) * 1e3:.1f} ms; "
            f"simulate median {statistics.median(sim_times) * 1e3:.1f} ms, "
            f"min {min(sim_times) * 1e3:.1f} ms; {evals} RHS evals, "
            f"{med / evals * 1e9:.0f} ns per RHS eval; status {res.counts.status}"
        )


if __name__ == "__main__":
    main()
