"""Numeric core of the sphere dynamics on the moving corrugated surface (MODEL.md s.1-6).

Plain numbers in, numpy arrays out: a SphereProblem is integrated by a compiled fixed-step
RK4 loop (simulate), with the friction stability limit (stability_limit) enforced.
"""

from creatio.dynamics.kinematics import centre_kinematics
from creatio.dynamics.laws import law_eval
from creatio.dynamics.problem import (
    RK4_REAL_STABILITY,
    STABILITY_MARGIN,
    SimulationResult,
    SphereProblem,
    UnstableStepError,
    simulate,
    stability_limit,
)

__all__ = [
    "RK4_REAL_STABILITY",
    "STABILITY_MARGIN",
    "SimulationResult",
    "SphereProblem",
    "UnstableStepError",
    "centre_kinematics",
    "law_eval",
    "simulate",
    "stability_limit",
]
