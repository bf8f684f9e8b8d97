"""Where a user's wall time goes beyond the computation: issue 23's before/after table in one run.

Each case runs from a fresh ``git clone`` of this repository's HEAD (this venv, the clone's
sources first on PYTHONPATH), with a new value each time so that something is computed, two
paths interleaved and repeated (median and range printed, with the machine and its load):

* before: one process per job (``CREATIO_WORKER=off``, no forked figures or frames:
  ``CREATIO_FORK=off``), beside the issue's own before figures (its table, as filed);
* now: the shared warm worker of Snakemake's jobs (started on demand by the first invocation,
  kept warm across invocations) and ``creatio worker start`` for ``creatio run``.

Rows: ``creatio run study=en02 sphere.mu=...`` (numba cache warm); the Snakemake override path
for one study; the en02 scene for one new mu; a fresh 40-point EN-02 mu sweep on 2 cores
against its summed core time / 2; ``snakemake all -c 2`` from the fresh clone with the numba
cache cold (then warm, data/ removed), with where its seconds go (compile, imports,
computation and writing, figures, Snakemake's own). Each row says whether issue 23's target
is met.

SLURM's ``scontrol show config`` is run by Snakemake's SLURM plugin at import (where the
plugin is installed: ``make slurm``; the default environment has none); where SLURM is
installed but its daemons are down it waits about 9 s. By default a stand-in ``scontrol``
that fails at once is put first on PATH (as on a machine without SLURM) and the cost is
printed; --keep-slurm measures with the real one.

    python scripts/bench_workflow.py                 # every case, 3 repeats (about 20 min)
    python scripts/bench_workflow.py --repeats 2 --skip-all
    python scripts/bench_workflow.py --only-all      # `snakemake all` cold and warm only
    python scripts/bench_workflow.py --quick         # the planning row only (a smoke test)
"""

from __future__ import annotations

import argparse
import glob
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections import defaultdict
from collections.abc import Callable
from datetime import datetime
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
MODES = ("off", "worker")

PLAN = """
import time
t0 = time.perf_counter()
from creatio.pipeline.planning import plan
plan()
print(time.perf_counter() - t0)
"""

COMPUTE = """
import time
from creatio.pipeline.config import resolve
from creatio.pipeline.run import run_study
r = resolve("en02", ["sphere.mu={mu}"])
names = [p.name for p in r.entry.parts(r.obj)]
for n in names:
    run_study(r, n)
best = []
for _ in range(3):
    t0 = time.perf_counter()
    for n in names:
        run_study(r, n)
    best.append(time.perf_counter() - t0)
print(min(best))
"""

IMPORTS = """
import time
t0 = time.perf_counter()
import numpy, xarray, netCDF4, numba, matplotlib.pyplot, hydra, omegaconf
import creatio.cli, creatio.pipeline.run, creatio.pipeline.provenance
print(time.perf_counter() - t0)
"""

SWEEP_CORE = """
import glob, xarray as xr
print(sum(float(xr.open_dataset(f).attrs["compute_s"])
          for f in glob.glob("data/sweeps/*/batches/*.nc")))
"""


class Clone:
    """A fresh clone of HEAD, run with this venv."""

    def __init__(self, root: Path, numba: Path, path: str) -> None:
        self.root, self.numba, self.path = root, numba, path

    def env(self, mode: str, **extra: str) -> dict[str, str]:
        env = dict(os.environ, PYTHONPATH=str(self.root / "src"),
                   CREATIO_CONF_DIR=str(self.root / "conf"), PATH=self.path,
                   NUMBA_CACHE_DIR=str(self.numba), CREATIO_NUMBA_CACHE=str(self.numba),
                   CREATIO_CONFIG_CACHE="off")
        env.pop("CREATIO_WORKER", None)
        env.pop("CREATIO_FORK", None)
        if mode == "off":  # before: a process per job, figures and frames drawn in order
            env["CREATIO_WORKER"] = "off"
            env["CREATIO_FORK"] = "off"
        env.update(extra)
        return env

    def run(self, args: list[str], mode: str, timeout: float = 1800, check: bool = True,
            **extra: str) -> tuple[float, str]:
        t0 = time.perf_counter()
        proc = subprocess.run(args, cwd=self.root, env=self.env(mode, **extra), timeout=timeout,
                              capture_output=True, text=True)
        dt = time.perf_counter() - t0
        if check and proc.returncode != 0:
            raise RuntimeError(f"{' '.join(args)} failed ({proc.returncode}):\n"
                               f"{proc.stderr[-3000:]}")
        return dt, proc.stdout

    def snakemake(self, mode: str, *args: str, cores: int = 2) -> float:
        return self.run([sys.executable, "-m", "snakemake", "-c", str(cores), *args], mode)[0]

    def python(self, code: str, mode: str = "off") -> float:
        return float(self.run([sys.executable, "-c", code], mode)[1].strip().splitlines()[-1])


def _shim(scratch: Path) -> str:
    """PATH with a stand-in scontrol that fails at once."""
    bin_dir = scratch / "no-slurm"
    bin_dir.mkdir()
    (bin_dir / "scontrol").write_text("#!/bin/sh\nexit 1\n")
    (bin_dir / "scontrol").chmod(0o755)
    return f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}"


def _fmt(values: list[float]) -> str:
    if len(values) == 1:
        return f"{values[0]:.1f} s"
    return f"{statistics.median(values):.1f} s ({min(values):.1f}-{max(values):.1f})"


class Daemon:
    """`creatio worker start` around the worker runs of `creatio run`."""

    def __init__(self, clone: Clone) -> None:
        self.clone = clone

    def __enter__(self) -> Daemon:
        self.clone.run([sys.executable, "-m", "creatio.cli", "worker", "start", "--idle",
                        "600"], "worker")
        return self

    def __exit__(self, *exc: object) -> None:
        self.clone.run([sys.executable, "-m", "creatio.cli", "worker", "stop"], "worker",
                       check=False)


def interleaved(repeats: int, case: Callable[[str, int], float]) -> dict[str, list[float]]:
    """case(mode, i) for each repeat, the modes alternating (off first, then first last)."""
    out: dict[str, list[float]] = {m: [] for m in MODES}
    for i in range(repeats):
        for mode in MODES if i % 2 == 0 else MODES[::-1]:
            out[mode].append(case(mode, i))
    return out


#: Issue 23's table as filed (its "before"), and its targets: (label, before, target).
ISSUE = {
    "run": ("4.0-6.1 s", "overhead <= 1 s"),
    "override": ("15.8 s", "<= 4 s"),
    "scene": ("18.9 s", "<= 5 s"),
    "sweep": ("28.2 s (25x)", "<= 3x core time / 2"),
    "all": ("38.6 s (quiet machine)", "<= 20 s"),
}


class Row:
    """One line of the table."""

    def __init__(self, key: str, name: str) -> None:
        self.key, self.name = key, name
        self.off = self.now = self.inside = self.verdict = ""

    def cells(self) -> list[str]:
        before, target = ISSUE.get(self.key, ("", ""))
        return [self.name, before, self.off, self.now, self.inside, target, self.verdict]


def guarded(rows: list[Row], row: Row, case: Callable[[], dict[str, list[float]]],
            judge: Callable[[dict[str, list[float]]], tuple[str, str]]) -> None:
    """Measure one row (judge gives its computation and verdict); a case that fails is a
    row saying so, and the others run."""
    rows.append(row)
    try:
        r = case()
        print(f"{row.name}: {r}", file=sys.stderr, flush=True)
    except (RuntimeError, subprocess.TimeoutExpired) as e:
        row.off = row.now = "failed"
        row.inside = str(e).splitlines()[0][:200]
        return
    row.off, row.now = _fmt(r["off"]), _fmt(r["worker"])
    row.inside, row.verdict = judge(r)


def _met(ok: bool, why: str = "") -> str:
    return "met" if ok else "missed" + (f" ({why})" if why else "")


def snakemake_log_rules(clone: Clone, since: float) -> dict[str, tuple[int, float]]:
    """Per rule: jobs and summed wall seconds, from the newest Snakemake log after since."""
    logs = sorted(p for p in (clone.root / ".snakemake" / "log").glob("*.snakemake.log")
                  if p.stat().st_mtime >= since)
    if not logs:
        return {}
    started: dict[str, datetime] = {}
    out: dict[str, list[float]] = defaultdict(list)
    stamp = None
    rule = None
    for line in logs[-1].read_text().splitlines():
        if m := re.match(r"\[(\w{3} \w{3} +\d+ [\d:]+ \d{4})\]$", line):
            stamp = datetime.strptime(m.group(1), "%a %b %d %H:%M:%S %Y")
        elif m := re.match(r"(?:local)?rule (\w+):$", line):
            rule = m.group(1)
        elif (m := re.match(r"\s+jobid: (\d+)$", line)) and rule and stamp:
            started[m.group(1)] = stamp
        elif (m := re.match(r"Finished jobid: (\d+) \(Rule: (\w+)\)", line)) and stamp:
            if m.group(1) in started:
                out[m.group(2)].append((stamp - started[m.group(1)]).total_seconds())
    return {k: (len(v), sum(v)) for k, v in out.items()}


#: The floor's Snakefile: one rule whose job runs `true`; at the end, like this workflow
#: (creatio.pipeline.invocation.release_worker), the scheduler's pending re-evaluation timer
#: is cancelled, which the interpreter would otherwise wait up to 1 s for before exiting.
FLOOR = (
    "import threading\n"
    "rule all:\n"
    "    output: 'done'\n"
    "    shell: 'true > {output}'\n"
    "onsuccess:\n"
    "    for thread in threading.enumerate():\n"
    "        if isinstance(thread, threading.Timer):\n"
    "            thread.cancel()\n"
)


def snakemake_floor(clone: Clone, scratch: Path, repeats: int) -> list[float]:
    """Wall time of `snakemake -c 2` on a one-rule Snakefile whose one job runs `true`: what
    any invocation costs before it plans or runs anything of creatio."""
    work = scratch / "floor"
    work.mkdir(exist_ok=True)
    (work / "Snakefile").write_text(FLOOR)
    out = []
    for _ in range(repeats):
        (work / "done").unlink(missing_ok=True)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "snakemake", "-c", "2", "-q"], cwd=work,
                       env=clone.env("off"), capture_output=True, check=True, timeout=300)
        out.append(time.perf_counter() - t0)
    return out


def logged_compute(clone: Clone) -> float:
    """Seconds the dataset jobs say they spent computing and writing ("wrote ... in X s")."""
    total = 0.0
    for log in glob.glob(str(clone.root / "data" / "logs" / "**" / "*.log"), recursive=True):
        for m in re.finditer(r"wrote .* in ([\d.]+) s", Path(log).read_text(errors="replace")):
            total += float(m.group(1))
    return total


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--skip-all", action="store_true", help="leave out `snakemake all` cold")
    ap.add_argument("--keep-slurm", action="store_true", help="the real scontrol on PATH")
    ap.add_argument("--only-all", action="store_true", help="`snakemake all` cold only")
    ap.add_argument("--quick", action="store_true", help="the planning row only")
    args = ap.parse_args()
    loads = [os.getloadavg()]
    rows: list[Row] = []
    notes: list[str] = []
    with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as tmp:
        scratch = Path(tmp)
        path = os.environ.get("PATH", "") if args.keep_slurm else _shim(scratch)
        root = scratch / "clone"
        subprocess.run(["git", "clone", "-q", str(REPO), str(root)], check=True)
        clone = Clone(root, scratch / "numba", path)
        try:
            if args.quick:
                t = clone.snakemake("off", "all", "-n")
                row = Row("", "snakemake all -n (creatio planning inside)")
                row.off, row.now = f"{t:.1f} s", f"({clone.python(PLAN):.2f} s)"
                rows.append(row)
                _print(rows, notes, loads, args)
                return
            _measure(clone, scratch, args, rows, notes, loads)
        finally:
            for mode in ("worker",):  # the shared and daemon workers of the clone stop
                clone.run([sys.executable, "-m", "creatio.cli", "worker", "stop"], mode,
                          check=False)
    _print(rows, notes, loads, args)


def _measure(clone: Clone, scratch: Path, args: argparse.Namespace, rows: list[Row],
             notes: list[str], loads: list[tuple[float, float, float]]) -> None:
    root = clone.root
    if shutil.which("scontrol") and not args.keep_slurm:
        t0 = time.perf_counter()
        subprocess.run(["scontrol", "show", "config"], capture_output=True, timeout=120)
        notes.append(f"`scontrol show config` (run by Snakemake's SLURM plugin at import) "
                     f"took {time.perf_counter() - t0:.1f} s here: a stand-in that fails "
                     "at once was first on PATH for every row")
    imports = clone.python(IMPORTS)
    notes.append(f"imports of one job's process (numpy, xarray, netCDF4, numba, "
                 f"matplotlib, hydra, creatio): {imports:.2f} s")
    floor = snakemake_floor(clone, scratch, max(3, args.repeats))
    notes.append(f"Snakemake's own floor, a Snakefile of one rule whose one job runs `true` "
                 f"and that cancels the scheduler's timer at the end as this workflow does "
                 f"(`snakemake -c 2`, same environment): {_fmt(floor)}; every Snakemake row "
                 "pays it once per invocation")

    if not args.skip_all:  # first: the clone is fresh and the cache cold
        row = Row("all", "`snakemake all -c 2`, fresh clone, numba cache cold")
        rows.append(row)
        cold: dict[str, float] = {}
        for mode in MODES:
            cache = scratch / f"numba-cold-{mode}"
            clone.numba = cache
            shutil.rmtree(root / "data", ignore_errors=True)
            clone.run([sys.executable, "-m", "creatio.cli", "worker", "stop"], "worker",
                      check=False)  # the worker starts cold too
            t0 = time.time()
            cold[mode] = clone.snakemake(mode, "all")
            loads.append(os.getloadavg())
            shutil.rmtree(root / "data")
            t1 = time.time()
            warm = clone.snakemake(mode, "all")
            per_rule = snakemake_log_rules(clone, t1)
            computed = logged_compute(clone)
            jobs = sum(n for n, _ in per_rule.values())
            figures = sum(s for k, (_, s) in per_rule.items()
                          if k.endswith("report") or k == "compare")
            datasets = per_rule.get("study_dataset", (0, 0.0))[1]
            where = (f"~{imports * jobs:.0f} s of imports ({jobs} job processes x "
                     f"{imports:.2f} s)" if mode == "off"
                     else "imports once, in the worker, while Snakemake plans")
            notes.append(
                f"all ({'before' if mode == 'off' else 'now'}): cold {cold[mode]:.1f} s, "
                f"warm (data/ removed) {warm:.1f} s; compile = cold - warm = "
                f"{cold[mode] - warm:.1f} s; {jobs} jobs; warm run's job seconds (summed "
                f"over 2 cores): dataset jobs {datasets:.1f} s of which computing and "
                f"writing {computed:.1f} s, report and comparison jobs (figures) "
                f"{figures:.1f} s; {where}; Snakemake's own start, planning and end: the "
                f"rest of the wall time (`snakemake -n` of a built tree: "
                f"{clone.snakemake(mode, 'all', '-n'):.1f} s)")
        row.off, row.now = f"{cold['off']:.1f} s", f"{cold['worker']:.1f} s"
        row.inside = "compile, computation, figures: see below"
        row.verdict = _met(cold["worker"] <= 20.0, "see where the seconds go below")
        clone.numba = scratch / "numba-cold-worker"
        if args.only_all:
            return
    else:
        clone.numba = scratch / "numba"
        clone.snakemake("off", "all")  # compile once

    compute = clone.python(COMPUTE.format(mu=0.3))
    run = [sys.executable, "-m", "creatio.cli", "run", "study=en02"]
    with Daemon(clone):  # started once, as a user would; its first job is not counted

        def creatio_run(mode: str, i: int) -> float:
            mu = 0.3 + 0.001 * (2 * i + (mode == "worker"))
            return clone.run([*run, f"sphere.mu={mu}"], mode)[0]

        clone.run([*run, "sphere.mu=0.299"], "worker")
        guarded(rows, Row("run", "`creatio run study=en02 sphere.mu=...` (numba cache warm; "
                                 "now: `creatio worker start` daemon)"),
                lambda: interleaved(args.repeats, creatio_run),
                lambda r: (f"two runs {compute:.2f} s",
                           _met(statistics.median(r["worker"]) - compute <= 1.0,
                                f"overhead {statistics.median(r['worker']) - compute:.1f} s")))
    loads.append(os.getloadavg())

    def override(mode: str, i: int) -> float:
        mu = 0.31 + 0.001 * (2 * i + (mode == "worker"))
        return clone.snakemake(mode, "all", "--config", f'overrides=["sphere.mu={mu}"]',
                               'studies=["en02"]')

    clone.run([sys.executable, "-m", "creatio.cli", "worker", "stop"], "worker", check=False)
    try:  # the first invocation starts the shared worker
        first = clone.snakemake("worker", "all", "--config", 'overrides=["sphere.mu=0.3099"]',
                                'studies=["en02"]')
        notes.append(f"override path, the first invocation (it starts the shared worker, "
                     f"which warms up while Snakemake plans): {first:.1f} s")
    except (RuntimeError, subprocess.TimeoutExpired) as e:
        notes.append(f"override path, the first invocation failed: {str(e).splitlines()[0]}")
    guarded(rows, Row("override", "`snakemake all --config 'overrides=[\"sphere.mu=...\"]' "
                                  "'studies=[\"en02\"]'`"),
            lambda: interleaved(args.repeats, override),
            lambda r: (f"two runs {compute:.2f} s",
                       _met(statistics.median(r["worker"]) <= 4.0)))
    loads.append(os.getloadavg())

    def scene(mode: str, i: int) -> float:
        mu = 0.21 + 0.001 * (2 * i + (mode == "worker"))
        return clone.snakemake(mode, "scenes", "--config", f'overrides=["sphere.mu={mu}"]',
                               'scenes=["en02"]')

    def scenes() -> dict[str, list[float]]:
        clone.snakemake("worker", "scenes", "--config", 'scenes=["en02"]')  # library, family
        return interleaved(args.repeats, scene)

    media: list[float] = []

    def scene_judge(r: dict[str, list[float]]) -> tuple[str, str]:
        for tsv in glob.glob(str(root / "data" / "runs" / "*" / "logs" / "scenes" /
                                 "en02_media.tsv")):
            media.append(float(Path(tsv).read_text().splitlines()[1].split()[0]))
        inside = (f"animation + poster job {statistics.median(media):.1f} s (median)"
                  if media else "")
        return inside, _met(statistics.median(r["worker"]) <= 5.0,
                            "the animation job alone is longer" if media and
                            statistics.median(media) > 5.0 else "")

    guarded(rows, Row("scene", "the en02 scene for one new mu (`snakemake scenes --config "
                               "'overrides=[...]' 'scenes=[\"en02\"]'`)"), scenes, scene_judge)
    loads.append(os.getloadavg())

    cores: dict[str, list[float]] = {m: [] for m in MODES}

    def sweep(mode: str, i: int) -> float:
        lo = 0.0001 * (1 + 2 * i + (mode == "worker"))
        shutil.rmtree(root / "data" / "sweeps", ignore_errors=True)
        t = clone.snakemake(mode, "sweep", "--config", "study=en02",
                            f'sweep=["sphere.mu=range({lo},{lo + 0.4},0.01)"]')
        cores[mode].append(clone.python(SWEEP_CORE))
        return t

    def sweep_judge(r: dict[str, list[float]]) -> tuple[str, str]:
        # the warm runs' core time: a process per job times its first point with the
        # compiled loop's loading from numba's cache inside (about 0.5 s a batch here)
        half = statistics.median(cores["worker"]) / 2
        ratio = statistics.median(r["worker"]) / half
        return (f"core time / 2: {half:.2f} s (before's own: "
                f"{statistics.median(cores['off']) / 2:.2f} s, compiled code loaded inside); "
                f"now {ratio:.1f}x, before {statistics.median(r['off']) / half:.1f}x",
                _met(ratio <= 3.0))

    guarded(rows, Row("sweep", "a fresh 40-point EN-02 mu sweep, `snakemake sweep -c 2`"),
            lambda: interleaved(args.repeats, sweep), sweep_judge)
    loads.append(os.getloadavg())


def _print(rows: list[Row], notes: list[str], loads: list[tuple[float, float, float]],
           args: argparse.Namespace) -> None:
    loads = [*loads, os.getloadavg()]
    ones = [f"{x[0]:.1f}" for x in loads]
    print(f"machine: {platform.platform()}, {os.cpu_count()} cores, python "
          f"{platform.python_version()}; load average (1 min) at start, after each case and "
          f"at end: {' '.join(ones)}; repeats {args.repeats}, median (min-max); before and "
          "now interleaved")
    print("| what a user runs | issue 23's before (as filed) | before: a process per job "
          "(CREATIO_WORKER=off) | now: warm worker | computation inside | target | |")
    print("|---|---|---|---|---|---|---|")
    for row in rows:
        print("| " + " | ".join(row.cells()) + " |")
    for note in notes:
        print(f"* {note}")


if __name__ == "__main__":
    main()
