"""Measure the Jacobian reuse threshold of the radau_high_order methods (radau.f's THET) on EN-02
and EN-02R: each method at thet 1e-3 (radau.f's default) and 0.1 (Hairer's advice when a
Jacobian is costly), or those of --thet, over tolerances, with grid-cut and dense-output
steps.

Prints one row per run: error against a dop853 rtol 1e-13 reference (m), steps, rhs
evaluations, Jacobians, LU decompositions, Newton iterations, rejections, and the core time
(min over interleaved repeats, ms). ``./.venv/bin/python scripts/radau_thet.py [--repeats N]``
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

from creatio.dynamics import simulate
from creatio.dynamics.layout import COL_X
from creatio.dynamics.simulation import _run_arguments
from creatio.dynamics.solvers import METHODS
from creatio.dynamics.solvers.driver import run
from creatio.dynamics.solvers.radau_high_order import PRM_THET
from creatio.pipeline.config import resolve


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--studies", default="en02,en02r")
    ap.add_argument("--methods", default="radau9,radau13,radau")
    ap.add_argument("--rtol", default="1e-8,1e-10,1e-12")
    ap.add_argument("--thet", default="1e-3,0.1")
    ap.add_argument("--dense", default="false,true")
    args = ap.parse_args()
    print("study method thet dense rtol error_m steps rhs jac lu newton rejected ms")
    for study in args.studies.split(","):
        base = resolve(study, []).obj.sphere_problem().replace(energy=False)
        ref = simulate(base.replace(method="dop853", rtol=1e-13, atol=1e-15,
                                    fixed_step=False)).histories.X
        calls = []
        for name in args.methods.split(","):
            for thet in (float(v) for v in args.thet.split(",")):
                params = list(METHODS[name].params)
                params[PRM_THET] = thet
                method = dataclasses.replace(METHODS[name], params=tuple(params))
                for dense in (v == "true" for v in args.dense.split(",")):
                    for rtol in (float(v) for v in args.rtol.split(",")):
                        prob = base.replace(method=name, rtol=rtol, atol=rtol * 0.01,
                                            fixed_step=False, dense_output=dense)
                        a, kw = _run_arguments(prob)
                        a = (method, *a[1:])
                        calls.append(((study, name, thet, dense, rtol), a, kw))
        results = {}
        times = {k: [] for k, _, _ in calls}
        for k, a, kw in calls:
            out = a[4]
            res = run(*a, **kw)
            rows = int(res[2])
            X = out[:rows, COL_X:COL_X + 3].copy()
            results[k] = (res, X)
        for _ in range(args.repeats):
            for k, a, kw in calls:
                t0 = time.perf_counter()
                run(*a, **kw)
                times[k].append(time.perf_counter() - t0)
        for k, _, _ in calls:
            res, X = results[k]
            status, steps, rows, evals, ext, rej, jac, lu, t, newton = res
            err = (float(np.linalg.norm(X - ref, axis=1).max()) if X.shape == ref.shape
                   else float("inf"))
            print(*k, f"{err:.3g}", steps, evals, jac, lu, newton, rej,
                  f"{1e3 * min(times[k]):.2f}", flush=True)


if __name__ == "__main__":
    main()
