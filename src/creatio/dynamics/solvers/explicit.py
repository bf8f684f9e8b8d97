"""Error estimate and step control of the explicit Runge-Kutta stepper (compiled).

The stages themselves are computed inside the driver's loop (creatio.dynamics.solvers
.driver), for any tableau. Step control is scipy's for the same pairs (safety 0.9, factors in
[0.2, 10], RMS norm of err / (atol + rtol max(|y|, |y_new|))), so native and scipy runs of a
method take comparable steps.
"""

from __future__ import annotations

import math

from creatio.dynamics.jit import njit
from creatio.dynamics.solvers import COMBINED_5_3, EMBEDDED

__all__ = ["ACCEPTED", "ERROR_REJECTED", "MAX_FACTOR", "MIN_FACTOR", "NEWTON_FAILED", "SAFETY",
           "error_norm", "scaled_rms", "step_factor"]

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0

#: Outcomes of one step attempt (both steppers).
ACCEPTED, NEWTON_FAILED, ERROR_REJECTED = 0, 1, 2


@njit(cache=True)
def error_norm(K, y, ynew, h, e, e3, estimator, rtol, atol):
    """Scaled local error of the step (< 1: acceptable); inf when not finite."""
    n = y.size
    s1 = e.size  # the stages and the end-of-step one (K may hold dense-output stages too)
    err = 0.0
    if estimator == EMBEDDED:
        s2 = 0.0
        for j in range(n):
            acc = 0.0
            for q in range(s1):
                acc += e[q] * K[q, j]
            sc = atol + max(abs(y[j]), abs(ynew[j])) * rtol
            s2 += (h * acc / sc) ** 2
        err = math.sqrt(s2 / n)
    elif estimator == COMBINED_5_3:
        e5 = 0.0
        e33 = 0.0
        for j in range(n):
            a5 = 0.0
            a3 = 0.0
            for q in range(s1):
                a5 += e[q] * K[q, j]
                a3 += e3[q] * K[q, j]
            sc = atol + max(abs(y[j]), abs(ynew[j])) * rtol
            e5 += (a5 / sc) ** 2
            e33 += (a3 / sc) ** 2
        if e5 == 0.0 and e33 == 0.0:
            err = 0.0
        else:
            err = h * e5 / math.sqrt((e5 + 0.01 * e33) * n)
    if not math.isfinite(err):
        err = math.inf
    return err


@njit(cache=True, inline="always")
def scaled_rms(err, y, ynew, rtol, atol):
    """RMS of err / (atol + rtol max(|y|, |y_new|)): the implicit steppers' error norm, the
    scale of the explicit pairs' (error_norm)."""
    n = y.size
    s2 = 0.0
    for j in range(n):
        sc = atol + max(abs(y[j]), abs(ynew[j])) * rtol
        s2 += (err[j] / sc) ** 2
    return math.sqrt(s2 / n)


@njit(cache=True)
def step_factor(err, error_order, rejected):
    """(accepted, factor) of scipy's controller: h_new = h factor."""
    expo = -1.0 / (error_order + 1)
    if err < 1.0:
        if err == 0.0:
            factor = MAX_FACTOR
        else:
            factor = min(MAX_FACTOR, SAFETY * err**expo)
        if rejected:
            factor = min(1.0, factor)
        return True, factor
    return False, max(MIN_FACTOR, SAFETY * err**expo)
