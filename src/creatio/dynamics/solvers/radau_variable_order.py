"""Variable-order Radau IIA (3, 5, 7 stages: orders 5, 9, 13), compiled, for y' = f(t, y).

The stepper of Hairer & Wanner's RADAU (Solving ODEs II, IV.8, and radau.f), generic over
the right-hand side: ``rhs(t, y, out, ctx)`` writes f(t, y) into out, ``jac(t, y, f, J,
work, tmp, ctx)`` writes df/dy into J and returns the right-hand-side evaluations it cost,
or jac is None for forward differences of every column; both are numba-compiled functions
passed as arguments (each pair compiles its own specialisation), ctx is anything they need
(a tuple of arrays and flags). The coefficients come from creatio.dynamics.solvers
.radau_coefficients, computed from the collocation nodes.

Why step and solve are inlined into their callers (numba's inline="always"): a compiled
function passed as a value makes numba embed its address, and a cached caller whose code
keeps that address cannot be cached ("dynamic globals"); inlined, rhs and jac are only ever
called, the address is optimised away, and the caller (the project's driver) stays
cacheable.

Contract (the caller owns time and the step size, as the project's driver does):

* ``ws = workspace(n, s_min, s_max, s_start, nit, thet)``: the carried state; s_min =
  s_max is a fixed-order method (at 3 stages the method of creatio's radau5).
  ``stages(ws)`` is the stage count the next step starts from.
* ``step(rhs, jac, ctx, t, t_next, h, y, f, ynew, ws, tol, fixed, rejected)`` is one try
  at the step t -> t_next = t + h from y with f = f(t, y); returns (outcome, factor, rhs
  evaluations, jacobians, decompositions, False): ACCEPTED (ynew filled; the next step is
  h factor), NEWTON_FAILED or ERROR_REJECTED (retry with h factor). The last item says
  that f(t_next, ynew) is NOT computed here: the caller evaluates it for the next step
  (the project's driver does so anyway, with its diagnostics), so nothing is spent twice.
  ``rejected`` says that the previous try of this step failed; ``fixed`` accepts every
  step whose Newton iteration converges (no error estimate, factor 1).
* ``dense(ws, t, yout)``: the last accepted step's collocation polynomial at t (degree s,
  local error O(h^(s+1)): of order s + 1 off the steps when 2 s - 1 >= s + 1).
* ``jac_ahead(ws)``: from then on, adaptive steps take their Jacobians at the stages'
  centroid (below): for free steps.
* ``ws[WS_CNT]`` holds the run's counts (CNT_*): right-hand-side calls of the stepper,
  Jacobians, real and complex LU factorisations, Newton iterations, rejected steps (error
  and Newton), accepted steps at 3, 5 and 7 stages, order changes.

Order selection (radau.f, restated). The stage count follows the contractivity of the
simplified Newton iteration, theta = ||dW_k|| / ||dW_(k-1)|| (the geometric mean of the
last two quotients from the third iteration on; thet when one iteration sufficed).
Before each new LU decomposition (new step size or new Jacobian), with
thetat = min(10, max(theta, thetat / 2)) (a slowly decaying memory of bad convergence) and
hquot = h / h_last_accepted:

* raise s by 2 (up to s_max) when the last Newton solve took more than one iteration,
  thetat <= VITU = 0.002 and 0.8 = HHOD < hquot < HHOU = 1.2: the iteration converges so
  fast that a larger system pays for itself, and the step is steady;
* lower s by 2 (down to s_min) when thetat >= VITD = 0.8, or after an unexpected rejection
  (Newton diverged, needed too many iterations, a singular matrix), or when the Newton
  rate predicted a step reduction by half or more;
* never raise within ten decompositions (or kept steps) of the last change.

A kept step (h unchanged, factors reused) counts towards those ten, and after ten of them
the order is reconsidered although nothing needs refactoring. On a change the step size
is NOT rescaled: the new order takes the same h, the tolerance is transformed for it
(rtol1 = 0.1 rtol^((s+1)/(2s)), atol1 = rtol1 atol / rtol: the estimate of order s is
matched to the global error of the order 2 s - 1 method), and its first accepted step uses
the standard controller h (1 / err)^(1/(s+1)) fac instead of Gustafsson's predictive one,
whose memory belongs to the old order. Newton's iteration limit grows with s (7, 12, 17).
One deviation from radau.f: after an order change the stages are predicted from the last
step's collocation polynomial (its own degree) instead of from zero: any degree predicts.

Step control (radau.f): err = RMS of (mu_real / h - J)^-1 (f(t, y) + sum e_i Z_i / h) over
atol1 + rtol1 |y| (refined once through f(t, y + err) on a first or retried step); factor
= 1 / max(1/8, min(5, err^(1/(s+1)) / fac)), fac = 0.9 (2 nit + 1) / (2 nit + newt),
Gustafsson's predictive controller from the second accepted step on; h is kept (factor 1,
the LU factors reused) when theta <= thet and the new step would lie in [1, 1.2] h; the
Jacobian is recomputed at the next step when theta > thet (thet: radau.f's THET, 1e-3 by
default), and at the same point after any rejection when it was not fresh.

Jacobians ahead (jac_ahead; off by default, so radau.f's choice). radau.f takes J at the
step's start; the simplified Newton iteration then contracts by about h |J(stage) - J|, the
drift of J across the step, which on long free steps (EN-02 at 0.3-0.6 s, 7 stages, rtol
1e-11) is theta 0.07-0.3 and 6.9 iterations a try, against 1.5 on the 0.1 s grid. With
jac_ahead, J is taken at the last step's collocation polynomial extrapolated to t + h c_bar,
c_bar the mean of the nodes (one more evaluation), which halves the drift: theta 0.03-0.05.
Newton's stopping tolerance there is FNEWT_AHEAD (10) times radau.f's rtol1^(1/expmns - 1),
still at most 0.03: at 7 stages and rtol 1e-11 the iteration stops at 0.2 rtol, below the
step's discretisation error. Measured on EN-02
and EN-02R over rtol 1e-10 to 2e-12 at 3-7 and 7 stages: 5.1-5.5 iterations a try at 7
stages instead of 6.9-7.5, steps up to 10 % longer (the step-size factor rewards fast
convergence), so up to 2.5x the error at a given rtol, and 22-28 % fewer evaluations at a
given error (1e-10 m; 3 times radau.f's tolerance: 11-22 %). The driver turns it on for
dense runs only (radau_high_order.passed), and only adaptive steps use it: a fixed step
keeps radau.f's Jacobian and tolerance (its Newton tolerance sets its accuracy, and radau13
at a fixed 0.4 s on EN-02 loses convergence near t = 1 s with the Jacobian ahead).

Deviations from radau.f, each for a reason: the stage predictor after an order change
(above); Jacobians ahead when asked (above); a fixed step iterates Newton up to nit instead
of giving up on a predicted slow convergence (it has no smaller step to retry); rtol is
taken as at least 10 UROUND (radau.f refuses smaller ones); no mass matrix, no second-order
(M1, M2) or index-2/3 options.
"""

from __future__ import annotations

import math

import numpy as np

from creatio.dynamics.jit import njit
from creatio.dynamics.solvers.explicit import ACCEPTED, ERROR_REJECTED, NEWTON_FAILED
from creatio.dynamics.solvers.linalg import lu_factor, lu_solve
from creatio.dynamics.solvers.radau_coefficients import STAGES, coefficients

__all__ = ["CNT_CHANGES", "CNT_JAC", "CNT_LU_COMPLEX", "CNT_LU_REAL", "CNT_NEWTON",
           "CNT_REJECTED_ERROR", "CNT_REJECTED_NEWTON", "CNT_RHS", "CNT_STEPS", "NWS", "WS_CNT",
           "WS_ERR", "WS_F", "WS_JAC", "WS_LU_COMPLEX", "WS_LU_REAL", "WS_PIV_COMPLEX",
           "WS_PIV_REAL", "WS_Q", "WS_RES_COMPLEX", "WS_RES_REAL", "WS_RS", "WS_SCAL", "WS_TMP",
           "WS_W", "WS_WORK", "WS_Y_OLD", "WS_Z", "dense", "jac_ahead", "solve", "stages",
           "step", "workspace"]

# radau.f's defaults
UROUND = 1e-16
THET = 1e-3
SAFE = 0.9
FACL = 5.0          # 1 / FAC1: h shrinks at most 5x
FACR = 0.125        # 1 / FAC2: h grows at most 8x
QUOT1 = 1.0
QUOT2 = 1.2
VITU = 0.002
VITD = 0.8
HHOU = 1.2
HHOD = 0.8
NIT = 7             # Newton iterations at s = 3; + 5 per two stages
FNEWT_AHEAD = 10.0  # Newton's stopping tolerance with jac_ahead, times radau.f's

SMAX = 7
_NM = len(STAGES)


def _tables() -> tuple[np.ndarray, ...]:
    """The three methods' constants, padded to 7 stages, in the compiled loop's layout."""
    c = np.zeros((_NM, SMAX))
    e = np.zeros((_NM, SMAX))
    t = np.zeros((_NM, SMAX, SMAX))
    ti = np.zeros((_NM, SMAX, SMAX))
    tic = np.zeros((_NM, 3, SMAX), dtype=np.complex128)
    p = np.zeros((_NM, SMAX, SMAX))
    mur = np.zeros(_NM)
    muc = np.zeros((_NM, 3), dtype=np.complex128)
    for k, s in enumerate(STAGES):
        m = coefficients(s)
        c[k, :s] = m.c
        e[k, :s] = m.e
        t[k, :s, :s] = m.t
        ti[k, :s, :s] = m.ti
        p[k, :s, :s] = m.p
        mur[k] = m.mu_real
        for q in range((s - 1) // 2):
            tic[k, q, :s] = m.ti[2 * q + 1] + 1j * m.ti[2 * q + 2]
            muc[k, q] = m.mu_complex[q]
    return c, e, t, ti, tic, p, mur, muc


_C, _E, _T, _TI, _TIC, _P, _MUR, _MUC = _tables()
#: The centroid of each method's nodes: where a free step's Jacobian is taken (jac_ahead).
_CMEAN = np.array([coefficients(s).c.mean() for s in STAGES])

# Slots of the carried float state rs
(RS_S, RS_SMIN, RS_SMAX, RS_NIT, RS_THET, RS_HAVE_JAC, RS_CURRENT_JAC, RS_NEED_JAC,
 RS_LU_H, RS_LU_S, RS_HAVE_OLD, RS_S_OLD, RS_T_OLD, RS_H_OLD, RS_THETA, RS_THETAT, RS_NEWT,
 RS_ICHAN, RS_UNEXP, RS_UNEXN, RS_CHANGE, RS_FACCON, RS_NACCPT, RS_HACC, RS_ERRACC,
 RS_AHEAD) = range(26)
_NRS = 26

# Slots of the counts
(CNT_RHS, CNT_JAC, CNT_LU_REAL, CNT_LU_COMPLEX, CNT_NEWTON, CNT_REJECTED_ERROR,
 CNT_REJECTED_NEWTON, CNT_STEPS3, CNT_STEPS5, CNT_STEPS7, CNT_CHANGES) = range(11)
_NCNT = 11
#: Count slot of the accepted steps at s stages.
CNT_STEPS = {3: CNT_STEPS3, 5: CNT_STEPS5, 7: CNT_STEPS7}


#: Slots of the workspace tuple (:func:`workspace`): the carried state (RS_*), the run's
#: counts (CNT_*), the Jacobian, the real LU factors and the complex ones (one per complex
#: pair) with their pivots, the stage increments Z, W = T^-1 Z, the stage derivatives F, the
#: last step's polynomial Q and its start y, the real and complex Newton residuals, the error
#: estimate, a trial state, a trial derivative and the error scale atol1 + rtol1 |y|.
(WS_RS, WS_CNT, WS_JAC, WS_LU_REAL, WS_LU_COMPLEX, WS_PIV_REAL, WS_PIV_COMPLEX, WS_Z, WS_W,
 WS_F, WS_Q, WS_Y_OLD, WS_RES_REAL, WS_RES_COMPLEX, WS_ERR, WS_WORK, WS_TMP,
 WS_SCAL) = range(18)
NWS = 18


@njit(cache=True)
def workspace(n, s_min, s_max, s_start, nit=NIT, thet=THET):
    """Carried state and work arrays for a state of size n, in the WS_* order, stages in
    [s_min, s_max] (odd, 3..7), starting at s_start; at most nit Newton iterations at 3
    stages (radau.f's IWORK(3); nit + 5 at 5 stages, nit + 10 at 7); the Jacobian kept while
    Newton contracts by thet or better (radau.f's WORK(3): 1e-3; Hairer advises 0.1 when a
    Jacobian is costly). Nothing computed yet."""
    rs = np.zeros(_NRS)
    rs[RS_S] = s_start
    rs[RS_NIT] = nit
    rs[RS_THET] = thet
    rs[RS_SMIN] = s_min
    rs[RS_SMAX] = s_max
    rs[RS_LU_H] = -1.0
    rs[RS_FACCON] = 1.0
    return (
        rs,                                         # WS_RS
        np.zeros(_NCNT, dtype=np.int64),            # WS_CNT
        np.empty((n, n)),                           # WS_JAC
        np.empty((n, n)),                           # WS_LU_REAL
        np.empty((3, n, n), dtype=np.complex128),   # WS_LU_COMPLEX
        np.empty(n, dtype=np.int64),                # WS_PIV_REAL
        np.empty((3, n), dtype=np.int64),           # WS_PIV_COMPLEX
        np.zeros((SMAX, n)),                        # WS_Z: stage increments
        np.zeros((SMAX, n)),                        # WS_W = T^-1 Z
        np.empty((SMAX, n)),                        # WS_F: stage derivatives
        np.zeros((SMAX, n)),                        # WS_Q: last step's polynomial (x^1 .. x^s)
        np.empty(n),                                # WS_Y_OLD: y at the last step's start
        np.empty(n),                                # WS_RES_REAL: real residual / work
        np.empty((3, n), dtype=np.complex128),      # WS_RES_COMPLEX: complex residuals
        np.empty(n),                                # WS_ERR: error estimate
        np.empty(n),                                # WS_WORK: a trial state
        np.empty(n),                                # WS_TMP: a trial derivative
        np.empty(n),                                # WS_SCAL: atol1 + rtol1 |y|
    )


@njit(cache=True)
def jac_ahead(ws):
    """Take every later Jacobian at the predicted state at the stages' centroid instead of
    at the step's start (for free steps; see the module docstring)."""
    ws[WS_RS][RS_AHEAD] = 1.0


@njit(cache=True)
def stages(ws):
    """The stage count the next step will start from."""
    return int(ws[WS_RS][RS_S])


@njit(cache=True, inline="always")
def _fd_jacobian(rhs, t, y, f, jac, work, tmp, ctx):
    """Forward-difference Jacobian df/dy of every column into jac; returns its cost in
    right-hand-side evaluations (n). Steps as creatio's radau5: sqrt(eps) max(|y_j|, 1)."""
    n = y.size
    for j in range(n):
        work[j] = y[j]
    for j in range(n):
        delta = 1.4901161193847656e-08 * max(abs(y[j]), 1.0)
        work[j] = y[j] + delta
        delta = work[j] - y[j]
        rhs(t, work, tmp, ctx)
        for i in range(n):
            jac[i, j] = (tmp[i] - f[i]) / delta
        work[j] = y[j]
    return n


@njit(cache=True)
def _select_order(h, rs):
    """radau.f's order selection before a decomposition (see the module docstring)."""
    s = int(rs[RS_S])
    s_min = int(rs[RS_SMIN])
    s_max = int(rs[RS_SMAX])
    rs[RS_ICHAN] += 1.0
    hquot = h / rs[RS_H_OLD] if rs[RS_H_OLD] > 0.0 else 1.0
    rs[RS_THETAT] = min(10.0, max(rs[RS_THETA], 0.5 * rs[RS_THETAT]))
    thetat = rs[RS_THETAT]
    snew = s
    if rs[RS_NEWT] > 1.0 and thetat <= VITU and HHOD < hquot < HHOU:
        snew = min(s_max, s + 2)
    if thetat >= VITD or rs[RS_UNEXP] > 0.0:
        snew = max(s_min, s - 2)
    if rs[RS_ICHAN] >= 1.0 and rs[RS_UNEXN] > 0.0:
        snew = max(s_min, s - 2)
    if rs[RS_ICHAN] <= 10.0:
        snew = min(s, snew)
    rs[RS_UNEXP] = 0.0
    rs[RS_UNEXN] = 0.0
    rs[RS_CHANGE] = 1.0 if snew != s else 0.0
    if snew != s:
        rs[RS_S] = snew
        rs[RS_ICHAN] = 1.0
        return True
    return False


@njit(cache=True)
def _factor(h, k, s, jac, lur, luc, pivr, pivc):
    """LU factors of mu_real / h - J and of each mu_complex / h - J; False when singular."""
    n = jac.shape[0]
    mr = _MUR[k] / h
    for i in range(n):
        for j in range(n):
            lur[i, j] = -jac[i, j]
        lur[i, i] += mr
    ok = lu_factor(lur, pivr)
    for q in range((s - 1) // 2):
        mc = _MUC[k, q] / h
        a = luc[q]
        for i in range(n):
            for j in range(n):
                a[i, j] = -jac[i, j]
            a[i, i] += mc
        ok = lu_factor(a, pivc[q]) and ok
    return ok


@njit(cache=True)
def _fail(rs, factor, unexpected):
    """Bookkeeping of a failed Newton solve: retry at h factor, with a fresh Jacobian at
    the same point when the one used was not (radau.f: caljac)."""
    if unexpected:
        rs[RS_UNEXP] = 1.0
    elif factor <= 0.5:
        rs[RS_UNEXN] = 1.0
    if rs[RS_CURRENT_JAC] == 0.0:
        rs[RS_NEED_JAC] = 1.0


@njit(cache=True, inline="always")
def step(rhs, jac, ctx, t, t_next, h, y, f, ynew, ws, tol, fixed, rejected):
    """One try at the step t -> t_next = t + h; see the module docstring for the contract.

    Returns (outcome, factor, rhs evaluations, jacobians, decompositions, False).
    """
    rs, cnt, J, lur, luc = ws[WS_RS], ws[WS_CNT], ws[WS_JAC], ws[WS_LU_REAL], ws[WS_LU_COMPLEX]
    pivr, pivc, Z, W, F = ws[WS_PIV_REAL], ws[WS_PIV_COMPLEX], ws[WS_Z], ws[WS_W], ws[WS_F]
    Q, yold, rreal, rcplx = ws[WS_Q], ws[WS_Y_OLD], ws[WS_RES_REAL], ws[WS_RES_COMPLEX]
    err, work, tmp, scal = ws[WS_ERR], ws[WS_WORK], ws[WS_TMP], ws[WS_SCAL]
    rtol, atol = tol
    n = y.size
    evals = 0
    n_jac = 0
    n_dec = 0
    if rs[RS_HAVE_JAC] == 0.0 or rs[RS_NEED_JAC] > 0.0:
        if rs[RS_AHEAD] > 0.0 and rs[RS_HAVE_OLD] > 0.0 and not fixed:
            # at the last step's collocation polynomial, extrapolated to the stages' centroid
            # (err and rreal are free until the Newton iteration)
            tm = t + _CMEAN[(int(rs[RS_S]) - 3) // 2] * h
            dense(ws, tm, err)
            rhs(tm, err, rreal, ctx)
            evals += 1
            if jac is None:
                evals += _fd_jacobian(rhs, tm, err, rreal, J, work, tmp, ctx)
            else:
                evals += jac(tm, err, rreal, J, work, tmp, ctx)
        elif jac is None:
            evals += _fd_jacobian(rhs, t, y, f, J, work, tmp, ctx)
        else:
            evals += jac(t, y, f, J, work, tmp, ctx)
        n_jac += 1
        rs[RS_HAVE_JAC] = 1.0
        rs[RS_CURRENT_JAC] = 1.0
        rs[RS_NEED_JAC] = 0.0
        rs[RS_LU_H] = -1.0
    # radau.f chooses the order before every decomposition; a kept step counts towards
    # the ten that must pass before an increase, and after them reconsiders the order
    refactor = rs[RS_LU_H] < 0.0 or abs(h - rs[RS_LU_H]) > 1e-3 * h
    if rs[RS_SMIN] < rs[RS_SMAX]:
        if not refactor:
            rs[RS_ICHAN] += 1.0
            if rs[RS_ICHAN] >= 10.0 and rs[RS_S] < rs[RS_SMAX]:
                refactor = True
        if refactor:
            if _select_order(h, rs):
                cnt[CNT_CHANGES] += 1
    s = int(rs[RS_S])
    k = (s - 3) // 2
    if refactor or rs[RS_LU_S] != s:
        regular = _factor(h, k, s, J, lur, luc, pivr, pivc)
        n_dec += 1
        cnt[CNT_LU_REAL] += 1
        cnt[CNT_LU_COMPLEX] += (s - 1) // 2
        rs[RS_LU_H] = h
        rs[RS_LU_S] = s
        if not regular:
            rs[RS_LU_H] = -1.0
            _fail(rs, 0.5, True)
            cnt[CNT_RHS] += evals
            cnt[CNT_JAC] += n_jac
            cnt[CNT_REJECTED_NEWTON] += 1
            return NEWTON_FAILED, 0.5, evals, n_jac, n_dec, False
    # tolerances transformed for the order (radau.f), the Newton stopping tolerance
    rt = max(rtol, 10.0 * UROUND)
    expmns = (s + 1.0) / (2.0 * s)
    rtol1 = 0.1 * rt**expmns
    atol1 = rtol1 * (atol / rt)
    for j in range(n):
        scal[j] = atol1 + rtol1 * abs(y[j])
    loose = FNEWT_AHEAD if rs[RS_AHEAD] > 0.0 and not fixed else 1.0
    fnewt = max(10.0 * UROUND / rtol1, min(0.03, loose * rtol1 ** (1.0 / expmns - 1.0)))
    # starting values: the last accepted step's collocation polynomial (any degree)
    if rs[RS_HAVE_OLD] > 0.0:
        so = int(rs[RS_S_OLD])
        for i in range(s):
            tc = t_next if i == s - 1 else t + _C[k, i] * h
            x = (tc - rs[RS_T_OLD]) / rs[RS_H_OLD]
            for j in range(n):
                acc = Q[so - 1, j]
                for q in range(so - 2, -1, -1):
                    acc = acc * x + Q[q, j]
                Z[i, j] = yold[j] + acc * x - y[j]
    else:
        for i in range(s):
            for j in range(n):
                Z[i, j] = 0.0
    for i in range(s):
        for j in range(n):
            acc = 0.0
            for q in range(s):
                acc += _TI[k, i, q] * Z[q, j]
            W[i, j] = acc
    # simplified Newton iteration on W (radau.f)
    nit = int(rs[RS_NIT]) + 5 * k
    faccon = max(rs[RS_FACCON], UROUND) ** 0.8
    thet = rs[RS_THET]
    theta = thet
    newt = 0
    dynold = 0.0
    thqold = 0.0
    mr = _MUR[k] / h
    converged = False
    failed = False
    factor = 0.5
    unexpected = True
    while True:
        if newt >= nit:
            failed = True
            break
        finite = True
        for i in range(s):
            tc = t_next if i == s - 1 else t + _C[k, i] * h
            for j in range(n):
                work[j] = y[j] + Z[i, j]
            rhs(tc, work, tmp, ctx)
            for j in range(n):
                F[i, j] = tmp[j]
                if not math.isfinite(tmp[j]):
                    finite = False
        evals += s
        if not finite:
            failed = True
            break
        for j in range(n):
            acc = 0.0
            for q in range(s):
                acc += _TI[k, 0, q] * F[q, j]
            rreal[j] = acc - mr * W[0, j]
        lu_solve(lur, pivr, rreal)
        for p in range((s - 1) // 2):
            mc = _MUC[k, p] / h
            rc = rcplx[p]
            for j in range(n):
                acc = 0.0j
                for q in range(s):
                    acc += _TIC[k, p, q] * F[q, j]
                rc[j] = acc - mc * (W[2 * p + 1, j] + 1j * W[2 * p + 2, j])
            lu_solve(luc[p], pivc[p], rc)
        newt += 1
        s2 = 0.0
        for j in range(n):
            sc = scal[j]
            s2 += (rreal[j] / sc) ** 2
            for p in range((s - 1) // 2):
                s2 += (rcplx[p, j].real / sc) ** 2 + (rcplx[p, j].imag / sc) ** 2
        dyno = math.sqrt(s2 / (n * s))
        if newt > 1 and newt < nit:
            thq = dyno / dynold
            theta = thq if newt == 2 else math.sqrt(thq * thqold)
            thqold = thq
            if theta < 0.99:
                faccon = theta / (1.0 - theta)
                dyth = faccon * dyno * theta ** (nit - 1 - newt) / fnewt
                # a fixed step has no smaller one to retry: it iterates up to nit
                if dyth >= 1.0 and not fixed:
                    # too slow to converge in time: a smaller step, chosen by the rate
                    qnewt = max(1e-4, min(20.0, dyth))
                    factor = 0.8 * qnewt ** (-1.0 / (4.0 + nit - 1 - newt))
                    unexpected = False
                    failed = True
                    break
            else:
                failed = True
                break
        dynold = max(dyno, UROUND)
        for j in range(n):
            W[0, j] += rreal[j]
            for p in range((s - 1) // 2):
                W[2 * p + 1, j] += rcplx[p, j].real
                W[2 * p + 2, j] += rcplx[p, j].imag
        for i in range(s):
            for j in range(n):
                acc = 0.0
                for q in range(s):
                    acc += _T[k, i, q] * W[q, j]
                Z[i, j] = acc
        if faccon * dyno <= fnewt:
            converged = True
            break
    rs[RS_THETA] = theta
    rs[RS_NEWT] = newt
    rs[RS_FACCON] = faccon
    cnt[CNT_NEWTON] += newt
    if not converged or failed:
        _fail(rs, factor, unexpected)
        cnt[CNT_RHS] += evals
        cnt[CNT_JAC] += n_jac
        cnt[CNT_REJECTED_NEWTON] += 1
        return NEWTON_FAILED, factor, evals, n_jac, n_dec, False
    for j in range(n):
        ynew[j] = y[j] + Z[s - 1, j]
    errn = 0.0
    first = rs[RS_NACCPT] == 0.0
    if not fixed:
        # (mu_real / h - J)^-1 (f + sum e_i Z_i / h): Hairer's embedded estimate of order s
        for j in range(n):
            acc = 0.0
            for i in range(s):
                acc += _E[k, i] * Z[i, j]
            tmp[j] = acc / h
            err[j] = f[j] + tmp[j]
        lu_solve(lur, pivr, err)
        s2 = 0.0
        for j in range(n):
            s2 += (err[j] / scal[j]) ** 2
        errn = max(math.sqrt(s2 / n), 1e-10)
        if errn >= 1.0 and (first or rejected):
            for j in range(n):
                work[j] = y[j] + err[j]
            rhs(t, work, rreal, ctx)
            evals += 1
            for j in range(n):
                err[j] = rreal[j] + tmp[j]
            lu_solve(lur, pivr, err)
            s2 = 0.0
            for j in range(n):
                s2 += (err[j] / scal[j]) ** 2
            errn = max(math.sqrt(s2 / n), 1e-10)
        if not math.isfinite(errn):
            errn = math.inf
    cnt[CNT_RHS] += evals
    cnt[CNT_JAC] += n_jac
    expo = 1.0 / (s + 1.0)
    fac = min(SAFE, (2 * nit + 1) * SAFE / (newt + 2 * nit))
    quot = max(FACR, min(FACL, errn**expo / fac))
    if errn >= 1.0:
        cnt[CNT_REJECTED_ERROR] += 1
        if rs[RS_CURRENT_JAC] == 0.0:
            rs[RS_NEED_JAC] = 1.0
        factor = 0.1 if first else 1.0 / quot
        return ERROR_REJECTED, factor, evals, n_jac, n_dec, False
    # accepted
    if fixed:
        factor = 1.0
    else:
        if rs[RS_CHANGE] == 0.0:
            # Gustafsson's predictive controller (not across an order change)
            if rs[RS_NACCPT] >= 1.0:
                facgus = rs[RS_HACC] / h * (errn * errn / rs[RS_ERRACC]) ** expo / SAFE
                facgus = max(FACR, min(FACL, facgus))
                quot = max(quot, facgus)
            rs[RS_HACC] = h
            rs[RS_ERRACC] = max(0.01, errn)
        factor = 1.0 / quot
        if rejected:
            factor = min(factor, 1.0)
        if theta <= thet and QUOT1 <= factor <= QUOT2:
            factor = 1.0  # keep h and the factors
    rs[RS_NACCPT] += 1.0
    rs[RS_CURRENT_JAC] = 0.0
    if theta > thet:
        rs[RS_NEED_JAC] = 1.0
    cnt[CNT_STEPS3 + k] += 1
    # the step's collocation polynomial u(t + x h) = y + sum_q Q[q] x^(q+1), Q = P^T Z
    for q in range(s):
        for j in range(n):
            acc = 0.0
            for i in range(s):
                acc += _P[k, i, q] * Z[i, j]
            Q[q, j] = acc
    for j in range(n):
        yold[j] = y[j]
    rs[RS_HAVE_OLD] = 1.0
    rs[RS_S_OLD] = s
    rs[RS_T_OLD] = t
    rs[RS_H_OLD] = h
    return ACCEPTED, factor, evals, n_jac, n_dec, False


@njit(cache=True)
def dense(ws, t, yout):
    """The last accepted step's collocation polynomial at t (inside the step, or beyond it
    for a prediction)."""
    rs = ws[WS_RS]
    Q = ws[WS_Q]
    yold = ws[WS_Y_OLD]
    so = int(rs[RS_S_OLD])
    x = (t - rs[RS_T_OLD]) / rs[RS_H_OLD]
    for j in range(yold.size):
        acc = Q[so - 1, j]
        for q in range(so - 2, -1, -1):
            acc = acc * x + Q[q, j]
        yout[j] = yold[j] + acc * x


@njit(cache=True, inline="always")
def solve(rhs, jac, ctx, t0, y0, t_end, h0, rtol, atol, s_min, s_max, s_start, fixed,
          max_steps, t_dense, nit=NIT, thet=THET, ahead=False):
    """A minimal driver for standalone use and tests: integrate from (t0, y0) to t_end.

    Steps run free (fixed: the constant h0, the last one shortened to land on t_end), and
    t_dense (increasing, inside (t0, t_end]) is sampled from each step's dense output;
    ahead: Jacobians at the stages' centroid (:func:`jac_ahead`).
    Returns (ok, y_end, samples, counts, rhs evaluations in all, steps, step times, step
    states): the counts are the stepper's (CNT_*), the evaluations include f at each step's
    end; the step times and states are the first `steps` rows.
    """
    n = y0.size
    ws = workspace(n, s_min, s_max, s_start, nit, thet)
    if ahead:
        jac_ahead(ws)
    y = y0.copy()
    ynew = np.empty(n)
    f = np.empty(n)
    out = np.full((t_dense.size, n), np.nan)
    ts = np.empty(max_steps)
    ys = np.empty((max_steps, n))
    rhs(t0, y, f, ctx)
    evals = 1
    t = t0
    h = min(h0, t_end - t0)
    steps = 0
    jd = 0
    ok = True
    while t < t_end:
        if steps >= max_steps or h < 1e-14 * max(1.0, abs(t_end)):
            ok = False
            break
        last = h >= (t_end - t) * (1.0 - 1e-12)
        h_use = t_end - t if last else h
        t_next = t_end if last else t + h_use
        rejected = False
        while True:
            outcome, factor, ev, _, _, _ = step(rhs, jac, ctx, t, t_next, h_use, y, f, ynew,
                                                ws, (rtol, atol), fixed, rejected)
            evals += ev
            if outcome == ACCEPTED:
                break
            if fixed and outcome == NEWTON_FAILED:
                ok = False
                break
            rejected = True
            h_use *= factor
            last = False
            t_next = t + h_use
            if h_use < 1e-14 * max(1.0, abs(t_end)):
                ok = False
                break
        if not ok:
            break
        while jd < t_dense.size and t_dense[jd] <= t_next:
            dense(ws, t_dense[jd], out[jd])
            jd += 1
        ts[steps] = t_next
        for j in range(n):
            ys[steps, j] = ynew[j]
        steps += 1
        t = t_next
        for j in range(n):
            y[j] = ynew[j]
        rhs(t, y, f, ctx)
        evals += 1
        if not fixed:
            h = h_use * factor
    return ok, y, out, ws[WS_CNT].copy(), evals, steps, ts, ys
