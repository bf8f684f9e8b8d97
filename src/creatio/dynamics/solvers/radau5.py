"""Radau IIA order 5, the implicit stepper, compiled (Hairer & Wanner, Solving ODEs II, IV.8).

3-stage collocation, L-stable: the stage equations damp the friction's stiff slip mode at
any h, so the step follows the slow dynamics. Simplified Newton on the transformed stage
increments with the real/complex eigen-split of the Radau matrix, a forward-difference
Jacobian reused across steps (only the columns the dynamics depend on are differenced: 7 on
a fixed structure, 9 on the structure path of docs/model.md s.9-10 and on the controlled
path of s.12.2),
LU factors kept while h is steady, and Gustafsson's predictive step control; the pieces
follow scipy.integrate's Radau (solve_collocation_system, predict_factor), so native and
scipy runs take comparable steps.

What a step carries to the next lives in a small float array (RS_*) and the work arrays of
:func:`workspace`; :func:`step` is one try at one step, under the stepper contract of
creatio.dynamics.solvers.driver. Dense output (free steps, rows between them) is the quintic
Hermite interpolant through (y, f) at the ends of the last two accepted steps
(:func:`dense_step`): local error O(h^6), against the collocation polynomial's O(h^4)
(:func:`dense`, stage order 3), so the rows are good to a tight tolerance without the steps
landing on them.
"""

from __future__ import annotations

import math

import numpy as np

from creatio.dynamics.jit import njit
from creatio.dynamics.layout import NQ, Y_OMEGA, Y_Q, control_start, structure_start
from creatio.dynamics.solvers import tableaus as tb
from creatio.dynamics.solvers.explicit import (
    ACCEPTED,
    ERROR_REJECTED,
    MAX_FACTOR,
    MIN_FACTOR,
    NEWTON_FAILED,
    scaled_rms,
)
from creatio.dynamics.solvers.linalg import lu_factor, lu_solve
from creatio.dynamics.sphere import control_columns, rhs_of, store

__all__ = ["NWS", "THETA", "WS_ERR", "WS_F", "WS_JAC", "WS_LU_COMPLEX", "WS_LU_REAL",
           "WS_PIV_COMPLEX", "WS_PIV_REAL", "WS_PREVIOUS", "WS_Q_OLD", "WS_RES_COMPLEX",
           "WS_RES_REAL", "WS_RS", "WS_TMP", "WS_W", "WS_WORK", "WS_Y_OLD", "WS_Z", "WS_Z0",
           "dense", "dense_step", "hermite5", "jacobian", "passed", "step", "workspace"]

NEWTON_MAXITER = 6
#: Newton contraction rate above which the Jacobian is refreshed (Hairer's THET).
THETA = 1e-3
_EPS = np.finfo(float).eps

# Radau IIA constants as plain arrays for the compiled loop.
_RC = tb.RADAU_C.copy()
_RE = tb.RADAU_E.copy()
_RT = tb.RADAU_T.copy()
_RTI = tb.RADAU_TI.copy()
_RP = tb.RADAU_P.copy()
_MU_R = tb.RADAU_MU_REAL
_MU_C = complex(tb.RADAU_MU_COMPLEX_RE, tb.RADAU_MU_COMPLEX_IM)
_TI_C = tb.RADAU_TI[1] + 1j * tb.RADAU_TI[2]

# Slots of the carried state: whether a Jacobian exists / is fresh at the current point, the
# h of the current LU factors (-1: none), whether the previous step's collocation polynomial
# exists, its start time and step, and the last accepted step and error (controller memory);
# whether the start of the step before the last is kept (dense output) and its time.
(RS_HAVE_JAC, RS_CURRENT_JAC, RS_LU_H, RS_HAVE_OLD, RS_T_OLD, RS_H_PREV, RS_H_OLD, RS_ERR_OLD,
 RS_HAVE_PREVIOUS, RS_T_PREVIOUS) = range(10)


#: Slots of the workspace tuple (:func:`workspace`), as the layouts of
#: creatio.dynamics.layout name a state's components: the carried state (RS_*), the
#: Jacobian, the real and complex LU factors and their pivots, the stage increments Z, their
#: prediction Z0, W = TI Z, the stage derivatives F, the previous step's collocation
#: polynomial and its start y, the real and complex Newton residuals, the error estimate, a
#: trial state and a trial derivative, and (y, f) at the start of the step before the last
#: (dense output's interpolant, :func:`dense_step`).
(WS_RS, WS_JAC, WS_LU_REAL, WS_LU_COMPLEX, WS_PIV_REAL, WS_PIV_COMPLEX, WS_Z, WS_Z0, WS_W, WS_F,
 WS_Q_OLD, WS_Y_OLD, WS_RES_REAL, WS_RES_COMPLEX, WS_ERR, WS_WORK, WS_TMP, WS_PREVIOUS) = (
    range(18))
NWS = 18


@njit(cache=True)
def workspace(n, params):
    """Carried state and work arrays of step for a state of size n, in the WS_* order:
    nothing computed yet (params, the method's parameters of the driver's contract, are not
    used)."""
    rs = np.zeros(10)
    rs[RS_LU_H] = -1.0
    rs[RS_H_OLD] = -1.0
    rs[RS_ERR_OLD] = -1.0
    return (
        rs,                                     # WS_RS
        np.empty((n, n)),                       # WS_JAC
        np.empty((n, n)),                       # WS_LU_REAL
        np.empty((n, n), dtype=np.complex128),  # WS_LU_COMPLEX
        np.empty(n, dtype=np.int64),            # WS_PIV_REAL
        np.empty(n, dtype=np.int64),            # WS_PIV_COMPLEX
        np.zeros((3, n)),                       # WS_Z: stage increments
        np.zeros((3, n)),                       # WS_Z0: predicted stage increments
        np.zeros((3, n)),                       # WS_W = TI Z
        np.empty((3, n)),                       # WS_F: stage derivatives
        np.zeros((n, 3)),                       # WS_Q_OLD: previous collocation polynomial
        np.empty(n),                            # WS_Y_OLD
        np.empty(n),                            # WS_RES_REAL: real Newton residual
        np.empty(n, dtype=np.complex128),       # WS_RES_COMPLEX: complex Newton residual
        np.empty(n),                            # WS_ERR: error estimate
        np.empty(n),                            # WS_WORK: a trial state
        np.empty(n),                            # WS_TMP: a trial derivative
        np.empty((2, n)),                       # WS_PREVIOUS: y, f before the last step
    )


@njit(cache=True)
def jacobian(t, y, f, jac, work, tmp, pp, lc, rot, en, free):
    """Jacobian df/dy into jac; returns the right-hand-side evaluations it cost.

    Only (R, alpha, Rdot, alphadot, omega) drive the dynamics, and on the structure path
    (theta, Theta), the last two states (theta turns the world-frame omega into the
    structure's frame, Theta enters the slip, Coriolis and centrifugal terms), and on the
    controlled path (phi_a, phidot_a), the control block (docs/model.md s.12.2: the surface
    moves with them and the servo reads them): their columns are forward differences. The
    quaternion block is exact (dQ/dt = Omega(omega) Q / 2 is linear in Q) and the
    accumulators (cumulative spin, surface work, dissipation, confinement work) feed nothing
    back, so their columns are zero. (Every column but R's and
    alpha's keeps (t, R, alpha) and could share one evaluation of the surface: measured,
    radau5 ran 0.967x, within the spread, and its first compile took 6 s longer.)
    """
    n = y.size
    for i in range(n):
        for j in range(n):
            jac[i, j] = 0.0
    for j in range(n):
        work[j] = y[j]
    # the feedback columns: the coordinates and rates, omega, then theta and Theta on the
    # structure path
    active = Y_OMEGA + 3 if rot else NQ
    n_cols = active + 2 if free else active
    n_all = n_cols + control_columns(lc)  # the control block last (never with free)
    for jj in range(n_all):
        if jj < active:
            j = jj
        elif jj < n_cols:
            j = structure_start(rot, en) + jj - active
        else:
            j = control_start(rot, en) + jj - n_cols
        delta = 1.4901161193847656e-08 * max(abs(y[j]), 1.0)
        work[j] = y[j] + delta
        delta = work[j] - y[j]
        rhs_of(free, t, work, tmp, pp, lc, rot, en, False)
        for i in range(n):
            jac[i, j] = (tmp[i] - f[i]) / delta
        work[j] = y[j]
    if rot:
        wx = 0.5 * y[Y_OMEGA]
        wy = 0.5 * y[Y_OMEGA + 1]
        wz = 0.5 * y[Y_OMEGA + 2]
        # rows dQ/dt against columns Q, from creatio.model.sphere.attitude_rates:
        # dq0 = -(wx q1 + wy q2 + wz q3)/2, dq1 = (q0 wx + wy q3 - wz q2)/2,
        # dq2 = (q0 wy + wz q1 - wx q3)/2, dq3 = (q0 wz + wx q2 - wy q1)/2
        q0, q1, q2, q3 = Y_Q, Y_Q + 1, Y_Q + 2, Y_Q + 3
        jac[q0, q1] = -wx
        jac[q0, q2] = -wy
        jac[q0, q3] = -wz
        jac[q1, q0] = wx
        jac[q1, q2] = -wz
        jac[q1, q3] = wy
        jac[q2, q0] = wy
        jac[q2, q1] = wz
        jac[q2, q3] = -wx
        jac[q3, q0] = wz
        jac[q3, q1] = -wy
        jac[q3, q2] = wx
    return n_all


@njit(cache=True)
def _predict(t, h, y, rs, Z0, Qold, yold):
    """Stage increments predicted from the previous step's collocation polynomial."""
    n = y.size
    if rs[RS_HAVE_OLD] > 0.0:
        for i in range(3):
            x = (t + h * _RC[i] - rs[RS_T_OLD]) / rs[RS_H_PREV]
            x2 = x * x
            x3 = x2 * x
            for j in range(n):
                acc = yold[j]
                acc += Qold[j, 0] * x
                acc += Qold[j, 1] * x2
                acc += Qold[j, 2] * x3
                Z0[i, j] = acc - y[j]
    else:
        Z0[:, :] = 0.0


@njit(cache=True)
def _newton(t, h, y, rtol, atol, newton_tol, lur, pivr, luc, pivc, Z0, Z, W, F, rreal, rcplx,
            work, tmp, pp, lc, rot, en, free):
    """Simplified Newton on W = TI Z; returns (converged, iterations, rate, evaluations)."""
    n = y.size
    for i in range(3):
        for j in range(n):
            W[i, j] = _RTI[i, 0] * Z0[0, j] + _RTI[i, 1] * Z0[1, j] + _RTI[i, 2] * Z0[2, j]
            Z[i, j] = Z0[i, j]
    mr = _MU_R / h
    mc = _MU_C / h
    dw_old = -1.0
    rate = -1.0
    converged = False
    n_iter = 0
    evals = 0
    for it in range(NEWTON_MAXITER):
        n_iter = it + 1
        finite = True
        for i in range(3):
            for j in range(n):
                work[j] = y[j] + Z[i, j]
            rhs_of(free, t + _RC[i] * h, work, tmp, pp, lc, rot, en, False)
            for j in range(n):
                F[i, j] = tmp[j]
                if not math.isfinite(tmp[j]):
                    finite = False
        evals += 3
        if not finite:
            break
        for j in range(n):
            rreal[j] = (
                _RTI[0, 0] * F[0, j] + _RTI[0, 1] * F[1, j] + _RTI[0, 2] * F[2, j]
                - mr * W[0, j]
            )
            rcplx[j] = (
                _TI_C[0] * F[0, j] + _TI_C[1] * F[1, j] + _TI_C[2] * F[2, j]
                - mc * (W[1, j] + 1j * W[2, j])
            )
        lu_solve(lur, pivr, rreal)
        lu_solve(luc, pivc, rcplx)
        s2 = 0.0
        for j in range(n):
            sc = atol + abs(y[j]) * rtol
            s2 += (rreal[j] / sc) ** 2 + (rcplx[j].real / sc) ** 2 + (rcplx[j].imag / sc) ** 2
        dw = math.sqrt(s2 / (3 * n))
        if dw_old > 0.0:
            rate = dw / dw_old
        if rate >= 0.0 and (
            rate >= 1.0 or rate ** (NEWTON_MAXITER - it) / (1.0 - rate) * dw > newton_tol
        ):
            break
        for j in range(n):
            W[0, j] += rreal[j]
            W[1, j] += rcplx[j].real
            W[2, j] += rcplx[j].imag
        for i in range(3):
            for j in range(n):
                Z[i, j] = _RT[i, 0] * W[0, j] + _RT[i, 1] * W[1, j] + _RT[i, 2] * W[2, j]
        if dw == 0.0 or (rate >= 0.0 and rate / (1.0 - rate) * dw < newton_tol):
            converged = True
            break
        dw_old = dw
    return converged, n_iter, rate, evals


@njit(cache=True)
def _factor(h, n_iter, rate, en_err, rs, fixed):
    """Gustafsson's predictive controller: (step factor, whether to refresh the Jacobian)."""
    safety = 0.9 * (2 * NEWTON_MAXITER + 1) / (2 * NEWTON_MAXITER + n_iter)
    mult = 1.0
    if rs[RS_H_OLD] > 0.0 and rs[RS_ERR_OLD] > 0.0 and en_err > 0.0:
        mult = h / rs[RS_H_OLD] * (rs[RS_ERR_OLD] / en_err) ** 0.25
    recompute = n_iter > 2 and rate > THETA
    if fixed:
        return 1.0, recompute
    if en_err > 1.0:
        fac = min(1.0, mult) * en_err**-0.25
        return max(MIN_FACTOR, safety * fac), False
    factor = MAX_FACTOR if en_err == 0.0 else min(1.0, mult) * en_err**-0.25
    factor = min(MAX_FACTOR, safety * factor)
    if not recompute and factor < 1.2:
        factor = 1.0
    return factor, recompute


@njit(cache=True)
def step(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, ws, tol, fixed, rejected, pp, lc, rot,
         en, free):
    """One try at the step t -> t_next = t + h (the driver's implicit-stepper contract;
    `stepper` is its kind, which the driver dispatches on at compile time).

    Returns (outcome, factor, rhs evaluations, jacobians, LU factorisations, Newton iterations,
    whether fnew and dbuf hold the end-of-step evaluation): ACCEPTED (ynew, fnew and the
    diagnostics dbuf filled; factor proposes the next step), NEWTON_FAILED (halve h) or
    ERROR_REJECTED (factor shrinks h).
    """
    rs, jac, lur, luc = ws[WS_RS], ws[WS_JAC], ws[WS_LU_REAL], ws[WS_LU_COMPLEX]
    pivr, pivc, Z, Z0, W, F = (ws[WS_PIV_REAL], ws[WS_PIV_COMPLEX], ws[WS_Z], ws[WS_Z0],
                               ws[WS_W], ws[WS_F])
    Qold, yold, rreal, rcplx = ws[WS_Q_OLD], ws[WS_Y_OLD], ws[WS_RES_REAL], ws[WS_RES_COMPLEX]
    err, work, tmp = ws[WS_ERR], ws[WS_WORK], ws[WS_TMP]
    rtol, atol = tol
    n = y.size
    evals = 0
    n_jac = 0
    n_lu = 0
    newton_tol = max(10.0 * _EPS / rtol, min(0.03, math.sqrt(rtol))) if rtol > 0 else 0.03
    if rs[RS_HAVE_JAC] == 0.0:
        evals += jacobian(t, y, f, jac, work, tmp, pp, lc, rot, en, free)
        n_jac += 1
        rs[RS_HAVE_JAC] = 1.0
        rs[RS_CURRENT_JAC] = 1.0
        rs[RS_LU_H] = -1.0
    _predict(t, h, y, rs, Z0, Qold, yold)
    converged = False
    n_iter = 0
    n_newton = 0
    rate = 0.0
    while not converged:
        if abs(h - rs[RS_LU_H]) > 1e-3 * h:
            mr = _MU_R / h
            mc = _MU_C / h
            for i in range(n):
                for j in range(n):
                    lur[i, j] = -jac[i, j]
                    luc[i, j] = -jac[i, j]
                lur[i, i] += mr
                luc[i, i] += mc
            regular = lu_factor(lur, pivr) and lu_factor(luc, pivc)
            n_lu += 1
            rs[RS_LU_H] = h
            if not regular:
                rs[RS_LU_H] = -1.0
                break
        converged, n_iter, rate, ev = _newton(t, h, y, rtol, atol, newton_tol, lur, pivr, luc,
                                              pivc, Z0, Z, W, F, rreal, rcplx, work, tmp, pp,
                                              lc, rot, en, free)
        evals += ev
        n_newton += n_iter
        if not converged:
            if rs[RS_CURRENT_JAC] > 0.0:
                break
            evals += jacobian(t, y, f, jac, work, tmp, pp, lc, rot, en, free)
            n_jac += 1
            rs[RS_CURRENT_JAC] = 1.0
            rs[RS_LU_H] = -1.0
    if not converged:
        rs[RS_LU_H] = -1.0
        return NEWTON_FAILED, 0.5, evals, n_jac, n_lu, n_newton, False
    for j in range(n):
        ynew[j] = y[j] + Z[2, j]
    # error estimate: (mu_real/h I - J)^-1 (f + Z^T E / h); a fixed step does not use it
    en_err = 0.0
    if not fixed:
        for j in range(n):
            ze = (Z[0, j] * _RE[0] + Z[1, j] * _RE[1] + Z[2, j] * _RE[2]) / h
            tmp[j] = ze
            err[j] = f[j] + ze
        lu_solve(lur, pivr, err)
        en_err = scaled_rms(err, y, ynew, rtol, atol)
        if rejected and en_err > 1.0:
            for j in range(n):
                work[j] = y[j] + err[j]
            rhs_of(free, t, work, rreal, pp, lc, rot, en, False)
            evals += 1
            for j in range(n):
                err[j] = rreal[j] + tmp[j]
            lu_solve(lur, pivr, err)
            en_err = scaled_rms(err, y, ynew, rtol, atol)
        if not math.isfinite(en_err):
            en_err = math.inf
    factor, recompute = _factor(h, n_iter, rate, en_err, rs, fixed)
    if en_err > 1.0 and not fixed:
        rs[RS_LU_H] = -1.0
        return ERROR_REJECTED, factor, evals, n_jac, n_lu, n_newton, False
    store(rhs_of(free, t_next, ynew, fnew, pp, lc, rot, en, True), dbuf)
    evals += 1
    if recompute:
        evals += jacobian(t_next, ynew, fnew, jac, work, tmp, pp, lc, rot, en, free)
        n_jac += 1
        rs[RS_CURRENT_JAC] = 1.0
        rs[RS_LU_H] = -1.0
    else:
        rs[RS_CURRENT_JAC] = 0.0
    rs[RS_H_OLD] = h
    rs[RS_ERR_OLD] = en_err
    # the step's collocation polynomial y_old + Q (x, x^2, x^3), Q = Z^T P, formed once
    # here: it predicts the next step's stages (also after rejections)
    for j in range(n):
        for q in range(3):
            Qold[j, q] = Z[0, j] * _RP[0, q] + Z[1, j] * _RP[1, q] + Z[2, j] * _RP[2, q]
        yold[j] = y[j]
    rs[RS_T_OLD] = t
    rs[RS_H_PREV] = h
    rs[RS_HAVE_OLD] = 1.0
    return ACCEPTED, factor, evals, n_jac, n_lu, n_newton, True


@njit(cache=True)
def dense(ws, tg, yout):
    """Dense output at tg inside the last accepted step: its collocation polynomial
    y_old + Q (x, x^2, x^3), x = (tg - t_old) / h, which matches the stage values (order 3)."""
    rs = ws[WS_RS]
    Qold = ws[WS_Q_OLD]
    yold = ws[WS_Y_OLD]
    x = (tg - rs[RS_T_OLD]) / rs[RS_H_PREV]
    x2 = x * x
    x3 = x2 * x
    for j in range(yold.size):
        yout[j] = yold[j] + Qold[j, 0] * x + Qold[j, 1] * x2 + Qold[j, 2] * x3


@njit(cache=True)
def hermite5(ta, ya, fa, tb, yb, fb, tc, yc, fc, tg, yout):
    """The quintic through (y, y') at three times ta < tb < tc, at tg, into yout: Newton's
    divided differences on the doubled nodes (ta, ta, tb, tb, tc, tc); its error is
    y^(6) (tg - ta)^2 (tg - tb)^2 (tg - tc)^2 / 6!, O(h^6) for steps of h."""
    hab = tb - ta
    hbc = tc - tb
    hac = tc - ta
    wa = tg - ta
    wb = tg - tb
    wc = tg - tc
    for j in range(yout.size):
        dab = (yb[j] - ya[j]) / hab
        dbc = (yc[j] - yb[j]) / hbc
        d_aab = (dab - fa[j]) / hab
        d_abb = (fb[j] - dab) / hab
        d_bbc = (dbc - fb[j]) / hbc
        d_bcc = (fc[j] - dbc) / hbc
        d_aabb = (d_abb - d_aab) / hab
        d_abbc = (d_bbc - d_abb) / hac
        d_bbcc = (d_bcc - d_bbc) / hbc
        d_aabbc = (d_abbc - d_aabb) / hac
        d_abbcc = (d_bbcc - d_abbc) / hac
        d5 = (d_abbcc - d_aabbc) / hac
        yout[j] = ya[j] + wa * (fa[j] + wa * (d_aab + wb * (d_aabb + wb * (d_aabbc + wc * d5))))


@njit(cache=True)
def dense_step(ws, tg, yout, t, y, f, t_next, ynew, fnew):
    """Dense output at tg inside the last accepted step t -> t_next (start y, f; end ynew,
    fnew): the quintic Hermite interpolant through (y, f) at the start of the step before it,
    its start and its end (:func:`hermite5`, local error O(h^6) from values the steps already
    have, no evaluation), good to the run's tolerance where the collocation polynomial
    (:func:`dense`, order 3) is not; the collocation polynomial in the first step."""
    rs = ws[WS_RS]
    if rs[RS_HAVE_PREVIOUS] == 0.0:
        dense(ws, tg, yout)
        return
    prev = ws[WS_PREVIOUS]
    hermite5(rs[RS_T_PREVIOUS], prev[0], prev[1], t, y, f, t_next, ynew, fnew, tg, yout)


@njit(cache=True)
def passed(ws, t, y, f):
    """Keep (t, y, f), the start of the step just accepted, as the first node of the next
    step's interpolant (:func:`dense_step`): the driver calls it after each dense step."""
    rs = ws[WS_RS]
    prev = ws[WS_PREVIOUS]
    for j in range(y.size):
        prev[0, j] = y[j]
        prev[1, j] = f[j]
    rs[RS_T_PREVIOUS] = t
    rs[RS_HAVE_PREVIOUS] = 1.0
