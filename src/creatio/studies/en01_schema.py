"""The config schema of EN-01 (docs/studies.md): derivative steps, the grid and times, the
time-law cases, the regularity grid, the pattern-velocity check; the run is en01.py."""

from __future__ import annotations

from dataclasses import dataclass, field

from creatio.studies.schema import (
    MAX_SAMPLES,
    MISSING,
    NO_CYCLE,
    GeometryConfig,
    LawConfig,
    check_grid,
    check_inclinations,
    check_positive_list,
    culprit,
    require,
    require_samples,
)

__all__ = ["En01Config", "En01Study", "LawSetConfig", "PatternConfig", "RegularityConfig"]


@dataclass
class LawSetConfig:
    """One EN-01 time-law case: radial phase, angular phase, inclination (no quintic T)."""

    r: LawConfig = field(default_factory=LawConfig)
    a: LawConfig = field(default_factory=LawConfig)
    gamma: LawConfig = field(default_factory=LawConfig)

    def check(self, path: str) -> None:
        """Each law valid (no quintic: there is no cycle length here), gamma in range."""
        self.r.check(f"{path}.r", kinds=NO_CYCLE)
        self.a.check(f"{path}.a", kinds=NO_CYCLE)
        self.gamma.check(f"{path}.gamma", inclination=True, kinds=NO_CYCLE)


@dataclass
class RegularityConfig:
    """Regularity grid: inclinations and a radius x angle grid per inclination."""

    inclinations_deg: list[float] = MISSING
    n_radii: int = 168
    n_angles: int = 168

    def check(self, path: str) -> None:
        """Inclinations in range, grid sizes sane."""
        check_inclinations(f"{path}.inclinations_deg", self.inclinations_deg)
        check_grid(path, self.n_radii, self.n_angles, len(self.inclinations_deg))


@dataclass
class PatternConfig:
    """Pattern velocity check over one quintic cycle of the angular phase."""

    T: float = 120.0
    a: LawConfig = field(default_factory=LawConfig)
    sample_interval: float = 0.1
    fd_step: float = 1e-3

    def check(self, path: str) -> None:
        """T, sample interval and difference step positive."""
        require(self.T > 0.0, f"{path}.T", self.T, "must be > 0")
        self.a.check(f"{path}.a")
        require(
            0.0 < self.sample_interval <= self.T,
            f"{path}.sample_interval",
            self.sample_interval,
            f"must lie in (0, T = {self.T}]",
        )
        require(self.fd_step > 0.0, f"{path}.fd_step", self.fd_step, "must be > 0")
        key = culprit(self, ["T", "sample_interval"],
                      lambda x: x.T / x.sample_interval <= MAX_SAMPLES)
        require_samples(f"{path}.{key}", getattr(self, key),
                        self.T / self.sample_interval, "pattern samples (T / sample_interval)")


@dataclass
class En01Study:
    """EN-01 sampling: FD steps, grid, times, three law cases, regularity, pattern."""

    id: str = "en01"
    title: str = ""
    h: list[float] = MISSING
    n_radii: int = 17
    n_angles: int = 36
    times: list[float] = MISSING
    laws: dict[str, LawSetConfig] = field(default_factory=dict)
    regularity: RegularityConfig = field(default_factory=RegularityConfig)
    pattern: PatternConfig = field(default_factory=PatternConfig)

    def check(self, path: str) -> None:
        """Every sub-config valid; at least one law case."""
        check_positive_list(f"{path}.h", self.h)
        require(len(self.times) >= 1, f"{path}.times", self.times, "needs at least 1 value")
        check_grid(path, self.n_radii, self.n_angles, len(self.times))
        require(len(self.laws) >= 1, f"{path}.laws", dict(self.laws), "needs at least 1 case")
        for name, case in self.laws.items():
            case.check(f"{path}.laws.{name}")
        self.regularity.check(f"{path}.regularity")
        self.pattern.check(f"{path}.pattern")


@dataclass
class En01Config:
    """Root schema of EN-01."""

    study: En01Study = field(default_factory=En01Study)
    geometry: GeometryConfig = field(default_factory=GeometryConfig)

    def check(self) -> None:
        """Validate every group."""
        self.geometry.check("geometry")
        self.study.check("study")
