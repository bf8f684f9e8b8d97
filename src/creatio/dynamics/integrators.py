"""Adaptive and stiffness-aware integrators of the sphere dynamics, each one compiled loop.

Three methods share one driver (`_drive`) and the RK4 loop's per-step diagnostics
(core._observe), so extrema are taken over every accepted step and histories are written on
the same output grid:

* ``dopri5``: Dormand-Prince 5(4), 6 stages + FSAL, error exponent -1/5;
* ``dop853``: Dormand-Prince 8(5,3), 12 stages + FSAL, Hairer's combined 5th/3rd-order
  error estimate, error exponent -1/8;
* ``radau5``: Radau IIA order 5 (3-stage collocation, L-stable), simplified Newton with
  the real/complex eigen-split of its matrix, a forward-difference Jacobian reused across
  steps, and Gustafsson's predictive step control (Hairer & Wanner, Solving ODEs II, IV.8).
  Its step is not capped by the friction's slip relaxation: the implicit stage equations
  damp the stiff slip mode at any h (L-stability), so h follows the slow dynamics.

Step control is scipy.integrate's for the same pairs (safety 0.9, factors in [0.2, 10], RMS
norm of err / (atol + rtol max(|y|, |y_new|))), so native and scipy runs of a method take
comparable steps. Steps never cross an output time: each output interval is split into
equal steps no longer than the controller's proposal, so histories are exact step values
(no interpolation error) and Radau's LU factors stay valid while the proposal is steady.
With ``fixed`` set every method takes the constant step h0 (error control off), which is
how the stability map probes an explicit scheme's limit.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from creatio.dynamics import tableaus as tb
from creatio.dynamics.core import _observe, _pack, _rhs, new_extrema

__all__ = ["METHODS", "ORDERS", "run", "real_stability_bound"]

#: Method name -> integer id of the compiled driver.
METHODS = {"dopri5": 1, "dop853": 2, "radau5": 3}

#: Classical order of each method (RK4 included for reference).
ORDERS = {"rk4": 4, "dopri5": 5, "dop853": 8, "radau5": 5}

_SAFETY = 0.9
_MIN_FACTOR = 0.2
_MAX_FACTOR = 10.0
_NEWTON_MAXITER = 6
#: Newton contraction rate above which radau5 refreshes its Jacobian (Hairer's THET).
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


@njit(cache=True)
def _lu(a, piv):
    """In-place LU factorisation with partial pivoting (real or complex square matrix);
    False when a pivot is exactly zero (singular: the factors must not be used)."""
    n = a.shape[0]
    ok = True
    for k in range(n):
        p = k
        best = abs(a[k, k])
        for i in range(k + 1, n):
            v = abs(a[i, k])
            if v > best:
                best = v
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                tmp = a[k, j]
                a[k, j] = a[p, j]
                a[p, j] = tmp
        d = a[k, k]
        if d == 0.0:
            ok = False
            continue
        for i in range(k + 1, n):
            a[i, k] /= d
            lik = a[i, k]
            if lik != 0.0:
                for j in range(k + 1, n):
                    a[i, j] -= lik * a[k, j]
    return ok


@njit(cache=True)
def _lu_solve(a, piv, b):
    """Solve in place a x = b with the factors of _lu (b overwritten by x)."""
    n = a.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= a[i, j] * b[j]
        b[i] = s
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= a[i, j] * b[j]
        b[i] = s / a[i, i]


@njit(cache=True)
def _rms(x):
    s = 0.0
    for v in x.flat:
        s += v * v
    return math.sqrt(s / x.size)


@njit(cache=True)
def _jacobian(t, y, f, jac, work, tmp, pp, lc, rot, en):
    """Jacobian df/dy into jac; returns the right-hand-side evaluations it cost.

    Only (R, alpha, Rdot, alphadot, omega) drive the dynamics: their columns are forward
    differences. The quaternion block is exact (dQ/dt = Omega(omega) Q / 2 is linear in Q)
    and the accumulators (cumulative spin, surface work, dissipation) feed nothing back, so
    their columns are zero.
    """
    n = y.size
    for i in range(n):
        for j in range(n):
            jac[i, j] = 0.0
    for j in range(n):
        work[j] = y[j]
    active = 7 if rot else 4
    for j in range(active):
        delta = 1.4901161193847656e-08 * max(abs(y[j]), 1.0)
        work[j] = y[j] + delta
        delta = work[j] - y[j]
        _rhs(t, work, tmp, pp, lc, rot, en, False)
        for i in range(n):
            jac[i, j] = (tmp[i] - f[i]) / delta
        work[j] = y[j]
    if rot:
        wx = 0.5 * y[4]
        wy = 0.5 * y[5]
        wz = 0.5 * y[6]
        # rows dQ/dt (7..10) against columns Q (7..10), from core._rhs:
        # dq0 = -(wx q1 + wy q2 + wz q3)/2, dq1 = (q0 wx + wy q3 - wz q2)/2,
        # dq2 = (q0 wy + wz q1 - wx q3)/2, dq3 = (q0 wz + wx q2 - wy q1)/2
        jac[7, 8] = -wx
        jac[7, 9] = -wy
        jac[7, 10] = -wz
        jac[8, 7] = wx
        jac[8, 9] = -wz
        jac[8, 10] = wy
        jac[9, 7] = wy
        jac[9, 8] = wz
        jac[9, 10] = -wx
        jac[10, 7] = wz
        jac[10, 8] = -wy
        jac[10, 9] = wx
    return active


@njit(cache=True)
def _initial_step(t, y, f, order, rtol, atol, h_cap, pp, lc, rot, en, work, tmp):
    """Hairer's starting step (Solving ODEs I, II.4), as scipy's select_initial_step."""
    n = y.size
    d0 = 0.0
    d1 = 0.0
    for j in range(n):
        sc = atol + abs(y[j]) * rtol
        d0 += (y[j] / sc) ** 2
        d1 += (f[j] / sc) ** 2
    d0 = math.sqrt(d0 / n)
    d1 = math.sqrt(d1 / n)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, h_cap)
    for j in range(n):
        work[j] = y[j] + h0 * f[j]
    _rhs(t + h0, work, tmp, pp, lc, rot, en, False)
    d2 = 0.0
    for j in range(n):
        sc = atol + abs(y[j]) * rtol
        d2 += ((tmp[j] - f[j]) / sc) ** 2
    d2 = math.sqrt(d2 / n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100.0 * h0, h1, h_cap)


@njit(cache=True)
def _drive(p, lawc, y0, t_end, interval, h0, rtol, atol, method, fixed, max_steps, out, rot, en):
    """Integrate from t = 0 to t_end with `method`; rows of `out` are the sampled histories.

    h0: the constant step when fixed, else the first step (<= 0: Hairer's estimate).
    Returns (status, steps, rows, rhs_evals, extrema, rejected, jacobians, lu_factorisations,
    stop_time). Status 6 (step_failed) when the step underflows, Newton fails at a fixed
    step, or max_steps is reached.
    """
    pp, lc = _pack(p, lawc)
    n = y0.size
    if method == 1:
        A = tb.DP5_A
        B = tb.DP5_B
        C = tb.DP5_C
        E5 = tb.DP5_E
        E3 = tb.DP5_E
        order = 4
    else:
        A = tb.DOP853_A
        B = tb.DOP853_B
        C = tb.DOP853_C
        E5 = tb.DOP853_E5
        E3 = tb.DOP853_E3
        order = 7
    if method == 3:
        order = 3
    stages = B.size
    K = np.empty((stages + 1, n))
    y = y0.copy()
    ynew = np.empty(n)
    f = np.empty(n)
    fnew = np.empty(n)
    work = np.empty(n)
    tmp = np.empty(n)
    # Radau work space
    jac = np.empty((n, n))
    lur = np.empty((n, n))
    luc = np.empty((n, n), dtype=np.complex128)
    pivr = np.empty(n, dtype=np.int64)
    pivc = np.empty(n, dtype=np.int64)
    Z = np.zeros((3, n))
    Z0 = np.zeros((3, n))
    W = np.zeros((3, n))
    F = np.empty((3, n))
    Qold = np.zeros((n, 3))
    yold = np.empty(n)
    rreal = np.empty(n)
    rcplx = np.empty(n, dtype=np.complex128)
    err = np.empty(n)
    ext = new_extrema(en)
    evals = 0
    n_rej = 0
    n_jac = 0
    n_lu = 0
    rows = 0
    steps = 0
    t = 0.0
    n_int = int(math.floor(t_end / interval * (1.0 + 1e-12)))
    jn = 1
    m = 1
    d = _rhs(t, y, f, pp, lc, rot, en, True)
    dn = d
    evals += 1
    status, wrote = _observe(True, t, y, d, p, ext, out, rows, t_end <= 0.0, True, rot, en)
    rows += wrote
    if fixed:
        h = h0
    elif h0 > 0.0:
        h = min(h0, interval)
    else:
        h = _initial_step(t, y, f, order, rtol, atol, interval, pp, lc, rot, en, work, tmp)
        evals += 1
    expo = -1.0 / (order + 1)
    newton_tol = max(10.0 * _EPS / rtol, min(0.03, math.sqrt(rtol))) if rtol > 0 else 0.03
    # Radau state between steps
    have_jac = False
    current_jac = False
    lu_h = -1.0
    have_old = False
    t_old = 0.0
    h_prev = 0.0
    h_abs_old = -1.0
    err_old = -1.0
    while status == 0 and t < t_end:
        t_target = jn * interval if jn <= n_int else t_end
        if t_target > t_end:
            t_target = t_end
        remaining = t_target - t
        rejected = False
        accepted = False
        n_iter = 0
        rate = 0.0
        newton_failed = False
        h_use = h
        while not accepted:
            if steps >= max_steps or h < 1e-12 * max(1.0, t_end) or not math.isfinite(h):
                status = 6
                break
            m = math.ceil(remaining / h * (1.0 - 1e-9))
            if m < 1:
                m = 1
            h_use = remaining / m
            if t + h_use <= t:
                status = 6
                break
            if method != 3:
                for j in range(n):
                    K[0, j] = f[j]
                for st in range(1, stages):
                    for j in range(n):
                        acc = 0.0
                        for q in range(st):
                            acc += A[st, q] * K[q, j]
                        work[j] = y[j] + h_use * acc
                    _rhs(t + C[st] * h_use, work, K[st], pp, lc, rot, en, False)
                for j in range(n):
                    acc = 0.0
                    for q in range(stages):
                        acc += B[q] * K[q, j]
                    ynew[j] = y[j] + h_use * acc
                dn = _rhs(t + h_use, ynew, fnew, pp, lc, rot, en, True)
                for j in range(n):
                    K[stages, j] = fnew[j]
                evals += stages
                if fixed:
                    accepted = True
                    break
                if method == 1:
                    s2 = 0.0
                    for j in range(n):
                        acc = 0.0
                        for q in range(stages + 1):
                            acc += E5[q] * K[q, j]
                        sc = atol + max(abs(y[j]), abs(ynew[j])) * rtol
                        s2 += (h_use * acc / sc) ** 2
                    en_err = math.sqrt(s2 / n)
                else:
                    e5 = 0.0
                    e3 = 0.0
                    for j in range(n):
                        a5 = 0.0
                        a3 = 0.0
                        for q in range(stages + 1):
                            a5 += E5[q] * K[q, j]
                            a3 += E3[q] * K[q, j]
                        sc = atol + max(abs(y[j]), abs(ynew[j])) * rtol
                        e5 += (a5 / sc) ** 2
                        e3 += (a3 / sc) ** 2
                    if e5 == 0.0 and e3 == 0.0:
                        en_err = 0.0
                    else:
                        en_err = h_use * e5 / math.sqrt((e5 + 0.01 * e3) * n)
                if not math.isfinite(en_err):
                    en_err = math.inf
                if en_err < 1.0:
                    if en_err == 0.0:
                        factor = _MAX_FACTOR
                    else:
                        factor = min(_MAX_FACTOR, _SAFETY * en_err**expo)
                    if rejected:
                        factor = min(1.0, factor)
                    # a step shortened to land on an output time says nothing against h
                    h = (
                        max(h, h_use * factor)
                        if (m == 1 and h_use < h and factor >= 1.0)
                        else (h_use * factor)
                    )
                    accepted = True
                else:
                    h = h_use * max(_MIN_FACTOR, _SAFETY * en_err**expo)
                    rejected = True
                    n_rej += 1
                continue
            # ---------------------------------------------------------- Radau IIA
            if not have_jac:
                evals += _jacobian(t, y, f, jac, work, tmp, pp, lc, rot, en)
                n_jac += 1
                have_jac = True
                current_jac = True
                lu_h = -1.0
            if have_old:
                for i in range(3):
                    x = (t + h_use * _RC[i] - t_old) / h_prev
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
            converged = False
            while not converged:
                if abs(h_use - lu_h) > 1e-3 * h_use:
                    mr = _MU_R / h_use
                    mc = _MU_C / h_use
                    for i in range(n):
                        for j in range(n):
                            lur[i, j] = -jac[i, j]
                            luc[i, j] = -jac[i, j]
                        lur[i, i] += mr
                        luc[i, i] += mc
                    regular = _lu(lur, pivr) and _lu(luc, pivc)
                    n_lu += 1
                    lu_h = h_use
                    if not regular:
                        lu_h = -1.0
                        break
                # simplified Newton on the transformed stage increments W = TI Z
                for i in range(3):
                    for j in range(n):
                        W[i, j] = (
                            _RTI[i, 0] * Z0[0, j] + _RTI[i, 1] * Z0[1, j] + _RTI[i, 2] * Z0[2, j]
                        )
                        Z[i, j] = Z0[i, j]
                mr = _MU_R / h_use
                mc = _MU_C / h_use
                dw_old = -1.0
                rate = -1.0
                converged = False
                n_iter = 0
                for it in range(_NEWTON_MAXITER):
                    n_iter = it + 1
                    finite = True
                    for i in range(3):
                        for j in range(n):
                            work[j] = y[j] + Z[i, j]
                        _rhs(t + _RC[i] * h_use, work, tmp, pp, lc, rot, en, False)
                        for j in range(n):
                            F[i, j] = tmp[j]
                            if not math.isfinite(tmp[j]):
                                finite = False
                    evals += 3
                    if not finite:
                        break
                    for j in range(n):
                        rreal[j] = (
                            _RTI[0, 0] * F[0, j]
                            + _RTI[0, 1] * F[1, j]
                            + _RTI[0, 2] * F[2, j]
                            - mr * W[0, j]
                        )
                        rcplx[j] = (
                            _TI_C[0] * F[0, j]
                            + _TI_C[1] * F[1, j]
                            + _TI_C[2] * F[2, j]
                            - mc * (W[1, j] + 1j * W[2, j])
                        )
                    _lu_solve(lur, pivr, rreal)
                    _lu_solve(luc, pivc, rcplx)
                    s2 = 0.0
                    for j in range(n):
                        sc = atol + abs(y[j]) * rtol
                        s2 += (
                            (rreal[j] / sc) ** 2
                            + (rcplx[j].real / sc) ** 2
                            + (rcplx[j].imag / sc) ** 2
                        )
                    dw = math.sqrt(s2 / (3 * n))
                    if dw_old > 0.0:
                        rate = dw / dw_old
                    if rate >= 0.0 and (
                        rate >= 1.0
                        or rate ** (_NEWTON_MAXITER - it) / (1.0 - rate) * dw > newton_tol
                    ):
                        break
                    for j in range(n):
                        W[0, j] += rreal[j]
                        W[1, j] += rcplx[j].real
                        W[2, j] += rcplx[j].imag
                    for i in range(3):
                        for j in range(n):
                            Z[i, j] = (
                                _RT[i, 0] * W[0, j] + _RT[i, 1] * W[1, j] + _RT[i, 2] * W[2, j]
                            )
                    if dw == 0.0 or (rate >= 0.0 and rate / (1.0 - rate) * dw < newton_tol):
                        converged = True
                        break
                    dw_old = dw
                if not converged:
                    if current_jac:
                        break
                    evals += _jacobian(t, y, f, jac, work, tmp, pp, lc, rot, en)
                    n_jac += 1
                    current_jac = True
                    lu_h = -1.0
            if not converged:
                if fixed:
                    newton_failed = True
                    status = 6
                    break
                h = 0.5 * h_use
                lu_h = -1.0
                n_rej += 1
                continue
            for j in range(n):
                ynew[j] = y[j] + Z[2, j]
            # error estimate: (mu_real/h I - J)^-1 (f + Z^T E / h)
            for j in range(n):
                ze = (Z[0, j] * _RE[0] + Z[1, j] * _RE[1] + Z[2, j] * _RE[2]) / h_use
                tmp[j] = ze
                err[j] = f[j] + ze
            _lu_solve(lur, pivr, err)
            s2 = 0.0
            for j in range(n):
                sc = atol + max(abs(y[j]), abs(ynew[j])) * rtol
                s2 += (err[j] / sc) ** 2
            en_err = math.sqrt(s2 / n)
            safety = 0.9 * (2 * _NEWTON_MAXITER + 1) / (2 * _NEWTON_MAXITER + n_iter)
            if rejected and en_err > 1.0 and not fixed:
                for j in range(n):
                    work[j] = y[j] + err[j]
                _rhs(t, work, rreal, pp, lc, rot, en, False)
                evals += 1
                for j in range(n):
                    err[j] = rreal[j] + tmp[j]
                _lu_solve(lur, pivr, err)
                s2 = 0.0
                for j in range(n):
                    sc = atol + max(abs(y[j]), abs(ynew[j])) * rtol
                    s2 += (err[j] / sc) ** 2
                en_err = math.sqrt(s2 / n)
            if not math.isfinite(en_err):
                en_err = math.inf
            if en_err > 1.0 and not fixed:
                mult = 1.0
                if h_abs_old > 0.0 and err_old > 0.0 and en_err > 0.0:
                    mult = h_use / h_abs_old * (err_old / en_err) ** 0.25
                fac = min(1.0, mult) * en_err**-0.25
                h = h_use * max(_MIN_FACTOR, safety * fac)
                lu_h = -1.0
                rejected = True
                n_rej += 1
                continue
            accepted = True
            recompute = n_iter > 2 and rate > THETA
            if fixed:
                factor = 1.0
            else:
                mult = 1.0
                if h_abs_old > 0.0 and err_old > 0.0 and en_err > 0.0:
                    mult = h_use / h_abs_old * (err_old / en_err) ** 0.25
                factor = _MAX_FACTOR if en_err == 0.0 else min(1.0, mult) * en_err**-0.25
                factor = min(_MAX_FACTOR, safety * factor)
                if not recompute and factor < 1.2:
                    factor = 1.0
            dn = _rhs(t + h_use, ynew, fnew, pp, lc, rot, en, True)
            evals += 1
            if recompute:
                evals += _jacobian(t + h_use, ynew, fnew, jac, work, tmp, pp, lc, rot, en)
                n_jac += 1
                current_jac = True
                lu_h = -1.0
            else:
                current_jac = False
            h_abs_old = h_use
            err_old = en_err
            if not fixed:
                # the controller's proposal continues from the step it judged (see explicit)
                h = (
                    max(h, h_use * factor)
                    if (m == 1 and h_use < h and factor >= 1.0)
                    else (h_use * factor)
                )
            # the step's collocation polynomial y_old + Q (x, x^2, x^3), Q = Z^T P, formed
            # once here: it predicts the next step's stages (also after rejections)
            for j in range(n):
                for q in range(3):
                    Qold[j, q] = Z[0, j] * _RP[0, q] + Z[1, j] * _RP[1, q] + Z[2, j] * _RP[2, q]
                yold[j] = y[j]
            t_old = t
            h_prev = h_use
            have_old = True
        if status != 0 or newton_failed or not accepted:
            break
        steps += 1
        hit = m == 1
        t = t_target if hit else t + h_use
        for j in range(n):
            y[j] = ynew[j]
            f[j] = fnew[j]
        if hit:
            jn += 1
        final = hit and t_target >= t_end
        status, wrote = _observe(False, t, y, dn, p, ext, out, rows, final, hit, rot, en)
        rows += wrote
        if final:
            break
    if status == 6:
        # record the state where the integrator gave up, so the stop is visible in histories
        d = _rhs(t, y, f, pp, lc, rot, en, True)
        evals += 1
        st, wrote = _observe(False, t, y, d, p, ext, out, rows, True, True, rot, en)
        rows += wrote
    return status, steps, rows, evals, ext, n_rej, n_jac, n_lu, t


@njit(cache=True)
def _drive_rot_en(p, lawc, y0, t_end, interval, h0, rtol, atol, method, fixed, max_steps, out):
    return _drive(
        p, lawc, y0, t_end, interval, h0, rtol, atol, method, fixed, max_steps, out, True, True
    )


@njit(cache=True)
def _drive_rot(p, lawc, y0, t_end, interval, h0, rtol, atol, method, fixed, max_steps, out):
    return _drive(
        p, lawc, y0, t_end, interval, h0, rtol, atol, method, fixed, max_steps, out, True, False
    )


@njit(cache=True)
def _drive_en(p, lawc, y0, t_end, interval, h0, rtol, atol, method, fixed, max_steps, out):
    return _drive(
        p, lawc, y0, t_end, interval, h0, rtol, atol, method, fixed, max_steps, out, False, True
    )


@njit(cache=True)
def _drive_bare(p, lawc, y0, t_end, interval, h0, rtol, atol, method, fixed, max_steps, out):
    return _drive(
        p, lawc, y0, t_end, interval, h0, rtol, atol, method, fixed, max_steps, out, False, False
    )


SPECIALISATIONS = {
    (True, True): _drive_rot_en,
    (True, False): _drive_rot,
    (False, True): _drive_en,
    (False, False): _drive_bare,
}


def run(
    p: np.ndarray,
    lawc: np.ndarray,
    y0: np.ndarray,
    t_end: float,
    interval: float,
    h0: float,
    rtol: float,
    atol: float,
    method: str,
    fixed: bool,
    max_steps: int,
    out: np.ndarray,
    rot: bool,
    en: bool,
) -> tuple:
    """Call the compiled driver of `method` specialised for the (rotation, energy) flags."""
    fn = SPECIALISATIONS[(bool(rot), bool(en))]
    return fn(
        p,
        lawc,
        y0,
        float(t_end),
        float(interval),
        float(h0),
        float(rtol),
        float(atol),
        METHODS[method],
        bool(fixed),
        int(max_steps),
        out,
    )


def _stability_polynomial(method: str) -> np.ndarray:
    """Coefficients (ascending) of R(z) = 1 + z b^T (I - z A)^-1 1 for an explicit tableau."""
    if method == "rk4":
        return np.array([1.0, 1.0, 1 / 2, 1 / 6, 1 / 24])
    A, B = (tb.DP5_A, tb.DP5_B) if method == "dopri5" else (tb.DOP853_A, tb.DOP853_B)
    s = B.size
    Af = np.zeros((s, s))
    Af[:, : A.shape[1]] = A[:s, : A.shape[1]]
    coeffs = [1.0]
    v = np.ones(s)
    for _ in range(s):
        coeffs.append(float(B @ v))
        v = Af @ v
    return np.array(coeffs)


def real_stability_bound(method: str) -> float:
    """Length of the negative real axis inside an explicit method's stability region.

    The largest x with |R(-y)| <= 1 for all y in [0, x] (RK4: 2.7853); inf for radau5
    (A-stable). Found by scanning then bisecting the stability polynomial.
    """
    if method == "radau5":
        return math.inf
    poly = np.polynomial.Polynomial(_stability_polynomial(method))
    ys = np.linspace(0.0, 20.0, 200001)
    bad = np.nonzero(np.abs(poly(-ys)) > 1.0 + 1e-12)[0]
    lo, hi = ys[bad[0] - 1], ys[bad[0]]
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if abs(poly(-mid)) > 1.0:
            hi = mid
        else:
            lo = mid
    return float(lo)
