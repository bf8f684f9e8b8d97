"""The step-retry loop the driver and the flight loop share (creatio.dynamics.solvers.driver
.accepted_step) and the grid's targets and landing, driven by a scripted stepper: the split of
what remains to the target, the exact landing, the controller's proposals after a rejection
and an acceptance, the budget, the floors and a failed fixed step, each against values worked
out by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from creatio.dynamics import status as st
from creatio.dynamics.solvers.driver import accepted_step, landed, plan, target
from creatio.dynamics.solvers.explicit import ACCEPTED, ERROR_REJECTED

#: Work counters each scripted try reports: evaluations, Jacobians, LU decompositions, Newton
#: iterations.
EV, NJ, NL, NN = 3, 1, 2, 4


@njit(cache=True)
def _scripted(sargs, t, t_next, h, rejected):
    """Try i answers outcomes[i] and factors[i] (the last entry for every later try) and logs
    (t_next, h, rejected) into row i of log (log[-1, 0] counts the tries)."""
    outcomes, factors, log = sargs
    i = int(log[-1, 0])
    log[-1, 0] += 1.0
    j = min(i, outcomes.size - 1)
    if i < log.shape[0] - 1:
        log[i, 0] = t_next
        log[i, 1] = h
        log[i, 2] = 1.0 if rejected else 0.0
    return outcomes[j], factors[j], EV, NJ, NL, NN, True


@njit(cache=True)
def _step(outcomes, factors, log, t, t_target, t_end, h, h_fixed, fixed, dense, land, evals,
          max_evals, h_small):
    """accepted_step with the scripted stepper, every counter from 0 but evals, no progress."""
    z = np.int64(0)
    return accepted_step(_scripted, (outcomes, factors, log), t, t_target, t_end, h, h_fixed,
                         fixed, dense, land, False, np.int64(evals), (z, z, z, z, z, z), z,
                         max_evals, h_small, math.inf, np.zeros(2))


def _run(outcomes, factors, *, t=0.0, t_target=1.0, t_end=1.0, h=0.3, h_fixed=0.0, fixed=False,
         dense=False, land=False, evals=0, max_evals=10**6, h_small=0.0, rows=8):
    """(result of accepted_step, the tries' log rows)."""
    log = np.zeros((rows + 1, 3))
    res = _step(np.array(outcomes, dtype=np.int64), np.array(factors, dtype=float), log, t,
                t_target, t_end, h, h_fixed, fixed, dense, land, evals, max_evals, h_small)
    return res, log[: int(log[-1, 0])]


def test_a_rejected_try_is_retried_with_the_shorter_proposal() -> None:
    """h = 0.3 splits [0, 1] into m = 4 steps of 0.25; rejected with factor 0.5 the proposal
    is 0.125, so m = 8 steps of 0.125; accepted with factor 2 the next proposal is 0.25."""
    (status, m, h_use, t_next, h, have_f, evals, tally), log = _run(
        [ERROR_REJECTED, ACCEPTED], [0.5, 2.0])
    assert status == st.OK and have_f
    assert (m, h_use, t_next, h) == (8, 0.125, 0.125, 0.25)
    assert log.tolist() == [[0.25, 0.25, 0.0], [0.125, 0.125, 1.0]]
    assert evals == 2 * EV
    assert tally == (1, 2 * NJ, 2 * NL, 2 * NN, 2, 0)


def test_a_single_step_lands_on_its_target_only_when_asked() -> None:
    """From t = 0.2 to 0.9 with a larger proposal: one step (m = 1); t + (0.9 - 0.2) rounds to
    0.8999999999999999, which the driver's grid steps keep and the landing steps replace by
    the target itself. The proposal 2 that was cut to land is kept (1.5 x 0.7 is less)."""
    res, _ = _run([ACCEPTED], [1.5], t=0.2, t_target=0.9, h=2.0)
    assert res[1] == 1 and res[3] == 0.2 + (0.9 - 0.2) == 0.8999999999999999
    assert res[4] == 2.0
    landing, _ = _run([ACCEPTED], [1.5], t=0.2, t_target=0.9, h=2.0, land=True)
    assert landing[1] == 1 and landing[3] == 0.9


def test_dense_steps_run_free_and_the_last_lands() -> None:
    """With dense output a step shorter than what remains is the proposal itself (m = 2); one
    that reaches the target is cut to it and lands on it exactly."""
    (status, m, h_use, t_next, *_), _ = _run([ACCEPTED], [1.0], t=0.1, h=0.3, dense=True,
                                             land=True)
    assert (status, m, h_use, t_next) == (st.OK, 2, 0.3, 0.1 + 0.3)
    (status, m, h_use, t_next, *_), _ = _run([ACCEPTED], [1.0], t=0.1, h=0.95, dense=True,
                                             land=True)
    assert (status, m, h_use, t_next) == (st.OK, 1, 1.0 - 0.1, 1.0)


def test_a_fixed_step_is_tried_once() -> None:
    """A fixed step is h_fixed long and ends at the target, its proposal unchanged; one the
    stepper refuses (Newton failing at a fixed step) fails the run, not retried."""
    (status, m, h_use, t_next, h, *_), log = _run([ACCEPTED], [7.0], h=0.3, h_fixed=0.2,
                                                  t=0.8, fixed=True)
    assert (status, m, h_use, t_next, h) == (st.OK, 1, 0.2, 1.0, 0.3) and len(log) == 1
    (status, *_, evals, tally), log = _run([ERROR_REJECTED], [0.5], h_fixed=0.2, fixed=True)
    assert status == st.STEP_FAILED and len(log) == 1 and evals == EV and tally[0] == 0


def test_the_budget_is_checked_before_each_try() -> None:
    """A spent budget stops before any try; a budget spent by rejections stops at the try
    that would exceed it (2 tries of 3 evaluations reach a budget of 5)."""
    (status, *_, evals, tally), log = _run([ACCEPTED], [1.0], evals=100, max_evals=100)
    assert status == st.BUDGET_EXCEEDED and len(log) == 0 and evals == 100
    (status, *_, evals, tally), log = _run([ERROR_REJECTED], [0.9], max_evals=5)
    assert status == st.BUDGET_EXCEEDED and len(log) == 2 and evals == 2 * EV
    assert tally[0] == 2 and tally[4] == 2  # a try is counted once past the budget check


@pytest.mark.parametrize(("h", "status"), [(math.nan, st.STEP_FAILED),
                                           (math.inf, st.STEP_FAILED),
                                           (0.9e-12, st.STEP_SIZE_COLLAPSE)])
def test_a_proposal_below_the_floor_stops_at_once(h: float, status: int) -> None:
    """A proposal that is not finite fails; one below UNDERFLOW x max(1 s, t_end) collapses
    (t_end = 1 s: 1e-12 s), in both cases before any try."""
    res, log = _run([ACCEPTED], [1.0], h=h)
    assert res[0] == status and len(log) == 0


def test_proposals_below_the_sustained_floor_collapse_after_collapse_tries() -> None:
    """A proposal above UNDERFLOW but below h_small, rejected with factor 1 every time:
    COLLAPSE_TRIES tries in a row are taken, the next one stops the run."""
    (status, *_, tally), log = _run([ERROR_REJECTED], [1.0], h=1e-9, h_small=1e-6)
    assert status == st.STEP_SIZE_COLLAPSE
    assert tally[0] == st.COLLAPSE_TRIES and tally[4] == st.COLLAPSE_TRIES + 1
    assert tally[5] == st.COLLAPSE_TRIES + 1


@njit(cache=True)
def _grid():
    """plan, target and landed at the cases of :func:`test_the_grid_plan_targets_and_landing`
    (one compiled function, cached: called from Python each would compile anew)."""
    plans = (plan(True, False, 1.0, 0.1, 0.01, 100), plan(False, False, 1.0, 0.1, 0.5, 0),
             plan(False, True, 1.05, 0.1, 0.5, 0), plan(True, False, 1.0, 0.1, 0.01, 0),
             plan(False, False, 0.0, 0.1, 0.5, 0))
    targets = (target(True, False, 4, 0.25, 1, 0, 0.1, 2.0),
               target(True, True, 7, 0.25, 1, 0, 0.1, 1.9),
               target(False, True, 0, 0.25, 3, 10, 0.1, 1.0),
               target(False, False, 0, 0.25, 3, 10, 0.1, 1.0),
               target(False, False, 0, 0.25, 11, 10, 0.1, 1.05))
    landings = (landed(True, False, 6, 8, 3, 1, 1.5, 1.5, 2.0, 1),
                landed(True, False, 8, 8, 3, 1, 2.0, 2.0, 2.0, 1),
                landed(False, False, 0, 0, 1, 3, 0.7, 0.9, 2.0, 4),
                landed(False, False, 0, 0, 1, 1, 0.9000000000000001, 0.9, 2.0, 4),
                landed(False, False, 0, 0, 1, 1, 2.0, 2.0, 2.0, 20),
                landed(False, True, 0, 0, 1, 2, 1.2, 2.0, 2.0, 4),
                landed(False, True, 0, 0, 1, 1, 2.0, 2.0, 2.0, 4))
    return plans, targets, landings


def test_the_grid_plan_targets_and_landing() -> None:
    """The start of a run (whole output intervals, first step, already at the end), the next
    step's target and the state after it, fixed, adaptive and dense."""
    plans, targets, landings = _grid()
    assert plans[:3] == ((0, 0.01, False), (10, 0.1, False), (10, 0.5, False))
    assert plans[3][2] and plans[4][2]  # no steps, or t_end = 0: the start is the end
    # a fixed step's grid time, the last dense step landing on t_end, dense steps aiming at
    # t_end, the next output time, t_end past the last whole interval
    assert targets == (1.25, 1.9, 1.0, 3 * 0.1, 1.05)
    assert landings == (
        (1.5, 1, False, True), (2.0, 1, True, False),  # fixed: final at n_steps, rows by stride
        (0.7, 4, False, False), (0.9, 5, False, True),  # adaptive: a split's last step lands
        (2.0, 21, True, True),
        (1.2, 4, False, False), (2.0, 4, True, True))  # dense: ends at t_next, final at t_end
