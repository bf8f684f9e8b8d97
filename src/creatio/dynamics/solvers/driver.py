"""The one output-grid driver of every method, with the explicit stepper, compiled.

The driver owns time, step size, output landing, diagnostics and the step budget; a step is
either the explicit Runge-Kutta stepper below (any tableau of the registry) or the Radau IIA
stepper of creatio.dynamics.solvers.radau.

* Fixed step (RK4, or any method with ``fixed``): step i runs from t_i = i dt to t_{i+1};
  histories are every ``stride`` steps, and the run is ``n_steps`` steps long.
* Adaptive: each output interval is split into equal steps no longer than the controller's
  proposal, so steps never cross an output time and histories are exact step values (no
  interpolation error); a step shortened to land on an output time says nothing against the
  proposal, which continues from the step it judged.

Every accepted step's end state is observed (creatio.dynamics.sphere.observe), so extrema are
over all steps. The stepper kind and the rotation / energy / structure flags are compile-time
constants of each entry in SPECIALISATIONS: a run compiles only the stepper, the right-hand
side (fixed structure or the structure path of docs/model.md s.9-10, resolved by
creatio.dynamics.sphere.rhs_of) and the bookkeeping it uses.

Why the explicit stages are written inside the loop and not in a function of their own:
measured on EN-02 (RK4, 60,000 steps), a function boundary per step, tuple unpacking or a
row view of the stage matrix inside the loop, or diagnostics carried from one iteration to
the next each cost 5-20 % of the run time (numba passes every array as a dozen scalars and
reference-counts views); written this way the generic stepper runs RK4 within a few per cent
of a hand-written RK4 loop and reproduces its results bit for bit.
"""

from __future__ import annotations

import math

import numpy as np
from numba.core import types
from numba.extending import overload

from creatio.dynamics import status as st
from creatio.dynamics.jit import njit
from creatio.dynamics.solvers import EXPLICIT, RADAU, ROSENBROCK, Method, radau, rosenbrock
from creatio.dynamics.solvers.explicit import (
    ACCEPTED,
    ERROR_REJECTED,
    error_norm,
    step_factor,
)
from creatio.dynamics.sphere import NDIAG, load, new_extrema, observe, pack, rhs_of, store

__all__ = ["SPECIALISATIONS", "run"]


def _implicit_step(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, ws, tol, fixed, rejected, pp,
                   lc, rot, en, free):
    """One try at one implicit step (compiled code only; resolved at compile time)."""
    raise NotImplementedError("called only from compiled code")


def _implicit_workspace(stepper, n):
    """The implicit stepper's carried state (compiled code only; resolved at compile time)."""
    raise NotImplementedError("called only from compiled code")


def _implicit_dense(stepper, ws, t, yout):
    """The implicit stepper's dense output at t within its last accepted step (compiled code
    only; resolved at compile time)."""
    raise NotImplementedError("called only from compiled code")


@overload(_implicit_step, prefer_literal=True, inline="always")
def _implicit_step_of(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, ws, tol, fixed, rejected,
                      pp, lc, rot, en, free):
    """Radau's or RODAS4's step for their kinds; for the explicit kind a stand-in that is
    never run, so an explicit run never types or compiles an implicit stepper."""
    if not isinstance(stepper, types.IntegerLiteral):
        return None
    if stepper.literal_value == RADAU:
        return radau.step.py_func
    elif stepper.literal_value == ROSENBROCK:
        return rosenbrock.step.py_func
    else:
        def impl(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, ws, tol, fixed, rejected, pp,
                 lc, rot, en, free):
            return ERROR_REJECTED, 1.0, 0, 0, 0, False
    return impl


@overload(_implicit_workspace, prefer_literal=True)
def _implicit_workspace_of(stepper, n):
    """The implicit kinds' workspaces, an empty placeholder for the explicit kind."""
    if not isinstance(stepper, types.IntegerLiteral):
        return None
    if stepper.literal_value == RADAU:
        return lambda stepper, n: radau.workspace(n)
    if stepper.literal_value == ROSENBROCK:
        return lambda stepper, n: rosenbrock.workspace(n)
    return lambda stepper, n: np.empty(0)


@overload(_implicit_dense, prefer_literal=True, inline="always")
def _implicit_dense_of(stepper, ws, t, yout):
    """Radau's collocation polynomial, RODAS4's Hermite cubic, a stand-in never run for the
    explicit kind."""
    if not isinstance(stepper, types.IntegerLiteral):
        return None
    if stepper.literal_value == RADAU:
        return lambda stepper, ws, t, yout: radau.dense(ws, t, yout)
    if stepper.literal_value == ROSENBROCK:
        return lambda stepper, ws, t, yout: rosenbrock.dense(ws, t, yout)
    return lambda stepper, ws, t, yout: None


@njit(cache=True)
def _next_h(h, h_use, factor, m):
    """The controller's next proposal; a step shortened (m == 1, h_use < h) to land on an
    output time keeps the larger proposal it was cut from when the step went well."""
    if m == 1 and h_use < h and factor >= 1.0:
        return max(h, h_use * factor)
    return h_use * factor


@njit(cache=True)
def _drive(stepper, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
           max_steps, tab, out, rot, en, free, dense):
    """Integrate from t = 0 to t_end with the stepper of kind `stepper` (a compile-time
    constant); rows of `out` are the sampled histories.

    Fixed step: h0 = dt, n_steps steps, a history row every `stride` steps. Adaptive: h0 is
    the first step, rows on the grid of `interval`. tab = (c, a_ptr, a_idx, a_val, b_idx,
    b_val, b_divisor, e, e3, estimator, error_order, c_extra, a_extra, dense_p) is the explicit
    tableau as its nonzeros and its dense output (creatio.dynamics.solvers.Tableau.arrays,
    dense_arrays). With `dense`, steps are not cut to the grid: the step size runs free (a
    fixed step need not divide the interval), only the last step lands on t_end, and the rows
    on the grid are the step's dense output (with one more right-hand-side evaluation each
    for their diagnostics). Returns (status, steps, rows, rhs_evals,
    extrema, rejected, jacobians, lu_factorisations, stop_time); STEP_FAILED when the step
    underflows, Newton fails at a fixed step, or max_steps accepted steps did not reach t_end.
    """
    pp, lc = pack(p, lawc)
    (c, a_ptr, a_idx, a_val, b_idx, b_val, b_divisor, e, e3, estimator, error_order, c_extra,
     a_extra, dense_p) = tab
    n = y0.size
    s = c.size
    n_extra = c_extra.size
    n_dense = dense_p.shape[0]
    y = y0.copy()
    ynew = np.empty(n)
    # explicit stages (one row each), the end-of-step stage and the dense output's extra ones
    K = np.empty((n_dense, n))
    f = K[0]  # f(t, y) is the first stage: a view made once, so never copied into K
    fnew = np.empty(n)
    dbuf = np.empty(NDIAG)
    work = np.empty(n)
    kst = np.empty(n)
    yout = np.empty(n)
    wq = np.empty(n_dense)
    iws = _implicit_workspace(stepper, n)
    tol = (rtol, atol)
    ext = new_extrema(en)
    # Counters and flags start as typed values, not literals: a literal argument would make
    # numba compile the callee once more for it (observe), costing seconds.
    evals = np.int64(0)
    n_rej = np.int64(0)
    n_jac = np.int64(0)
    n_lu = np.int64(0)
    rows = np.int64(0)
    steps = np.int64(0)
    yes = np.bool_(True)
    no = not yes
    t = 0.0
    status = st.OK
    # output grid of an adaptive run: n_int whole intervals, then t_end
    n_int = int(math.floor(t_end / interval * (1.0 + 1e-12))) if dense or not fixed else 0
    jn = 1
    h = h0 if fixed or dense else min(h0, interval)
    final = n_steps == 0 if fixed else t_end <= 0.0
    sample = yes
    # whether f and dbuf already hold f(t, y) and its diagnostics (an adaptive step's last
    # stage); otherwise they are evaluated at the top of the step, as the notebook's RK4 did
    have_f = not yes
    # One place observes a state and one place takes a step, so each is compiled once.
    while True:
        if have_f:
            d = load(dbuf)
        else:
            d = rhs_of(free, t, y, f, pp, lc, rot, en, True)
            evals += 1
        status, wrote = observe(steps == 0, t, y, d, pp, ext, out, rows, final, sample, rot, en,
                                free)
        rows += wrote
        if status != st.OK or final:
            break
        if fixed:
            t_target = (steps + 1) * h0
            if dense and t_target >= t_end * (1.0 - 1e-12):
                t_target = t_end
        elif dense:
            t_target = t_end
        else:
            t_target = jn * interval if jn <= n_int else t_end
            if t_target > t_end:
                t_target = t_end
        remaining = t_target - t
        rejected = not yes
        accepted = not yes
        m = 1
        h_use = h
        t_next = t_target
        while not accepted:
            if not fixed:
                if steps >= max_steps or h < 1e-12 * max(1.0, t_end) or not math.isfinite(h):
                    status = st.STEP_FAILED
                    break
                if dense:
                    # free steps; the one that reaches t_end lands on it
                    m = 1 if h >= remaining * (1.0 - 1e-9) else 2
                    h_use = remaining if m == 1 else h
                else:
                    m = math.ceil(remaining / h * (1.0 - 1e-9))
                    if m < 1:
                        m = 1
                    h_use = remaining / m
                t_next = t_target if dense and m == 1 else t + h_use
                if t_next <= t:
                    status = st.STEP_FAILED
                    break
            elif dense and t_target == t_end:
                h_use = t_end - t
            if stepper == EXPLICIT:
                # Explicit Runge-Kutta, any tableau: K[0] = f(t, y) (f is K's first row); stage
                # st from
                # y + h sum_q a[st, q] K[q], its terms added in column order from the first
                # (0 + x = x exactly, so skipping zero coefficients changes no rounding);
                # stages at c = 1 are evaluated at t_next exactly.
                for stg in range(1, s):
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
                            work[j] = y[j] + h_use * work[j]
                    ts = t_next if c[stg] == 1.0 else t + c[stg] * h_use
                    rhs_of(free, ts, work, kst, pp, lc, rot, en, False)
                    for j in range(n):
                        K[stg, j] = kst[j]
                # y_new = y + (h / divisor) sum b_q K[q], in the tableau's summation order
                q = b_idx[0]
                v = b_val[0]
                for j in range(n):
                    ynew[j] = v * K[q, j]
                for pq in range(1, b_idx.size):
                    q = b_idx[pq]
                    v = b_val[pq]
                    for j in range(n):
                        ynew[j] += v * K[q, j]
                hb = h_use / b_divisor
                for j in range(n):
                    ynew[j] = y[j] + hb * ynew[j]
                nj = 0
                nl = 0
                if fixed and not dense:
                    # the end-of-step derivative is the next step's first stage, evaluated
                    # with its diagnostics at the top of the next step
                    outcome = ACCEPTED
                    factor = 1.0
                    ev = s - 1
                    have_f = not yes
                else:
                    # the error estimate (FSAL) or the dense output needs the end-of-step
                    # derivative now: with its diagnostics, the next step's first stage
                    store(rhs_of(free, t_next, ynew, fnew, pp, lc, rot, en, True), dbuf)
                    for j in range(n):
                        K[s, j] = fnew[j]
                    ev = s
                    if fixed:
                        outcome = ACCEPTED
                        factor = 1.0
                        have_f = yes
                    else:
                        en_err = error_norm(K, y, ynew, h_use, e, e3, estimator, rtol, atol)
                        ok, factor = step_factor(en_err, error_order, rejected)
                        outcome = ACCEPTED if ok else ERROR_REJECTED
                        have_f = ok
            else:
                outcome, factor, ev, nj, nl, have_f = _implicit_step(
                    stepper, t, t_next, h_use, y, f, ynew, fnew, dbuf, iws, tol, fixed,
                    rejected, pp, lc, rot, en, free)
            evals += ev
            n_jac += nj
            n_lu += nl
            if outcome == ACCEPTED:
                accepted = yes
                if not fixed:
                    h = _next_h(h, h_use, factor, m)
            elif fixed:
                status = st.STEP_FAILED
                break
            else:
                h = h_use * factor
                rejected = yes
                n_rej += 1
        if status != st.OK:
            break
        if dense:
            # rows on the grid inside the step (t_end's row is the landing step's end)
            extras = n_extra == 0
            while jn <= n_int:
                tg = jn * interval
                if tg > t_next or tg >= t_end * (1.0 - 1e-12):
                    break
                if stepper == EXPLICIT:
                    if not extras:
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
                                work[j] = y[j] + h_use * work[j]
                            rhs_of(free, t + c_extra[i] * h_use, work, kst, pp, lc, rot, en,
                                   False)
                            for j in range(n):
                                K[row, j] = kst[j]
                        evals += n_extra
                        extras = yes
                    x = (tg - t) / h_use
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
                        yout[j] = y[j] + h_use * acc
                else:
                    _implicit_dense(stepper, iws, tg, yout)
                d = rhs_of(free, tg, yout, kst, pp, lc, rot, en, True)
                evals += 1
                status, wrote = observe(no, tg, yout, d, pp, ext, out, rows, no, yes, rot, en,
                                        free)
                rows += wrote
                jn += 1
                if status != st.OK:
                    break
            if status != st.OK:
                break
        steps += 1
        for j in range(n):
            y[j] = ynew[j]
        if have_f:
            for j in range(n):
                f[j] = fnew[j]
        if dense:
            t = t_next
            final = t_next == t_end
            sample = final
        elif fixed:
            t = t_next
            final = steps == n_steps
            sample = steps % stride == 0
        else:
            hit = m == 1
            t = t_target if hit else t_next
            if hit:
                jn += 1
            final = hit and t_target >= t_end
            sample = hit
    if status == st.STEP_FAILED:
        # record the state where the integrator gave up, so the stop is visible in histories
        d = rhs_of(free, t, y, f, pp, lc, rot, en, True)
        evals += 1
        _, wrote = observe(steps == 0, t, y, d, pp, ext, out, rows, yes, yes, rot, en, free)
        rows += wrote
    return status, steps, rows, evals, ext, n_rej, n_jac, n_lu, t


# The table of compiled specialisations: (stepper, rotation, energy, structure) -> entry. Each
# entry hands the driver constant flags, so a run compiles only the stepper, right-hand side
# and bookkeeping it uses; an entry is compiled (and cached) on its first call only.
@njit(cache=True)
def _explicit_rot_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
                     max_steps, tab, out, dense):
    return _drive(EXPLICIT, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, True, False, dense)


@njit(cache=True)
def _explicit_rot(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed, max_steps,
                  tab, out, dense):
    return _drive(EXPLICIT, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, False, False, dense)


@njit(cache=True)
def _explicit_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed, max_steps,
                 tab, out, dense):
    return _drive(EXPLICIT, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, True, False, dense)


@njit(cache=True)
def _explicit_bare(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed, max_steps,
                   tab, out, dense):
    return _drive(EXPLICIT, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, False, False, dense)


@njit(cache=True)
def _explicit_structure_rot_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                               fixed, max_steps, tab, out, dense):
    return _drive(EXPLICIT, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, True, True, dense)


@njit(cache=True)
def _explicit_structure_rot(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
                            max_steps, tab, out, dense):
    return _drive(EXPLICIT, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, False, True, dense)


@njit(cache=True)
def _explicit_structure_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
                           max_steps, tab, out, dense):
    return _drive(EXPLICIT, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, True, True, dense)


@njit(cache=True)
def _explicit_structure_bare(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
                             max_steps, tab, out, dense):
    return _drive(EXPLICIT, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, False, True, dense)


@njit(cache=True)
def _radau_rot_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed, max_steps,
                  tab, out, dense):
    return _drive(RADAU, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, True, False, dense)


@njit(cache=True)
def _radau_rot(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed, max_steps,
               tab, out, dense):
    return _drive(RADAU, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, False, False, dense)


@njit(cache=True)
def _radau_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed, max_steps, tab,
              out, dense):
    return _drive(RADAU, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, True, False, dense)


@njit(cache=True)
def _radau_bare(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed, max_steps,
                tab, out, dense):
    return _drive(RADAU, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, False, False, dense)


@njit(cache=True)
def _radau_structure_rot_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
                            max_steps, tab, out, dense):
    return _drive(RADAU, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, True, True, dense)


@njit(cache=True)
def _radau_structure_rot(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
                         max_steps, tab, out, dense):
    return _drive(RADAU, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, False, True, dense)


@njit(cache=True)
def _radau_structure_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
                        max_steps, tab, out, dense):
    return _drive(RADAU, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, True, True, dense)


@njit(cache=True)
def _radau_structure_bare(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
                          max_steps, tab, out, dense):
    return _drive(RADAU, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, False, True, dense)


@njit(cache=True)
def _rosenbrock_rot_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                       fixed, max_steps, tab, out, dense):
    return _drive(ROSENBROCK, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, True, False, dense)


@njit(cache=True)
def _rosenbrock_rot(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                    fixed, max_steps, tab, out, dense):
    return _drive(ROSENBROCK, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, False, False, dense)


@njit(cache=True)
def _rosenbrock_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                   fixed, max_steps, tab, out, dense):
    return _drive(ROSENBROCK, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, True, False, dense)


@njit(cache=True)
def _rosenbrock_bare(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                     fixed, max_steps, tab, out, dense):
    return _drive(ROSENBROCK, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, False, False, dense)


@njit(cache=True)
def _rosenbrock_structure_rot_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                                 fixed, max_steps, tab, out, dense):
    return _drive(ROSENBROCK, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, True, True, dense)


@njit(cache=True)
def _rosenbrock_structure_rot(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                              fixed, max_steps, tab, out, dense):
    return _drive(ROSENBROCK, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, True, False, True, dense)


@njit(cache=True)
def _rosenbrock_structure_en(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                             fixed, max_steps, tab, out, dense):
    return _drive(ROSENBROCK, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, True, True, dense)


@njit(cache=True)
def _rosenbrock_structure_bare(p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                               fixed, max_steps, tab, out, dense):
    return _drive(ROSENBROCK, p, lawc, y0, t_end, interval, h0, n_steps, stride, rtol, atol,
                  fixed, max_steps, tab, out, False, False, True, dense)


SPECIALISATIONS = {
    (EXPLICIT, True, True, False): _explicit_rot_en,
    (EXPLICIT, True, False, False): _explicit_rot,
    (EXPLICIT, False, True, False): _explicit_en,
    (EXPLICIT, False, False, False): _explicit_bare,
    (EXPLICIT, True, True, True): _explicit_structure_rot_en,
    (EXPLICIT, True, False, True): _explicit_structure_rot,
    (EXPLICIT, False, True, True): _explicit_structure_en,
    (EXPLICIT, False, False, True): _explicit_structure_bare,
    (RADAU, True, True, False): _radau_rot_en,
    (RADAU, True, False, False): _radau_rot,
    (RADAU, False, True, False): _radau_en,
    (RADAU, False, False, False): _radau_bare,
    (RADAU, True, True, True): _radau_structure_rot_en,
    (RADAU, True, False, True): _radau_structure_rot,
    (RADAU, False, True, True): _radau_structure_en,
    (RADAU, False, False, True): _radau_structure_bare,
    (ROSENBROCK, True, True, False): _rosenbrock_rot_en,
    (ROSENBROCK, True, False, False): _rosenbrock_rot,
    (ROSENBROCK, False, True, False): _rosenbrock_en,
    (ROSENBROCK, False, False, False): _rosenbrock_bare,
    (ROSENBROCK, True, True, True): _rosenbrock_structure_rot_en,
    (ROSENBROCK, True, False, True): _rosenbrock_structure_rot,
    (ROSENBROCK, False, True, True): _rosenbrock_structure_en,
    (ROSENBROCK, False, False, True): _rosenbrock_structure_bare,
}


def run(
    method: Method,
    p: np.ndarray,
    lawc: np.ndarray,
    y0: np.ndarray,
    out: np.ndarray,
    *,
    t_end: float,
    interval: float,
    h0: float,
    n_steps: int,
    stride: int,
    rtol: float,
    atol: float,
    fixed: bool,
    max_steps: int,
    rotation: bool,
    energy: bool,
    free: bool = False,
    dense: bool = False,
) -> tuple:
    """Run `method` through its compiled specialisation; see _drive for the result tuple.
    free selects the structure path (docs/model.md s.9-10); dense the rows from dense output
    instead of steps cut to land on the grid."""
    fn = SPECIALISATIONS[(method.stepper, bool(rotation), bool(energy), bool(free))]
    return fn(p, lawc, y0, float(t_end), float(interval), float(h0), int(n_steps), int(stride),
              float(rtol), float(atol), bool(fixed), int(max_steps), method.driver_tableau, out,
              bool(dense))
