"""The config schema of EN-03 (docs/studies.md): EN-02 on a structure free to yaw, the
inertia sweep and the fixed-structure limit; the run is en03.py."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from creatio.dynamics import problem as core
from creatio.dynamics.problem import SphereProblem
from creatio.studies.schema import (
    MISSING,
    DynamicConfig,
    DynamicStudy,
    StructureConfig,
    check_inertia,
    require,
)

__all__ = ["En03Config", "En03Study"]


@dataclass
class En03Study(DynamicStudy):
    """EN-03: the single run at structure.inertia, the inertia sweep, and the I_s -> inf
    limit check (a run at limit_inertia against the fixed structure)."""

    inertia_sweep: list[float] = MISSING
    limit_inertia: float = 1.0e12

    def check(self, path: str) -> None:
        """The EN-02 rules; every inertia > 0."""
        super().check(path)
        require(len(self.inertia_sweep) >= 1, f"{path}.inertia_sweep", self.inertia_sweep,
                "needs at least 1 value")
        for i, v in enumerate(self.inertia_sweep):
            check_inertia(f"{path}.inertia_sweep[{i}]", v)
        check_inertia(f"{path}.limit_inertia", self.limit_inertia)


@dataclass
class En03Config(DynamicConfig):
    """Root schema of EN-03 (docs/studies.md): EN-02 on a structure free to yaw."""

    study: En03Study = field(default_factory=En03Study)
    structure: StructureConfig = field(default_factory=StructureConfig)

    def check(self) -> None:
        """The structure group, then the rules of the sphere studies over every run."""
        self.structure.check("structure")
        super().check()

    def run_structure(self) -> core.Structure:
        """The single run's structure (structure.inertia, confinement, force)."""
        return self.structure.to_structure()

    def sweep_problems(self, dt: float | None = None) -> list[tuple[float, SphereProblem]]:
        """(I_s, problem) of the inertia sweep, then of the limit check (limit_inertia and
        the fixed structure, inf)."""
        base = self.sphere_problem(dt)
        inertias = [*self.study.inertia_sweep, self.study.limit_inertia, math.inf]
        return [(float(v), base.replace(inertia=float(v))) for v in inertias]

    def stability_problems(self) -> list[SphereProblem]:
        """The single run and the inertia sweep (the smallest I_s sets the limit)."""
        return [self.sphere_problem()] + [p for _, p in self.sweep_problems()]
