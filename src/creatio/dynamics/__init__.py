"""Numeric core of the sphere dynamics on the moving corrugated surface (docs/model.md s.4-11).

Plain numbers in, NumPy arrays out. A SphereProblem (a Model, its Start, and the Solver,
Output and Events of the run) is integrated by :func:`simulate`, one compiled loop
(creatio.dynamics.solvers.driver) running any registered method
(creatio.dynamics.solvers.METHODS: fixed-step RK4, the notebook's reference; the adaptive
pairs dopri5 and dop853; the L-stable radau5 and rodas4). The friction stability limit of a
fixed-step explicit scheme (:func:`stability_limit`, :func:`check_stable`) is enforced. Its
SimulationResult holds named records: ``res.histories``, ``res.extrema``, ``res.counts``,
``res.events``.

Importing this package compiles nothing: the compiler loads with the first
:func:`simulate` call, so validation and planning can build problems without it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from creatio.dynamics.problem import (
    Counts,
    EventLog,
    Events,
    Extrema,
    Histories,
    Model,
    Output,
    SimulationResult,
    Solver,
    Sphere,
    SphereProblem,
    Start,
    Structure,
    UnstableStepError,
    check_stable,
    normal_reaction_at_start,
    stability_limit,
)
from creatio.dynamics.solvers import METHODS

if TYPE_CHECKING:
    from creatio.dynamics.simulation import compiled_call, simulate

__all__ = [
    "METHODS",
    "Counts",
    "EventLog",
    "Events",
    "Extrema",
    "Histories",
    "Model",
    "Output",
    "SimulationResult",
    "Solver",
    "Sphere",
    "SphereProblem",
    "Start",
    "Structure",
    "UnstableStepError",
    "check_stable",
    "compiled_call",
    "normal_reaction_at_start",
    "simulate",
    "stability_limit",
]


def __getattr__(name: str):
    """Load the compiled half on first use: ``simulate`` and ``compiled_call`` import numba."""
    if name in ("simulate", "compiled_call"):
        from creatio.dynamics import simulation

        return getattr(simulation, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
