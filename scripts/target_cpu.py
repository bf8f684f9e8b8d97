"""The CPU time a Snakemake target costs, the warm worker's included: what `snakemake TARGET`
spends in every process, its jobs forked from the shared worker too.

`/usr/bin/time snakemake ...` counts only the invocation's own process tree: with the shared
warm worker (the default), the jobs run in that worker, a daemon that outlives the
invocation, so their CPU is not counted there. This script stops this checkout's workers
(so the run starts its own and its warm-up is counted), removes the given paths (a point
store is reused across runs by config hash, so a fresh sample must be removed to be
computed), runs `snakemake TARGET -c CORES --forceall`, and adds the invocation tree's CPU
(getrusage of the children) to the worker's own and its reaped jobs' (/proc/PID/stat), read
before the worker is stopped. With --off every job runs in its own process
(CREATIO_WORKER=off) and the tree holds everything. Repeats alternate the two modes when
both are asked; the machine's load is printed beside each run.

    python scripts/target_cpu.py en05 --remove data/sweeps/en05          # the warm worker
    python scripts/target_cpu.py en05 --remove data/sweeps/en05 --off --worker --repeats 2
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
BIN = Path(sys.executable).parent


def _worker_pids() -> list[int]:
    """The pids of this checkout's running workers (`creatio worker status`)."""
    out = subprocess.run([str(BIN / "creatio"), "worker", "status"], cwd=REPO,
                         capture_output=True, text=True).stdout
    return [int(pid) for pid in re.findall(r"\bpid (\d+)", out)]


def _proc_cpu(pid: int) -> tuple[float, float]:
    """(the process's own CPU seconds, its reaped children's) from /proc/PID/stat."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    tick = os.sysconf("SC_CLK_TCK")
    # after the state field: utime, stime, cutime, cstime are fields 14-17 of the line
    utime, stime, cutime, cstime = (int(x) for x in fields[11:15])
    return (utime + stime) / tick, (cutime + cstime) / tick


def _stop_workers() -> None:
    subprocess.run([str(BIN / "creatio"), "worker", "stop"], cwd=REPO, capture_output=True)
    deadline = time.monotonic() + 30.0
    while _worker_pids() and time.monotonic() < deadline:
        time.sleep(0.2)


def run_once(target: str, cores: int, remove: list[str], off: bool) -> dict[str, float]:
    """One measured run of the target (see the module docstring)."""
    _stop_workers()
    for path in remove:
        p = REPO / path
        if p.is_dir():
            shutil.rmtree(p)
        elif p.exists():
            p.unlink()
    env = {k: v for k, v in os.environ.items() if k != "CREATIO_WORKER"}
    if off:
        env["CREATIO_WORKER"] = "off"
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    proc = subprocess.run([str(BIN / "snakemake"), target, "-c", str(cores), "--forceall"],
                          cwd=REPO, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"target_cpu: snakemake {target} failed ({proc.returncode}):\n"
                 + proc.stderr[-2000:])
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    tree = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    own = jobs = 0.0
    for pid in ([] if off else _worker_pids()):
        a, b = _proc_cpu(pid)
        own, jobs = own + a, jobs + b
    _stop_workers()
    return {"wall": wall, "tree": tree, "worker": own, "jobs": jobs,
            "cpu": tree + own + jobs, "load": load}


def main(argv: list[str] | None = None) -> int:
    """Measure, print one line per run and a median line per mode."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("target", help="a Snakemake target (rule or file), e.g. en05")
    ap.add_argument("--cores", type=int, default=2)
    ap.add_argument("--remove", nargs="*", default=[],
                    help="paths (relative to the checkout) removed before each run")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--off", action="store_true", help="measure CREATIO_WORKER=off")
    ap.add_argument("--worker", action="store_true",
                    help="measure the shared worker (the default when --off is not given)")
    args = ap.parse_args(argv)
    modes = [m for m, on in (("worker", args.worker or not args.off), ("off", args.off)) if on]
    print(f"machine: {os.cpu_count()} cores, {sys.platform}; target {args.target}, "
          f"-c {args.cores}, --forceall, removed first: {args.remove or 'nothing'}")
    results: dict[str, list[dict[str, float]]] = {m: [] for m in modes}
    for i in range(args.repeats):
        for mode in modes:
            r = run_once(args.target, args.cores, args.remove, mode == "off")
            results[mode].append(r)
            print(f"{mode:6s} run {i + 1}: CPU {r['cpu']:.1f} s (invocation tree {r['tree']:.1f}, "
                  f"worker {r['worker']:.1f}, its jobs {r['jobs']:.1f}), wall {r['wall']:.1f} s, "
                  f"load {r['load']:.2f}", flush=True)
    for mode, rs in results.items():
        cpu = [r["cpu"] for r in rs]
        print(f"{mode:6s} median CPU {statistics.median(cpu):.1f} s (range {min(cpu):.1f}-"
              f"{max(cpu):.1f}), median wall {statistics.median(r['wall'] for r in rs):.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
