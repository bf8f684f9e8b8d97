"""The one output-grid driver of every method, compiled, and its entry points.

The driver owns time, step size, output landing, diagnostics, the evaluation budget, the
step-size floors (creatio.dynamics.status.UNDERFLOW, COLLAPSE_TRIES) and the progress lines of
a long run (creatio.dynamics.progress); a specialisation a run must compile is announced first
(creatio.dynamics.jit.ensure_compiled); a step is taken by the stepper of
the method's kind (creatio.dynamics.solvers.STEPPERS). The controller around a step (budget,
progress, floors, the split to the output grid, accept or reject: :func:`accepted_step`) and
the grid's start, targets and landing (:func:`plan`, :func:`target`, :func:`landed`) are
written once, for this loop and the flight loop (creatio.dynamics.solvers.flight), which hands
:func:`accepted_step` its own try at a step, inlined as the driver's is.

The explicit Runge-Kutta stepper (creatio.dynamics.solvers.explicit) reads any tableau of the
registry; the implicit kinds, Radau IIA (3 stages; 5, 7 and variable order) and RODAS4, are
modules under one contract: ``workspace(n, params)`` their arrays and carried state (params:
the method's parameters, creatio.dynamics.solvers.Method.params), ``step(...)`` one try at one
step (outcome, step factor, work counters: evaluations, Jacobians, LU decompositions, Newton
iterations; whether the end-of-step evaluation is done), ``dense(ws, t, yout)`` the dense
output inside the last accepted step, or ``dense_step(ws, t, yout, t0, y0, f0, t1, y1, f1)``
from that step's ends where a kind has it, with ``passed(ws, t0, y0, f0)`` after each dense
step (radau5: a quintic Hermite interpolant over two steps). A new implicit kind is such a
module and an entry of STEPPERS; the explicit kind's arrays are the driver's own (see below).

* Fixed step (RK4, or any method with ``fixed``): step i runs from t_i = i dt to t_{i+1};
  histories are every ``stride`` steps, and the run is ``n_steps`` steps long.
* Adaptive: each output interval is split into equal steps no longer than the controller's
  proposal, so steps never cross an output time and histories are exact step values (no
  interpolation error); a step shortened to land on an output time says nothing against the
  proposal, which continues from the step it judged.

Every accepted step's end state is observed (creatio.dynamics.sphere.observe), so extrema are
over all steps. The stepper kind and the rotation / energy / structure flags are compile-time
constants of each entry point in SPECIALISATIONS: a run compiles only the stepper, the
right-hand side (fixed structure or the structure path of docs/model.md s.9-10, resolved by
creatio.dynamics.sphere.rhs_of) and the bookkeeping it uses.

How the loop is kept fast: :func:`run` allocates every array of the run (_arrays, the
implicit workspace) and hands them to the entry point, _drive inlined, which allocates
nothing and is compiled without reference counting (numba's ``_nrt=False``), as are the
right-hand sides and the step's observation. numba inlines the explicit step into the loop
(creatio.dynamics.solvers.explicit.step, with the tableau and stage arrays unpacked once,
before it), so a step neither crosses a function boundary nor takes or drops a reference to
an array: the atomic reference counts were a fifth of RK4's time (perf, EN-02), and inlining
a stepper that takes arrays in a counted loop cost 21-43 % more (measured). The generic
stepper reproduces the notebook's RK4, y + dt/6 (k1 + 2 (k2 + k3) + k4), bit for bit.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
from numba.core import types
from numba.extending import overload

from creatio.dynamics import status as st
from creatio.dynamics.jit import ensure_compiled, njit
from creatio.dynamics.layout import NDIAG
from creatio.dynamics.progress import CLOCK_MASK, tick
from creatio.dynamics.solvers import (
    EXPLICIT,
    RADAU,
    RADAU_VO,
    ROSENBROCK,
    STEPPERS,
    Method,
    explicit,
    radau5,
    radau_high_order,
    rosenbrock,
)
from creatio.dynamics.solvers.explicit import ACCEPTED, ERROR_REJECTED, next_step
from creatio.dynamics.sphere import (
    load,
    new_extrema,
    observe,
    pack_run,
    rhs_of,
)

__all__ = ["CONTROLLED", "SPECIALISATIONS", "accepted_step", "gave_up", "landed", "plan", "run",
           "target"]

#: The module of each implicit kind (the contract of the module docstring).
_IMPLICIT = {RADAU: radau5, ROSENBROCK: rosenbrock, RADAU_VO: radau_high_order}
assert set(_IMPLICIT) | {EXPLICIT} == set(STEPPERS)


def _implicit_step(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, ws, tol, fixed, rejected, pp,
                   lc, rot, en, free):
    """One try at one implicit step (compiled code only; resolved at compile time)."""
    raise NotImplementedError("called only from compiled code")


def _implicit_dense(stepper, ws, tg, yout, t, y, f, t_next, ynew, fnew):
    """The implicit stepper's dense output at tg inside its last accepted step t -> t_next
    (start y, f; end ynew, fnew) (compiled code only; resolved at compile time)."""
    raise NotImplementedError("called only from compiled code")


def _implicit_passed(stepper, ws, t, y, f):
    """Tell the implicit stepper that the dense step from (t, y, f) is done (compiled code
    only; resolved at compile time)."""
    raise NotImplementedError("called only from compiled code")


@overload(_implicit_step, prefer_literal=True, inline="always")
def _implicit_step_of(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, ws, tol, fixed, rejected,
                      pp, lc, rot, en, free):
    """The kind's step, inlined into the loop; for the explicit kind a stand-in that is never
    run, so an explicit run never types or compiles an implicit stepper."""
    if not isinstance(stepper, types.IntegerLiteral):
        return None
    module = _IMPLICIT.get(stepper.literal_value)
    if module is not None:
        return module.step.py_func

    def impl(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, ws, tol, fixed, rejected, pp, lc,
             rot, en, free):
        return ERROR_REJECTED, 1.0, 0, 0, 0, 0, False
    return impl


@overload(_implicit_dense, prefer_literal=True, inline="always")
def _implicit_dense_of(stepper, ws, tg, yout, t, y, f, t_next, ynew, fnew):
    """The kind's dense output: ``dense_step`` (from the step's ends) where the module has
    one, else ``dense``; a stand-in never run for the explicit kind."""
    if not isinstance(stepper, types.IntegerLiteral):
        return None
    module = _IMPLICIT.get(stepper.literal_value)
    if module is None:
        return lambda stepper, ws, tg, yout, t, y, f, t_next, ynew, fnew: None
    if hasattr(module, "dense_step"):
        dense_step = module.dense_step
        return lambda stepper, ws, tg, yout, t, y, f, t_next, ynew, fnew: dense_step(
            ws, tg, yout, t, y, f, t_next, ynew, fnew)
    dense = module.dense
    return lambda stepper, ws, tg, yout, t, y, f, t_next, ynew, fnew: dense(ws, tg, yout)


@overload(_implicit_passed, prefer_literal=True, inline="always")
def _implicit_passed_of(stepper, ws, t, y, f):
    """The kind's ``passed`` (what its dense output keeps of a finished step) where the module
    has one; else nothing."""
    if not isinstance(stepper, types.IntegerLiteral):
        return None
    module = _IMPLICIT.get(stepper.literal_value)
    if module is None or not hasattr(module, "passed"):
        return lambda stepper, ws, t, y, f: None
    passed = module.passed
    return lambda stepper, ws, t, y, f: passed(ws, t, y, f)


def _arrays(n: int, n_dense: int, en: bool) -> tuple:
    """Every array the loop writes for a state of size n, allocated once per run (the loop
    allocates nothing): the new state, the explicit stages (n_dense rows: the stages, the
    end-of-step one, the dense output's extra ones), the end-of-step derivative and its
    diagnostics, a trial state, a stage derivative, a dense-output state, the dense weights,
    the running extrema and the progress clock."""
    return (np.empty(n), np.empty((n_dense, n)), np.empty(n), np.empty(NDIAG), np.empty(n),
            np.empty(n), np.empty(n), np.empty(n_dense), new_extrema(en), np.zeros(2))


#: The running extrema's place in the tuple of _arrays.
_EXT = 8


@njit(inline="always")
def plan(fixed, dense, t_end, interval, h0, n_steps):
    """(whole output intervals of an adaptive or dense grid, first step size, whether the
    start is already the end) of a run: the loops' common start."""
    n_int = int(math.floor(t_end / interval * (1.0 + 1e-12))) if dense or not fixed else 0
    h = h0 if fixed or dense else min(h0, interval)
    final = n_steps == 0 if fixed else t_end <= 0.0
    return n_int, h, final


@njit(inline="always")
def target(fixed, dense, k, h0, jn, n_int, interval, t_end):
    """Where the next step aims: grid time (k + 1) h0 at a fixed step (t_end for the last one
    with dense output), t_end with dense output, else the output time jn (of n_int)."""
    if fixed:
        t_target = (k + 1) * h0
        if dense and t_target >= t_end * (1.0 - 1e-12):
            t_target = t_end
    elif dense:
        t_target = t_end
    else:
        t_target = jn * interval if jn <= n_int else t_end
        if t_target > t_end:
            t_target = t_end
    return t_target


@njit(inline="always")
def accepted_step(try_step, sargs, t, t_target, t_end, h, h_fixed, fixed, dense, land, have_f,
                  evals, tally, steps, max_evals, h_small, progress, clock):
    """One accepted step from t towards t_target, retried under the controller: the step-retry
    loop of the driver and of the flight loop (creatio.dynamics.solvers.flight), written once.

    Before each try: the evaluation budget, the progress line (creatio.dynamics.progress), and
    for an adaptive step the floors (creatio.dynamics.status.UNDERFLOW, COLLAPSE_TRIES) and the
    split of what remains to t_target into m equal steps no longer than the proposal h (with
    `dense`, steps of h, the last cut to what remains); a single step (m = 1) ends at t_target
    exactly with `land`, every other at t + h_use, which fails the run unless it passes t. A
    fixed step is h_fixed long, tried once: refused, it fails the run.
    try_step(sargs, t, t_next, h_use, rejected) is the loop's stepper, inlined: (outcome,
    factor, evaluations, Jacobians, LU decompositions, Newton iterations, whether the
    end-of-step evaluation is done). evals counts the run's evaluations against max_evals;
    tally = (rejected steps, Jacobians, LU decompositions, Newton iterations, tries, tries in a
    row below h_small). Returns (status, m, h_use, t_next, next proposal h, have_f, evals,
    tally).
    """
    n_rej, n_jac, n_lu, n_newton, tries, small = tally
    yes = np.bool_(True)
    status = st.OK
    remaining = t_target - t
    rejected = not yes
    accepted = not yes
    m = 1
    h_use = h_fixed
    t_next = t_target
    while not accepted:
        if evals >= max_evals:
            status = st.BUDGET_EXCEEDED
            break
        tries += 1
        if tries & CLOCK_MASK == 1 and progress < math.inf:
            tick(clock, t, t_end, steps, evals, max_evals, progress)
        if not fixed:
            if not math.isfinite(h):
                status = st.STEP_FAILED
                break
            small = small + 1 if h < h_small else 0
            if h < st.UNDERFLOW * max(1.0, t_end) or small > st.COLLAPSE_TRIES:
                status = st.STEP_SIZE_COLLAPSE
                break
            if dense:
                m = 1 if h >= remaining * (1.0 - 1e-9) else 2
                h_use = remaining if m == 1 else h
            else:
                m = math.ceil(remaining / h * (1.0 - 1e-9))
                if m < 1:
                    m = 1
                h_use = remaining / m
            if land and m == 1:
                t_next = t_target
            else:
                t_next = t + h_use
                if t_next <= t:
                    status = st.STEP_FAILED
                    break
        outcome, factor, ev, nj, nl, nn, have_f = try_step(sargs, t, t_next, h_use, rejected)
        evals += ev
        n_jac += nj
        n_lu += nl
        n_newton += nn
        if outcome == ACCEPTED:
            accepted = yes
            if not fixed:
                h = next_step(h, h_use, factor, m)
        elif fixed:
            status = st.STEP_FAILED
            break
        else:
            h = h_use * factor
            rejected = yes
            n_rej += 1
    return status, m, h_use, t_next, h, have_f, evals, (n_rej, n_jac, n_lu, n_newton, tries,
                                                        small)


@njit(inline="always")
def landed(fixed, dense, k, n_steps, stride, m, t_next, t_target, t_end, jn):
    """(t, jn, final, sample) after an accepted step, the k-th of a fixed-step run: a fixed
    or dense step ends at t_next; an adaptive one at t_target when it was the last of its
    split (m == 1), which is then the output time jn, and the next one is jn + 1."""
    if dense:
        return t_next, jn, t_next == t_end, t_next == t_end
    if fixed:
        return t_next, jn, k == n_steps, k % stride == 0
    hit = m == 1
    if hit:
        return t_target, jn + 1, t_target >= t_end, hit
    return t_next, jn, False, False


@njit(inline="always")
def gave_up(status):
    """Whether the run stopped for its integrator's sake (a failed step or foot point, the
    budget, a collapsed step size) rather than the model's: its last state gets a row."""
    return (status == st.STEP_FAILED or status == st.FOOT_POINT_FAILED
            or status == st.BUDGET_EXCEEDED or status == st.STEP_SIZE_COLLAPSE)


@njit(inline="always")
def _try(sargs, t, t_next, h, rejected):
    """One try at the driver's step t -> t_next = t + h by the stepper of its kind (the
    try_step of :func:`accepted_step`)."""
    (stepper, free, c, a_ptr, a_idx, a_val, b_idx, b_val, e, e3, scalars, y, f, ynew, fnew,
     dbuf, K, work, kst, iws, tol, fixed, dense, pp, lc, rot, en) = sargs
    if stepper == EXPLICIT:
        outcome, factor, ev, have_f = explicit.step(
            free, c, a_ptr, a_idx, a_val, b_idx, b_val, e, e3, scalars, t, t_next, h, y, ynew,
            fnew, dbuf, K, work, kst, tol, fixed, dense, rejected, pp, lc, rot, en)
        return outcome, factor, ev, 0, 0, 0, have_f
    return _implicit_step(stepper, t, t_next, h, y, f, ynew, fnew, dbuf, iws, tol, fixed,
                          rejected, pp, lc, rot, en, free)


# inlined by numba into each entry point (the entry is the one compiled function of a run)
@njit(inline="always")
def _drive(stepper, p, lawc, y, arrays, iws, t_end, interval, h0, n_steps, stride, rtol, atol,
           fixed, max_evals, progress, tab, out, rot, en, free, dense, ctl):
    """Integrate from t = 0 to t_end, from the initial state y (overwritten), with the
    stepper of kind `stepper` (a compile-time constant); rows of `out` are the sampled
    histories. The arrays it writes come from _arrays and, for an implicit kind, its
    workspace iws: it allocates none, and is compiled without reference counting (numba's
    _nrt=False), so no step takes or drops a reference to an array.

    Fixed step: h0 = dt, n_steps steps, a history row every `stride` steps. Adaptive: h0 is
    the first step, rows on the grid of `interval`. tab is the explicit tableau
    (creatio.dynamics.solvers.DriverTableau; a stand-in for an implicit kind). With `dense`,
    steps are not cut to the grid: the step size runs free (a
    fixed step need not divide the interval), only the last step lands on t_end, and the rows
    on the grid are the step's dense output (with one more right-hand-side evaluation each
    for their diagnostics). Returns (status, steps, rows, rhs_evals, rejected, jacobians,
    lu_factorisations, newton_iterations, stop_time), the extrema in the arrays;
    STEP_SIZE_COLLAPSE when the adaptive step size falls below its floors (creatio.dynamics
    .status.UNDERFLOW, COLLAPSE_TRIES), STEP_FAILED when the step size is not finite or Newton
    fails at a fixed step, BUDGET_EXCEEDED when max_evals right-hand-side evaluations did not
    reach t_end (neither the budget nor the floors ever change a step; all three are
    :func:`accepted_step`'s). A line of progress goes to stderr every `progress` seconds (inf:
    never). ctl: the controlled path (docs/model.md s.12.2), whose parameter vector carries
    the controller's row after its parameters.
    """
    pp, lc = pack_run(ctl, p, lawc)
    (c, a_ptr, a_idx, a_val, b_idx, b_val, b_divisor, e, e3, estimator, error_order, c_extra,
     a_extra, dense_p) = tab
    n = y.size
    s = c.size
    ynew, K, fnew, dbuf, work, kst, yout, wq, ext, clock = arrays
    f = K[0]  # f(t, y) is the first stage: a view made once, so never copied into K
    sargs = (stepper, free, c, a_ptr, a_idx, a_val, b_idx, b_val, e, e3,
             (b_divisor, estimator, error_order), y, f, ynew, fnew, dbuf, K, work, kst, iws,
             (rtol, atol), fixed, dense, pp, lc, rot, en)
    # Counters and flags start as typed values, not literals: a literal argument would make
    # numba compile the callee once more for it (observe), costing seconds.
    evals = np.int64(0)
    tally = (evals, evals, evals, evals, evals, evals)
    rows = np.int64(0)
    steps = np.int64(0)
    h_small = t_end / max_evals
    top_wrote = np.int64(0)
    yes = np.bool_(True)
    no = not yes
    t = 0.0
    status = st.OK
    n_int, h, final = plan(fixed, dense, t_end, interval, h0, n_steps)
    jn = 1
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
        status, top_wrote = observe(steps == 0, t, y, d, pp, ext, out, rows, final, sample, rot,
                                    en, free)
        rows += top_wrote
        if status != st.OK or final:
            break
        t_target = target(fixed, dense, steps, h0, jn, n_int, interval, t_end)
        h_fixed = t_end - t if dense and t_target == t_end else h
        status, m, h_use, t_next, h, have_f, evals, tally = accepted_step(
            _try, sargs, t, t_target, t_end, h, h_fixed, fixed, dense, dense, have_f, evals,
            tally, steps, max_evals, h_small, progress, clock)
        if status != st.OK:
            break
        if dense:
            # rows on the grid inside the step (t_end's row is the landing step's end)
            extras_done = not yes
            while jn <= n_int:
                tg = jn * interval
                if tg > t_next or tg >= t_end * (1.0 - 1e-12):
                    break
                if stepper == EXPLICIT:
                    evals += explicit.dense(free, s, c_extra, a_extra, dense_p, extras_done, t,
                                            h_use, y, tg, yout, K, work, kst, wq, pp, lc, rot,
                                            en)
                    extras_done = yes
                else:
                    _implicit_dense(stepper, iws, tg, yout, t, y, f, t_next, ynew, fnew)
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
            if stepper != EXPLICIT:
                _implicit_passed(stepper, iws, t, y, f)
        steps += 1
        for j in range(n):
            y[j] = ynew[j]
        if have_f:
            for j in range(n):
                f[j] = fnew[j]
        t, jn, final, sample = landed(fixed, dense, steps, n_steps, stride, m, t_next, t_target,
                                      t_end, jn)
    if gave_up(status) and top_wrote == 0:
        # record the state where the run gave up, so the stop is visible in the histories
        # (unless that state's row was just written)
        d = rhs_of(free, t, y, f, pp, lc, rot, en, True)
        evals += 1
        _, wrote = observe(steps == 0, t, y, d, pp, ext, out, rows, yes, yes, rot, en, free)
        rows += wrote
    n_rej, n_jac, n_lu, n_newton, _, _ = tally
    return status, steps, rows, evals, n_rej, n_jac, n_lu, n_newton, t


def _entry(stepper: int, rot: bool, en: bool, free: bool, ctl: bool = False):
    """The compiled entry point of one specialisation: _drive with the stepper kind and the
    rotation, energy and structure flags as constants (numba freezes a closure's variables),
    so a run compiles only the stepper, right-hand side and bookkeeping it uses. Its name
    spells the key, and is what numba's cache files it under (one file per entry).

    _drive is inlined into it and the arrays come from :func:`run`, so a run compiles one
    function around the loop, without reference counting: a separate entry that allocated
    them and called _drive cost a second LLVM optimisation of the whole linked loop and its
    machine code (about 2 s of every cold compile)."""
    def entry(p, lawc, y, arrays, iws, t_end, interval, h0, n_steps, stride, rtol, atol, fixed,
              max_evals, progress, tab, out, dense):
        return _drive(stepper, p, lawc, y, arrays, iws, t_end, interval, h0, n_steps, stride,
                      rtol, atol, fixed, max_evals, progress, tab, out, rot, en, free, dense,
                      ctl)

    flags = [name for name, on in (("structure", free), ("rot", rot), ("en", en),
                                   ("control", ctl)) if on]
    entry.__name__ = entry.__qualname__ = "_".join(["", STEPPERS[stepper], *flags])
    return njit(cache=True, _nrt=False)(entry)


#: The compiled specialisations, (stepper kind, rotation, energy, structure) -> entry point,
#: generated from STEPPERS and the three flags; each is compiled and cached on first use.
SPECIALISATIONS = {key: _entry(*key) for key in itertools.product(
    STEPPERS, (True, False), (True, False), (True, False))}
#: The controlled path's entry points (docs/model.md s.12.2), (stepper kind, rotation,
#: energy) -> entry point: every stepper kind on the fixed structure (the implicit kinds'
#: Jacobian differences the control block's columns too, creatio.dynamics.solvers.radau5).
CONTROLLED = {(stepper, rot, en): _entry(stepper, rot, en, False, True)
              for stepper, rot, en in itertools.product(STEPPERS, (True, False),
                                                        (True, False))}


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
    max_evals: int,
    progress: float,
    rotation: bool,
    energy: bool,
    free: bool = False,
    dense: bool = False,
    control: bool = False,
) -> tuple:
    """Run `method` through its compiled specialisation: (status, steps, rows, rhs_evals,
    extrema, rejected, jacobians, lu_factorisations, stop_time, newton_iterations), see _drive.
    free selects the structure path (docs/model.md s.9-10); dense the rows from dense output
    instead of steps cut to land on the grid; control the controlled phase (s.12.2: p then
    carries the controller's row after its parameters, y0 the control block last)."""
    if control:
        fn = CONTROLLED[(method.stepper, bool(rotation), bool(energy))]
    else:
        fn = SPECIALISATIONS[(method.stepper, bool(rotation), bool(energy), bool(free))]
    tab = method.driver_tableau
    n = y0.size
    arrays = _arrays(n, tab.dense.shape[0], bool(energy))
    module = _IMPLICIT.get(method.stepper)
    iws = module.workspace(n, tab.c) if module is not None else np.empty(0)
    call = (p, lawc, y0.copy(), arrays, iws, float(t_end), float(interval), float(h0),
            int(n_steps), int(stride), float(rtol), float(atol), bool(fixed), int(max_evals),
            float(progress), tab, out, bool(dense))
    ensure_compiled(fn, call, f"the {method.name} loop")
    status, steps, rows, evals, n_rej, n_jac, n_lu, n_newton, t = fn(*call)
    return status, steps, rows, evals, arrays[_EXT], n_rej, n_jac, n_lu, t, n_newton
