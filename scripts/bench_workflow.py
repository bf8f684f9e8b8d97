"""Where a user's wall time goes, here and at another git revision, measured in one run.

For each case the same command runs against this tree and against the other revision (its
tree exported with ``git archive`` into a temporary directory and run with this venv), one
after the other, in fresh working directories:

* ``snakemake all -n`` (and the seconds spent in creatio's planning, timed in-process);
* a no-op ``snakemake all -c 2`` (every output present);
* one dataset job (``creatio task dataset ct02``) against the computation inside it;
* ``snakemake all -c 2`` from an empty data/, with numba's cache cold and warm;
* a sweep of 12 EN-02 points on one core, through Snakemake and in one process;
* the dry run of a 10^5-point sweep (given up after --timeout seconds);
* with --big: a 1,000-point EN-02 mu x T sweep (trajectory outputs) on 2 cores, against its
  summed core time (this tree only: the other would run 1,000 jobs).

    python scripts/bench_workflow.py              # against bdffec5 (before the rework)
    python scripts/bench_workflow.py HEAD~3 --big --timeout 120
    python scripts/bench_workflow.py HEAD --quick   # the planning row only (a smoke test)
"""

from __future__ import annotations

import argparse
import os
import platform
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SWEEP12 = ['sweep=["sphere.mu=0,0.05,0.1,0.15","study.initial.R=0.43,0.5,0.6"]', "study=en02"]
SWEEP1E5 = ['sweep=["sphere.mu=range(0,500)","phases.T=range(1,201)"]', "study=en02"]
SWEEP1K = ['sweep=["sphere.mu=range(0,0.3,0.012)","phases.T=range(20,120,2.5)"]',
           "study=en02", 'overrides=["study.outputs=[trajectory]"]']


class Tree:
    """A source tree to run: this one, or an exported revision."""

    def __init__(self, label: str, root: Path, cache: Path) -> None:
        self.label, self.root, self.cache = label, root, cache

    def env(self, numba_cache: Path | None = None) -> dict[str, str]:
        env = dict(os.environ, PYTHONPATH=str(self.root / "src"),
                   CREATIO_CONF_DIR=str(self.root / "conf"))
        env["NUMBA_CACHE_DIR"] = str(numba_cache or self.cache / "numba")
        env["CREATIO_NUMBA_CACHE"] = str(numba_cache or self.cache / "numba")
        env["CREATIO_CONFIG_CACHE"] = str(self.cache / "configs")
        return env

    def run(self, args: list[str], cwd: Path, timeout: float, numba_cache: Path | None = None
            ) -> tuple[float, int]:
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(args, cwd=cwd, env=self.env(numba_cache), timeout=timeout,
                                  capture_output=True, text=True)
            code = proc.returncode
        except subprocess.TimeoutExpired:
            return float("inf"), -1
        return time.perf_counter() - t0, code

    def snakemake(self, work: Path, *args: str, cores: int = 2, timeout: float = 1800,
                  numba_cache: Path | None = None) -> tuple[float, int]:
        cmd = [sys.executable, "-m", "snakemake", "-s", str(self.root / "Snakefile"), "-d",
               str(work), "-c", str(cores), *args]
        return self.run(cmd, work, timeout, numba_cache)

    def python(self, code: str, cwd: Path, timeout: float = 600) -> str:
        out = subprocess.run([sys.executable, "-c", code], cwd=cwd, env=self.env(),
                             timeout=timeout, capture_output=True, text=True, check=True)
        return out.stdout.strip()


def export(revision: str, into: Path) -> Path:
    """The whole tree of a git revision under into/then."""
    data = subprocess.run(["git", "archive", revision], cwd=REPO, capture_output=True,
                          check=True).stdout
    (into / "then.tar").write_bytes(data)
    root = into / "then"
    root.mkdir()
    with tarfile.open(into / "then.tar") as tar:
        tar.extractall(root, filter="data")
    return root


PLAN = """
import time
t0 = time.perf_counter()
try:
    from creatio.pipeline.planning import plan
except ImportError:
    from creatio.workflow import plan
plan()
print(time.perf_counter() - t0)
"""

ONE_PROCESS = """
import time
t0 = time.perf_counter()
try:
    from creatio.pipeline.sweep import plan_sweep, write_sweep
    write_sweep(plan_sweep("en02", {sweep}, [], data_dir="data", batch_size=12),
                compute_missing=True)
except ImportError:
    from creatio.config import resolve
    from creatio.studies import run_study
    from creatio.sweep import plan_sweep
    for p in plan_sweep("en02", {sweep}, []).points:
        run_study(p.resolved)
print(time.perf_counter() - t0)
"""

COMPUTE = """
import time
try:
    from creatio.pipeline.config import resolve
    from creatio.pipeline.run import run_study
except ImportError:
    from creatio.config import resolve
    from creatio.studies import run_study
r = resolve("ct02")
run_study(r)
t0 = time.perf_counter(); run_study(r); print(time.perf_counter() - t0)
"""


def measure(tree: Tree, scratch: Path, args: argparse.Namespace) -> dict[str, str]:
    """Every case for one tree (with --quick, the planning row alone); values are formatted
    seconds (or a note)."""
    out: dict[str, str] = {}
    work = scratch / f"{tree.label}-all"
    work.mkdir()
    cold = scratch / f"{tree.label}-numba-cold"
    if args.quick:
        t, _ = tree.snakemake(work, "all", "-n", numba_cache=cold)
        creatio = float(tree.python(PLAN, work))
        out["snakemake all -n (creatio planning inside)"] = f"{t:.1f} s ({creatio:.2f} s)"
        return out
    t, code = tree.snakemake(work, "all", numba_cache=cold)
    out["snakemake all -c 2, numba cache cold"] = f"{t:.1f} s" + ("" if code == 0 else " (failed)")
    shutil.rmtree(work / "data")
    t, _ = tree.snakemake(work, "all", numba_cache=cold)
    out["snakemake all -c 2, numba cache warm, data/ removed"] = f"{t:.1f} s"
    t, _ = tree.snakemake(work, "all", numba_cache=cold)
    out["snakemake all with nothing to do"] = f"{t:.1f} s"
    t, _ = tree.snakemake(work, "all", "-n", numba_cache=cold)
    creatio = float(tree.python(PLAN, work))
    out["snakemake all -n (creatio planning inside)"] = f"{t:.1f} s ({creatio:.2f} s)"
    job = [sys.executable, "-m", "creatio.cli", "task", "dataset", "ct02", "x.nc"]
    t, _ = tree.run(job, work, 300, cold)
    compute = float(tree.python(COMPUTE, work))
    out["one dataset job (ct02) (computation inside)"] = f"{t:.1f} s ({compute:.2f} s)"
    sweep = scratch / f"{tree.label}-sweep12"
    sweep.mkdir()
    t, _ = tree.snakemake(sweep, "sweep", "--config", *SWEEP12, cores=1, numba_cache=cold)
    out["snakemake sweep of 12 EN-02 points, one core"] = f"{t:.1f} s"
    one = scratch / f"{tree.label}-one"
    one.mkdir()
    axes = '["sphere.mu=0,0.05,0.1,0.15", "study.initial.R=0.43,0.5,0.6"]'
    out["the same 12 points in one process"] = (
        f"{float(tree.python(ONE_PROCESS.format(sweep=axes), one)):.1f} s")
    big = scratch / f"{tree.label}-1e5"
    big.mkdir()
    t, code = tree.snakemake(big, "sweep", "-n", "--config", *SWEEP1E5, timeout=args.timeout,
                             numba_cache=cold)
    out["dry run of a sweep of 10^5 points"] = (
        f"> {args.timeout:.0f} s (given up)" if code == -1 else f"{t:.1f} s")
    return out


def main() -> None:
    """Export the other revision, measure both trees, print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("revision", nargs="?", default="bdffec5")
    parser.add_argument("--timeout", type=float, default=60.0,
                        help="seconds before a dry run of the 10^5-point sweep is given up")
    parser.add_argument("--big", action="store_true",
                        help="also the 1,000-point sweep on 2 cores (this tree; minutes)")
    parser.add_argument("--quick", action="store_true",
                        help="the planning row only: checks the script runs")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        scratch = Path(tmp)
        now = Tree("now", REPO, scratch / "now-cache")
        then = Tree(f"then {args.revision}", export(args.revision, scratch), scratch / "then")
        then.label = "then"
        rows = {"now": measure(now, scratch, args), "then": measure(then, scratch, args)}
        if args.big:
            work = scratch / "now-1k"
            work.mkdir()
            t, _ = now.snakemake(work, "sweep", "--config", *SWEEP1K)
            core = float(now.python(
                "import glob, xarray as xr; print(sum(xr.open_dataset(f).attrs['compute_s'] "
                "for f in glob.glob('data/sweeps/*/batches/*.nc')))", work))
            rows["now"]["1,000-point EN-02 mu x T sweep, 2 cores (core time / 2)"] = (
                f"{t:.1f} s ({core / 2:.1f} s)")
            rows["then"]["1,000-point EN-02 mu x T sweep, 2 cores (core time / 2)"] = "not run"
    print(f"machine: {platform.platform()}, {os.cpu_count()} cores, python "
          f"{platform.python_version()}")
    print(f"| what a user runs | then ({args.revision}) | now |")
    print("|---|---|---|")
    for key in rows["now"]:
        print(f"| {key} | {rows['then'].get(key, '')} | {rows['now'][key]} |")


if __name__ == "__main__":
    main()
