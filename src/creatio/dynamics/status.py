"""How a sphere run ended: status codes named once, for the compiled loops and their callers.

A run stops at the first step where the model no longer applies (docs/model.md s.4), where
its integrator gives up, where its step size collapses (:data:`COLLAPSE_TRIES`), or where it
has spent its budget of right-hand-side evaluations; the status is data in the dataset, never
an exception. Leaving the
cavity's cell (docs/model.md s.8.2) is an outcome, recorded as a time and not a stop, unless
a run asks to stop there (the bisection probes of EN-03M); a run whose equilibrium start
(docs/model.md s.8.1) does not exist computes nothing and says so.
"""

from __future__ import annotations

__all__ = [
    "CONTACT_LOST",
    "EDGE_CROSSED",
    "FOOT_POINT_FAILED",
    "LEFT_ANNULUS",
    "LEFT_CAVITY",
    "NAMES",
    "NO_EQUILIBRIUM",
    "NON_FINITE",
    "OFFSET_SINGULAR",
    "OK",
    "STEP_FAILED",
    "BUDGET_EXCEEDED",
    "COLLAPSE_TRIES",
    "STEP_SIZE_COLLAPSE",
    "UNDERFLOW",
    "collapse_message",
]

OK = 0               # the run completed
CONTACT_LOST = 1     # the normal reaction N reached 0
LEFT_ANNULUS = 2     # the contact point left R in [0, dR]
EDGE_CROSSED = 3     # the sphere's envelope crossed an edge of the annulus
OFFSET_SINGULAR = 4  # b times a principal curvature of the surface reached 1
NON_FINITE = 5       # a state or diagnostic stopped being finite
STEP_FAILED = 6      # the step control or Newton iteration gave up
LEFT_CAVITY = 7      # the contact point left its cavity's cell; a stop only when asked for
NO_EQUILIBRIUM = 8   # an equilibrium start was asked for and none is acceptable: nothing ran
FOOT_POINT_FAILED = 9  # in flight, Newton found no foot point of the centre on the surface
BUDGET_EXCEEDED = 10   # the run spent its budget of right-hand-side evaluations before t_end
STEP_SIZE_COLLAPSE = 11  # the adaptive step size fell below its floor: the run cannot progress

#: The step-size floors of an adaptive run (t0 = 0). At once: a step proposal below UNDERFLOW
#: times max(1 s, t_end) ends the run; there t + h is within ~100 rounding units of t (the
#: spacing of doubles near 120 s is 1.4e-14 s), so a step no longer moves time meaningfully.
#: Sustained: proposals below t_end / max_rhs_evals for COLLAPSE_TRIES step tries in a row end
#: it too; steps that small cannot cover the run within its budget even at one evaluation a
#: step (with the default budget, 5e7, 2.4e-6 s for 120 s). EN-02 with radau5 at
#: sphere.eps = 1e-9 steps ~8e-10 s and would spend its budget in a minute of one core (the
#: example of issue 28); the default runs' steps stay orders of magnitude above both floors.
UNDERFLOW = 1e-12
COLLAPSE_TRIES = 1000

#: Status names by code, as written into datasets and reports.
NAMES = (
    "ok",
    "contact_lost",
    "left_annulus",
    "edge_crossed",
    "offset_singular",
    "non_finite",
    "step_failed",
    "left_cavity",
    "no_equilibrium",
    "foot_point_failed",
    "budget_exceeded",
    "step_size_collapse",
)


def collapse_message(stop_time: float, t_end: float, steps: int, budget: int, cause: str) -> str:
    """The one line of a run stopped by step_size_collapse: where, the floors, the likely
    cause (a phrase naming the config key to change)."""
    return (f"stopped at t = {stop_time:.6g} of {t_end:.6g} s after {steps:,} steps: the step size "
            f"collapsed (below {UNDERFLOW:g} x max(1 s, t_end) once, or below t_end / "
            f"solver.max_rhs_evals = {t_end / budget:.3g} s for {COLLAPSE_TRIES:,} tries in a "
            f"row); likely cause: {cause}")
