"""The config schema of a strain scene: a sphere scene whose membrane is coloured by strain.

Its ``scene`` node is a sphere scene's (:class:`~creatio.scenes.schema.SphereSceneSettings`:
studies, what it draws, playback, mesh, media, axes) plus ``strain``: which strain colours
the membrane. The legend's range is the data's, rounded outward (creatio.scenes.strain).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from creatio.scenes.schema import Element, SphereSceneConfig, SphereSceneSettings
from creatio.studies.schema import require

__all__ = ["StrainColours", "StrainSceneConfig", "StrainSceneSettings"]

#: Thickest sheet a strain scene colours (m): the faces' strain is the thin-sheet one.
MAX_THICKNESS = 0.05


@dataclass
class StrainColours:
    """What colours the membrane: the largest principal Green-Lagrange strain of the face
    of a sheet of ``thickness`` h (m); h = 0 is the mid-surface's (membrane) strain."""

    thickness: float = 0.0

    def check(self, path: str) -> None:
        """thickness finite, in [0, MAX_THICKNESS]."""
        h = self.thickness
        require(isinstance(h, int | float) and not isinstance(h, bool) and math.isfinite(h)
                and 0.0 <= h <= MAX_THICKNESS, f"{path}.thickness", h,
                f"must be a finite number in [0, {MAX_THICKNESS}] m")


@dataclass
class StrainSceneSettings(SphereSceneSettings):
    """A sphere scene whose membrane is coloured by strain, with a legend in its units."""

    strain: StrainColours = field(default_factory=StrainColours)

    def extra_page_bytes(self, runs: int, frames: int) -> int:
        """Bytes the strain field adds to the page: a 16-bit code per run, frame and mesh
        vertex, in base64 (creatio.scenes.page)."""
        return math.ceil(runs * frames * self.mesh.n_alpha * self.mesh.n_R * 2 * 4 / 3)


@dataclass
class StrainSceneConfig(SphereSceneConfig):
    """Root schema of a strain scene: its settings and the full config of each study."""

    scene: StrainSceneSettings = field(default_factory=StrainSceneSettings)

    def check(self) -> None:
        """The sphere scene's rules; the membrane drawn (the strain colours it); the
        strain settings valid."""
        super().check()
        s = self.scene
        require(Element.membrane in s.draw, "scene.draw", [str(x) for x in s.draw],
                "must draw the membrane: the strain colours it")
        s.strain.check("scene.strain")
