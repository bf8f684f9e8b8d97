"""The config schema of EN-07 (docs/aerospace.md): a demonstrator in microgravity. The sphere
study it scales (``bases.<study.base>``, EN-02's), the platforms (their group,
conf/platform/), the similarity check's cases, the requirements search, the interfaces'
host inertias, the closed loop (EN-04's controller, group ``control``), the membrane
material (group ``material``) and the grids of the actuation and strain figures; the run
is en07.py.

Every value is checked before anything runs and refused in one line naming the key, the
value and the rule (exit code 2 at the command line).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from creatio.studies.en06_schema import StrainGrid
from creatio.studies.material_schema import MaterialConfig
from creatio.studies.platform_schema import PlatformConfig
from creatio.studies.schema import (
    MAX_RUNS,
    MAX_SAMPLES,
    MISSING,
    ControlGroup,
    DynamicConfig,
    check_bases,
    check_inertia,
    check_positive_list,
    culprit,
    require,
    require_runs,
    require_samples,
)

__all__ = ["LAWS", "ActuationSettings", "En07Config", "En07Study", "InterfacesConfig",
           "RequirementsConfig", "SimilarityConfig"]

#: The transport laws of the requirements search: EN-02's quintic cycle (open loop) and
#: EN-04's closed loop.
LAWS = ("quintic", "closed_loop")

#: Largest and smallest scale factor a config may ask for (beyond, a sphere of a few
#: micrometres or a device of hundreds of metres: not a demonstrator).
SCALE_RANGE = (1e-3, 1e3)


def _check_scale(key: str, value: float) -> None:
    lo, hi = SCALE_RANGE
    require(lo <= value <= hi, key, value, f"must lie in [{lo:g}, {hi:g}] (a length scale "
            "factor of the base study)")


def _check_pull(key: str, value: float) -> None:
    require(0.0 < value <= 100.0, key, value, "must lie in (0, 100] g (the pull P / (m g))")


@dataclass
class SimilarityConfig:
    """The similarity check: each (scales[i], pulls_g[i]) case is the base study scaled and
    run under the pull, both it and the base at method / rtol / atol (adaptive)."""

    scales: list[float] = field(default_factory=lambda: [0.5, 2.0])
    pulls_g: list[float] = field(default_factory=lambda: [2.0, 0.5])
    method: str = "dop853"
    rtol: float = 1.0e-10
    atol: float = 1.0e-12

    def check(self, path: str) -> None:
        """As many pulls as scales (at least 1), each in range; tolerances > 0."""
        check_positive_list(f"{path}.scales", self.scales)
        require(len(self.pulls_g) == len(self.scales), f"{path}.pulls_g", list(self.pulls_g),
                f"must hold one pull per scale ({len(self.scales)})")
        for i, s in enumerate(self.scales):
            _check_scale(f"{path}.scales[{i}]", s)
        for i, a in enumerate(self.pulls_g):
            _check_pull(f"{path}.pulls_g[{i}]", a)
        require(0.0 < self.rtol < 1e-3, f"{path}.rtol", self.rtol, "must lie in (0, 1e-3)")
        require(0.0 < self.atol < 1e-3, f"{path}.atol", self.atol, "must lie in (0, 1e-3)")


@dataclass
class RequirementsConfig:
    """The requirements search: per platform and law, the largest scale in [scale_min,
    scale_max] at the preload ceiling, then (at scale_max) the smallest pull down to
    preload_min_g, each by bisection to rel_tol; one transport must fit in window / margin
    (untimed_transport_s without a window), and the residual may displace the sphere by at
    most drift_max sphere radii."""

    laws: list[str] = field(default_factory=lambda: list(LAWS))
    margin: float = 1.2
    untimed_transport_s: float = 120.0
    scale_min: float = 0.1
    scale_max: float = 1.0
    preload_min_g: float = 1.0e-4
    rel_tol: float = 0.01
    drift_max: float = 0.1

    def check(self, path: str) -> None:
        """Known laws without repeats; margin >= 1; budgets > 0; 0 < scale_min < scale_max;
        0 < preload_min_g; 0 < rel_tol <= 0.5; drift_max > 0."""
        require(len(self.laws) >= 1, f"{path}.laws", list(self.laws), "needs at least 1 law")
        for i, law in enumerate(self.laws):
            require(law in LAWS, f"{path}.laws[{i}]", law, f"must be one of {', '.join(LAWS)}")
        require(len(set(self.laws)) == len(self.laws), f"{path}.laws", list(self.laws),
                "must not repeat a law")
        require(math.isfinite(self.margin) and self.margin >= 1.0, f"{path}.margin",
                self.margin, "must be >= 1 (the transport takes at most window / margin)")
        require(self.untimed_transport_s > 0.0, f"{path}.untimed_transport_s",
                self.untimed_transport_s, "must be > 0 s")
        _check_scale(f"{path}.scale_min", self.scale_min)
        _check_scale(f"{path}.scale_max", self.scale_max)
        require(self.scale_max > self.scale_min, f"{path}.scale_max", self.scale_max,
                f"must be > scale_min = {self.scale_min}")
        _check_pull(f"{path}.preload_min_g", self.preload_min_g)
        require(1e-9 <= self.rel_tol <= 0.5, f"{path}.rel_tol", self.rel_tol,
                "must lie in [1e-9, 0.5] (the bracket's relative width, above rounding)")
        require(self.drift_max > 0.0, f"{path}.drift_max", self.drift_max,
                "must be > 0 (sphere radii)")

    def bisections(self, lo: float, hi: float) -> int:
        """Runs a bisection on log x from [lo, hi] to a bracket hi / lo <= 1 + rel_tol takes."""
        return max(0, math.ceil(math.log2(math.log(hi / lo) / math.log1p(self.rel_tol))))


@dataclass
class InterfacesConfig:
    """The interfaces: the base study at ``scale`` under the base pull ``pull_g`` (g = 0
    besides), on EN-03's free structure of each host inertia, every step recorded."""

    scale: float = 1.0
    pull_g: float = 1.0
    inertias: list[float] = field(default_factory=lambda: [1.0, 10.0, 100.0, 1000.0])

    def check(self, path: str) -> None:
        """Scale and pull in range; every inertia > 0 and finite."""
        _check_scale(f"{path}.scale", self.scale)
        _check_pull(f"{path}.pull_g", self.pull_g)
        check_positive_list(f"{path}.inertias", self.inertias)
        for i, v in enumerate(self.inertias):
            check_inertia(f"{path}.inertias[{i}]", v)
            require(math.isfinite(v), f"{path}.inertias[{i}]", v,
                    "must be finite (a host that turns)")


@dataclass
class ActuationSettings:
    """EN-04's actuation figures along each design run (creatio.studies.en04_control.
    DemandSettings): membrane areal density and damping, the quadrature's first grid,
    growth, tolerance and most levels, the stroke's start grid, the bandwidth's fraction."""

    sigma: float = 0.5
    c_d: float = 0.0
    n_alpha: int = 9
    n_R: int = 5
    growth: float = 1.5
    rtol: float = 1.0e-8
    max_levels: int = 10
    extrema_n_alpha: int = 16
    extrema_n_R: int = 9
    energy_fraction: float = 0.99

    def check(self, path: str) -> None:
        """sigma > 0, c_d >= 0, grids >= 3, growth > 1, 0 < rtol < 1, max_levels >= 1, the
        finest quadrature grid and the stroke's start grid within MAX_SAMPLES (named by the
        key that sets them), 0 < energy_fraction < 1."""
        require(self.sigma > 0.0, f"{path}.sigma", self.sigma, "must be > 0 kg/m^2")
        require(self.c_d >= 0.0, f"{path}.c_d", self.c_d, "must be >= 0")
        for name in ("n_alpha", "n_R", "extrema_n_alpha", "extrema_n_R"):
            v = getattr(self, name)
            require(v >= 3, f"{path}.{name}", v, "must be >= 3")
        require(self.growth > 1.0, f"{path}.growth", self.growth, "must be > 1")
        require(0.0 < self.rtol < 1.0, f"{path}.rtol", self.rtol, "must lie in (0, 1)")
        require(self.max_levels >= 1, f"{path}.max_levels", self.max_levels, "must be >= 1")

        def finest(x: ActuationSettings) -> float:
            try:
                return x.n_alpha * x.n_R * x.growth ** (2 * (x.max_levels - 1))
            except OverflowError:
                return math.inf

        key = culprit(self, ["n_alpha", "n_R", "growth", "max_levels"],
                      lambda x: finest(x) <= MAX_SAMPLES)
        require_samples(f"{path}.{key}", getattr(self, key), finest(self),
                        "points of the finest quadrature grid (n_alpha x n_R x "
                        "growth^(2 (max_levels - 1)))")
        key = culprit(self, ["extrema_n_alpha", "extrema_n_R"],
                      lambda x: x.extrema_n_alpha * x.extrema_n_R <= MAX_SAMPLES)
        require_samples(f"{path}.{key}", getattr(self, key),
                        self.extrema_n_alpha * self.extrema_n_R,
                        "start points of the stroke's search (extrema_n_alpha x extrema_n_R)")
        require(0.0 < self.energy_fraction < 1.0, f"{path}.energy_fraction",
                self.energy_fraction, "must lie in (0, 1)")


@dataclass
class En07Study:
    """EN-07's settings (docs/aerospace.md)."""

    id: str = MISSING
    title: str = ""
    base: str = "en02"
    platforms: dict[str, PlatformConfig] = field(default_factory=dict)
    control: ControlGroup = field(default_factory=ControlGroup)
    material: MaterialConfig = field(default_factory=MaterialConfig)
    similarity: SimilarityConfig = field(default_factory=SimilarityConfig)
    requirements: RequirementsConfig = field(default_factory=RequirementsConfig)
    interfaces: InterfacesConfig = field(default_factory=InterfacesConfig)
    actuation: ActuationSettings = field(default_factory=ActuationSettings)
    strain: StrainGrid = field(default_factory=lambda: StrainGrid(96, 17, 121))

    def check(self, path: str, bases: dict[str, DynamicConfig]) -> None:
        """The base is one of bases, prescribed (no control group); each platform valid and
        its residual below the membrane at the smallest pull searched; every part's rules;
        the run count within MAX_RUNS."""
        require(self.base in bases, f"{path}.base", self.base,
                f"must be one of bases ({', '.join(bases) or 'none'})")
        base = bases[self.base]
        require(base.control is None, f"bases.{self.base}.control", "pd",
                "must be null: EN-07 runs the base's prescribed cycle and its own closed loop")
        require(len(self.platforms) >= 1, f"{path}.platforms", dict(self.platforms),
                "needs at least 1 platform (a platform group)")
        rq = self.requirements
        rq.check(f"{path}.requirements")
        for name, p in self.platforms.items():
            p.check(f"{path}.platforms.{name}")
            up = p.residual_g * p.unit_direction()[2]
            require(up < rq.preload_min_g, f"{path}.platforms.{name}.residual_direction",
                    list(p.residual_direction),
                    f"lifts the sphere by {up:.3g} g, not less than requirements."
                    f"preload_min_g = {rq.preload_min_g:g}: the pull plus the residual must "
                    "point below the membrane")
            require(p.preload_max_g > rq.preload_min_g, f"{path}.platforms.{name}."
                    "preload_max_g", p.preload_max_g,
                    f"must be > requirements.preload_min_g = {rq.preload_min_g:g}")
        require(base.sphere.g > 0.0, f"bases.{self.base}.sphere.g", base.sphere.g,
                "must be > 0 (the unit of every pull and residual, and the base's pull)")
        for name, p in self.platforms.items():
            key, T = ((f"{path}.platforms.{name}.window_s", p.window_s)
                      if p.window_s is not None
                      else (f"{path}.requirements.untimed_transport_s",
                            rq.untimed_transport_s))
            budget = T / rq.margin if p.window_s is not None else T
            rows = budget / (base.solver.dt * math.sqrt(rq.scale_min / p.preload_max_g))
            require_samples(key, T, rows, "rows of a transport run (every step recorded: its "
                            "budget / the base's step at scale_min under preload_max_g)")
        self.control.check(f"{path}.control", base.geometry.Ka)
        self.material.check(f"{path}.material")
        self.similarity.check(f"{path}.similarity")
        self.interfaces.check(f"{path}.interfaces")
        self.actuation.check(f"{path}.actuation")
        self.strain.check(f"{path}.strain")
        most = max(p.preload_max_g for p in self.platforms.values())
        per = (rq.bisections(rq.scale_min, rq.scale_max)
               + rq.bisections(rq.preload_min_g, most) + 6)
        require_runs(f"{path}.platforms", f"[{len(self.platforms)} platforms]",
                     len(self.platforms) * len(rq.laws) * per,
                     f"runs of the requirements search (platforms x laws x {per}; "
                     f"at most {MAX_RUNS:,})")


@dataclass
class En07Config:
    """Root schema of EN-07: its settings and the full config of the sphere study it scales."""

    study: En07Study = field(default_factory=En07Study)
    bases: dict[str, DynamicConfig] = field(default_factory=dict)

    def check(self) -> None:
        """Every base valid (errors named under bases.<study>), then the study's rules."""
        check_bases(self.bases)
        self.study.check("study", self.bases)
