"""The config schema of EN-02G (docs/studies.md): EN-02 at each constant inclination and
under an oscillating one, each run from the static equilibrium; the run is en02g.py."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from creatio.dynamics.problem import SphereProblem
from creatio.model.laws import Law, LawKind
from creatio.studies.schema import (
    MISSING,
    DynamicConfig,
    DynamicStudy,
    check_inclinations,
    require,
)

__all__ = ["En02gConfig", "En02gStudy", "OscillationConfig"]


@dataclass
class OscillationConfig:
    """EN-02G's oscillating inclination gamma(t) = gamma0 + G sin(Omega t), at each gamma0."""

    gamma0_deg: list[float] = field(default_factory=lambda: [0.0, 10.0, 20.0])
    amplitude_deg: float = 10.0
    omega: float = 0.7

    def check(self, path: str) -> None:
        """G >= 0, Omega finite, |gamma0| + G <= 90 deg for each gamma0."""
        require(self.amplitude_deg >= 0.0, f"{path}.amplitude_deg", self.amplitude_deg,
                "must be >= 0")
        require(math.isfinite(self.omega), f"{path}.omega", self.omega, "must be finite")
        for i, g0 in enumerate(self.gamma0_deg):
            require(abs(g0) + self.amplitude_deg <= 90.0, f"{path}.gamma0_deg[{i}]", g0,
                    f"|gamma0| + amplitude_deg ({self.amplitude_deg}) must be <= 90 degrees")


@dataclass
class En02gStudy(DynamicStudy):
    """EN-02G: EN-02 at each constant inclination, and under the oscillating law, each run
    started at the static equilibrium of the cavity nearest study.initial."""

    inclinations_deg: list[float] = MISSING
    oscillation: OscillationConfig = field(default_factory=OscillationConfig)

    def check(self, path: str) -> None:
        """The EN-02 rules, inclinations in [-90, 90], the oscillation law in range."""
        super().check(path)
        check_inclinations(f"{path}.inclinations_deg", self.inclinations_deg)
        self.oscillation.check(f"{path}.oscillation")


@dataclass
class En02gConfig(DynamicConfig):
    """Root schema of EN-02G (docs/studies.md): the inclination is set per run by the study,
    so phases.gamma stays at its default (constant 0)."""

    study: En02gStudy = field(default_factory=En02gStudy)

    def check(self) -> None:
        """phases.gamma untouched, gravity to find the equilibrium, then the rules of the
        sphere studies over every run."""
        require(self.sphere.g > 0.0, "sphere.g", self.sphere.g,
                "must be > 0: every EN-02G run starts at the static equilibrium, the lowest "
                "point under gravity")
        gamma = self.phases.gamma
        require(gamma.kind is LawKind.constant and gamma.phi0 == 0.0, "phases.gamma",
                f"{gamma.kind.value}, phi0 = {gamma.phi0}",
                "EN-02G sets the inclination of each run (study.inclinations_deg, "
                "study.oscillation): leave phases.gamma constant at 0")
        super().check()

    def run_problems(self, dt: float | None = None
                     ) -> list[tuple[str, float, SphereProblem]]:
        """(kind, inclination or gamma0 in degrees, problem) of every run: "constant" at each
        inclination, then "oscillating" at each gamma0; all start at the equilibrium."""
        base = self.sphere_problem(dt)
        T = self.phases.T
        osc = self.study.oscillation
        out = []
        for g in self.study.inclinations_deg:
            law = Law(phi0=math.radians(g), T=T, kind=LawKind.constant)
            out.append(("constant", float(g), base.replace(gamma=law, equilibrium=True)))
        for g0 in osc.gamma0_deg:
            law = Law(phi0=math.radians(g0), T=T, amplitude=math.radians(osc.amplitude_deg),
                      omega=osc.omega, kind=LawKind.sinusoid)
            out.append(("oscillating", float(g0), base.replace(gamma=law, equilibrium=True)))
        return out

    def stability_problems(self) -> list[SphereProblem]:
        """Every run of the study."""
        return [p for _, _, p in self.run_problems()]
