"""The config schema of CT-02 (docs/studies.md): derivative steps, inclinations, the grid
and times, the time-varying inclination case, the feature times; the run is ct02.py."""

from __future__ import annotations

from dataclasses import dataclass, field

from creatio.studies.schema import (
    MISSING,
    NO_CYCLE,
    GeometryConfig,
    LawConfig,
    PhasePairConfig,
    check_grid,
    check_inclinations,
    check_positive_list,
    require,
)

__all__ = ["Ct02Config", "Ct02Study"]


@dataclass
class Ct02Study:
    """CT-02 sampling: FD steps, inclinations, grid, times, gamma(t) case, feature times."""

    id: str = "ct02"
    title: str = ""
    h: list[float] = MISSING
    inclinations_deg: list[float] = MISSING
    n_radii: int = 9
    n_angles: int = 24
    times: list[float] = MISSING
    varying_gamma: LawConfig = field(default_factory=LawConfig)
    feature_times: list[float] = MISSING
    feature_h: float = 1e-4

    def check(self, path: str) -> None:
        """Steps positive, inclinations in range, grid sizes sane, gamma(t) in range."""
        check_positive_list(f"{path}.h", self.h)
        check_inclinations(f"{path}.inclinations_deg", self.inclinations_deg)
        require(len(self.times) >= 1, f"{path}.times", self.times, "needs at least 1 value")
        check_grid(path, self.n_radii, self.n_angles, len(self.times))
        require(len(self.feature_times) >= 1, f"{path}.feature_times", self.feature_times,
                "needs at least 1 value (the report's feature check)")
        self.varying_gamma.check(f"{path}.varying_gamma", inclination=True, kinds=NO_CYCLE)
        require(self.feature_h > 0.0, f"{path}.feature_h", self.feature_h, "must be > 0")


@dataclass
class Ct02Config:
    """Root schema of CT-02."""

    study: Ct02Study = field(default_factory=Ct02Study)
    geometry: GeometryConfig = field(default_factory=GeometryConfig)
    phases: PhasePairConfig = field(default_factory=PhasePairConfig)

    def check(self) -> None:
        """Validate every group."""
        self.geometry.check("geometry")
        self.phases.check("phases")
        self.study.check("study")
