"""What a long run says while it runs, and why it stopped: one line each, to stderr.

The compiled loops look at the clock every CLOCK_MASK + 1 step attempts (:func:`tick`, a
short trip to the interpreter through numba's object mode, cheap at that rate) and print a
line when ``interval`` seconds have passed since the last one: how far the run is, how many
steps and right-hand-side evaluations it took (against its budget), and its rate. A run that
spends its budget ends with :func:`budget_message`.
"""

from __future__ import annotations

import sys
import time

from numba import objmode

from creatio.dynamics.jit import njit

__all__ = ["CLOCK_MASK", "budget_message", "tick"]

#: Step attempts between two looks at the clock, minus one (a mask: a look every 4096).
CLOCK_MASK = 4095


def _report(clock, t: float, t_end: float, steps: int, evals: int, budget: int,
            interval: float) -> None:
    """Start the clock on the first look (clock = [start, last line]); later, print a line
    when `interval` seconds have passed since the last."""
    now = time.perf_counter()
    if clock[0] == 0.0:
        clock[0] = clock[1] = now
        return
    if now - clock[1] < interval:
        return
    clock[1] = now
    rate = steps / (now - clock[0])
    print(f"creatio: t = {t:.6g} of {t_end:.6g} s ({100 * t / t_end:.1f} %), {steps:,} steps, "
          f"{evals:,} right-hand-side evaluations ({100 * evals / budget:.1f} % of the "
          f"budget), {rate:,.0f} steps/s", file=sys.stderr, flush=True)


@njit(cache=True)
def tick(clock, t, t_end, steps, evals, budget, interval):
    """A look at the clock from compiled code (see the module)."""
    with objmode():
        _report(clock, t, t_end, steps, evals, budget, interval)


def budget_message(stop_time: float, t_end: float, steps: int, budget: int) -> str:
    """The one line of a run stopped by its budget."""
    return (f"stopped at t = {stop_time:.6g} of {t_end:.6g} s after {steps:,} steps: the budget "
            f"of {budget:,} right-hand-side evaluations (solver.max_rhs_evals) is spent")
