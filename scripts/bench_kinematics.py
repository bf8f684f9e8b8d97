"""Time the CT-02 and EN-01 dataset computations (config in, xarray.Dataset out).

Usage: .venv/bin/python scripts/bench_kinematics.py [REPEATS] [--quick]
Reports the median and minimum over REPEATS (default 7) after one warm-up run, with the
machine, so ratios can be compared within one run on a noisy machine. --quick: one repeat
(checks the script runs, measures nothing worth keeping).
"""

from __future__ import annotations

import os
import platform
import statistics
import sys
import time

import numpy as np

from creatio.pipeline.config import resolve
from creatio.pipeline.run import run_study


def main() -> None:
    """Warm up, then time each kinematic study REPEATS times."""
    args = [a for a in sys.argv[1:] if a != "--quick"]
    repeats = 1 if "--quick" in sys.argv[1:] else int(args[0]) if args else 7
    print(f"platform: {platform.platform()}; cpu count: {os.cpu_count()}; "
          f"python {platform.python_version()}, numpy {np.__version__}")
    for study in ("ct02", "en01"):
        resolved = resolve(study)
        run_study(resolved)  # warm-up (imports, caches)
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            run_study(resolved)
            times.append(time.perf_counter() - t0)
        print(f"{study}: median {statistics.median(times):.3f} s, min {min(times):.3f} s "
              f"over {repeats} runs")


if __name__ == "__main__":
    main()
