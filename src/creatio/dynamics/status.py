"""How a sphere run ended: status codes named once, for the compiled loops and their callers.

A run stops at the first step where the model no longer applies (docs/model.md s.4), where
its integrator gives up, or where it has spent its budget of right-hand-side evaluations; the
status is data in the dataset, never an exception. Leaving the
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
)
