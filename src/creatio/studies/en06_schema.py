"""The config schema of EN-06 (docs/materials.md): what the membrane must be made of. The
surfaces of EN-02 and EN-02R (their phase groups on one geometry), the materials (their
groups, conf/material/), and the grids of each part; the run is en06.py.

Every size that sets an allocation or a count of evaluations is checked against
MAX_SAMPLES before anything runs, and refused in one line naming the key. Later parts
(tolerances, ribs) add their own group beside ``strain``, ``beyond`` and ``fatigue``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from creatio.studies.material_schema import MaterialConfig
from creatio.studies.schema import (
    MISSING,
    GeometryConfig,
    PhasesConfig,
    require,
    require_samples,
)

__all__ = ["BeyondGrid", "En06Config", "En06Study", "FatigueCheckConfig", "FatigueGrid",
           "StrainGrid"]

#: Most halvings a maximum's refinement may take (each halves the spacing: 2^-60 is far
#: below double precision of any coordinate).
MAX_LEVELS = 60


def _check_sizes(path: str, n_alpha: int, n_R: int, n_t: int, what: str,
                 min_t: int = 2) -> None:
    """n_alpha >= 3, n_R >= 2, n_t >= min_t, and their product within MAX_SAMPLES (named by
    the largest of the three)."""
    require(n_alpha >= 3, f"{path}.n_alpha", n_alpha, "must be >= 3")
    require(n_R >= 2, f"{path}.n_R", n_R, "must be >= 2 (both edges are sampled)")
    require(n_t >= min_t, f"{path}.n_t", n_t, f"must be >= {min_t}")
    sizes = {"n_alpha": n_alpha, "n_R": n_R, "n_t": n_t}
    name = max(sizes, key=lambda k: sizes[k])
    require_samples(f"{path}.{name}", sizes[name], n_alpha * n_R * n_t,
                    f"{what} ({n_alpha} x {n_R} x {n_t})")


@dataclass
class StrainGrid:
    """The base grid of the maximum (and of the map and the envelope along R): alpha_i =
    2 pi i / n_alpha, R_j = dR j / (n_R - 1), n_t times over [0, T] with both ends; the
    refinement's tolerance, candidates and most halvings (creatio.model.strain.maximum)."""

    n_alpha: int = 192
    n_R: int = 33
    n_t: int = 241
    rtol: float = 1.0e-6
    candidates: int = 4
    max_levels: int = 40

    def check(self, path: str) -> None:
        """Sizes within MAX_SAMPLES, 0 < rtol < 1, candidates >= 1, 1 <= max_levels <= 60."""
        _check_sizes(path, self.n_alpha, self.n_R, self.n_t, "strain evaluations per base grid")
        require(0.0 < self.rtol < 1.0, f"{path}.rtol", self.rtol, "must lie in (0, 1)")
        require(1 <= self.candidates <= 64, f"{path}.candidates", self.candidates,
                "must lie in [1, 64]")
        require(1 <= self.max_levels <= MAX_LEVELS, f"{path}.max_levels", self.max_levels,
                f"must lie in [1, {MAX_LEVELS}]")


@dataclass
class BeyondGrid:
    """The grid of the area beyond the ultimate strain (creatio.model.strain.area_beyond):
    cell centres in alpha and R, n_t times over [0, T] with both ends."""

    n_alpha: int = 128
    n_R: int = 64
    n_t: int = 121

    def check(self, path: str) -> None:
        """Sizes within MAX_SAMPLES."""
        _check_sizes(path, self.n_alpha, self.n_R, self.n_t, "strain evaluations",
                     min_t=1)


@dataclass
class FatigueGrid:
    """The fatigue map's grid (creatio.model.fatigue.fatigue_map): alpha_i = 2 pi i /
    n_alpha, R_j = dR j / (n_R - 1) (both edges), n_t times of one period (t_k = T k / n_t,
    the last not repeating the first): its whole history is held at once."""

    n_alpha: int = 48
    n_R: int = 25
    n_t: int = 960

    def check(self, path: str) -> None:
        """Sizes within MAX_SAMPLES, at least 4 times (a cycle needs two turning points)."""
        _check_sizes(path, self.n_alpha, self.n_R, self.n_t, "history samples", min_t=4)


@dataclass
class FatigueCheckConfig:
    """The closed-form check of the fatigue count (docs/materials.md s.5) on one surface at
    h = 0: times where phi_a = phi_a(0) +- n pi / samples_per_half_turn, alpha_i = 2 pi i /
    n_alpha (so every extreme of v is sampled exactly), R_j = dR j / (n_R - 1)."""

    surface: str = "en02"
    samples_per_half_turn: int = 8
    n_alpha: int = 48
    n_R: int = 7

    def check(self, path: str, surfaces: dict[str, PhasesConfig], Ka: int) -> None:
        """The surface is one of the study's; samples_per_half_turn even and >= 4;
        n_alpha divides 2 Ka samples_per_half_turn (alpha on the phase grid); the history
        within MAX_SAMPLES."""
        require(self.surface in surfaces, f"{path}.surface", self.surface,
                f"must be one of the study's surfaces ({', '.join(surfaces)})")
        m = self.samples_per_half_turn
        require(m >= 4 and m % 2 == 0, f"{path}.samples_per_half_turn", m,
                "must be an even number >= 4 (the extremes v = k pi / 2 are sampled)")
        require(self.n_alpha >= 1 and (2 * Ka * m) % self.n_alpha == 0, f"{path}.n_alpha",
                self.n_alpha, f"must divide 2 Ka samples_per_half_turn = {2 * Ka * m} (Ka "
                "alpha then lies on the phase grid)")
        require(self.n_R >= 2, f"{path}.n_R", self.n_R, "must be >= 2 (both edges are sampled)")
        ph = surfaces[self.surface]
        law = ph.a.to_law(ph.T)
        travel = abs(float(law(ph.T).value) - float(law(0.0).value))
        n_t = m * max(1, round(travel / math.pi)) if math.isfinite(travel) else m
        sizes = {"n_alpha": self.n_alpha, "n_R": self.n_R, "samples_per_half_turn": m}
        name = max(sizes, key=lambda k: sizes[k])
        require_samples(f"{path}.{name}", sizes[name], self.n_alpha * self.n_R * n_t,
                        f"history samples ({self.n_alpha} x {self.n_R} x {n_t})")


@dataclass
class En06Study:
    """EN-06 parts 1-2: the strain the surfaces of EN-02 and EN-02R demand of the membrane,
    the stress and fatigue it causes in each material, and the closed-form fatigue check."""

    id: str = MISSING
    title: str = ""
    surfaces: dict[str, PhasesConfig] = field(default_factory=dict)
    materials: dict[str, MaterialConfig] = field(default_factory=dict)
    strain: StrainGrid = field(default_factory=StrainGrid)
    beyond: BeyondGrid = field(default_factory=BeyondGrid)
    fatigue: FatigueGrid = field(default_factory=FatigueGrid)
    fatigue_check: FatigueCheckConfig = field(default_factory=FatigueCheckConfig)

    def check(self, path: str, Ka: int) -> None:
        """At least one surface and material, each valid; every grid within the limits."""
        require(len(self.surfaces) >= 1, f"{path}.surfaces", dict(self.surfaces),
                "needs at least 1 surface (a phases group)")
        require(len(self.materials) >= 1, f"{path}.materials", dict(self.materials),
                "needs at least 1 material (a material group)")
        for name, ph in self.surfaces.items():
            ph.check(f"{path}.surfaces.{name}")
        for name, mat in self.materials.items():
            mat.check(f"{path}.materials.{name}")
        self.strain.check(f"{path}.strain")
        self.beyond.check(f"{path}.beyond")
        self.fatigue.check(f"{path}.fatigue")
        self.fatigue_check.check(f"{path}.fatigue_check", self.surfaces, Ka)


@dataclass
class En06Config:
    """Root schema of EN-06 (docs/materials.md): one geometry, the surfaces' phases and the
    materials under ``study``."""

    study: En06Study = field(default_factory=En06Study)
    geometry: GeometryConfig = field(default_factory=GeometryConfig)

    def check(self) -> None:
        """Validate the geometry, then the study."""
        self.geometry.check("geometry")
        self.study.check("study", self.geometry.Ka)
