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
"""

from __future__ import annotations

from creatio.dynamics.jit import njit
from creatio.dynamics.solvers import radau_variable_order as rvo
from creatio.dynamics.solvers.explicit import NEWTON_FAILED
from creatio.dynamics.solvers.radau5 import jacobian
from creatio.dynamics.sphere import pack, rhs_of

__all__ = ["NWS", "PRM_S_MAX", "PRM_S_MIN", "PRM_S_START", "PRM_THET", "dense", "solve",
           "step", "workspace"]

#: Slots of the workspace: radau_variable_order's (its WS_*), NWS of them.
NWS = rvo.NWS

#: Slots of the method's parameter vector: the stage range, the first step's stage count and
#: the Jacobian reuse threshold (radau.f's THET).
PRM_S_MIN, PRM_S_MAX, PRM_S_START, PRM_THET = range(4)


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
def solve(p, lawc, y0, t_end, h0, rtol, atol, s_min, s_max, s_start, fixed, max_steps, t_dense,
          thet):
    """radau_variable_order.solve (steps free, samples at t_dense from the dense output) on the
    sphere's fixed structure with rotation and no energy bookkeeping, the work-precision benchmark's
    state: for tests and scripts that need what the driver does not return (the steps at
    each stage count, every step's time and state). p, lawc: SphereProblem
    .parameter_vector() and .law_matrix(); y0: .initial_state(True, False)."""
    pp, lc = pack(p, lawc)
    return rvo.solve(_rhs, _jac, (False, pp, lc, True, False), 0.0, y0, t_end, h0, rtol,
                     atol, s_min, s_max, s_start, fixed, max_steps, t_dense, rvo.NIT, thet)
