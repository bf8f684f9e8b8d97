"""The explicit Runge-Kutta stepper, any tableau of the registry, with scipy's step control.

:func:`stages` computes a step's stages and its new state for any right-hand side (the
sphere's, and the hybrid loop's contact and flight phases, creatio.dynamics.solvers.flight);
:func:`step` is one try at one step of the driver (creatio.dynamics.solvers.driver), and
:func:`dense` its dense output. Step control is scipy's for the same pairs (safety 0.9,
factors in [0.2, 10], RMS norm of err / (atol + rtol max(|y|, |y_new|))), so native and scipy
runs of a method take comparable steps.

Written for the compiled loop: numba inlines :func:`stages` and :func:`step` where they are
called (the driver's loop, compiled without reference counting, where an inlined argument
costs nothing; a call per step cost RK4 5-20 % when measured). Their sums run in the
tableau's own order, so the generic stepper reproduces the notebook's RK4,
y + dt/6 (k1 + 2 (k2 + k3) + k4), bit for bit.
"""

from __future__ import annotations

import math

from creatio.dynamics.jit import njit
from creatio.dynamics.solvers import COMBINED_5_3, EMBEDDED
from creatio.dynamics.sphere import rhs_of, store

__all__ = ["ACCEPTED", "ERROR_REJECTED", "MAX_FACTOR", "MIN_FACTOR", "NEWTON_FAILED", "SAFETY",
           "dense", "error_norm", "next_step", "scaled_rms", "stages", "step", "step_factor"]

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
def next_step(h, h_use, factor, m):
    """The controller's next proposal; a step shortened (m == 1, h_use < h) to land on an
    output time keeps the larger proposal it was cut from when the step went well."""
    if m == 1 and h_use < h and factor >= 1.0:
        return max(h, h_use * factor)
    return h_use * factor


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


@njit(cache=True, inline="always")
def stages(f, key, c, a_ptr, a_idx, a_val, b_idx, b_val, b_divisor, t, h, t_next, y, ynew, K,
           work, kst, pp, lc, rot, en):
    """The stages K[1 .. s-1] of a step from (t, y) of size h (K[0] = f(t, y) given), and
    the new state ynew = y + (h / b_divisor) sum_q b_q K[q].

    f(key, t, y, dy, pp, lc, rot, en, diag) is the right-hand side (creatio.dynamics.sphere
    .rhs_of, key its structure flag; the hybrid loop's, key its phase); the tableau comes as
    the arrays of creatio.dynamics.solvers.DriverTableau. Stage st starts from
    y + h sum_q a[st, q] K[q], its terms added in column order from the first (0 + x = x
    exactly, so skipping zero coefficients changes no rounding); stages at c = 1 are
    evaluated at t_next exactly; b is summed in the tableau's order.
    """
    n = y.size
    for stg in range(1, c.size):
        p0 = a_ptr[stg]
        p1 = a_ptr[stg + 1]
        if p1 == p0:
            for j in range(n):
                work[j] = y[j]
        else:
            q = a_idx[p0]
            v = a_val[p0]
            for j in range(n):
                work[j] = v * K[q, j]
            for pq in range(p0 + 1, p1):
                q = a_idx[pq]
                v = a_val[pq]
                for j in range(n):
                    work[j] += v * K[q, j]
            for j in range(n):
                work[j] = y[j] + h * work[j]
        ts = t_next if c[stg] == 1.0 else t + c[stg] * h
        f(key, ts, work, kst, pp, lc, rot, en, False)
        for j in range(n):
            K[stg, j] = kst[j]
    q = b_idx[0]
    v = b_val[0]
    for j in range(n):
        ynew[j] = v * K[q, j]
    for pq in range(1, b_idx.size):
        q = b_idx[pq]
        v = b_val[pq]
        for j in range(n):
            ynew[j] += v * K[q, j]
    hb = h / b_divisor
    for j in range(n):
        ynew[j] = y[j] + hb * ynew[j]


@njit(cache=True, inline="always")
def step(free, c, a_ptr, a_idx, a_val, b_idx, b_val, e, e3, scalars, t, t_next, h, y, ynew,
         fnew, dbuf, K, work, kst, tol, fixed, dense, rejected, pp, lc, rot, en):
    """One try at the driver's step t -> t_next = t + h from K[0] = f(t, y): (outcome,
    factor, rhs evaluations, whether fnew and dbuf hold the end-of-step evaluation).
    scalars = (b_divisor, estimator, error_order) of the tableau, tol = (rtol, atol).

    A fixed step without dense output leaves the end-of-step derivative to the next step's
    top, as the notebook's RK4 did; otherwise it is taken here with its diagnostics (the next
    step's first stage: FSAL, into K[s]), and an adaptive step's error is measured.
    """
    b_divisor, estimator, error_order = scalars
    stages(rhs_of, free, c, a_ptr, a_idx, a_val, b_idx, b_val, b_divisor, t, h, t_next, y,
           ynew, K, work, kst, pp, lc, rot, en)
    s = c.size
    if fixed and not dense:
        return ACCEPTED, 1.0, s - 1, False
    store(rhs_of(free, t_next, ynew, fnew, pp, lc, rot, en, True), dbuf)
    for j in range(y.size):
        K[s, j] = fnew[j]
    if fixed:
        return ACCEPTED, 1.0, s, True
    rtol, atol = tol
    en_err = error_norm(K, y, ynew, h, e, e3, estimator, rtol, atol)
    ok, factor = step_factor(en_err, error_order, rejected)
    return ACCEPTED if ok else ERROR_REJECTED, factor, s, ok


@njit(cache=True)
def dense(free, s, c_extra, a_extra, dense_p, extras_done, t, h, y, tg, yout, K, work, kst, wq,
          pp, lc, rot, en):
    """The dense output at tg inside the last accepted step from (t, y) of size h:
    y + h sum_q K_q P_q(x), x = (tg - t) / h (docs/model.md s.6.1), over the s stages, the
    end-of-step derivative and the extra stages, computed on the step's first dense row
    (unless extras_done). Returns the right-hand-side evaluations it cost."""
    n = y.size
    n_dense = dense_p.shape[0]
    n_extra = c_extra.size
    evals = 0
    if n_extra > 0 and not extras_done:
        for i in range(n_extra):
            row = s + 1 + i
            for j in range(n):
                work[j] = 0.0
            for q in range(row):
                v = a_extra[i, q]
                if v != 0.0:
                    for j in range(n):
                        work[j] += v * K[q, j]
            for j in range(n):
                work[j] = y[j] + h * work[j]
            rhs_of(free, t + c_extra[i] * h, work, kst, pp, lc, rot, en, False)
            for j in range(n):
                K[row, j] = kst[j]
        evals = n_extra
    x = (tg - t) / h
    for q in range(n_dense):
        acc = 0.0
        xp = x
        for k in range(dense_p.shape[1]):
            acc += dense_p[q, k] * xp
            xp *= x
        wq[q] = acc
    for j in range(n):
        acc = 0.0
        for q in range(n_dense):
            acc += wq[q] * K[q, j]
        yout[j] = y[j] + h * acc
    return evals
