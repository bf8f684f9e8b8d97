"""The config schema of a membrane material (conf/material/<name>.yaml, docs/materials.md):
its constitutive law and moduli, sheet thickness, ultimate strain and strain-life law.

Plain dataclasses and their rules, like creatio.studies.schema; nothing here computes a strain.
``check`` raises ConfigError naming the key, the value and the rule, in one line, before
anything is computed. The shipped values (elastomer, fabric) are illustrative.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from enum import StrEnum
from typing import Any

from creatio.errors import ConfigError
from creatio.model.fatigue import StrainLife
from creatio.studies.schema import MISSING, check_finite, require

__all__ = ["MaterialConfig", "MaterialLaw"]


class MaterialLaw(StrEnum):
    """Constitutive law of the membrane (docs/materials.md)."""

    neo_hookean = "neo_hookean"  # incompressible neo-Hookean membrane: shear_modulus
    svk = "svk"                  # Saint Venant-Kirchhoff plane stress: youngs_modulus, poisson


#: The moduli each law reads; the others must stay 0 (a value set there would be ignored).
_USED = {MaterialLaw.neo_hookean: {"shear_modulus"},
         MaterialLaw.svk: {"youngs_modulus", "poisson"}}
_MODULI = ("shear_modulus", "youngs_modulus", "poisson")


@dataclass
class MaterialConfig:
    """One membrane material: law, moduli (Pa), thickness h (m), ultimate strain eps_u and
    the strain-life law N_f = (eps_aeq / eps_f)^(1 / c)."""

    name: str = MISSING
    law: MaterialLaw = MaterialLaw.neo_hookean
    shear_modulus: float = 0.0
    youngs_modulus: float = 0.0
    poisson: float = 0.0
    thickness: float = MISSING
    eps_u: float = MISSING
    eps_f: float = MISSING
    c: float = MISSING

    def check(self, path: str = "material") -> None:
        """Types, finiteness, then each rule: the law's moduli > 0 (0 <= poisson < 0.5), the
        unused ones 0, thickness > 0, eps_u > 0, eps_f > 0, c < 0."""
        require(isinstance(self.name, str) and self.name not in ("", MISSING),
                f"{path}.name", self.name, "must be a non-empty name")
        if not isinstance(self.law, MaterialLaw):
            choices = " | ".join(m.value for m in MaterialLaw)
            require(self.law in {m.value for m in MaterialLaw}, f"{path}.law", self.law,
                    f"must be one of {choices}")
            self.law = MaterialLaw(self.law)
        for f in fields(self):
            if f.name in ("name", "law"):
                continue
            value = getattr(self, f.name)
            require(_is_number(value), f"{path}.{f.name}", value, "must be a number")
            require(math.isfinite(value), f"{path}.{f.name}", value, "must be a finite number")
        check_finite(self, f"{path}.")
        for name in _MODULI:
            if name not in _USED[self.law]:
                require(getattr(self, name) == 0.0, f"{path}.{name}", getattr(self, name),
                        f"is not used by law={self.law.value}: leave it 0")
        if self.law is MaterialLaw.neo_hookean:
            require(self.shear_modulus > 0.0, f"{path}.shear_modulus", self.shear_modulus,
                    "must be > 0 (Pa)")
        else:
            require(self.youngs_modulus > 0.0, f"{path}.youngs_modulus", self.youngs_modulus,
                    "must be > 0 (Pa)")
            require(0.0 <= self.poisson < 0.5, f"{path}.poisson", self.poisson,
                    "must satisfy 0 <= poisson < 0.5")
        require(self.thickness > 0.0, f"{path}.thickness", self.thickness, "must be > 0 (m)")
        require(self.eps_u > 0.0, f"{path}.eps_u", self.eps_u, "must be > 0")
        require(self.eps_f > 0.0, f"{path}.eps_f", self.eps_f, "must be > 0")
        require(self.c < 0.0, f"{path}.c", self.c, "must be < 0 (life falls as strain grows)")

    def strain_life(self) -> StrainLife:
        """The material's strain-life law for creatio.model.fatigue."""
        return StrainLife(eps_f=float(self.eps_f), c=float(self.c), eps_u=float(self.eps_u))

    @classmethod
    def from_mapping(cls, values: dict[str, Any], path: str = "material") -> MaterialConfig:
        """A checked material from a plain mapping (a YAML group); unknown keys refused."""
        known = {f.name for f in fields(cls)}
        for key in values:
            if key not in known:
                raise ConfigError(f"{path}.{key}", values[key],
                                  f"is not a material key (known: {', '.join(sorted(known))})")
        cfg = cls(**values)
        cfg.check(path)
        return cfg


def _is_number(value: Any) -> bool:
    """A real number that is not a bool (YAML's true/false are not moduli)."""
    return isinstance(value, int | float) and not isinstance(value, bool)
