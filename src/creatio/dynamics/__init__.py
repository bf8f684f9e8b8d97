"""Numeric core of the sphere dynamics on the moving corrugated surface (MODEL.md s.1-6).

Plain numbers in, numpy arrays out: a SphereProblem is integrated by a compiled loop
(simulate): fixed-step RK4 (the notebook's reference), the adaptive pairs dopri5 and
dop853, or the L-stable radau5; the friction stability limit of a fixed-step explicit
scheme (stability_limit) is enforced.
"""

from creatio.dynamics.kinematics import centre_kinematics
from creatio.dynamics.laws import law_eval
from creatio.dynamics.problem import (
    METHODS,
    RK4_REAL_STABILITY,
    STABILITY_MARGIN,
    SimulationResult,
    SphereProblem,
    UnstableStepError,
    simulate,
    stability_limit,
)

__all__ = [
    "METHODS",
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
