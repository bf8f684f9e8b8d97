"""The config schema of EN-03M (docs/studies.md): microgravity with a confining force,
the search for the smallest carrying force; the run is en03m.py."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from creatio.dynamics import problem as core
from creatio.dynamics.problem import SphereProblem, stability_limit
from creatio.studies.schema import (
    Confinement,
    DynamicConfig,
    DynamicStudy,
    check_inertia,
    require,
    require_runs,
)

__all__ = ["BisectionConfig", "En03mConfig", "En03mStudy"]


@dataclass
class BisectionConfig:
    """EN-03M's search for the smallest carrying force: a scan up the decades, then bisection."""

    decades: list[int] = field(default_factory=lambda: [-4, -3, -2, -1, 0, 1])
    rtol: float = 1.0e-3

    def check(self, path: str) -> None:
        """At least one decade; 0 < rtol < 1."""
        require(len(self.decades) >= 1, f"{path}.decades", self.decades,
                "needs at least 1 value")
        require(0.0 < self.rtol < 1.0, f"{path}.rtol", self.rtol, "must lie in (0, 1)")


@dataclass
class En03mStudy(DynamicStudy):
    """EN-03M: for each confinement and structure inertia, the smallest confining force that
    carries the sphere through the cycle, then a run at figure_factor times it."""

    reference_gravity: float = 9.81
    confinements: list[Confinement] = field(
        default_factory=lambda: [Confinement.normal, Confinement.base])
    inertias: list[float] = field(default_factory=lambda: [10.0, math.inf])
    max_force_factor: float = 100.0
    bisection: BisectionConfig = field(default_factory=BisectionConfig)
    figure_factor: float = 2.0
    fallback_force: float = 9.81

    def check(self, path: str) -> None:
        """The EN-02 rules, confinements normal/base, inertias > 0, factors positive."""
        super().check(path)
        require(self.reference_gravity > 0.0, f"{path}.reference_gravity",
                self.reference_gravity, "must be > 0")
        require(len(self.confinements) >= 1, f"{path}.confinements",
                [c.value for c in self.confinements], "needs at least 1 value")
        for i, c in enumerate(self.confinements):
            require(c is not Confinement.none, f"{path}.confinements[{i}]", c.value,
                    "must be normal or base")
        require(len(self.inertias) >= 1, f"{path}.inertias", self.inertias,
                "needs at least 1 value")
        for i, v in enumerate(self.inertias):
            check_inertia(f"{path}.inertias[{i}]", v)
        require(self.max_force_factor > 0.0, f"{path}.max_force_factor",
                self.max_force_factor, "must be > 0")
        self.bisection.check(f"{path}.bisection")
        cases = {n: len(getattr(self, n)) for n in ("confinements", "inertias")}
        cases["bisection.decades"] = len(self.bisection.decades)
        longest = max(cases, key=lambda n: cases[n])
        searches = len(self.confinements) * len(self.inertias)
        per = len(self.bisection.decades) + math.ceil(math.log2(1.0 / self.bisection.rtol)) + 2
        require_runs(f"{path}.{longest}", f"[{cases[longest]:,} values]", searches * per,
                     f"runs (confinements x inertias x ({len(self.bisection.decades)} decades + "
                     "the bisection's steps + 2))")
        require(self.figure_factor >= 1.0, f"{path}.figure_factor", self.figure_factor,
                "must be >= 1")
        require(self.fallback_force > 0.0, f"{path}.fallback_force", self.fallback_force,
                "must be > 0")


@dataclass
class En03mConfig(DynamicConfig):
    """Root schema of EN-03M (docs/studies.md): microgravity with a confining force."""

    study: En03mStudy = field(default_factory=En03mStudy)

    def force_problem(self, confinement: Confinement, inertia: float, force: float,
                      dt: float | None = None, stop_on_leaving: bool = False) -> SphereProblem:
        """The run of one confinement, structure inertia and force P at timestep dt (default
        solver.dt), its fixed step refined to stay inside the friction stability limit:
        dt / ceil(dt / limit) for a fixed-step explicit method (docs/studies.md EN-03M)."""
        p = self.sphere_problem(dt).replace(
            structure=core.Structure(float(inertia), confinement.value, float(force)),
            stop_on_leaving_cavity=stop_on_leaving)
        dt, limit = p.solver.dt, stability_limit(p)
        if dt > limit and not p.solver.allow_unstable:
            p = p.replace(dt=dt / math.ceil(dt / limit * (1.0 + 1e-12)))
        return p

    def stability_problems(self) -> list[SphereProblem]:
        """None: the study refines the step of each run to its own limit (force_problem)."""
        return []
