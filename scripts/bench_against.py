"""Core time of EN-02 (and other study defaults) here against another git revision, in one run.

The other revision's package is exported (``git archive``) into a temporary directory under
the name ``creatio_then``, so both versions load in this one process; their compiled cores
are then called round-robin (then, now, then, now, ...) so that both see the same machine
state. Printed per case: median and minimum of each, and the median and range of the paired
ratios now / then. With --control the other revision is loaded a second time, as
``creatio_control``, and timed in the same rounds: its ratio to then is the bench's own bias
for that case (the same code under another name and place in memory: 1.05 for en02:radau5,
40 rounds of CPU time), against which now / then is read. Use it to check that a change
keeps the core as fast as before:

    python scripts/bench_against.py                  # against the revision before HEAD
    python scripts/bench_against.py bdffec5 --repeats 15 --cases en02:rk4,en02:radau5
    python scripts/bench_against.py HEAD --cases en02:radau5@0.05   # radau5 at a fixed 0.05 s
    python scripts/bench_against.py HEAD --quick     # one round of en02:rk4 (a smoke test)
    python scripts/bench_against.py ee38bd5 --repeats 40 --cases en02:radau5 --control
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import os
import platform
import re
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def export(revision: str, into: Path, name: str = "creatio_then") -> Path:
    """The package of a git revision as `name` under into (imports rewritten), and its conf/
    beside it."""
    archive = subprocess.run(["git", "archive", revision, "src/creatio", "conf"], cwd=REPO,
                             capture_output=True, check=True).stdout
    tmp = into / "archive.tar"
    tmp.write_bytes(archive)
    with tarfile.open(tmp) as tar:
        tar.extractall(into, filter="data")
    src = into / "src" / "creatio"
    dst = into / name
    src.rename(dst)
    for path in dst.rglob("*.py"):
        text = path.read_text()
        text = re.sub(r"\bcreatio\.", f"{name}.", text)
        text = re.sub(r"^from creatio import", f"from {name} import", text, flags=re.M)
        text = re.sub(r"^import creatio$", f"import {name} as creatio", text, flags=re.M)
        path.write_text(text)
    return dst


def compiled_call(pkg: str, study: str, method: str) -> Callable[[], object]:
    """A zero-argument call of the compiled core of a study's default problem in package pkg,
    through the API of either side: a problem split into records (SphereProblem.replace,
    creatio.dynamics.compiled_call) or a flat one (dataclasses.replace, its compiled_call)."""
    dyn = importlib.import_module(f"{pkg}.dynamics")
    resolve = importlib.import_module(f"{pkg}.pipeline.config").resolve
    name, _, fixed_dt = method.partition("@")
    changes: dict[str, object] = {"method": name}
    if fixed_dt:  # "radau5@0.05": a fixed step of 0.05 s
        changes |= {"dt": float(fixed_dt), "fixed_step": dyn.METHODS[name].adaptive}
    problem = resolve(study).obj.sphere_problem()
    if hasattr(problem, "replace"):
        return dyn.compiled_call(problem.replace(**changes))
    return dataclasses.replace(problem, **changes).compiled_call()


def main() -> None:
    """Export the other revision, warm both up, time them round-robin, print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("revision", nargs="?", default="HEAD~1",
                        help="git revision to compare with (default HEAD~1)")
    parser.add_argument("--repeats", type=int, default=12, help="rounds (default 12)")
    parser.add_argument("--cases", default="en02:rk4,en02:radau5",
                        help="study:method pairs, method@dt for a fixed step (default "
                             "en02:rk4,en02:radau5)")
    parser.add_argument("--quick", action="store_true",
                        help="one round of en02:rk4: checks the script runs, measures nothing")
    parser.add_argument("--control", action="store_true",
                        help="time the other revision twice (then, control): control / then "
                             "is the bench's own bias")
    args = parser.parse_args()
    if args.quick:
        args.repeats, args.cases = 1, "en02:rk4"
    cases = [tuple(c.split(":")) for c in args.cases.split(",")]
    rev = subprocess.run(["git", "rev-parse", "--short", args.revision], cwd=REPO,
                         capture_output=True, text=True, check=True).stdout.strip()
    sides = ["then", "now", *(["control"] if args.control else [])]
    with tempfile.TemporaryDirectory() as tmp:
        export(args.revision, Path(tmp))
        if args.control:
            # a second copy in its own directory (its conf/ beside it, as the first's)
            (Path(tmp) / "control").mkdir()
            export(args.revision, Path(tmp) / "control", "creatio_control")
            sys.path.insert(0, str(Path(tmp) / "control"))
        sys.path.insert(0, tmp)
        importlib.import_module("creatio.pipeline.config")  # reads conf/ of this tree first
        os.environ["CREATIO_CONF_DIR"] = str(Path(tmp) / "conf")
        os.environ.setdefault("NUMBA_CACHE_DIR", str(Path(tmp) / "numba-then"))
        calls = {}
        for study, method in cases:
            calls[(study, method, "then")] = compiled_call("creatio_then", study, method)
            calls[(study, method, "now")] = compiled_call("creatio", study, method)
            if args.control:
                calls[(study, method, "control")] = compiled_call("creatio_control", study,
                                                                  method)
        for call in calls.values():
            call()  # compile or load from cache, outside the timing
        times: dict[tuple, list[float]] = {k: [] for k in calls}
        for _ in range(args.repeats):
            for key, call in calls.items():
                t0 = time.perf_counter()
                call()
                times[key].append(time.perf_counter() - t0)
    print(f"machine: {platform.platform()}, {os.cpu_count()} cores, python "
          f"{platform.python_version()}; {args.repeats} rounds, round-robin")
    print(f"{'case':16s} {'then ' + rev:>24s} {'now':>24s}   now/then (paired)")
    for study, method in cases:
        then = times[(study, method, "then")]
        for side in sides[1:]:
            now = times[(study, method, side)]
            ratios = sorted(b / a for a, b in zip(then, now, strict=True))
            label = study + ":" + method + ("" if side == "now" else f" ({side})")
            print(f"{label:16s} "
                  f"med {statistics.median(then) * 1e3:7.2f} min {min(then) * 1e3:7.2f} ms "
                  f"med {statistics.median(now) * 1e3:7.2f} min {min(now) * 1e3:7.2f} ms   "
                  f"median {statistics.median(ratios):.3f} "
                  f"(range {ratios[0]:.3f}-{ratios[-1]:.3f})")


if __name__ == "__main__":
    main()
