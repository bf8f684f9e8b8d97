"""Radau IIA of orders 9 and 13 and variable order (5, 9, 13) in the sphere's driver.

One stepper kind of the driver (creatio.dynamics.solvers.RADAU_VO) under its implicit-stepper
contract (creatio.dynamics.solvers.driver): the generic stepper of creatio.dynamics.solvers
.radau_variable_order, Hairer and Wanner's RADAU, on the sphere's right-hand side (creatio.dynamics
.sphere.rhs_of) and its Jacobian (creatio.dynamics.solvers.radau5.jacobian: forward
differences of the feedback columns, the quaternion block exact). The registry's methods
radau9, radau13 (fixed order, 5 and 7 stages) and radau (5/9/13 by the Newton contraction)
differ only in data: the stage range, the first stage count and the Jacobian reuse
threshold, carried in the method's parameter vector (creatio.dynamics.solvers.Method.params,
the PRM_* slots below), so all three share one compiled specialisation per flag set.

radau5 keeps its own stepper (creatio.dynamics.solvers.radau5): the variable-order stepper at
3 stages is radau.f's control, not scipy's, and radau5's runs stay as they were.

Dense output (free steps, rows between them: :func:`dense_step`) is the last step's
collocation polynomial u (degree s, error O(h^(s+1)) between the steps) corrected by its
defect at the step's start: the polynomial of degree s + 1 through the step's ends whose
derivative interpolates f at the start and at the s stages (error O(h^(s+2))). It needs
f(t, y) at the start, which the driver holds: no evaluation, no history, and a run without
dense output is untouched. On EN-02 at rtol 1e-10 to 1e-13 its rows are as close to the
reference as u's or closer (up to 10x). A Hermite interpolant through (y, f) at the ends of
the last 2 to 5 steps (radau5's kind) was measured 7 to 1600x worse than u there: two
values a step do not resolve what the s stages of a long step do.
"""

from __future__ import annotations

import numpy as np

from creatio.dynamics.jit import njit
from creatio.dynamics.solvers import radau_variable_order as rvo
from creatio.dynamics.solvers.explicit import NEWTON_FAILED
from creatio.dynamics.solvers.radau5 import jacobian
from creatio.dynamics.solvers.radau_coefficients import STAGES, coefficients
from creatio.dynamics.sphere import pack, rhs_of

__all__ = ["NWS", "PRM_S_MAX", "PRM_S_MIN", "PRM_S_START", "PRM_THET", "dense", "dense_step",
           "defect_shapes", "passed", "solve", "step", "workspace"]

#: Slots of the workspace: radau_variable_order's (its WS_*), NWS of them.
NWS = rvo.NWS

#: Slots of the method's parameter vector: the stage range, the first step's stage count and
#: the Jacobian reuse threshold (radau.f's THET).
PRM_S_MIN, PRM_S_MAX, PRM_S_START, PRM_THET = range(4)


def defect_shapes() -> np.ndarray:
    """Per stage count (row k for STAGES[k]), the coefficients of x^0 .. x^(s+1) of the
    shape W(x) = integral_0^x prod_i (xi - c_i) dxi / prod_i (-c_i) of dense output's
    correction (:func:`dense_step`): W(0) = W(1) = 0 (Radau's quadrature, exact to degree
    2 s - 1, integrates the node polynomial to 0), W'(0) = 1 and W'(c_i) = 0."""
    w = np.zeros((len(STAGES), rvo.SMAX + 2))
    for k, s in enumerate(STAGES):
        c = coefficients(s).c
        w[k, :s + 2] = np.polynomial.Polynomial.fromroots(c).integ().coef / np.prod(-c)
    return w


_SHAPE = defect_shapes()


@njit(cache=True)
def _rhs(t, y, out, ctx):
    """f(t, y) into out, no diagnostics (radau_variable_order's rhs signature); ctx carries
    the sphere's flags and parameters, its flags literal so rhs_of resolves at compile time."""
    free, pp, lc, rot, en = ctx
    rhs_of(free, t, y, out, pp, lc, rot, en, False)


@njit(cache=True)
def _jac(t, y, f, J, work, tmp, ctx):
    """The sphere's Jacobian (radau_variable_order's jac signature); returns its evaluations."""
    free, pp, lc, rot, en = ctx
    return jacobian(t, y, f, J, work, tmp, pp, lc, rot, en, free)


@njit(cache=True)
def workspace(n, params):
    """radau_variable_order's workspace for the method whose parameters are params (PRM_*)."""
    return rvo.workspace(n, int(params[PRM_S_MIN]), int(params[PRM_S_MAX]),
                              int(params[PRM_S_START]), rvo.NIT, params[PRM_THET])


@njit(cache=True)
def step(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, ws, tol, fixed, rejected, pp, lc, rot,
         en, free):
    """One try at the step t -> t_next = t + h (the driver's implicit-stepper contract):
    (outcome, factor, rhs evaluations, Jacobians, LU decompositions, Newton iterations,
    False). The end-of-step evaluation is left to the driver, which takes it with its
    diagnostics at the top of the next step (so fnew and dbuf are not written here).

    A fixed step has no smaller step to retry, so when its Newton iteration fails with a
    Jacobian that was not fresh it is tried once more at the same h with a fresh one (what
    radau.f does before it would shrink h; radau5's stepper does the same)."""
    rs = ws[rvo.WS_RS]
    cnt = ws[rvo.WS_CNT]
    newton0 = cnt[rvo.CNT_NEWTON]
    evals = 0
    n_jac = 0
    n_dec = 0
    outcome = NEWTON_FAILED
    factor = 0.5
    for _ in range(2):
        outcome, factor, ev, nj, nd, _ = rvo.step(
            _rhs, _jac, (free, pp, lc, rot, en), t, t_next, h, y, f, ynew, ws, tol, fixed,
            rejected)
        evals += ev
        n_jac += nj
        n_dec += nd
        if not (fixed and outcome == NEWTON_FAILED and rs[rvo.RS_NEED_JAC] > 0.0):
            break
    return outcome, factor, evals, n_jac, n_dec, cnt[rvo.CNT_NEWTON] - newton0, False


@njit(cache=True)
def dense(ws, tg, yout):
    """The last accepted step's collocation polynomial at tg (degree s)."""
    rvo.dense(ws, tg, yout)


@njit(cache=True)
def dense_step(ws, tg, yout, t, y, f, t_next, ynew, fnew):
    """Dense output at tg inside the last accepted step t -> t_next from y, f = f(t, y): its
    collocation polynomial u corrected by the defect at the start, u(tg) + (h f - h u'(t))
    W(x), x = (tg - t) / h, W from :func:`defect_shapes`. That is the polynomial of degree
    s + 1 through y and ynew whose derivative interpolates f at t and at the s stages (u's
    derivative interpolates it at the stages alone): error O(h^(s+2)) against u's
    O(h^(s+1)), from the start's f, which the driver holds (no evaluation; ynew, fnew and
    t_next, the driver's contract, are not needed)."""
    rs = ws[rvo.WS_RS]
    q = ws[rvo.WS_Q]
    s = int(rs[rvo.RS_S_OLD])
    k = (s - 3) // 2
    h = rs[rvo.RS_H_OLD]
    x = (tg - rs[rvo.RS_T_OLD]) / h
    w = _SHAPE[k, s + 1]
    for p in range(s, 0, -1):
        w = w * x + _SHAPE[k, p]
    w *= x
    rvo.dense(ws, tg, yout)
    for j in range(yout.size):
        yout[j] += (h * f[j] - q[0, j]) * w


@njit(cache=True)
def passed(ws, t, y, f):
    """The driver's hook after each dense step: from then on adaptive steps take their
    Jacobians at the stages' centroid (radau_variable_order.jac_ahead), where a long free
    step's Newton iteration contracts about twice as fast; runs without dense output, whose
    steps end on the grid, never call it and stay as they were, and fixed steps ignore it."""
    rvo.jac_ahead(ws)


@njit(cache=True)
def solve(p, lawc, y0, t_end, h0, rtol, atol, s_min, s_max, s_start, fixed, max_steps, t_dense,
          thet, ahead=False):
    """radau_variable_order.solve (steps free, samples at t_dense from the dense output) on the
    sphere's fixed structure with rotation and no energy bookkeeping, the work-precision benchmark's
    state: for tests and scripts that need what the driver does not return (the steps at
    each stage count, every step's time and state). p, lawc: SphereProblem
    .parameter_vector() and .law_matrix(); y0: .initial_state(True, False); ahead: the
    Jacobians of the driver's dense runs (:func:`passed`)."""
    pp, lc = pack(p, lawc)
    return rvo.solve(_rhs, _jac, (False, pp, lc, True, False), 0.0, y0, t_end, h0, rtol,
                     atol, s_min, s_max, s_start, fixed, max_steps, t_dense, rvo.NIT, thet,
                     ahead)
