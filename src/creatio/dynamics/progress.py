"""What a long run says while it runs, and why it stopped: one line each, to stderr.

The compiled loops look at the clock every CLOCK_MASK + 1 step tries (:func:`tick`) and print
a line when ``interval`` seconds have passed since the last one: how far the run is, how many
steps and right-hand-side evaluations it took (against its budget), and its rate. A run that
spends its budget ends with :func:`budget_message`.

The clock and the line are libc's (``clock_gettime`` on the monotonic clock, ``dprintf`` to
file descriptor 2), called from compiled code directly: the loops are compiled without
reference counting (creatio.dynamics.solvers.driver), where numba's object mode fails, and a
look costs a few tens of nanoseconds. 64-bit platforms (``time_t`` and ``long`` of 64 bits).
"""

from __future__ import annotations

import time

import numpy as np
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

from creatio.dynamics.jit import njit

__all__ = ["CLOCK_MASK", "budget_message", "tick"]

#: Step tries between two looks at the clock, minus one (a mask: a look every 4096).
CLOCK_MASK = 4095

#: The platform's id of the monotonic clock, for clock_gettime.
_MONOTONIC = time.CLOCK_MONOTONIC

#: The progress line (printf format, NUL-terminated for dprintf).
_LINE = (b"creatio: t = %.6g of %.6g s (%.1f %%), %lld steps, %lld right-hand-side "
         b"evaluations (%.1f %% of the budget), %.0f steps/s\n\0")


@intrinsic
def _now(typingctx):
    """Seconds on the monotonic clock (libc clock_gettime)."""
    def codegen(context, builder, signature, args):
        i64 = ir.IntType(64)
        timespec = ir.LiteralStructType([i64, i64])
        fnty = ir.FunctionType(ir.IntType(32), [ir.IntType(32), timespec.as_pointer()])
        clock_gettime = cgutils.get_or_insert_function(builder.module, fnty, "clock_gettime")
        ts = cgutils.alloca_once(builder, timespec)
        builder.call(clock_gettime, [ir.Constant(ir.IntType(32), _MONOTONIC), ts])
        sec = builder.load(cgutils.gep_inbounds(builder, ts, 0, 0))
        nsec = builder.load(cgutils.gep_inbounds(builder, ts, 0, 1))
        d = ir.DoubleType()
        return builder.fadd(builder.sitofp(sec, d),
                            builder.fmul(builder.sitofp(nsec, d), ir.Constant(d, 1e-9)))
    return types.float64(), codegen


@intrinsic
def _print_line(typingctx, t, t_end, percent, steps, evals, of_budget, rate):
    """dprintf(2, _LINE, ...): the progress line, straight to stderr."""
    def codegen(context, builder, signature, args):
        i32 = ir.IntType(32)
        text = cgutils.global_constant(builder.module, "creatio_progress_line",
                                       cgutils.make_bytearray(_LINE))
        fnty = ir.FunctionType(i32, [i32, cgutils.voidptr_t], var_arg=True)
        dprintf = cgutils.get_or_insert_function(builder.module, fnty, "dprintf")
        builder.call(dprintf, [ir.Constant(i32, 2), builder.bitcast(text, cgutils.voidptr_t),
                               *args])
        return context.get_dummy_value()
    return types.void(types.float64, types.float64, types.float64, types.int64, types.int64,
                      types.float64, types.float64), codegen


@njit(cache=True, _nrt=False)
def tick(clock, t, t_end, steps, evals, budget, interval):
    """A look at the clock (clock = [start, last line]): the first starts the clock; a later
    one prints a line when `interval` seconds have passed since the last."""
    now = _now()
    if clock[0] == 0.0:
        clock[0] = now
        clock[1] = now
        return
    if now - clock[1] < interval:
        return
    clock[1] = now
    _print_line(float(t), float(t_end), 100.0 * t / t_end, np.int64(steps), np.int64(evals),
                100.0 * evals / budget, steps / (now - clock[0]))


def budget_message(stop_time: float, t_end: float, steps: int, budget: int) -> str:
    """The one line of a run stopped by its budget."""
    return (f"stopped at t = {stop_time:.6g} of {t_end:.6g} s after {steps:,} steps: the budget "
            f"of {budget:,} right-hand-side evaluations (solver.max_rhs_evals) is spent")
