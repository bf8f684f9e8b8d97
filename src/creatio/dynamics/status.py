"""How a sphere run ended: status codes named once, for the compiled loops and their callers.

A run stops at the first step where the model no longer applies (docs/model.md s.4) or where
its integrator gives up; the status is data in the dataset, never an exception.
"""

from __future__ import annotations

__all__ = [
    "CONTACT_LOST",
    "EDGE_CROSSED",
    "LEFT_ANNULUS",
    "NAMES",
    "NON_FINITE",
    "OFFSET_SINGULAR",
    "OK",
    "STEP_FAILED",
]

OK = 0               # the run completed
CONTACT_LOST = 1     # the normal reaction N reached 0
LEFT_ANNULUS = 2     # the contact point left R in [0, dR]
EDGE_CROSSED = 3     # the sphere's envelope crossed an edge of the annulus
OFFSET_SINGULAR = 4  # b times a principal curvature of the surface reached 1
NON_FINITE = 5       # a state or diagnostic stopped being finite
STEP_FAILED = 6      # the step control or Newton iteration gave up (or the step budget ran out)

#: Status names by code, as written into datasets and reports.
NAMES = (
    "ok",
    "contact_lost",
    "left_annulus",
    "edge_crossed",
    "offset_singular",
    "non_finite",
    "step_failed",
)
