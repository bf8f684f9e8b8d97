"""RODAS4, the linearly implicit (Rosenbrock) stepper, compiled (Hairer & Wanner, Solving ODEs
II, s. VI.4).

Six stages, each one linear solve with the same matrix W = I / (h gamma) - J and no Newton
iteration: stiffly accurate and L-stable, so like Radau IIA it damps the friction's slip
mode at any h. Its order needs the Jacobian at each step's start: J is the forward-difference
Jacobian of the feedback columns with the exact quaternion block (radau5.jacobian), and the
explicit time dependence of the surface enters through a forward difference df/dt. Step
control is the explicit pairs' (creatio.dynamics.solvers.explicit: safety 0.9, factors in
[0.2, 10], RMS norm). Dense output: the cubic Hermite polynomial of the step's ends.
"""

from __future__ import annotations

import math

import numpy as np

from creatio.dynamics.jit import njit
from creatio.dynamics.solvers import tableaus as tb
from creatio.dynamics.solvers.explicit import (
    ACCEPTED,
    ERROR_REJECTED,
    NEWTON_FAILED,
    scaled_rms,
    step_factor,
)
from creatio.dynamics.solvers.linalg import lu_factor, lu_solve
from creatio.dynamics.solvers.radau5 import jacobian
from creatio.dynamics.sphere import rhs_of, store

__all__ = ["NWS", "WS_DFDT", "WS_HERMITE", "WS_JAC", "WS_LU", "WS_PIV", "WS_RS", "WS_TMP",
           "WS_U", "WS_WORK", "dense", "step", "workspace"]

_GAMMA = tb.RODAS4_GAMMA
_ALPHA = tb.RODAS4_ALPHA.copy()
_GAMMAS = tb.RODAS4_GAMMAS.copy()
_A = tb.RODAS4_A.copy()
_C = tb.RODAS4_C.copy()
_M = tb.RODAS4_M.copy()
_E = tb.RODAS4_E.copy()
_S = 6
#: Order of the embedded solution (step_factor's exponent is -1 / (ERROR_ORDER + 1)).
ERROR_ORDER = 3

# Slots of the carried state: the time of the Jacobian held (NaN: none), the h of the LU
# factors held (-1: none), and the last accepted step (start time, size) for dense output.
RS_JAC_T, RS_LU_H, RS_T_OLD, RS_H_OLD = range(4)


#: Slots of the workspace tuple (:func:`workspace`): the carried state (RS_*), the Jacobian,
#: the LU factors of W and their pivots, the stage increments U, df/dt, a stage state, a
#: stage derivative, and the last step's y0, f0, y1, f1 for the dense output.
(WS_RS, WS_JAC, WS_LU, WS_PIV, WS_U, WS_DFDT, WS_WORK, WS_TMP, WS_HERMITE) = range(9)
NWS = 9


@njit(cache=True)
def workspace(n, params):
    """Carried state and work arrays of step for a state of size n, in the WS_* order:
    nothing computed yet (params, the method's parameters of the driver's contract, are not
    used)."""
    rs = np.zeros(4)
    rs[RS_JAC_T] = math.nan
    rs[RS_LU_H] = -1.0
    return (
        rs,                             # WS_RS
        np.empty((n, n)),               # WS_JAC
        np.empty((n, n)),               # WS_LU: LU of W
        np.empty(n, dtype=np.int64),    # WS_PIV
        np.empty((_S, n)),              # WS_U: stage increments
        np.empty(n),                    # WS_DFDT: df/dt
        np.empty(n),                    # WS_WORK: a stage state
        np.empty(n),                    # WS_TMP: a stage derivative
        np.empty((4, n)),               # WS_HERMITE: y0, f0, y1, f1 of the last step
    )


@njit(cache=True)
def step(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, ws, tol, fixed, rejected, pp, lc, rot,
         en, free):
    """One try at the step t -> t_next = t + h (the driver's implicit-stepper contract, as
    creatio.dynamics.solvers.radau5.step): (outcome, factor, rhs evaluations, jacobians, LU
    factorisations, Newton iterations (none: 0), whether fnew and dbuf hold the end-of-step
    evaluation)."""
    rs, jac, lu, piv = ws[WS_RS], ws[WS_JAC], ws[WS_LU], ws[WS_PIV]
    U, dfdt, work, tmp, hermite = ws[WS_U], ws[WS_DFDT], ws[WS_WORK], ws[WS_TMP], ws[WS_HERMITE]
    rtol, atol = tol
    n = y.size
    evals = 0
    n_jac = 0
    n_lu = 0
    if rs[RS_JAC_T] != t:
        # J and df/dt at the step's start (kept for a retry from the same point)
        evals += jacobian(t, y, f, jac, work, tmp, pp, lc, rot, en, free)
        dt_ = 1.4901161193847656e-08 * max(1e-5, abs(t))
        rhs_of(free, t + dt_, y, tmp, pp, lc, rot, en, False)
        evals += 1
        for j in range(n):
            dfdt[j] = (tmp[j] - f[j]) / dt_
        n_jac += 1
        rs[RS_JAC_T] = t
        rs[RS_LU_H] = -1.0
    if rs[RS_LU_H] != h:
        d = 1.0 / (h * _GAMMA)
        for i in range(n):
            for j in range(n):
                lu[i, j] = -jac[i, j]
            lu[i, i] += d
        n_lu += 1
        if not lu_factor(lu, piv):
            rs[RS_LU_H] = -1.0
            return NEWTON_FAILED, 0.5, evals, n_jac, n_lu, 0, False
        rs[RS_LU_H] = h
    finite = True
    for i in range(_S):
        if i == 0:
            for j in range(n):
                tmp[j] = f[j]
        else:
            for j in range(n):
                acc = y[j]
                for q in range(i):
                    acc += _A[i, q] * U[q, j]
                work[j] = acc
            rhs_of(free, t + _ALPHA[i] * h, work, tmp, pp, lc, rot, en, False)
            evals += 1
        hg = h * _GAMMAS[i]
        for j in range(n):
            acc = tmp[j] + hg * dfdt[j]
            for q in range(i):
                acc += _C[i, q] / h * U[q, j]
            U[i, j] = acc
            if not math.isfinite(acc):
                finite = False
        if not finite:
            break
        lu_solve(lu, piv, U[i])
    if not finite:
        return NEWTON_FAILED, 0.5, evals, n_jac, n_lu, 0, False
    for j in range(n):
        acc = y[j]
        err = 0.0
        for q in range(_S):
            acc += _M[q] * U[q, j]
            err += _E[q] * U[q, j]
        ynew[j] = acc
        work[j] = err
    en_err = scaled_rms(work, y, ynew, rtol, atol)
    if not math.isfinite(en_err):
        en_err = math.inf
    ok, factor = step_factor(en_err, ERROR_ORDER, rejected)
    if fixed:
        if not math.isfinite(en_err):
            return NEWTON_FAILED, 0.5, evals, n_jac, n_lu, 0, False
        factor = 1.0
    elif not ok:
        return ERROR_REJECTED, factor, evals, n_jac, n_lu, 0, False
    store(rhs_of(free, t_next, ynew, fnew, pp, lc, rot, en, True), dbuf)
    evals += 1
    for j in range(n):
        hermite[0, j] = y[j]
        hermite[1, j] = f[j]
        hermite[2, j] = ynew[j]
        hermite[3, j] = fnew[j]
    rs[RS_T_OLD] = t
    rs[RS_H_OLD] = h
    return ACCEPTED, factor, evals, n_jac, n_lu, 0, True


@njit(cache=True)
def dense(ws, tg, yout):
    """Dense output at tg inside the last accepted step: the cubic Hermite polynomial through
    both ends' states and derivatives (order 3)."""
    rs = ws[WS_RS]
    hermite = ws[WS_HERMITE]
    h_old = rs[RS_H_OLD]
    x = (tg - rs[RS_T_OLD]) / h_old
    h00 = (1.0 + 2.0 * x) * (1.0 - x) ** 2
    h10 = x * (1.0 - x) ** 2
    h01 = x * x * (3.0 - 2.0 * x)
    h11 = x * x * (x - 1.0)
    for j in range(yout.size):
        yout[j] = (h00 * hermite[0, j] + h_old * h10 * hermite[1, j] + h01 * hermite[2, j]
                   + h_old * h11 * hermite[3, j])
