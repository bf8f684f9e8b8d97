"""Work of Radau IIA at 3, 5, 7 stages and variable order on standalone problems (issue 26).

Counts, not times: steps, right-hand-side calls, Jacobians, real and complex LU
factorisations, Newton iterations, rejected steps and the steps taken at each stage count,
with the error against an exact or doubly computed reference, for rtol = atol = 1e-6 ...
1e-12 (atol 1e-3 rtol on the linear system). Problems:

* vdp: Van der Pol at mu = 1000 in Hairer's scaling (eps = 1e-6, t in [0, 2]), the
  reference from 7 and from 5 stages at 1e-14 (they agree to 1e-14);
* linear: y' = A (y - g(t)) + g'(t), eigenvalues -1, -1e3, -1e6, exact solution;
* oscillator: y = (sin 10t, cos 10t) with a weak quadratic nonlinearity, non-stiff, exact.

scipy's Radau (an independent implementation of the 3-stage method, rtol applied to its
estimate as given, where radau.f, and so these steppers, transform it) is listed beside.
Every Jacobian is a forward difference (n right-hand-side calls, counted), as in scipy.

    python scripts/radau_orders.py            # prints a markdown table
    python scripts/radau_orders.py --no-scipy
    python scripts/radau_orders.py --quick    # rtol 1e-6 only, no scipy (a smoke test)
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np
from numba import njit
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from creatio.dynamics.solvers import radau_variable_order as rv

RTOLS = (1e-6, 1e-8, 1e-10, 1e-12)
METHODS = ((3, 3), (5, 5), (7, 7), (3, 7))


@njit(cache=True)
def _vdp_rhs(t, y, out, ctx):
    eps = ctx[0]
    out[0] = y[1]
    out[1] = ((1.0 - y[0] * y[0]) * y[1] - y[0]) / eps


@njit(cache=True)
def _vdp(ctx, y0, t_end, rtol, atol, s_min, s_max, td):
    return rv.solve(_vdp_rhs, None, ctx, 0.0, y0, t_end, 1e-6, rtol, atol, s_min, s_max,
                    s_min, False, 1000000, td)


@njit(cache=True)
def _lin_rhs(t, y, out, ctx):
    a = ctx[0]
    g0 = math.sin(t)
    g1 = math.cos(2.0 * t)
    g2 = math.exp(-0.5 * t)
    d = (math.cos(t), -2.0 * math.sin(2.0 * t), -0.5 * g2)
    for i in range(3):
        out[i] = d[i] + a[i, 0] * (y[0] - g0) + a[i, 1] * (y[1] - g1) + a[i, 2] * (y[2] - g2)


@njit(cache=True)
def _lin(ctx, y0, t_end, rtol, atol, s_min, s_max, td):
    return rv.solve(_lin_rhs, None, ctx, 0.0, y0, t_end, 1e-6, rtol, atol, s_min, s_max, s_min,
                    False, 1000000, td)


@njit(cache=True)
def _osc_rhs(t, y, out, ctx):
    e, w = ctx
    s = math.sin(w * t)
    c = math.cos(w * t)
    out[0] = w * y[1] + e * (y[1] * y[1] - c * c)
    out[1] = -w * y[0] + e * (y[0] * y[0] - s * s)


@njit(cache=True)
def _osc(ctx, y0, t_end, rtol, atol, s_min, s_max, td):
    return rv.solve(_osc_rhs, None, ctx, 0.0, y0, t_end, 1e-3, rtol, atol, s_min, s_max, s_min,
                    False, 1000000, td)


def problems() -> dict:
    """name -> (runner, ctx, y0, check times (the last is the end), reference at them,
    atol / rtol, the right-hand side for scipy)."""
    q, _ = np.linalg.qr(np.random.default_rng(3).normal(size=(3, 3)))
    a = q @ np.diag([-1.0, -1e3, -1e6]) @ q.T

    def g(t: float) -> np.ndarray:
        return np.array([np.sin(t), np.cos(2 * t), np.exp(-0.5 * t)])

    def dg(t: float) -> np.ndarray:
        return np.array([np.cos(t), -2 * np.sin(2 * t), -0.5 * np.exp(-0.5 * t)])

    y_lin = g(0.0) + np.array([1.0, -0.5, 0.25])
    td_lin = np.array([0.5, 2.0, 5.0])
    ref_lin = np.array([g(t) + expm(a * t) @ (y_lin - g(0.0)) for t in td_lin])
    y_vdp = np.array([2.0, -0.66])
    td_vdp = np.array([0.5, 1.0, 1.5, 2.0])
    # the reference at each check time from 7 and from 5 stages at 1e-14, both run to it
    ref_vdp = []
    for t in td_vdp:
        a7 = _vdp((1e-6,), y_vdp, t, 1e-14, 1e-14, 7, 7, np.array([t]))[1]
        a5 = _vdp((1e-6,), y_vdp, t, 1e-14, 1e-14, 5, 5, np.array([t]))[1]
        assert np.max(np.abs(a7 - a5)) < 1e-12, (t, a7 - a5)
        ref_vdp.append(a7)
    w = 10.0
    td_osc = np.array([4.0, 8.0, 12.0, 16.0, 20.0])
    ref_osc = np.stack([np.sin(w * td_osc), np.cos(w * td_osc)], axis=-1)

    def f_vdp(t: float, y: np.ndarray) -> list[float]:
        return [y[1], ((1 - y[0] ** 2) * y[1] - y[0]) / 1e-6]

    def f_lin(t: float, y: np.ndarray) -> np.ndarray:
        return a @ (y - g(t)) + dg(t)

    def f_osc(t: float, y: np.ndarray) -> list[float]:
        return [w * y[1] + 0.1 * (y[1] ** 2 - np.cos(w * t) ** 2),
                -w * y[0] + 0.1 * (y[0] ** 2 - np.sin(w * t) ** 2)]

    return {
        "vdp": (_vdp, (1e-6,), y_vdp, td_vdp, np.array(ref_vdp), 1.0, f_vdp),
        "linear": (_lin, (a,), y_lin, td_lin, ref_lin, 1e-3, f_lin),
        "oscillator": (_osc, (0.1, w), np.array([0.0, 1.0]), td_osc, ref_osc, 1.0, f_osc),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-scipy", action="store_true", help="leave scipy's Radau out")
    parser.add_argument("--quick", action="store_true",
                        help="rtol 1e-6 only, without scipy: checks the script runs")
    args = parser.parse_args()
    rtols = RTOLS[:1] if args.quick else RTOLS
    args.no_scipy |= args.quick
    t0 = time.perf_counter()
    probs = problems()
    print(f"(compiled and references in {time.perf_counter() - t0:.0f} s)\n")
    print("| problem | rtol | stages | max error | steps | rhs | jac | LU real/cplx | newton | "
          "rejected err/newton | steps at 3/5/7 |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, (run, ctx, y0, td, ref, af, f) in probs.items():
        for rtol in rtols:
            for s_min, s_max in METHODS:
                # every check time is a step end (one run to each; the counts are the run to
                # t_end, the last check time): dense output would add its own, lower order
                err = 0.0
                for t, r in zip(td, ref, strict=True):
                    ok, y, _, cnt, evals, steps, _, _ = run(ctx, y0, t, rtol, af * rtol, s_min,
                                                            s_max, np.array([t]))
                    err = max(err, float(np.max(np.abs(y - r)))) if ok else math.inf
                label = f"{s_min}" if s_min == s_max else f"{s_min}-{s_max}"
                print(f"| {name} | {rtol:.0e} | {label} | {err:.1e} | {steps} | {evals} | "
                      f"{cnt[rv.CNT_JAC]} | {cnt[rv.CNT_LU_REAL]}/{cnt[rv.CNT_LU_COMPLEX]} | "
                      f"{cnt[rv.CNT_NEWTON]} | {cnt[rv.CNT_REJECTED_ERROR]}/"
                      f"{cnt[rv.CNT_REJECTED_NEWTON]} | {cnt[rv.CNT_STEPS3]}/"
                      f"{cnt[rv.CNT_STEPS5]}/{cnt[rv.CNT_STEPS7]} |")
            if not args.no_scipy and rtol >= 1e-10:
                err = 0.0
                for t, r in zip(td, ref, strict=True):
                    sol = solve_ivp(f, (0.0, t), y0, method="Radau", rtol=rtol, atol=af * rtol)
                    err = max(err, float(np.max(np.abs(sol.y[:, -1] - r))))
                print(f"| {name} | {rtol:.0e} | scipy Radau | {err:.1e} | {sol.t.size - 1} | "
                      f"{sol.nfev} | {sol.njev} | {sol.nlu}/{sol.nlu} | | | |")
            sys.stdout.flush()

if __name__ == "__main__":
    main()
